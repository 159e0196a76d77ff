"""The control statements from Python, end to end: the real simulator (scaratwin-sim, MuJoCo,
camera) and the real firmware in the emulator (scaratwin-robot, the exact robot: --plant
ideal) behind its pty. The emulator's truth channel (the motors' true step positions from the
STEP/DIR pins) is the measuring instrument; the twin never reads it."""
import math
import os
import signal
import socket
import sqlite3
import subprocess
import threading
import time

import numpy as np
import pytest

import scaratwin as st

from rig import HOME_Z


@pytest.fixture(scope="module")
def twin(rig):
    t = st.connect(serial=rig["pty"], sim=rig["sim"], db=rig["db"], label="pytest")
    yield t
    t.close()


def cli(rig, *args):
    """`scaratwin ARGS` against the same robot and simulator."""
    return subprocess.run([str(st.bin_dir() / "scaratwin"), *args, "--serial", rig["pty"],
                           "--sim", rig["sim"], "--no-db"], capture_output=True, text=True,
                          timeout=120)


def test_connect_to_a_simulator_or_robot_that_is_not_running_raises_link_error(rig):
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        free = s.getsockname()[1]
    with pytest.raises(st.LinkError) as e:
        st.connect(serial=rig["pty"], sim=f"127.0.0.1:{free}", db=None)
    assert str(free) in str(e.value)
    with pytest.raises(st.LinkError) as e:
        st.connect(serial=str(rig["dir"] / "no-such-pty"), sim=rig["sim"], db=None)
    assert "no-such-pty" in str(e.value)
    with pytest.raises(ValueError, match="connect: sim 'nowhere': expected HOST:PORT"):
        st.connect(serial=rig["pty"], sim="nowhere", db=None)


def test_home_then_move_lands_on_the_true_steps(twin, rig):
    assert twin.home() == "homed"
    truth = rig["truth"]
    assert truth.steps()[0] == HOME_Z
    target = np.array([0.18, 0.08, -0.015, math.radians(90)])
    q, status = st.ik(target, seed=twin.robot.home)
    assert status == 0
    line = twin.move(*target)
    assert line.startswith("tool at (0.1800, 0.0800, -0.0150) m")
    assert truth.at_rest()
    expected = st.joints_to_steps(q)
    assert np.abs(truth.steps() - expected).max() <= 1, (truth.steps(), expected)
    state = twin.state()
    np.testing.assert_allclose(st.fk(state["q"])[:3], target[:3], atol=2e-4)


def test_unreachable_move_raises_the_cli_message_and_nothing_moves(twin, rig):
    before = rig["truth"].steps()
    with pytest.raises(st.StatementError) as e:
        twin.move(0.5, 0.0, 0.0)
    assert str(e.value).startswith("move 0.5 0 0: target (0.5, 0, 0) m unreachable")
    rig["messages"]["move 0.5 0 0"] = str(e.value)  # compared with the CLI's once closed
    assert rig["truth"].at_rest()
    assert np.array_equal(rig["truth"].steps(), before)
    with pytest.raises(ValueError, match="move: arguments must be finite numbers, got nan"):
        twin.move(float("nan"), 0.0, 0.0)


def test_spawn_objects_and_shoot(twin):
    twin.reset()
    cube = twin.spawn("red", 0.2, -0.05)
    objs = twin.objects()
    assert objs["id"].tolist() == [cube] and objs["color"].tolist() == ["red"]
    assert (objs[0]["x_m"], objs[0]["y_m"]) == pytest.approx((0.2, -0.05), abs=1e-3)
    img = twin.shoot()
    cam = twin.robot.scene["camera"]
    assert img.shape == (cam["height_px"], cam["width_px"], 3) and img.dtype == np.uint8
    r, g, b = (img[..., i].astype(int) for i in range(3))
    red = (r > 120) & (r > 2 * g) & (r > 2 * b)
    assert red.sum() > 20  # the red cube is in the picture
    with pytest.raises(ValueError, match="spawn: .*purple"):
        twin.spawn("purple", 0.2, 0.0)


def virtual_grip_becomes(twin, closed, timeout_s=10.0):
    """Waits until the virtual gripper (which follows the physical one through the mirror)
    reports `closed`."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if twin.virtual_state()["grip_closed"] is closed:
            return True
        time.sleep(0.05)
    return False


def test_grip_and_release_reach_the_virtual_gripper(twin):
    twin.grip()
    assert virtual_grip_becomes(twin, True)
    twin.release()
    assert virtual_grip_becomes(twin, False)


def test_state_stream_runs_while_a_move_holds_no_gil(twin):
    seen = []
    with twin.on_state(seen.append):
        twin.movej([0.1, math.radians(20), math.radians(30), math.radians(40)])
    # the watcher's thread ran Python during the blocking move: the GIL was released
    assert len(seen) > 20
    seqs = [s["seq"] for s in seen]
    assert all((b - a) % 65536 >= 1 for a, b in zip(seqs, seqs[1:]))
    d1 = [s["q"][0] for s in seen]
    assert max(d1) - min(d1) > 0.01  # it saw the robot move
    states = list(twin.states(seconds=0.3))
    assert len(states) >= 5


def test_ctrl_c_during_a_move_stops_the_robot_and_the_next_move_works(twin, rig):
    truth = rig["truth"]
    twin.movej(twin.robot.home)

    def interrupt_when_moving():
        if truth.wait(lambda s: s[0] < HOME_Z - 2000):
            os.kill(os.getpid(), signal.SIGINT)

    t = threading.Thread(target=interrupt_when_moving)
    t.start()
    with pytest.raises(KeyboardInterrupt):
        twin.movej([0.02, 0.0, 0.0, 0.0])  # Z down 10 cm: about 9 s
    t.join()
    assert truth.at_rest()
    z_stopped = truth.steps()[0]
    assert z_stopped > 0.02 * 205560 + 1000  # stopped well before the goal, not at its end
    time.sleep(1.0)
    assert truth.steps()[0] == z_stopped  # and stays stopped
    twin.movej(twin.robot.home)  # the session goes on
    assert truth.steps()[0] == HOME_Z


def test_sort_puts_the_cube_in_its_tray(twin):
    twin.reset()
    twin.spawn("green", 0.19, 0.06)
    line = twin.sort()
    assert line.startswith("1 cubes:")
    tray = twin.robot.scene["trays"]["green"]
    cube = twin.objects()[0]
    assert abs(cube["x_m"] - tray["x_m"]) < tray["size_m"] / 2
    assert abs(cube["y_m"] - tray["y_m"]) < tray["size_m"] / 2


def test_the_session_is_in_the_twin_database(twin, rig):
    run = twin.run_id
    twin.set_mirror(True)
    twin.wait(0.2)
    twin.close()
    db = st.TwinDb(rig["db"])
    runs = db.runs()
    mine = runs[runs["id"] == run][0]
    assert (mine["kind"], mine["label"], mine["status"]) == ("python", "pytest", "ok")
    samples = db.samples(run, "physical")
    con = sqlite3.connect(rig["db"])
    n, t_max = con.execute("SELECT COUNT(*), MAX(t_s) FROM samples WHERE run = ? AND "
                           "source = 'physical'", (run,)).fetchone()
    assert len(samples) == n > 100 and samples["t_s"].max() == t_max
    details = db.events(run)["detail"].tolist()
    assert "move 0.18 0.08 -0.015 90.00000000000001" in details or any(
        d.startswith("move 0.18 0.08 -0.015") for d in details)
    assert "interrupted" in db.events(run)["kind"].tolist()


def test_statement_errors_read_as_the_command_lines(rig):
    # the robot takes one host at a time: the CLI runs once the session above is closed
    assert rig["messages"]
    for statement, message in rig["messages"].items():
        out = cli(rig, *statement.split())
        assert out.returncode == 1
        assert out.stderr.strip() == f"scaratwin {statement.split()[0]}: {message}"


def test_a_robot_that_vanishes_mid_move_raises(rig):
    with st.connect(serial=rig["pty"], sim=rig["sim"], db=None) as t:
        t.home()
        truth = rig["truth"]

        def kill_when_moving():
            if truth.wait(lambda s: s[0] < HOME_Z - 2000):
                rig["robot"].kill()

        k = threading.Thread(target=kill_when_moving)
        k.start()
        with pytest.raises(st.StatementError) as e:
            t.movej([0.02, 0.0, 0.0, 0.0])
        k.join()
        assert "movej 0.02 0 0 0: " in str(e.value)
