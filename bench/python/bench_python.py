#!/usr/bin/env python3
"""Batched and single FK/IK from Python beside the C++ benchmark (bench/core).

    PYTHONPATH=build/release/python taskset -c 1 python3 bench/python/bench_python.py [N]

10^6 random reachable targets by default (FK of random joints inside the limits, fixed
seed); IK seeded with the home pose, as bench_kinematics does. Runs bench_kinematics (BM_Fk,
BM_Ik) from the same build for the C++ per-call figures and prints one table with the ratios.
"""
import json
import subprocess
import sys
import time
import timeit

import numpy as np

import scaratwin as st


def best_of(f, repeat=5):
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t0)
    return best


def cpp_figures():
    exe = st.bin_dir() / "bench_kinematics"
    out = subprocess.run([str(exe), "--benchmark_filter=BM_(Fk|Ik)$",
                          "--benchmark_min_time=0.3", "--benchmark_format=json"],
                         capture_output=True, text=True, check=True)
    text = out.stdout[out.stdout.index("{"):out.stdout.rindex("}") + 1]
    runs = json.loads(text)["benchmarks"]
    return {b["name"]: b["real_time"] for b in runs}  # ns


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    robot = st.default_robot()
    rng = np.random.default_rng(12345)
    lim = robot.limits
    q = lim[:, 0] + rng.random((n, 4)) * (lim[:, 1] - lim[:, 0])
    poses = st.fk(q)

    fk_batch = best_of(lambda: st.fk(q)) / n * 1e9
    ik_batch = best_of(lambda: st.ik(poses)) / n * 1e9
    joints, status = st.ik(poses)
    solved = (status == 0).mean()
    worst = np.abs(st.fk(joints)[:, :3] - poses[:, :3]).max()

    one_q = q[0].copy()
    one_list = [float(v) for v in q[0]]
    one_pose = poses[0].copy()
    reps = 200_000
    fk_single = min(timeit.repeat(lambda: st.fk(one_q), number=reps, repeat=5)) / reps * 1e9
    fk_list = min(timeit.repeat(lambda: st.fk(one_list), number=reps, repeat=5)) / reps * 1e9
    ik_single = min(timeit.repeat(lambda: st.ik(one_pose), number=reps, repeat=5)) / reps * 1e9

    cpp = cpp_figures()
    print(f"scaratwin from Python, {n:,} targets (best of 5), beside bench_kinematics (C++)")
    print(f"{'':34}{'Python':>12}{'C++':>12}{'C++/Python':>12}")
    print(f"{'IK batched, per target':34}{ik_batch:>10.1f}ns{cpp['BM_Ik']:>10.1f}ns"
          f"{cpp['BM_Ik'] / ik_batch:>12.2f}")
    print(f"{'FK batched, per target':34}{fk_batch:>10.1f}ns{cpp['BM_Fk']:>10.1f}ns"
          f"{cpp['BM_Fk'] / fk_batch:>12.2f}")
    print(f"{'fk() one (4,) float64 array':34}{fk_single:>10.1f}ns")
    print(f"{'fk() one list of 4 floats':34}{fk_list:>10.1f}ns")
    print(f"{'ik() one (4,) float64 array':34}{ik_single:>10.1f}ns")
    print(f"IK solved {solved:.2%}, worst FK round-trip position error {worst:.1e} m")


if __name__ == "__main__":
    main()
