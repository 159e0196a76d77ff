"""The twin database from Python: rows written with Python's own sqlite3 module (the oracle)
come back from scaratwin.TwinDb as structured arrays with the same values."""
import sqlite3

import numpy as np
import pytest

import scaratwin as st


@pytest.fixture()
def db_path(tmp_path):
    path = tmp_path / "twin.db"
    st.TwinDb(path).close()  # creates the tables
    con = sqlite3.connect(path)
    con.execute("INSERT INTO runs (id, kind, label, status, started_unix_s, duration_s) "
                "VALUES (1, 'control', 'move 0.2 0 0', 'ok', 1700000000.5, 2.25)")
    con.execute("INSERT INTO runs (id, parent, ref, kind, label, started_unix_s) "
                "VALUES (2, 1, 1, 'replay', 'é label, with comma', 1700000003.0)")
    rng = np.random.default_rng(1)
    rows = [(1, "physical", 0.01 * i, 100 + i, *rng.random(4), 75.0 * (i % 2)) for i in range(500)]
    con.executemany("INSERT INTO samples VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)", rows)
    con.execute("INSERT INTO samples VALUES (1, 'planned', 0.0, NULL, 0.12, 0, 0, 0, 0)")
    con.executemany("INSERT INTO events VALUES (?, ?, ?, ?)",
                    [(1, 0.5, "statement", "move 0.2 0 0"), (1, 1.5, "error", "a: b: c")])
    con.executemany("INSERT INTO latencies VALUES (?, ?, ?, ?, ?)",
                    [(1, i, 10 * i, 1000 + i, 1400 + 2 * i) for i in range(50)])
    con.execute("INSERT INTO metrics VALUES (1, 'tool_error', 0.0004, 'm')")
    con.commit()
    con.close()
    return path, rows


def test_runs(db_path):
    path, _ = db_path
    with st.TwinDb(path) as db:
        runs = db.runs()
    assert runs.dtype.names == ("id", "parent", "ref", "kind", "label", "status",
                                "started_unix_s", "duration_s")
    assert runs["id"].tolist() == [1, 2]
    assert runs[1]["label"] == "é label, with comma"
    assert runs[1]["parent"] == 1 and runs[1]["status"] == "running"
    assert runs[0]["duration_s"] == 2.25


def test_samples_are_the_rows_sqlite_holds(db_path):
    path, rows = db_path
    db = st.TwinDb(path)
    s = db.samples(1, "physical")
    assert s.dtype.names == ("t_s", "seq", "d1_m", "q2_rad", "q3_rad", "q4_rad", "grip_deg")
    assert s.dtype["seq"] == np.int64 and len(s) == 500
    expect = np.array([r[2:] for r in rows], dtype=float)
    got = np.stack([s[n].astype(float) for n in s.dtype.names], axis=1)
    np.testing.assert_array_equal(got, expect)
    planned = db.samples(1, "planned")
    assert planned["seq"].tolist() == [-1]  # NULL: no device sequence number
    assert len(db.samples(2, "physical")) == 0
    with pytest.raises(ValueError, match="source 'physcal': expected 'planned', 'virtual'"):
        db.samples(1, "physcal")


def test_latencies_events_metrics(db_path):
    path, _ = db_path
    db = st.TwinDb(path)
    lat = db.latencies(1)
    assert (lat["sim_apply_us"] - lat["hub_rx_us"]).tolist() == [400 + i for i in range(50)]
    ev = db.events(1)
    assert ev["kind"].tolist() == ["statement", "error"]
    assert ev["detail"].tolist() == ["move 0.2 0 0", "a: b: c"]
    m = db.metrics(1)
    assert (m[0]["name"], m[0]["value"], m[0]["unit"]) == ("tool_error", 0.0004, "m")


def test_frames_with_pandas(db_path):
    pd = pytest.importorskip("pandas")
    path, rows = db_path
    df = st.TwinDb(path).samples(1, frame=True)
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == ["t_s", "seq", "d1_m", "q2_rad", "q3_rad", "q4_rad", "grip_deg"]
    assert df["seq"].sum() == sum(r[3] for r in rows)


def test_a_file_that_is_not_a_database(tmp_path):
    bad = tmp_path / "not.db"
    bad.write_text("this is not sqlite" * 100)
    with pytest.raises(st.DatabaseError) as e:
        st.TwinDb(bad)
    assert "database" in str(e.value)
