"""scaratwin: the digital twin of a desktop SCARA robot, from Python.

The C++ libraries of scaratwin with numpy arrays in and out (docs/python.md):

* the robot description: ``load_robot()``, ``default_robot()``, ``Robot``;
* kinematics, single or batched: ``fk``, ``ik``, ``ik_all``, ``jacobian``, ``outside_limits``,
  ``joints_to_motors``, ``joints_to_steps``, ``motors_to_joints``;
* trajectories: ``quintic``, ``plan_quintic``, ``plan_trapezoid``, ``plan_via_points``,
  ``plan_line``, ``plan_pick_place`` -> ``Trajectory`` (t, q, qd, qdd as arrays);
* the control statements against a running simulator and robot: ``connect()`` -> ``Twin``;
* the twin database: ``TwinDb``;
* the paper's procedures, as the ``scaratwin`` command runs them: ``demo()`` -> ``DemoResult``,
  ``calibrate()`` -> ``CalibrationResult``.

Units are SI: joints (d1_m, q2_rad, q3_rad, q4_rad), tool poses (x_m, y_m, z_m, yaw_rad).
"""

import enum as _enum
import os as _os
import threading as _threading
from pathlib import Path as _Path

from . import _paths
from ._core import (  # noqa: F401  (re-exported)
    CalibrationResult,
    ConfigError,
    DatabaseError,
    DemoResult,
    Error,
    LinkError,
    PlanError,
    Robot,
    StatementError,
    Trajectory,
    Twin,
    TwinDb,
    UnreachableError,
    calibrate,
    connect,
    demo,
    detect_cubes,
    firmware_to_joints,
    fk,
    ik,
    ik_all,
    jacobian,
    joints_to_firmware,
    joints_to_motors,
    joints_to_steps,
    load_robot,
    motors_to_joints,
    outside_limits,
    paper_robot,
    parse_robot,
    plan_line,
    plan_pick_place,
    plan_quintic,
    plan_trapezoid,
    plan_via_points,
    quintic,
)
from . import _core

__all__ = [
    "CalibrationResult", "ConfigError", "DatabaseError", "DemoResult", "Error", "IkError", "LinkError", "PlanError", "Robot",
    "StatementError", "StateWatcher", "Trajectory", "Twin", "TwinDb", "UnreachableError",
    "bin_dir", "calibrate", "connect", "default_robot", "demo", "default_robot_path", "detect_cubes",
    "firmware_to_joints", "fk", "ik", "ik_all", "jacobian", "joints_to_firmware",
    "joints_to_motors", "joints_to_steps", "load_robot", "motors_to_joints", "outside_limits",
    "paper_robot", "parse_robot", "plan_line", "plan_pick_place", "plan_quintic",
    "plan_trapezoid", "plan_via_points", "quintic", "set_default_robot",
]

__version__ = "0.1.0"


class IkError(_enum.IntEnum):
    """The status codes of ``ik`` (0 is solved), as ``scaratwin/kinematics/kinematics.hpp``."""

    NOT_FINITE = 1  #: a coordinate is NaN or infinite
    BEYOND_REACH = 2  #: farther from the shoulder than both links stretched out
    INSIDE_DEAD_ZONE = 3  #: closer to the shoulder than |a2 - a3|
    Z_OUT_OF_TRAVEL = 4  #: needs a d1 outside the Z travel
    J2_LIMIT = 5  #: the shoulder would leave its limits on every elbow solution
    J3_LIMIT = 6  #: the elbow would leave its limits on every elbow solution
    J4_LIMIT = 7  #: the wrist would leave its limits on every elbow solution


def default_robot_path() -> _Path:
    """The description used when none is given: $SCARATWIN_CONFIG, else scara.toml in the
    robot descriptions' folder (the source tree's config/ from a build tree,
    <prefix>/share/scaratwin/config when installed; $SCARATWIN_DATA_DIR overrides)."""
    env = _os.environ.get("SCARATWIN_CONFIG")
    if env:
        return _Path(env)
    return _paths.config_dir / "scara.toml"


def bin_dir() -> _Path:
    """Where the scaratwin executables are (scaratwin, scaratwin-sim, scaratwin-robot)."""
    return _paths.bin_dir


_default_lock = _threading.Lock()
_default = None


def default_robot() -> Robot:
    """The robot every call uses when given none: loaded from ``default_robot_path()`` on
    first use (raises ConfigError when it cannot be read), or what ``set_default_robot`` set."""
    global _default
    with _default_lock:
        if _default is None:
            _default = _core.load_robot(str(default_robot_path()))
            _core._set_default_robot(_default)
        return _default


def set_default_robot(robot: Robot) -> None:
    """Makes ``robot`` the one every call uses when given none."""
    global _default
    if not isinstance(robot, Robot):
        raise TypeError(
            f"set_default_robot: expected a scaratwin.Robot, got {type(robot).__name__}")
    with _default_lock:
        _default = robot
        _core._set_default_robot(robot)


class StateWatcher:
    """Calls a function with every state report of the physical robot, on a thread of its
    own, until ``stop()`` (returned by ``Twin.on_state``)."""

    def __init__(self, twin: Twin, callback, timeout_s: float = 2.0):
        self._twin = twin
        self._callback = callback
        self._timeout_s = timeout_s
        self._stop = _threading.Event()
        self.error = None  #: the exception that ended the watcher early, if any
        self._thread = _threading.Thread(target=self._run, name="scaratwin-state", daemon=True)
        self._thread.start()

    def _run(self):
        try:
            while not self._stop.is_set() and not self._twin.closed:
                self._callback(self._twin.state(self._timeout_s))
        except Exception as e:  # noqa: BLE001  (kept for the caller)
            if not self._stop.is_set():
                self.error = e

    def stop(self) -> None:
        """Stops calling the callback and waits for the thread to end."""
        self._stop.set()
        if self._thread is not _threading.current_thread():
            self._thread.join()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()


def _states(self: Twin, seconds=None, timeout_s: float = 2.0):
    """Yields every state report of the physical robot (a dict, as ``state()``) for
    ``seconds`` (None: until the caller stops iterating)."""
    import time

    end = None if seconds is None else time.monotonic() + seconds
    while end is None or time.monotonic() < end:
        yield self.state(timeout_s)


def _on_state(self: Twin, callback, timeout_s: float = 2.0) -> StateWatcher:
    """Calls ``callback(state)`` with every state report on a thread of its own; returns the
    ``StateWatcher`` (``stop()`` it, or use it in a ``with`` block)."""
    return StateWatcher(self, callback, timeout_s)


Twin.states = _states
Twin.on_state = _on_state
