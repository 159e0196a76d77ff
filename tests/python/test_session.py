"""The paper's procedures from Python through the session library, as `scaratwin demo` and
`scaratwin calibrate` run them: scaratwin.demo() and scaratwin.calibrate() start the real
simulator and our firmware in the emulator (as built), run the procedure and return its figures.
The checks read what the procedure wrote with independent readers (json, sqlite3) and judge the
calibration against the emulator's truth, a measuring instrument the fit never sees."""
import json
import math
import sqlite3

import pytest

import scaratwin as st


def test_the_short_demo_sorts_its_cube_and_writes_every_record(tmp_path):
    lines = []
    # the emulated robot at twice the wall clock, as CI runs the demo's own test (its budget)
    r = st.demo(out=tmp_path, cubes=1, calibrate=False, robot_speed=2.0, on_line=lines.append)
    assert r.ok, (r.failure, lines[-20:])
    assert r.failure is None
    assert r.plant == "as-built"
    assert r.cubes_in_trays == 1
    assert r.lost_frames == 0
    # the progress as the command line prints it: the five phases, then the verdict
    steps = [line for line in lines if line.startswith("==> [")]
    assert [s[:9] for s in steps] == ["==> [1/5]", "==> [2/5]", "==> [3/5]", "==> [4/5]",
                                      "==> [5/5]"]
    assert any(line.startswith("demo passed in ") for line in lines)
    # results.json, read as a user would
    res = json.loads((tmp_path / "results.json").read_text())
    assert res["physical_cubes_in_trays"] == 1
    assert res["virtual_cubes_in_trays"] == 1
    assert r.results == tmp_path / "results.json"
    assert r.report == tmp_path / "report.html"
    assert (tmp_path / "report.html").stat().st_size > 10000
    # the database with SQLite itself: the demo's run, ok, with its phases under it
    with sqlite3.connect(tmp_path / "twin.db") as db:
        status, kind = db.execute("SELECT status, kind FROM runs WHERE id = ?",
                                  (r.run,)).fetchone()
        assert (status, kind) == ("ok", "demo")
        kinds = [k for (k,) in db.execute(
            "SELECT kind FROM runs WHERE parent = ? ORDER BY id", (r.run,))]
    assert kinds == ["home", "mirror", "control", "prediction", "replay", "rehome"]
    assert sorted(p.name.split("-", 1)[1] for p in (tmp_path / "csv").iterdir()) == sorted(kinds)


def test_bad_arguments_are_refused_before_anything_starts(tmp_path):
    with pytest.raises(ValueError, match=r"demo: cubes=0: must be 1\.\.3"):
        st.demo(out=tmp_path / "a", cubes=0)
    assert not (tmp_path / "a").exists()
    with pytest.raises(ValueError, match=r"calibrate: poses=5: must be 12\.\.500"):
        st.calibrate(out=tmp_path / "b", poses=5)
    assert not (tmp_path / "b").exists()
    # a line callback that raises stops the procedure at once; its exception reaches the
    # caller, and nothing moved (no phase began: no run in the database)
    said = []
    def boom(line):
        said.append(line)
        raise RuntimeError("stop here: " + line[:20])
    with pytest.raises(RuntimeError, match="stop here: physical robot"):
        st.demo(out=tmp_path / "c", cubes=1, calibrate=False, on_line=boom)
    assert len(said) == 1
    with sqlite3.connect(tmp_path / "c" / "twin.db") as db:
        assert db.execute("SELECT COUNT(*) FROM runs").fetchone() == (0,)


def test_calibrate_identifies_the_build_the_emulator_drew(tmp_path):
    base = st.load_robot(st.default_robot_path())
    overlay = tmp_path / "scara.calibrated.toml"
    lines = []
    c = st.calibrate(out=tmp_path, robot=base, overlay=overlay, poses=12, touch_offs=3,
                     as_built_seed=11, robot_speed=2.0, on_line=lines.append)
    assert c.overlay == overlay
    assert c.pixel_rms < 1.0
    # the overlay is a description the library loads, and it is the calibrated one
    text = overlay.read_text()
    assert "[calibration]" in text
    calibrated = st.load_robot(overlay)
    assert calibrated.path == str(overlay)
    # each link length as identified lies within 3 standard errors of the emulator's truth
    for key in c.parameters:
        if not key.startswith(("a2", "a3")):
            continue
        value, se = c.parameters[key]
        truth = c.truth[key]
        assert not math.isnan(truth)
        assert abs(value - truth) <= 3 * se, (key, value, se, truth)
        # and within docs/calibration.md's absolute bound (0.3 mm): inflated errors cannot pass
        assert abs(value - truth) <= 0.3, (key, value, truth)
    assert any("calibrated description: " + str(overlay) in line for line in lines)
