"""The robot kept across statements (docs/owner.md), on an emulated Uno that resets whenever its
port is opened (the emulator's default, as a real board): `scaratwin hub` owns the port, and
the statements, each a process of its own, go to it. Judged by the emulator's truth channel (the
motors' true steps and the endstop switches), a measuring instrument the hub never reads.
Also: nothing of ours is left running when a program is killed with SIGKILL."""
import math
import os
import signal
import subprocess
import threading
import time

import pytest

import scaratwin as st
from rig import HOME_Z, Truth

# the description's conversions (config/scara.toml), the oracle for where a motion must end
Z_STEPS_PER_M = 205560.0
J2_STEPS_PER_RAD = 945.0
J3_STEPS_PER_RAD = 1455.0
J3_PER_J2_STEP = 0.8


def expected_steps(d1_m, q2_deg, q3_deg):
    j2 = round(math.radians(q2_deg) * J2_STEPS_PER_RAD)
    return (round(d1_m * Z_STEPS_PER_M), j2,
            round(math.radians(q3_deg) * J3_STEPS_PER_RAD + J3_PER_J2_STEP * j2))


def truth_fields(truth):
    line = truth.command("query")
    return dict(kv.split("=", 1) for kv in line.split()[1:] if "=" in kv)


class Watch:
    """Samples the truth (its own side-channel connection) until stopped: every sample's
    endstop mask and steps."""

    def __init__(self, side_port):
        self.truth = Truth(side_port)
        self.samples = []
        self.stop = False
        self.thread = threading.Thread(target=self.run)
        self.thread.start()

    def run(self):
        while not self.stop:
            f = truth_fields(self.truth)
            self.samples.append((int(f["endstops"]), int(f["z"]), int(f["j2"]), int(f["j3"])))
            time.sleep(0.005)

    def end(self):
        self.stop = True
        self.thread.join()
        return self.samples


def cli(*args, timeout=120):
    return subprocess.run([str(st.bin_dir() / "scaratwin"), *args], capture_output=True,
                          text=True, timeout=timeout)


def start_hub(rig, tmp_path, name="hub"):
    log = tmp_path / f"{name}.log"
    proc = subprocess.Popen([str(st.bin_dir() / "scaratwin"), "hub", "--serial", rig["pty"],
                             "--sim", rig["sim"], "--db", str(tmp_path / f"{name}.db")],
                            stdout=open(log, "w"), stderr=subprocess.STDOUT)
    return proc, log


def wait_for(log, text, proc, timeout_s=60):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if text in log.read_text(errors="replace"):
            return
        if proc.poll() is not None:
            raise RuntimeError(f"exited {proc.returncode}:\n{log.read_text()}")
        time.sleep(0.05)
    raise TimeoutError(f"no '{text}' in:\n{log.read_text()}")


def stop(proc):
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def side_port(rig):
    return rig["truth"].sock.getpeername()[1]


def test_a_robot_homed_by_one_statement_stays_homed_for_the_next(rig, tmp_path):
    truth = rig["truth"]
    hub, log = start_hub(rig, tmp_path)
    try:
        wait_for(log, "its port's statements at", hub)
        r = cli("home", "--serial", rig["pty"], "--sim", rig["sim"])
        assert r.returncode == 0, r.stderr
        assert r.stdout.strip() == "homed"
        assert truth.steps()[0] == HOME_Z
        resets = int(truth_fields(truth)["resets"])
        # the next statement, another process: no reset, no homing, the move runs at once
        watch = Watch(side_port(rig))
        r = cli("movej", "0.05", "30", "45", "0", "--serial", rig["pty"], "--sim", rig["sim"])
        samples = watch.end()
        assert r.returncode == 0, r.stderr
        assert truth.at_rest()
        want = expected_steps(0.05, 30, 45)
        got = tuple(int(v) for v in truth.steps())
        assert all(abs(g - w) <= 1 for g, w in zip(got, want)), (got, want)
        # no switch closed while the statement ran, and Z never rose towards its switch
        # (homing seeks each switch first): the robot was not homed again
        assert samples and all(s[0] == 0 for s in samples), [s for s in samples if s[0]][:5]
        assert max(s[1] for s in samples) <= HOME_Z
        assert int(truth_fields(truth)["resets"]) == resets
        # a second hub for the same port is refused before it opens the port, naming the first
        r = cli("hub", "--serial", rig["pty"], "--sim", rig["sim"], "--no-db", timeout=30)
        assert r.returncode == 1
        assert f"is owned by another scaratwin hub (pid {hub.pid})" in r.stderr, r.stderr
        # ... and the first one's robot is still homed: a script through it moves at once
        script = tmp_path / "back.txt"
        script.write_text("movej 0.12 0 0 0\n")
        r = cli("run", str(script), "--serial", rig["pty"], "--sim", rig["sim"])
        assert r.returncode == 0, r.stderr
        assert r.stdout.startswith("   1  movej 0.12 0 0 0"), r.stdout
        assert truth.at_rest()
        assert tuple(int(v) for v in truth.steps()) == (HOME_Z, 0, 0)
    finally:
        stop(hub)
    assert "command \"local-" in log.read_text()


def test_a_statement_killed_mid_move_stops_the_robot_and_the_hub_serves_on(rig, tmp_path):
    truth = rig["truth"]
    hub, log = start_hub(rig, tmp_path)
    try:
        wait_for(log, "its port's statements at", hub)
        assert cli("home", "--serial", rig["pty"], "--sim", rig["sim"]).returncode == 0
        mover = subprocess.Popen([str(st.bin_dir() / "scaratwin"), "movej", "0.02", "90", "90",
                                  "0", "--serial", rig["pty"], "--sim", rig["sim"]],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert truth.wait(lambda s: s[0] < HOME_Z - 2000, timeout_s=30)
        mover.kill()
        mover.wait()
        # the robot stops (ramping down at its acceleration limit) well before its goal
        end = time.monotonic() + 10
        while not truth.at_rest():
            assert time.monotonic() < end, "the robot did not stop"
        stopped = tuple(int(v) for v in truth.steps())
        assert stopped != expected_steps(0.02, 90, 90)  # it stopped on the way
        # the hub serves the next statement
        r = cli("movej", "0.12", "0", "0", "0", "--serial", rig["pty"], "--sim", rig["sim"])
        if r.returncode != 0:
            # a stopped robot may need homing again, as without a hub
            assert cli("home", "--serial", rig["pty"], "--sim", rig["sim"]).returncode == 0
            r = cli("movej", "0.12", "0", "0", "0", "--serial", rig["pty"], "--sim", rig["sim"])
        assert r.returncode == 0, r.stderr
        assert tuple(int(v) for v in truth.steps()) == (HOME_Z, 0, 0)
    finally:
        stop(hub)


def test_without_a_hub_the_board_resets_and_a_move_is_refused_with_the_way_out(rig, tmp_path):
    truth = rig["truth"]
    hub, log = start_hub(rig, tmp_path)
    try:
        wait_for(log, "its port's statements at", hub)
        assert cli("home", "--serial", rig["pty"], "--sim", rig["sim"]).returncode == 0
    finally:
        stop(hub)
    before = tuple(int(v) for v in truth.steps())
    resets = int(truth_fields(truth)["resets"])
    # no owner now: the statement opens the port, the board resets and comes back un-homed
    r = cli("movej", "0.05", "30", "45", "0", "--serial", rig["pty"], "--sim", rig["sim"],
            "--no-db")
    assert r.returncode == 1
    assert r.stderr.startswith("scaratwin movej: movej 0.05 30 45 0: the robot is not homed"), \
        r.stderr
    assert "keep the port with `scaratwin hub`" in r.stderr, r.stderr
    assert int(truth_fields(truth)["resets"]) == resets + 1  # its open reset the board
    time.sleep(0.5)
    assert tuple(int(v) for v in truth.steps()) == before  # nothing moved


def test_a_move_while_the_robot_is_silent_is_refused_and_nothing_moves(rig, tmp_path):
    """docs/protocol.md 11.1: "A move started while the robot is silent is refused before
    anything moves"; once the link is back, the robot is driven again."""
    truth = rig["truth"]
    hub, log = start_hub(rig, tmp_path)
    try:
        wait_for(log, "its port's statements at", hub)
        assert cli("home", "--serial", rig["pty"], "--sim", rig["sim"]).returncode == 0
        before = tuple(int(v) for v in truth.steps())
        assert truth.command("cut 9000") == "OK cut 9000"
        # the hub counts the robot silent after 3 s without a report (HubOptions'
        # robot_silence_s; at rest it says so in its event log only): 4 s, well inside the cut
        time.sleep(4.0)
        r = cli("movej", "0.05", "30", "45", "0", "--serial", rig["pty"], "--sim", rig["sim"])
        assert r.returncode == 1, r.stdout
        assert ("the robot link is silent (no state report: cut or unplugged): nothing moved"
                in r.stderr), r.stderr
        assert truth.at_rest()
        assert tuple(int(v) for v in truth.steps()) == before
        # the cut ends: the hub says so, and the robot is driven again (homed again if the
        # hub stopped it)
        wait_for(log, "the robot link is back", hub, timeout_s=30)
        r = cli("movej", "0.10", "0", "0", "0", "--serial", rig["pty"], "--sim", rig["sim"])
        if r.returncode != 0:
            assert cli("home", "--serial", rig["pty"], "--sim", rig["sim"]).returncode == 0
            r = cli("movej", "0.10", "0", "0", "0", "--serial", rig["pty"], "--sim", rig["sim"])
        assert r.returncode == 0, r.stderr
        assert truth.at_rest()
        assert abs(int(truth.steps()[0]) - round(0.10 * Z_STEPS_PER_M)) <= 1
    finally:
        stop(hub)


def children_of(pid):
    kids = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            kids.append(int(entry))
    return kids


def alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.parametrize("command", [["demo", "--cubes", "1", "--no-calibrate"],
                                     ["calibrate", "--poses", "12"]])
def test_kill_9_leaves_no_simulator_or_robot_running(tmp_path, command):
    proc = subprocess.Popen([str(st.bin_dir() / "scaratwin"), *command, "--out",
                             str(tmp_path / "out"), "--http-port", "0"] if command[0] == "demo"
                            else [str(st.bin_dir() / "scaratwin"), *command, "--output",
                                  str(tmp_path / "cal.toml")],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        end = time.monotonic() + 60
        kids = []
        while time.monotonic() < end and len(kids) < 2:
            kids = [k for k in children_of(proc.pid) if alive(k)]
            time.sleep(0.1)
        names = sorted(open(f"/proc/{k}/comm").read().strip() for k in kids)
        assert names == ["scaratwin-robot", "scaratwin-sim"], names
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        end = time.monotonic() + 15
        while time.monotonic() < end and any(alive(k) for k in kids):
            time.sleep(0.1)
        assert not any(alive(k) for k in kids), [k for k in kids if alive(k)]
    finally:
        if proc.poll() is None:
            proc.kill()
