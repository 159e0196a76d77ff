"""The Python examples (examples/python/) run as a user runs them, against the real simulator
and the emulated robot: the pick-and-place and the colour sort must put their cubes in the
trays (each script checks, and the test checks the scene again itself), the plot script must
draw the recorded run."""
import subprocess
import sys
from pathlib import Path

import pytest

import scaratwin as st


EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "python"


def run_example(rig, name, *args):
    out = subprocess.run([sys.executable, str(EXAMPLES / name), *args], capture_output=True,
                         text=True, timeout=300)
    print(out.stdout, out.stderr)
    return out


def link_args(rig):
    return ["--serial", rig["pty"], "--sim", rig["sim"], "--db", str(rig["db"])]


def cubes_in_trays(rig):
    robot = st.default_robot()
    with st.connect(serial=rig["pty"], sim=rig["sim"], db=None) as twin:
        objects = twin.objects()
    inside = []
    for o in objects:
        tray = robot.scene["trays"][o["color"]]
        inside.append(abs(o["x_m"] - tray["x_m"]) < tray["size_m"] / 2
                      and abs(o["y_m"] - tray["y_m"]) < tray["size_m"] / 2)
    return objects, inside


def test_pick_place(rig):
    out = run_example(rig, "pick_place.py", *link_args(rig))
    assert out.returncode == 0, out.stdout + out.stderr
    assert "in the red tray" in out.stdout
    objects, inside = cubes_in_trays(rig)
    assert len(objects) == 1 and all(inside)


def test_sort_colours(rig, tmp_path):
    picture = tmp_path / "camera.png"
    out = run_example(rig, "sort_colours.py", *link_args(rig), "--picture", str(picture))
    assert out.returncode == 0, out.stdout + out.stderr
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    objects, inside = cubes_in_trays(rig)
    assert sorted(objects["color"].tolist()) == ["blue", "green", "red"] and all(inside)


def test_plot_run(rig, tmp_path):
    pytest.importorskip("matplotlib")
    png = tmp_path / "run.png"
    out = run_example(rig, "plot_run.py", "--db", str(rig["db"]), "--out", str(png))
    assert out.returncode == 0, out.stdout + out.stderr
    assert "sort_colours.py" in out.stdout  # the latest run with samples
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20000
