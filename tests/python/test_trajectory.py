"""Trajectories from Python: the arrays are the C++ samples (views, no copy), the quintic is
the polynomial written out here, and the planners keep their limits and error codes."""
import math

import numpy as np
import pytest

import scaratwin as st


def test_quintic_is_the_jtraj_polynomial():
    q0 = np.array([0.12, 0.0, 0.0, 0.0])
    q1 = np.array([0.1, math.radians(30), math.radians(45), math.radians(10)])
    tr = st.quintic(q0, q1, 6.0, 61)
    assert len(tr) == 61 and tr.duration_s == pytest.approx(6.0)
    s = tr.t / 6.0
    blend = 10 * s**3 - 15 * s**4 + 6 * s**5
    dblend = (30 * s**2 - 60 * s**3 + 30 * s**4) / 6.0
    ddblend = (60 * s - 180 * s**2 + 120 * s**3) / 36.0
    np.testing.assert_allclose(tr.t, np.linspace(0, 6, 61), atol=1e-12)
    np.testing.assert_allclose(tr.q, q0 + np.outer(blend, q1 - q0), atol=1e-12)
    np.testing.assert_allclose(tr.qd, np.outer(dblend, q1 - q0), atol=1e-12)
    np.testing.assert_allclose(tr.qdd, np.outer(ddblend, q1 - q0), atol=1e-12)


def test_arrays_are_read_only_views_of_the_samples():
    tr = st.quintic(np.zeros(4), np.ones(4) * 0.05, 1.0, 10)
    q = tr.q
    assert q.base is not None and not q.flags.writeable and not q.flags.owndata
    # t, q, qd and qdd interleave in one buffer of 13 doubles per sample
    assert q.strides == (13 * 8, 8)
    assert isinstance(q.base, st.Trajectory)
    address = {name: getattr(tr, name).__array_interface__["data"][0] for name in
               ("t", "q", "qd", "qdd")}
    assert [address[n] - address["t"] for n in ("q", "qd", "qdd")] == [8, 5 * 8, 9 * 8]
    assert tr.q.__array_interface__["data"][0] == address["q"]  # the same buffer each time
    with pytest.raises(ValueError):
        q[0, 0] = 1.0
    del tr  # the view keeps the samples alive
    assert q[-1, 0] == pytest.approx(0.05)


def test_plan_quintic_honours_the_motor_limits():
    robot = st.default_robot()
    q1 = np.array([0.05, math.radians(60), math.radians(-45), math.radians(90)])
    tr = st.plan_quintic(robot.home, q1)
    assert len(tr) == 60
    tr.check_limits()
    # the motors' peak speed (steps/s) stays within 5,000 steps/s of the description
    k = robot.motors
    speeds = np.abs(tr.qd[:, :3]) * [k["z"]["steps_per_unit"], k["j2"]["steps_per_unit"], 1]
    assert speeds[:, :2].max() <= k["z"]["max_speed_steps_s"] * (1 + 1e-6)


def test_plan_quintic_outside_the_limits_raises_plan_error():
    with pytest.raises(st.PlanError) as e:
        st.plan_quintic([0.12, 0, 0, 0], [0.2, 0, 0, 0])
    assert e.value.code == 11


def test_trapezoid_via_line_and_pick_place():
    robot = st.default_robot()
    q1 = np.array([0.08, 0.5, 0.5, 0.5])
    tr = st.plan_trapezoid(robot.home, q1, dt_s=0.01)
    np.testing.assert_allclose(tr.q[-1], q1, atol=1e-12)
    assert np.all(np.diff(tr.t) > 0)
    via = st.plan_via_points([robot.home, q1, robot.home], profile="quintic", quintic_samples=20)
    np.testing.assert_allclose(via.q[-1], robot.home, atol=1e-12)
    start, status = st.ik([0.2, 0.0, -0.02, 1.5])
    assert status == 0
    line = st.plan_line(start, [0.2, 0.08, -0.02, 1.5])
    poses = st.fk(line.q)
    # every sample on the straight line x = 0.2, z = -0.02 (the IK samples are 1 mm apart)
    np.testing.assert_allclose(poses[:, 0], 0.2, atol=1e-6)
    np.testing.assert_allclose(poses[:, 2], -0.02, atol=1e-9)
    pp = st.plan_pick_place(robot.home, [0.18, 0.08, -0.02, 1.5], [0.17, -0.11, -0.02, 1.5])
    assert [a for _, a in pp.events] == ["grip", "release"]
    pp.check_limits()


def test_trajectory_from_arrays_round_trips():
    t = np.array([0.0, 0.5, 1.0])
    q = np.array([[0.1, 0, 0, 0], [0.1, 0.1, 0, 0], [0.1, 0.2, 0, 0]])
    tr = st.Trajectory(t, q, events=[(0.5, "grip")])
    np.testing.assert_array_equal(tr.q, q)
    np.testing.assert_array_equal(tr.qd, np.zeros((3, 4)))
    assert tr.sample_at(0.25)[1] == pytest.approx(0.05)
    with pytest.raises(ValueError, match="times must start at 0 and strictly increase"):
        st.Trajectory([0.0, 0.0], q[:2])
    with pytest.raises(ValueError, match="expected 'grip' or 'release'"):
        st.Trajectory(t, q, events=[(0.1, "open")])
