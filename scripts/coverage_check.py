#!/usr/bin/env python3
"""Coverage per module from gcovr's JSON summary (scripts/coverage.sh): prints lines and branches
per module and fails, naming each module, when one is under its floor (docs/coverage.md): the
pure core (kinematics, trajectory, protocol: docs/DESIGN) at 95 % of lines, each of the
firmware's host-built modules at 90 %. The other modules measured are reported, with no floor."""
import json
import re
import sys

# (module, path pattern, floor in % of lines or None)
MODULES = [
    ("kinematics", r"src/kinematics/", 95.0),
    ("trajectory", r"src/trajectory/", 95.0),
    ("protocol", r"src/protocol/", 95.0),
    ("firmware motion", r"firmware/src/motion\.", 90.0),
    ("firmware ramp", r"firmware/src/ramp\.", 90.0),
    ("firmware settings", r"firmware/src/settings\.", 90.0),
    ("firmware companion", r"firmware/src/companion\.", 90.0),
    ("firmware segment", r"firmware/src/segment\.", 90.0),
    ("firmware servo_math", r"firmware/src/servo_math\.", 90.0),
    ("calibration", r"src/calibration/", None),
    ("config", r"src/config/", None),
    ("plant", r"src/plant/", None),
    ("vision", r"src/vision/", None),
    ("fleet (topics, watcher)", r"src/fleet/(topics|fleet_watch)\.", None),
]


def main(path):
    with open(path) as f:
        files = json.load(f)["files"]
    rows, failed, seen = [], [], set()
    for name, pattern, floor in MODULES:
        mine = [f for f in files if re.match(pattern, f["filename"])]
        seen.update(f["filename"] for f in mine)
        if not mine:
            failed.append(f"{name}: no file measured (pattern {pattern})")
            continue
        lc = sum(f["line_covered"] for f in mine)
        lt = sum(f["line_total"] for f in mine)
        bc = sum(f["branch_covered"] for f in mine)
        bt = sum(f["branch_total"] for f in mine)
        lines = 100.0 * lc / lt if lt else 100.0
        branches = 100.0 * bc / bt if bt else 100.0
        verdict = "-" if floor is None else ("ok" if lines >= floor else "UNDER")
        rows.append((name, lc, lt, lines, bc, bt, branches, floor, verdict))
        if floor is not None and lines < floor:
            worst = min(mine, key=lambda f: f["line_percent"])
            failed.append(f"{name}: {lines:.1f} % of lines, under its floor of {floor:.0f} % "
                          f"(least covered: {worst['filename']}, {worst['line_percent']:.1f} %)")
    stray = sorted(f["filename"] for f in files if f["filename"] not in seen)
    if stray:
        failed.append("files in no module: " + ", ".join(stray))
    print(f"{'module':<20} {'lines':>13} {'%':>6} {'branches':>13} {'%':>6} {'floor':>6}")
    for name, lc, lt, lines, bc, bt, branches, floor, verdict in rows:
        fl = "" if floor is None else f"{floor:.0f}"
        print(f"{name:<20} {lc:>6}/{lt:<6} {lines:>6.1f} {bc:>6}/{bt:<6} {branches:>6.1f} "
              f"{fl:>6} {verdict}")
    for msg in failed:
        print(f"coverage: {msg}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: coverage_check.py <gcovr --json-summary file>")
    sys.exit(main(sys.argv[1]))
