"""The robot description and kinematics from Python, checked against independent oracles: the
standard DH product written here in numpy from the paper's Table 1, finite differences, the
motor conversions of the description written out, and the scaratwin command line."""
import json
import math
import subprocess

import numpy as np
import pytest

import scaratwin as st

# The paper's DH table (Table 1; DESIGN.md): (a_m, d_m) of J1..J4, J1 prismatic.
PAPER_A = [0.067, 0.092, 0.095, 0.0]
PAPER_D = [0.0, -0.017, -0.010, -0.040]


def dh(theta, d, a, alpha):
    """Standard DH (Craig): Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    ct, stt, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -stt * ca, stt * sa, a * ct],
                     [stt, ct * ca, -ct * sa, a * stt],
                     [0, sa, ca, d],
                     [0, 0, 0, 1.0]])


def fk_oracle(q):
    """Tool pose (x, y, z, yaw) from the DH product of the paper's table."""
    d1, q2, q3, q4 = q
    T = dh(0.0, d1 + PAPER_D[0], PAPER_A[0], 0.0)
    T = T @ dh(q2, PAPER_D[1], PAPER_A[1], 0.0)
    T = T @ dh(q3, PAPER_D[2], PAPER_A[2], 0.0)
    T = T @ dh(q4, PAPER_D[3], PAPER_A[3], 0.0)
    return np.array([T[0, 3], T[1, 3], T[2, 3], math.atan2(T[1, 0], T[0, 0])])


def random_joints(robot, n, seed=7):
    rng = np.random.default_rng(seed)
    lim = robot.limits
    return lim[:, 0] + rng.random((n, 4)) * (lim[:, 1] - lim[:, 0])


@pytest.fixture(scope="module")
def robot():
    return st.default_robot()


def test_description_is_the_papers_robot(robot):
    assert robot.name == "paper-scara"
    assert robot.path.endswith("scara.toml")
    np.testing.assert_allclose(robot.dh["a_m"], PAPER_A)
    np.testing.assert_allclose(robot.dh["d_m"], PAPER_D)
    assert list(robot.dh["type"]) == ["prismatic", "revolute", "revolute", "revolute"]
    np.testing.assert_allclose(robot.limits[0], [0.01, 0.12])
    np.testing.assert_allclose(np.degrees(robot.limits[1]), [-105, 115])
    np.testing.assert_allclose(robot.home, [0.12, 0, 0, 0])
    assert robot.motors["j3_per_j2_coupling"] == 0.8
    assert set(robot.scene["trays"]) == {"red", "green", "blue"}


def test_as_built_profile_and_draw(robot):
    prof = robot.as_built
    assert prof["tolerance"]["a2_m"] == pytest.approx(1e-3)  # 1 mm by default
    drawn = robot.draw_as_built()
    assert set(drawn) == set(prof["tolerance"])
    for key, tol in prof["tolerance"].items():
        assert abs(drawn[key]) <= tol + 1e-15, key
    # the same seed is the same robot
    assert st.load_robot(robot.path).draw_as_built() == drawn


def test_fk_matches_the_dh_product(robot):
    q = random_joints(robot, 200)
    poses = st.fk(q)
    assert poses.shape == (200, 4) and poses.dtype == np.float64
    for qi, pi in zip(q, poses):
        o = fk_oracle(qi)
        np.testing.assert_allclose(pi[:3], o[:3], atol=1e-12)
        assert abs(math.remainder(pi[3] - o[3], 2 * math.pi)) < 1e-12


def test_fk_of_home_is_the_design_closed_form():
    x, y, z, yaw = st.fk([0.12, 0, 0, 0])
    assert (x, y, z, yaw) == pytest.approx((0.067 + 0.092 + 0.095, 0.0, 0.12 - 0.067, 0.0))


def test_batched_equals_single_bit_for_bit(robot):
    q = random_joints(robot, 50, seed=3)
    batch = st.fk(q)
    for i in range(len(q)):
        assert np.array_equal(st.fk(q[i]), batch[i])
    joints, status = st.ik(batch)
    for i in range(len(q)):
        j1, s1 = st.ik(batch[i])
        assert s1 == status[i]
        assert np.array_equal(j1, joints[i])


def test_ik_returns_the_joints_the_dh_product_came_from(robot):
    q = random_joints(robot, 500, seed=11)
    poses = np.array([fk_oracle(qi) for qi in q])
    joints, status = st.ik(poses, seed=q)  # one seed per row: the nearest solution is q itself
    assert status.dtype == np.int32 and status.shape == (500,)
    assert (status == 0).all()
    np.testing.assert_allclose(joints, q, atol=1e-9)


def test_ik_status_codes_and_nan_rows():
    poses = np.array([
        [0.20, 0.05, -0.02, 1.5],            # reachable
        [0.067 + 0.20, 0.0, 0.0, 0.0],       # r = 0.2 m > a2 + a3 = 0.187 m
        [0.067 + 0.001, 0.0, 0.0, 0.0],      # r = 1 mm < |a2 - a3| = 3 mm
        [0.20, 0.05, 0.10, 0.0],             # d1 = z + 0.067 = 0.167 m > 0.12 m
    ])
    joints, status = st.ik(poses)
    assert status.tolist() == [0, st.IkError.BEYOND_REACH, st.IkError.INSIDE_DEAD_ZONE,
                               st.IkError.Z_OUT_OF_TRAVEL]
    assert np.isfinite(joints[0]).all()
    assert np.isnan(joints[1:]).all()
    q, s = st.ik(poses[1])
    assert s == 2 and isinstance(s, int) and np.isnan(q).all() and q.shape == (4,)


def test_ik_all_gives_both_elbows_and_the_cli_reason(robot):
    sols = st.ik_all([0.247, 0.0, -0.02, math.pi / 2])
    assert sols.shape == (2, 4)
    assert sols[0, 2] * sols[1, 2] < 0  # the two elbow signs
    with pytest.raises(st.UnreachableError) as e:
        st.ik_all([0.067 + 0.2, 0, 0, 0])
    assert e.value.code == 2
    cli = subprocess.run([str(st.bin_dir() / "scaratwin"), "ik", str(0.067 + 0.2), "0", "0", "0"],
                         capture_output=True, text=True)
    assert cli.returncode == 1
    assert cli.stderr.strip() == "scaratwin ik: " + str(e.value)


def test_fk_and_ik_agree_with_the_command_line():
    q_deg = [0.1, 30.0, 45.0, 10.0]
    out = subprocess.run([str(st.bin_dir() / "scaratwin"), "fk", *map(str, q_deg), "--json"],
                         capture_output=True, text=True, check=True)
    cli = json.loads(out.stdout)
    p = st.fk([0.1, math.radians(30), math.radians(45), math.radians(10)])
    assert p == pytest.approx([cli["x_m"], cli["y_m"], cli["z_m"], math.radians(cli["yaw_deg"])],
                              abs=1e-12)
    out = subprocess.run([str(st.bin_dir() / "scaratwin"), "ik", "0.2", "0.05", "-0.02", "150",
                          "--json"], capture_output=True, text=True, check=True)
    cli = json.loads(out.stdout)
    q, s = st.ik([0.2, 0.05, -0.02, math.radians(150)])
    assert s == 0
    assert q == pytest.approx([cli["d1_m"], math.radians(cli["q2_deg"]),
                               math.radians(cli["q3_deg"]), math.radians(cli["q4_deg"])], abs=1e-12)


def test_jacobian_matches_finite_differences(robot):
    q = random_joints(robot, 20, seed=5)
    J = st.jacobian(q)
    assert J.shape == (20, 4, 4)
    h = 1e-6
    for qi, Ji in zip(q, J):
        num = np.empty((4, 4))
        for j in range(4):
            dq = np.zeros(4)
            dq[j] = h
            num[:, j] = (fk_oracle(qi + dq) - fk_oracle(qi - dq)) / (2 * h)
        np.testing.assert_allclose(Ji, num, atol=1e-8)
    assert st.jacobian(q[0]).shape == (4, 4)


def test_joint_step_conversions_follow_the_description(robot):
    m = robot.motors
    q = np.array([[0.1, 0.4, -0.3, 1.0], [0.05, -1.0, 2.0, 0.2]])  # no half steps
    steps, wrist = st.joints_to_motors(q)
    kz, k2, k3 = m["z"]["steps_per_unit"], m["j2"]["steps_per_unit"], m["j3"]["steps_per_unit"]
    assert (kz, k2, k3) == (205560.0, 945.0, 1455.0)
    m2 = q[:, 1] * k2
    expected = np.stack([q[:, 0] * kz, m2, q[:, 2] * k3 + 0.8 * m2], axis=1)
    np.testing.assert_allclose(steps, expected, rtol=1e-12)
    whole = st.joints_to_steps(q)
    assert whole.dtype == np.int32
    assert np.array_equal(whole, np.rint(expected).astype(np.int32))
    back = st.motors_to_joints(steps, wrist)
    np.testing.assert_allclose(back, q, atol=1e-12)


def test_outside_limits_names_the_joint(robot):
    assert st.outside_limits(robot.home) == -1
    assert st.outside_limits([[0.2, 0, 0, 0], [0.1, 0, math.radians(210), 0]]).tolist() == [0, 2]


@pytest.mark.parametrize("bad, exc, message", [
    (np.zeros(3), ValueError, "fk: joints must have shape (4,) or (N, 4), got shape (3,)"),
    (np.zeros((2, 5)), ValueError, "fk: joints must have shape (4,) or (N, 4), got shape (2, 5)"),
    (np.zeros((2, 4, 1)), ValueError, "got shape (2, 4, 1)"),
    (np.zeros(4, dtype=complex), TypeError,
     "fk: joints has dtype complex128; expected real numbers"),
    (np.array(["a", "b", "c", "d"]), TypeError, "fk: joints has dtype <U1"),
])
def test_fk_refuses_bad_arrays(bad, exc, message):
    with pytest.raises(exc) as e:
        st.fk(bad)
    assert message in str(e.value)


def test_ik_refuses_nan_targets_naming_the_row():
    poses = np.array([[0.2, 0.05, -0.02, 0.0], [np.nan, 0.0, 0.0, 0.0]])
    with pytest.raises(ValueError) as e:
        st.ik(poses)
    assert str(e.value) == ("ik: poses[1] has a value that is not finite (NaN or infinite) "
                            "in column 0")
    with pytest.raises(ValueError, match=r"ik: seed must have shape \(4,\) or the shape of poses"):
        st.ik(poses[:1], seed=np.zeros((3, 4)))


def test_integer_and_list_input_is_accepted():
    assert np.array_equal(st.fk([0, 0, 0, 0]), st.fk(np.zeros(4)))
    assert np.array_equal(st.fk(np.zeros((2, 4), dtype=np.int64)), st.fk(np.zeros((2, 4))))
    q = [0.1, 0.2, -0.3, 1]
    assert np.array_equal(st.fk(q), st.fk(np.array(q, dtype=float)))
    assert np.array_equal(st.fk(tuple(q)), st.fk(np.array(q, dtype=float)))
    assert np.array_equal(st.fk(np.array(q)[::-1][::-1]), st.fk(q))  # a strided view
    with pytest.raises(ValueError, match=r"got shape \(3,\)"):
        st.fk([0.1, 0.2, 0.3])
    with pytest.raises(TypeError, match="dtype bool"):
        st.fk([True, False, True, False])


def test_bad_description_raises_the_cli_message(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[limits]\nj1_m = [0.2, 0.1]\n")
    with pytest.raises(st.ConfigError) as e:
        st.load_robot(bad)
    assert isinstance(e.value, ValueError)
    cli = subprocess.run([str(st.bin_dir() / "scaratwin"), "fk", "0.1", "0", "0", "0",
                          "--config", str(bad)], capture_output=True, text=True)
    assert cli.returncode == 2
    assert cli.stderr.strip() == "scaratwin: " + str(e.value)


def test_another_robot_changes_the_kinematics():
    longer = st.parse_robot("[dh.j2]\na_m = 0.1\n")
    assert st.fk([0.12, 0, 0, 0], robot=longer)[0] == pytest.approx(0.067 + 0.1 + 0.095)
    assert st.fk([0.12, 0, 0, 0])[0] == pytest.approx(0.067 + 0.092 + 0.095)


def test_a_calibration_overlay_is_the_robot_as_measured(tmp_path):
    base = st.default_robot()
    overlay = tmp_path / "calibrated.toml"
    overlay.write_text(f'base = "{base.path}"\n\n[calibration]\ndate = "2026-11-24T05:00:00Z"\n'
                       '[calibration.identified]\na2_mm = [0.5, 0.01]\n'
                       'j2_zero_deg = [0.3, 0.02]\nwrist_gain_percent = [1.0, 0.1]\n')
    robot = st.load_robot(overlay)
    assert not base.calibrated and base.webcam is None
    assert robot.calibrated and robot.path == str(overlay)
    assert robot.dh["a_m"][1] == pytest.approx(0.0925, abs=1e-15)
    cal = robot.calibration
    assert cal["j2_zero_rad"] == pytest.approx(math.radians(0.3))
    assert cal["wrist_gain"] == pytest.approx(0.01)
    # FK of the measured robot: the DH product with a2 = 92.5 mm
    q = np.array([0.1, 0.4, 0.7, 0.2])
    expected = fk_oracle(q) + np.array([0.0005 * math.cos(0.4), 0.0005 * math.sin(0.4), 0, 0])
    np.testing.assert_allclose(st.fk(q, robot=robot), expected, atol=1e-12)
    # the joint map of robot_model.hpp: q2 = q2_fw + j2_zero, q4 = (1 + wrist_gain) q4_fw
    true = st.firmware_to_joints(q, robot=robot)
    np.testing.assert_allclose(true, [0.1, 0.4 + math.radians(0.3), 0.7, 0.2 * 1.01], atol=1e-12)
    np.testing.assert_allclose(st.joints_to_firmware(true, robot=robot), q, atol=1e-12)
    np.testing.assert_array_equal(st.firmware_to_joints(q), q)  # identity uncalibrated
