#!/usr/bin/env python3
"""Write an event folder of safe passes beside stationary roadside objects.

Usage: scripts/roadside-passes.py OUT_DIR

The ego drives a straight lane at constant speed past a stationary object (parked car, post,
small object, van, parked truck) with 3-8 m of lateral clearance between the boxes, on either
side, at 1-50 m/s, from 150 m before the object (or 40 s before, whichever is nearer) to 30 m
past it at 10 Hz: the geometry of tests/tests/roadside_objects.rs on a finer grid (every speed,
clearance and object of the test is here, with more between). `riskctl calibrate --never-warn
OUT_DIR` keeps a model's default threshold above every frame of these passes
(scripts/ship-models.sh). Format: docs/event-format.md. Refuses an existing OUT_DIR.
"""
import csv
import math
import os
import sys

SPEEDS = [1, 2, 3, 4, 5, 6, 8, 10, 12, 15, 18, 20, 22, 25, 28, 30, 32, 35, 38, 40, 42, 45, 48, 50]
CLEARANCES = [3.0, 3.25, 3.5, 4.0, 4.5, 6.0, 8.0]
OBJECTS = [
    ("car", 4.5, 1.8),
    ("post", 0.5, 0.5),
    ("object", 1.0, 1.0),
    ("van", 6.0, 2.2),
    ("truck", 12.0, 2.5),
]
EGO_LENGTH, EGO_WIDTH, DT = 4.5, 1.8, 0.1


def passes():
    for name, length, width in OBJECTS:
        for clearance in CLEARANCES:
            for side, side_name in ((-1.0, "right"), (1.0, "left")):
                y = side * (clearance + (width + EGO_WIDTH) / 2.0)
                for v in SPEEDS:
                    start = max(-150.0, -40.0 * v)
                    frames = math.ceil((30.0 - start) / (v * DT))
                    event_id = f"roadside/{name}-{clearance}m-{side_name}-{v}mps"
                    yield event_id, (length, width), y, v, start, frames


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    if os.path.exists(out):
        sys.exit(f"{out}: exists; give a new folder")
    os.makedirs(out)
    with open(os.path.join(out, "events.csv"), "w", newline="") as ef, open(
        os.path.join(out, "frames.csv"), "w", newline=""
    ) as ff:
        events = csv.writer(ef)
        frames = csv.writer(ff)
        events.writerow(["event_id", "kind", "t_start", "t_end", "t_impact", "length_ego",
                         "width_ego", "length_sur", "width_sur"])
        frames.writerow(["event_id", "time", "x_ego", "y_ego", "vx_ego", "vy_ego", "hx_ego",
                         "hy_ego", "acc_ego", "x_sur", "y_sur", "vx_sur", "vy_sur", "hx_sur",
                         "hy_sur", "acc_sur"])
        count = 0
        for event_id, (length, width), y, v, start, n in passes():
            events.writerow([event_id, "safe", 0, round(n * DT, 1), "", EGO_LENGTH, EGO_WIDTH,
                             length, width])
            for k in range(n + 1):
                x = start + v * DT * k
                frames.writerow([event_id, round(k * DT, 1), round(x, 4), 0, v, 0, 1, 0, 0,
                                 0, y, 0, 0, 1, 0, 0])
            count += 1
    print(f"wrote {count} roadside passes to {out}")


if __name__ == "__main__":
    main()
