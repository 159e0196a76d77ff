#!/usr/bin/env python3
"""Colour sorting from the camera picture, in Python: spawn cubes, take the overhead camera's
picture as a numpy array, find the cubes in it (the twin's colour recognition, and a plain
numpy mask beside it), then pick every cube and place it in the tray of its colour.

    PYTHONPATH=build/release/python python3 examples/python/sort_colours.py --serial /dev/pts/3

Exit status 0 when every cube lies in its tray.
"""
import argparse
import sys

import numpy as np

import scaratwin as st

# on the free side of the table, 45 mm or more apart, none in a tray (a cube spawned inside
# another colour's tray is in the way of the cube placed there)
CUBES = [("red", 0.20, 0.06), ("green", 0.16, -0.02), ("blue", 0.15, 0.10)]


def numpy_mask(picture, color):
    """Pixels whose colour channel dominates the other two (uint8 RGB, (H, W, 3))."""
    rgb = picture.astype(np.int32)
    c = {"red": 0, "green": 1, "blue": 2}[color]
    others = [i for i in range(3) if i != c]
    return (rgb[..., c] > 80) & (rgb[..., c] > 1.8 * rgb[..., others].max(axis=-1))


def in_tray(robot, obj):
    tray = robot.scene["trays"][obj["color"]]
    return (abs(obj["x_m"] - tray["x_m"]) < tray["size_m"] / 2
            and abs(obj["y_m"] - tray["y_m"]) < tray["size_m"] / 2)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--serial", help="the robot's serial port (default: $SCARATWIN_SERIAL)")
    ap.add_argument("--sim", default="127.0.0.1:55016", help="the simulator, HOST:PORT")
    ap.add_argument("--db", default="scaratwin-out/twin.db", help="twin database")
    ap.add_argument("--picture", help="save the camera picture (PNG) here")
    args = ap.parse_args()

    with st.connect(serial=args.serial, sim=args.sim, db=args.db, label="sort_colours.py") as twin:
        robot = twin.robot
        scene = robot.scene
        print(twin.home())
        twin.reset()
        for color, x, y in CUBES:
            twin.spawn(color, x, y)

        picture = twin.shoot(args.picture)
        print(f"picture {picture.shape} {picture.dtype}")
        found = st.detect_cubes(picture)
        for d in found:
            mask = numpy_mask(picture, d["color"])
            rows, cols = np.nonzero(mask)
            print(f"{d['color']:>5}: {d['area_px']} px at pixel ({d['col']:.1f}, {d['row']:.1f}) "
                  f"-> table ({d['x_m']:.4f}, {d['y_m']:.4f}) m; numpy mask {mask.sum()} px "
                  f"around ({cols.mean():.1f}, {rows.mean():.1f})")
        if len(found) != len(CUBES):
            print(f"found {len(found)} cubes, spawned {len(CUBES)}")
            return 1

        for d in found:
            q0 = twin.state()["q"]
            tray = scene["trays"][d["color"]]
            z = scene["grasp_z_m"]
            # a heading the wrist reaches at both ends: one batched IK over 24 headings each
            yaws = np.radians(np.arange(0, 360, 15))
            ends = []
            for x, y in ((d["x_m"], d["y_m"]), (tray["x_m"], tray["y_m"])):
                poses = np.column_stack([np.full(24, x), np.full(24, y), np.full(24, z), yaws])
                ends.append((poses, st.ik(poses, seed=q0)[1] == 0))
            both = np.flatnonzero(ends[0][1] & ends[1][1])
            k = both[0] if both.size else 0
            plan = st.plan_pick_place(q0, ends[0][0][k], ends[1][0][k])
            twin.run_trajectory(plan)
            print(f"{d['color']}: placed ({plan.duration_s:.1f} s)")

        objects = twin.objects()
        ok = all(in_tray(robot, o) for o in objects)
        for o in objects:
            print(f"cube {o['id']} {o['color']:>5} at ({o['x_m']:.4f}, {o['y_m']:.4f}) m "
                  f"{'in its tray' if in_tray(robot, o) else 'NOT in its tray'}")
        twin.movej(robot.home)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
