"""The real simulator and the emulated robot for the Python tests: scaratwin-sim (MuJoCo,
camera) and scaratwin-robot (the firmware in simavr, the exact robot: --plant ideal) behind its
pty, started from the build tree; and the emulator's truth channel, the measuring instrument
(the motors' true step positions from the STEP/DIR pins)."""
import os
import re
import signal
import socket
import subprocess
import time

import numpy as np
import pytest

import scaratwin as st

HOME_Z = 24667  # Z motor count at the home pose (d1 = 0.12 m)


def wait_for_line(log, pattern, proc, timeout_s=60):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if log.exists():
            m = re.search(pattern, log.read_text(errors="replace"))
            if m:
                return m
        if proc.poll() is not None:
            raise RuntimeError(f"{log.name}: exited {proc.returncode}:\n{log.read_text()}")
        time.sleep(0.05)
    raise TimeoutError(f"{log.name}: no line matching {pattern!r}:\n{log.read_text()}")


class Truth:
    """The emulator's side channel: the true motor positions (steps)."""

    def __init__(self, port):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=5)
        self.buf = b""
        assert self.command("rate 0").startswith("OK")

    def command(self, c):
        self.sock.sendall((c + "\n").encode())
        while True:
            while b"\n" not in self.buf:
                self.buf += self.sock.recv(4096)
            line, self.buf = self.buf.split(b"\n", 1)
            text = line.decode()
            if text.startswith("TR ") and c != "query":
                continue
            return text

    def steps(self):
        fields = dict(kv.split("=", 1) for kv in self.command("query").split()[1:] if "=" in kv)
        return np.array([int(fields["z"]), int(fields["j2"]), int(fields["j3"])])

    def wait(self, pred, timeout_s=60):
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            if pred(self.steps()):
                return True
            time.sleep(0.02)
        return False

    def sim_us(self):
        fields = dict(kv.split("=", 1) for kv in self.command("query").split()[1:] if "=" in kv)
        return int(fields["sim_us"])

    def at_rest(self):
        """No motor moves for 300 ms of the emulated robot's own clock, which must advance (a
        stalled emulator's motors keep still too); False if it does not within 10 s."""
        start = self.sim_us()
        a = self.steps()
        end = time.monotonic() + 10
        while self.sim_us() < start + 300_000:
            if time.monotonic() > end:
                return False
            time.sleep(0.02)
        return np.array_equal(a, self.steps())


# the emulated robot's clock against the wall clock (SCARATWIN_TEST_ROBOT_SPEED). Real time by
# default: the virtual robot mirrors the physical one, so at 2x the simulator's cubes are carried
# twice as fast, and under the sanitizer build a cube of the colour sort once ended outside its
# tray (CI, 2026-11-24)
ROBOT_SPEED = os.environ.get("SCARATWIN_TEST_ROBOT_SPEED", "1")


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    d = tmp_path_factory.mktemp("rig")
    pty = d / "robot.pty"
    bin_dir = st.bin_dir()
    robot_log, sim_log = d / "robot.log", d / "sim.log"
    robot = subprocess.Popen([str(bin_dir / "scaratwin-robot"), "--pty-link", str(pty),
                              "--plant", "ideal", "--speed", ROBOT_SPEED], stdout=open(robot_log, "w"),
                             stderr=subprocess.STDOUT)
    sim = subprocess.Popen([str(bin_dir / "scaratwin-sim"), "--port", "0", "--http-port", "0"],
                           stdout=open(sim_log, "w"), stderr=subprocess.STDOUT)
    try:
        side = int(wait_for_line(robot_log, r"side channel: \S+:(\d+)", robot).group(1))
        port = int(wait_for_line(sim_log, r"listening on \S+:(\d+) \(", sim).group(1))
        yield {"dir": d, "pty": str(pty), "sim": f"127.0.0.1:{port}", "truth": Truth(side),
               "robot": robot, "sim_proc": sim, "db": d / "twin.db", "messages": {}}
    finally:
        for p in (robot, sim):
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
                try:
                    p.wait(10)
                except subprocess.TimeoutExpired:
                    p.kill()
