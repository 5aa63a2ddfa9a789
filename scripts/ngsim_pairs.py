#!/usr/bin/env python3
"""Ego/partner pairs from real freeway trajectories, as a `riskctl ssm` input CSV.

Reads NGSIM US-101 scenarios in the CommonRoad XML format (one `<dynamicObstacle>` per recorded
road user, states at 0.1 s steps), and writes one row per ordered pair of road users present in the
same time step whose box centres are at most --radius metres apart:

    scenario,step,id_i,id_j,x_i,y_i,vx_i,vy_i,hx_i,hy_i,acc_i,length_i,width_i,x_j,...,width_j

Positions, accelerations and box sizes are copied as recorded; velocity is recorded as a scalar
along the heading, so v_x = v cos(theta), v_y = v sin(theta), and the heading vector is
(cos(theta), sin(theta)), written with 4 and 6 decimals like highD/NGSIM exports.

The recordings hold about 73,000 states; when --rows asks for more pairs than they contain, the
pairs are repeated in the same order (a "pass" column counts the repetitions) so every row is still
a real pair. Standard library only.

    scripts/ngsim_pairs.py --data ../shared/data/ngsim-us101 --rows 1000000 --out pairs.csv
"""
import argparse
import glob
import math
import os
import sys
import xml.etree.ElementTree as ET


def road_users(path):
    """Yield (id, length, width, {step: (x, y, theta, v, acc, x_text, y_text, acc_text)})."""
    root = ET.parse(path).getroot()
    for obstacle in root.iter("dynamicObstacle"):
        rect = obstacle.find("shape/rectangle")
        length = rect.findtext("length")
        width = rect.findtext("width")
        states = {}
        nodes = [obstacle.find("initialState")] + list(obstacle.iter("state"))
        for s in nodes:
            x = s.findtext("position/point/x")
            y = s.findtext("position/point/y")
            theta = float(s.findtext("orientation/exact"))
            step = int(s.findtext("time/exact"))
            v = float(s.findtext("velocity/exact"))
            acc = s.findtext("acceleration/exact") or "0"
            states[step] = (float(x), float(y), theta, v, x, y, acc)
        yield obstacle.get("id"), length, width, states


def pairs_of(path, radius):
    scenario = os.path.basename(path).removesuffix(".xml")
    users = list(road_users(path))
    by_step = {}
    for uid, length, width, states in users:
        for step, st in states.items():
            by_step.setdefault(step, []).append((uid, length, width, st))
    r2 = radius * radius
    for step in sorted(by_step):
        present = by_step[step]
        for ego in present:
            for partner in present:
                if ego is partner:
                    continue
                dx = ego[3][0] - partner[3][0]
                dy = ego[3][1] - partner[3][1]
                if dx * dx + dy * dy <= r2:
                    yield scenario, step, ego, partner


def vehicle_columns(user):
    _, length, width, (_, _, theta, v, x, y, acc) = user
    c, s = math.cos(theta), math.sin(theta)
    return [x, y, f"{v * c:.4f}", f"{v * s:.4f}", f"{c:.6f}", f"{s:.6f}", acc, length, width]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="folder with the CommonRoad *.xml files")
    ap.add_argument("--rows", type=int, default=1_000_000, help="rows to write (default 1,000,000)")
    ap.add_argument("--radius", type=float, default=60.0, help="max centre distance of a pair (m)")
    ap.add_argument("--out", required=True, help="output CSV ('-' for stdout)")
    args = ap.parse_args()

    files = sorted(glob.glob(os.path.join(args.data, "*.xml")))
    if not files:
        sys.exit(f"no *.xml files in {args.data}")
    rows = []
    for path in files:
        for scenario, step, ego, partner in pairs_of(path, args.radius):
            rows.append(",".join([scenario, str(step), ego[0], partner[0]]
                                 + vehicle_columns(ego) + vehicle_columns(partner)))
    header = ["scenario", "pass", "step", "id_i", "id_j"] + [
        f"{f}_{s}" for s in "ij" for f in ["x", "y", "vx", "vy", "hx", "hy", "acc", "length", "width"]
    ]
    out = sys.stdout if args.out == "-" else open(args.out, "w", newline="")
    out.write(",".join(header) + "\n")
    written = 0
    rep = 0
    while written < args.rows:
        for row in rows:
            if written == args.rows:
                break
            scenario, rest = row.split(",", 1)
            out.write(f"{scenario},{rep},{rest}\n")
            written += 1
        rep += 1
    if out is not sys.stdout:
        out.close()
    print(f"{len(files)} scenarios, {len(rows)} distinct pairs within {args.radius} m, "
          f"{written} rows written ({rep} pass(es))", file=sys.stderr)


if __name__ == "__main__":
    main()
