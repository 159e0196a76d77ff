"""Type stubs of scaratwin._core (the C++ core; import scaratwin, not this module)."""

from os import PathLike
from pathlib import Path as _PathLib
from typing import Any, Iterator, Literal

import numpy as np
import numpy.typing as npt

from . import StateWatcher

_Rows = npt.ArrayLike  # shape (4,) or (N, 4), float or integer dtype
_F64 = npt.NDArray[np.float64]
_I32 = npt.NDArray[np.int32]
_Path = str | PathLike[str]

class Error(RuntimeError):
    """Base of every scaratwin error; ``code`` is the library's error code (docs/errors.md)."""

    code: int

class ConfigError(Error, ValueError):
    """A robot description that cannot be read or is invalid (names the key)."""

class UnreachableError(Error):
    """A tool pose without IK solution; ``code`` is an IkError."""

class PlanError(Error):
    """A planner refused; ``code`` is a PlanError (10..14)."""

class LinkError(Error):
    """The simulator or the robot cannot be reached, or a link was lost."""

class StatementError(Error):
    """A control statement failed (the message the scaratwin command prints)."""

class DatabaseError(Error):
    """The twin database cannot be opened or read."""

class Robot:
    """A robot description, loaded and validated once. SI units."""

    @property
    def name(self) -> str: ...
    @property
    def path(self) -> str:
        """The file it was loaded from ('' for the built-in paper robot)."""
    @property
    def dh(self) -> np.ndarray:
        """Standard DH table: structured (joint, type, theta_rad, d_m, a_m, alpha_rad), 4 rows."""
    @property
    def limits(self) -> _F64:
        """Joint travel (4, 2): [min, max] of d1 (m), q2, q3, q4 (rad)."""
    @property
    def home(self) -> _F64:
        """Home joints (4,)."""
    @property
    def motors(self) -> dict[str, Any]:
        """Stepper conversions and limits, the belt coupling, the servos."""
    @property
    def endstops(self) -> dict[str, Any]: ...
    @property
    def scene(self) -> dict[str, Any]:
        """Table, cube size, grasp height, trays, camera (base frame, SI)."""
    @property
    def as_built(self) -> dict[str, Any]:
        """The [as_built] tolerance profile: seed, tolerance and explicit values (SI keys)."""
    @property
    def calibrated(self) -> bool:
        """True for a calibration overlay that identified anything."""
    @property
    def calibration(self) -> dict[str, Any]:
        """The joint map firmware -> true joints (zero until calibrated)."""
    @property
    def webcam(self) -> dict[str, Any] | None:
        """The physical webcam as calibrated, None before."""
    def draw_as_built(self) -> dict[str, float]:
        """The robot as built that the emulator draws from the profile (SI deviations)."""

def load_robot(path: _Path | None = None) -> Robot:
    """Loads and validates a robot description (TOML); None: the default one."""

def parse_robot(text: str, source: str = "<string>") -> Robot:
    """Parses a robot description from TOML text."""

def paper_robot() -> Robot:
    """The paper's robot with every default (no file)."""

def _set_default_robot(robot: Robot) -> None: ...
def fk(joints: _Rows, robot: Robot | None = None) -> _F64:
    """Joints (d1_m, q2_rad, q3_rad, q4_rad) (4,) or (N, 4) -> poses (x_m, y_m, z_m, yaw_rad)."""

def ik(poses: _Rows, seed: _Rows | None = None, robot: Robot | None = None) -> tuple[_F64, Any]:
    """Poses (4,) or (N, 4) -> (joints, status): status 0 solved, else the IkError code with
    NaN joints; an int status for one (4,) pose, an int32 (N,) array for (N, 4)."""
def ik_all(pose: _Rows, seed: _Rows | None = None, robot: Robot | None = None) -> _F64:
    """Every elbow solution (k, 4) of one pose, nearest to seed first; UnreachableError."""

def jacobian(joints: _Rows, robot: Robot | None = None) -> _F64:
    """d(x, y, z, yaw)/d(d1, q2, q3, q4): (4, 4) or (N, 4, 4)."""

def outside_limits(joints: _Rows, robot: Robot | None = None) -> Any:
    """First joint (0..3) outside its limits, -1 inside: an int for (4,), int32 (N,)."""
def joints_to_motors(joints: _Rows, robot: Robot | None = None) -> tuple[_F64, _F64 | float]:
    """(steps of Z, J2, J3 (N, 3) not rounded, wrist servo angle (deg))."""

def firmware_to_joints(joints: _Rows, robot: Robot | None = None) -> _F64:
    """The calibration's joint map: true joints from the firmware's (identity uncalibrated)."""

def joints_to_firmware(joints: _Rows, robot: Robot | None = None) -> _F64:
    """The inverse of firmware_to_joints."""

def joints_to_steps(joints: _Rows, robot: Robot | None = None) -> _I32:
    """Nearest whole steps of Z, J2, J3: (3,) or (N, 3) int32."""

def motors_to_joints(
    steps: npt.ArrayLike, wrist_deg: npt.ArrayLike, robot: Robot | None = None
) -> _F64:
    """Joints from steps (3,) or (N, 3) and the wrist servo angle (deg)."""

class Trajectory:
    """A timed joint trajectory; t, q, qd, qdd are read-only views of the C++ samples."""

    def __init__(
        self,
        t: npt.ArrayLike,
        q: npt.ArrayLike,
        qd: npt.ArrayLike | None = None,
        qdd: npt.ArrayLike | None = None,
        events: list[tuple[float, Literal["grip", "release"]]] = ...,
    ) -> None: ...
    @property
    def t(self) -> _F64:
        """Sample times (s), (N,)."""
    @property
    def q(self) -> _F64:
        """Positions (N, 4): d1_m, q2_rad, q3_rad, q4_rad."""
    @property
    def qd(self) -> _F64:
        """Velocities (N, 4)."""
    @property
    def qdd(self) -> _F64:
        """Accelerations (N, 4)."""
    @property
    def events(self) -> list[tuple[float, str]]:
        """Gripper events (t_s, 'grip' | 'release')."""
    @property
    def duration_s(self) -> float: ...
    def __len__(self) -> int: ...
    def sample_at(self, t_s: float) -> _F64: ...
    def check_limits(self, robot: Robot | None = None, tolerance: float = 1e-6) -> None:
        """Raises PlanError when a joint, speed or acceleration limit is exceeded."""

def quintic(q0: _Rows, q1: _Rows, duration_s: float, samples: int = 60) -> Trajectory:
    """The paper's jtraj (no limit check)."""

def plan_quintic(
    q0: _Rows, q1: _Rows, duration_s: float = 0.0, samples: int = 60, robot: Robot | None = None
) -> Trajectory: ...
def plan_trapezoid(
    q0: _Rows,
    q1: _Rows,
    dt_s: float = 0.01,
    speed_scale: float = 1.0,
    accel_scale: float = 1.0,
    robot: Robot | None = None,
) -> Trajectory: ...
def plan_via_points(
    points: npt.ArrayLike,
    profile: Literal["trapezoid", "quintic"] = "trapezoid",
    dt_s: float = 0.01,
    speed_scale: float = 1.0,
    accel_scale: float = 1.0,
    quintic_samples: int = 60,
    robot: Robot | None = None,
) -> Trajectory: ...
def plan_line(
    q0: _Rows,
    goal: _Rows,
    max_step_m: float = 0.001,
    dt_s: float = 0.01,
    speed_scale: float = 1.0,
    accel_scale: float = 1.0,
    robot: Robot | None = None,
) -> Trajectory: ...
def plan_pick_place(
    q0: _Rows,
    pick: _Rows,
    place: _Rows,
    approach_height_m: float | None = None,
    grip_dwell_s: float = 0.4,
    speed_scale: float = 1.0,
    accel_scale: float = 1.0,
    dt_s: float = 0.01,
    robot: Robot | None = None,
) -> Trajectory: ...

class Twin:
    """A connected twin: the robot, the simulator and the hub between them."""

    @property
    def robot(self) -> Robot: ...
    @property
    def run_id(self) -> int: ...
    @property
    def closed(self) -> bool: ...
    def home(self) -> str: ...
    def stop(self) -> str: ...
    def move(self, x_m: float, y_m: float, z_m: float, yaw_rad: float | None = None) -> str: ...
    def line(self, x_m: float, y_m: float, z_m: float, yaw_rad: float | None = None) -> str: ...
    def movej(self, joints: _Rows) -> str: ...
    def grip(self) -> str: ...
    def release(self) -> str: ...
    def reset(self) -> str: ...
    def sort(self) -> str: ...
    def pick(self, cube_id: int) -> str: ...
    def wait(self, seconds: float) -> str: ...
    def run_script(self, text: str, name: str = "<script>") -> int: ...
    def spawn(self, color: Literal["red", "green", "blue"], x_m: float, y_m: float) -> int: ...
    def shoot(self, path: _Path | None = None) -> npt.NDArray[np.uint8]:
        """The virtual camera's picture, (H, W, 3) uint8 RGB, row 0 at the top."""
    def objects(self) -> np.ndarray:
        """Cubes of the virtual scene: structured (id, color, x_m, y_m, z_m, yaw_rad)."""
    def mirror(self, seconds: float) -> dict[str, float]: ...
    def run_trajectory(self, trajectory: Trajectory) -> int: ...
    def state(self, timeout_s: float = 2.0) -> dict[str, Any]:
        """The next state report: q, steps, grip_deg, seq, device_t_us, flags, queue_free."""
    def virtual_state(self) -> dict[str, Any]: ...
    def mirror_counters(self) -> dict[str, float]: ...
    def set_mirror(self, on: bool) -> None: ...
    def states(
        self, seconds: float | None = None, timeout_s: float = 2.0
    ) -> Iterator[dict[str, Any]]: ...
    def on_state(self, callback: Any, timeout_s: float = 2.0) -> StateWatcher: ...
    def close(self) -> None: ...
    def __enter__(self) -> Twin: ...
    def __exit__(self, *exc: object) -> None: ...

def detect_cubes(image: npt.ArrayLike, robot: Robot | None = None) -> np.ndarray:
    """Colour recognition on a camera picture: structured (color, col, row, area_px, x_m, y_m)."""

def connect(
    serial: str | None = None,
    sim: str = "127.0.0.1:55016",
    db: _Path | None = "scaratwin-out/twin.db",
    robot: Robot | None = None,
    mirror: bool = True,
    label: str = "python",
) -> Twin: ...

class TwinDb:
    """The twin database (SQLite)."""

    def __init__(self, path: _Path) -> None: ...
    @property
    def path(self) -> str: ...
    def runs(self, frame: bool = False) -> Any: ...
    def children(self, parent: int, frame: bool = False) -> Any: ...
    def samples(
        self,
        run: int,
        source: Literal["planned", "virtual", "physical", "truth"] = "physical",
        frame: bool = False,
    ) -> Any:
        """Structured (t_s, seq, d1_m, q2_rad, q3_rad, q4_rad, grip_deg), or a DataFrame."""
    def latencies(self, run: int, frame: bool = False) -> Any: ...
    def events(self, run: int, frame: bool = False) -> Any: ...
    def metrics(self, run: int, frame: bool = False) -> Any: ...
    def export_csv(self, run: int, dir: _Path) -> None: ...
    def close(self) -> None: ...
    def __enter__(self) -> TwinDb: ...
    def __exit__(self, *exc: object) -> None: ...

class DemoResult:
    """What ``demo()`` measured (``results`` names results.json, which has every figure)."""

    ok: bool
    plant: str
    run: int
    duration_s: float
    cubes_in_trays: int
    database: _PathLib
    results: _PathLib | None
    report: _PathLib | None
    csv_dir: _PathLib
    failure: str | None
    failure_code: int | None
    lost_frames: int | None
    latency_mean_ms: float | None

def demo(
    out: _Path = "scaratwin-out",
    robot: Robot | None = None,
    cubes: int = 3,
    seed: int = 7,
    calibrate: bool = True,
    as_built_seed: int | None = None,
    layout_seed: int | None = None,
    http_port: int = 0,
    robot_speed: float = 1.0,
    mirror_s: float = 6.0,
    on_line: Any = None,
) -> DemoResult:
    """The paper's procedure as ``scaratwin demo`` runs it (simulator and emulated robot)."""

class CalibrationResult:
    """What ``calibrate()`` identified; ``overlay`` is the description it wrote."""

    overlay: _PathLib
    pixel_rms: float
    robot_s: float
    pictures: int
    parameters: dict[str, tuple[float, float]]
    truth: dict[str, float]

def calibrate(
    out: _Path = "scaratwin-calibration",
    robot: Robot | None = None,
    overlay: _Path | None = None,
    poses: int = 24,
    touch_offs: int = 4,
    seed: int = 1,
    as_built_seed: int | None = None,
    robot_speed: float = 1.0,
    on_line: Any = None,
) -> CalibrationResult:
    """The calibration routine as ``scaratwin calibrate`` runs it on the emulated robot."""
