#!/usr/bin/env python3
"""Pick and place from Python: spawn a cube in the virtual scene, plan its pick-and-place with
numpy arrays (a batched IK picks a heading the wrist can reach), run the plan on the robot
while the simulator mirrors it, and check that the cube ended in its tray.

    scaratwin sim &  scaratwin robot &        # the robot prints its pty
    PYTHONPATH=build/release/python python3 examples/python/pick_place.py --serial /dev/pts/3

Exit status 0 when the cube lies in the tray of its colour.
"""
import argparse
import sys

import numpy as np

import scaratwin as st


def reachable_pose(x_m, y_m, z_m, seed):
    """(x, y, z, yaw) with the first heading, in 15 degree steps, that IK solves."""
    yaws = np.radians(np.arange(0, 360, 15))
    poses = np.column_stack([np.full_like(yaws, x_m), np.full_like(yaws, y_m),
                             np.full_like(yaws, z_m), yaws])
    _, status = st.ik(poses, seed=seed)  # one call for every heading
    solved = np.flatnonzero(status == 0)
    if solved.size == 0:
        raise SystemExit(f"no heading reaches ({x_m}, {y_m}, {z_m}): IK codes {set(status)}")
    return poses[solved[0]]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--serial", help="the robot's serial port (default: $SCARATWIN_SERIAL)")
    ap.add_argument("--sim", default="127.0.0.1:55016", help="the simulator, HOST:PORT")
    ap.add_argument("--db", default="scaratwin-out/twin.db", help="twin database")
    ap.add_argument("--color", default="red", choices=["red", "green", "blue"])
    ap.add_argument("--at", nargs=2, type=float, default=[0.18, 0.08], metavar=("X_M", "Y_M"))
    args = ap.parse_args()

    with st.connect(serial=args.serial, sim=args.sim, db=args.db, label="pick_place.py") as twin:
        robot = twin.robot
        scene = robot.scene
        print(twin.home())
        twin.reset()
        cube_id = twin.spawn(args.color, *args.at)
        cube = twin.objects()[0]
        print(f"cube {cube_id} ({cube['color']}) at ({cube['x_m']:.4f}, {cube['y_m']:.4f}) m")

        q0 = twin.state()["q"]
        tray = scene["trays"][args.color]
        pick = reachable_pose(cube["x_m"], cube["y_m"], scene["grasp_z_m"], q0)
        place = reachable_pose(tray["x_m"], tray["y_m"], scene["grasp_z_m"], q0)
        plan = st.plan_pick_place(q0, pick, place)
        print(f"plan: {len(plan)} samples over {plan.duration_s:.2f} s, gripper {plan.events}")
        # the plan as arrays: the tool's path and the fastest joint
        tool = st.fk(plan.q)
        print(f"tool travels {np.linalg.norm(np.diff(tool[:, :3], axis=0), axis=1).sum():.3f} m; "
              f"peak shoulder speed {np.degrees(np.abs(plan.qd[:, 1]).max()):.1f} deg/s")

        points = twin.run_trajectory(plan)
        print(f"ran {points} points")
        cube = twin.objects()[0]
        inside = (abs(cube["x_m"] - tray["x_m"]) < tray["size_m"] / 2
                  and abs(cube["y_m"] - tray["y_m"]) < tray["size_m"] / 2)
        print(f"cube now at ({cube['x_m']:.4f}, {cube['y_m']:.4f}) m: "
              f"{'in' if inside else 'NOT in'} the {args.color} tray")
        twin.movej(robot.home)
    return 0 if inside else 1


if __name__ == "__main__":
    sys.exit(main())
