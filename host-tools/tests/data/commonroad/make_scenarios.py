#!/usr/bin/env python3
"""Writes the two small CommonRoad test scenarios of host-tools/tests/commonroad_import.rs.

Every state is a closed form (constant heading, constant acceleration), so the expected vx, vy,
gaps and sequences can be computed by hand. Run from this folder: python3 make_scenarios.py
"""
import math

DT = 0.1


def fmt(v):
    s = f"{v:.4f}".rstrip("0").rstrip(".")
    return s if s not in ("-0", "") else "0"


def state(tag, ind, x, y, th, step, v, acc):
    o = [f"{ind}<{tag}>",
         f"{ind}  <position>", f"{ind}    <point>", f"{ind}      <x>{fmt(x)}</x>",
         f"{ind}      <y>{fmt(y)}</y>", f"{ind}    </point>", f"{ind}  </position>",
         f"{ind}  <orientation>", f"{ind}    <exact>{fmt(th)}</exact>", f"{ind}  </orientation>",
         f"{ind}  <time>", f"{ind}    <exact>{step}</exact>", f"{ind}  </time>",
         f"{ind}  <velocity>", f"{ind}    <exact>{fmt(v)}</exact>", f"{ind}  </velocity>"]
    if acc is not None:
        o += [f"{ind}  <acceleration>", f"{ind}    <exact>{fmt(acc)}</exact>",
              f"{ind}  </acceleration>"]
    o.append(f"{ind}</{tag}>")
    return o


def obstacle(oid, typ, length, width, states, elem="dynamicObstacle", role=None):
    o = [f'  <{elem} id="{oid}">']
    if role:
        o.append(f"    <role>{role}</role>")
    o += [f"    <type>{typ}</type>", "    <shape>", "      <rectangle>",
          f"        <length>{fmt(length)}</length>", f"        <width>{fmt(width)}</width>",
          "      </rectangle>", "    </shape>"]
    o += state("initialState", "    ", *states[0])
    if len(states) > 1:
        o.append("    <trajectory>")
        for s in states[1:]:
            o += state("state", "      ", *s)
        o.append("    </trajectory>")
    o.append(f"  </{elem}>")
    return o


TH = 0.5
C, S = math.cos(TH), math.sin(TH)


def along(d, lat, v0, a, steps):
    """Heading TH; longitudinal position d + v0 t + a t^2 / 2, lateral offset lat (left)."""
    out = []
    for k in steps:
        t = k * DT
        lon = d + v0 * t + 0.5 * a * t * t
        out.append((lon * C - lat * S, lon * S + lat * C, TH, k, v0 + a * t, a))
    return out


HEADER = """<?xml version="1.0" ?>
<!-- Hand-made test scenario for riskctl import commonroad (host-tools/tests/commonroad_import.rs). -->
<commonRoad author="riskscore tests" affiliation="riskscore" benchmarkID="{bid}" \
commonRoadVersion="{ver}" date="2026-11-23" source="hand-made" timeStepSize="0.1"{tags}>"""

# 2020a: 10 follows the truck 20 (same lane, 12 m gap); 70 follows 30 two lanes to the left,
# with an overlap artefact at steps 10-14; 40 (no acceleration recorded) and the pedestrian 50
# are far away; a static obstacle, a lanelet and a planning problem are ignored.
L = [HEADER.format(bid="ZAM_Merge-1_1_T-1", ver="2020a", tags=""),
     "  <location>", "    <geoNameId>0</geoNameId>", "    <gpsLatitude>0</gpsLatitude>",
     "    <gpsLongitude>0</gpsLongitude>", "  </location>",
     "  <scenarioTags>", "    <highway/>", "  </scenarioTags>",
     '  <lanelet id="1">', "    <leftBound>", "      <point>", "        <x>0</x>", "        <y>2</y>",
     "      </point>", "      <point>", "        <x>100</x>", "        <y>2</y>", "      </point>",
     "    </leftBound>", "    <rightBound>", "      <point>", "        <x>0</x>",
     "        <y>-2</y>", "      </point>", "      <point>", "        <x>100</x>",
     "        <y>-2</y>", "      </point>", "    </rightBound>", "  </lanelet>"]
L += ['  <staticObstacle id="60">', "    <type>parkedVehicle</type>", "    <shape>",
      "      <rectangle>", "        <length>4</length>", "        <width>2</width>",
      "      </rectangle>", "    </shape>"]
L += state("initialState", "    ", 50, -20, 0, 0, 0, None) + ["  </staticObstacle>"]
L += obstacle(10, "car", 4.0, 1.8, along(0, 0, 10, 0.2, range(0, 31)))
L += obstacle(20, "truck", 12.0, 2.5, along(20, 0, 10, -0.3, range(0, 31)))
L += obstacle(30, "car", 4.0, 1.8, along(0, 12, 10, 0, range(0, 41)))
L += obstacle(70, "car", 4.0, 1.8,
              [along(-3 if 10 <= k <= 14 else -6, 12, 10, 0, [k])[0] for k in range(0, 41)])
L += obstacle(40, "car", 4.5, 1.9,
              [(x, y, th, k, v, None) for (x, y, th, k, v, _) in along(0, -30, 8, 1.0, range(0, 31))])
L += obstacle(50, "pedestrian", 0.5, 0.5, along(0, -8, 1.2, 0, range(0, 31)))
L += ['  <planningProblem id="99">'] + state("initialState", "    ", 0, 0, 0, 0, 10, 0)
L += ["    <goalState>", "      <time>", "        <intervalStart>10</intervalStart>",
      "        <intervalEnd>20</intervalEnd>", "      </time>", "    </goalState>",
      "  </planningProblem>", "</commonRoad>", ""]
open("ZAM_Merge-1_1_T-1.xml", "w").write("\n".join(L))


# 2018b: <obstacle> with <role>; 1 and 2 drive side by side in adjacent lanes, 3 is static.
def straight(x0, y0, v, steps):
    return [(x0 + v * k * DT, y0, 0.0, k, v, 0.0) for k in steps]


L = [HEADER.format(bid="ZAM_Legacy-1_1_T-1", ver="2018b", tags=' tags="highway"')]
L += obstacle(1, "car", 4.0, 2.0, straight(0, 0, 12, range(0, 26)), elem="obstacle", role="dynamic")
L += obstacle(2, "car", 4.0, 2.0, straight(15, 3.5, 12, range(0, 26)), elem="obstacle", role="dynamic")
L += ['  <obstacle id="3">', "    <role>static</role>", "    <type>parkedVehicle</type>",
      "    <shape>", "      <rectangle>", "        <length>4</length>", "        <width>2</width>",
      "      </rectangle>", "    </shape>"]
L += state("initialState", "    ", 80, -6, 0, 0, 0, None) + ["  </obstacle>", "</commonRoad>", ""]
open("ZAM_Legacy-1_1_T-1.xml", "w").write("\n".join(L))
