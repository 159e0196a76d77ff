#!/usr/bin/env python3
"""Plot a recorded run from the twin database with matplotlib: the planned, physical and
virtual joints over time, and the tool path seen from above (FK of the physical joints).

    PYTHONPATH=build/release/python python3 examples/python/plot_run.py \\
        --db scaratwin-out/twin.db --out run.png          # the latest run by default
"""
import argparse
import sys

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import scaratwin as st  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--db", default="scaratwin-out/twin.db")
    ap.add_argument("--run", type=int, help="run id (default: the latest run with samples)")
    ap.add_argument("--out", default="run.png")
    args = ap.parse_args()

    db = st.TwinDb(args.db)
    runs = db.runs()
    if args.run is None:
        with_samples = [r for r in runs["id"][::-1] if len(db.samples(int(r), "physical"))]
        if not with_samples:
            print(f"{args.db}: no run has physical samples")
            return 1
        args.run = int(with_samples[0])
    run = runs[runs["id"] == args.run][0]
    sources = {s: db.samples(args.run, s) for s in ("planned", "physical", "virtual")}
    print(f"run {args.run} ({run['kind']}: {run['label']}, {run['status']}): " +
          ", ".join(f"{len(v)} {k}" for k, v in sources.items()))

    fig, axes = plt.subplots(2, 3, figsize=(14, 7))
    joints = [("d1_m", "d1 (m)", 1.0), ("q2_rad", "q2 (deg)", 180 / np.pi),
              ("q3_rad", "q3 (deg)", 180 / np.pi), ("q4_rad", "q4 (deg)", 180 / np.pi)]
    for ax, (name, label, scale) in zip(axes.flat, joints):
        for source, samples in sources.items():
            if len(samples):
                ax.plot(samples["t_s"], samples[name] * scale, label=source, lw=1)
        ax.set_xlabel("t (s)")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes.flat[0].legend()
    physical = sources["physical"]
    ax = axes.flat[4]
    q = np.column_stack([physical[n] for n in ("d1_m", "q2_rad", "q3_rad", "q4_rad")])
    tool = st.fk(q)  # the tool path, batched FK
    ax.plot(tool[:, 0], tool[:, 1], lw=1)
    for color, tray in db_robot_trays().items():
        ax.add_patch(plt.Rectangle((tray["x_m"] - tray["size_m"] / 2,
                                    tray["y_m"] - tray["size_m"] / 2),
                                   tray["size_m"], tray["size_m"], fill=False, color=color))
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("tool path (physical)")
    axes.flat[5].plot(physical["t_s"], physical["grip_deg"])
    axes.flat[5].set_xlabel("t (s)")
    axes.flat[5].set_ylabel("gripper (deg)")
    fig.suptitle(f"run {args.run}: {run['label']}")
    fig.tight_layout()
    fig.savefig(args.out, dpi=80)
    print(f"wrote {args.out}")
    return 0


def db_robot_trays():
    return st.default_robot().scene["trays"]


if __name__ == "__main__":
    sys.exit(main())
