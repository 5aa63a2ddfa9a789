#!/usr/bin/env python3
"""Write an event folder of safe passes beside stationary roadside objects.

Usage: scripts/roadside-passes.py OUT_DIR

The ego drives a straight lane at constant speed past a stationary object (van, small object,
trailer) with 3.25-7 m of lateral clearance between the boxes, on either side, at 2-47 m/s, from
150 m before the object (or 40 s before, whichever is nearer) to 30 m past it at 10 Hz: the
geometry of tests/tests/roadside_objects.rs on a grid DISJOINT from the test's (no speed,
clearance or object of the test is here), so the test measures whether what DRL learns from these
passes generalises. scripts/ship-models.sh gives them to DRL alone as training-only safe data
(`riskctl demo --extra-drl-only OUT_DIR`) and to GSSM as normal driving; `riskctl calibrate
--never-warn OUT_DIR` would keep a threshold above every frame of them (not used for the shipped
models: it cost recall). Format: docs/event-format.md. Refuses an existing OUT_DIR.
"""
import csv
import math
import os
import sys

# The test (tests/tests/roadside_objects.rs) uses speeds 1,3,5,8,10,15,...,50 m/s, clearances
# 3,3.5,4.5,6 m and a parked car, a post and a parked truck: none of them is here.
SPEEDS = [2, 4, 6, 7, 9, 12, 14, 17, 19, 22, 24, 27, 29, 32, 34, 37, 39, 42, 44, 47]
CLEARANCES = [3.25, 4.0, 5.0, 7.0]
OBJECTS = [
    ("van", 6.0, 2.2),
    ("object", 1.0, 1.0),
    ("trailer", 16.5, 2.55),
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
