#!/usr/bin/env python3
"""Frictional twisting table rows (docs/verification/friction.md): M_z / P_z of the rim reaction at the published
angles, deviations from Sauer & De Lorenzis 2015, Newton its per twist step, cutbacks, wall time.
Usage: python3 ci/twisting_friction_table.py RUNDIR [RUNDIR ...]"""
import csv, json, sys
PUB_M = {0: 0.002, 20: 0.146, 40: 0.267, 80: 0.395, 120: 0.403, 180: 0.401}
PUB_P = {0: 1.230, 20: 1.234, 40: 1.245, 80: 1.273, 120: 1.282, 180: 1.289}
def series(d):
    r = list(csv.DictReader(open(d + "/history.csv")))
    ang = [(float(x["load_factor"]) - 1) * 180 for x in r]
    M = [float(x["M_shell_rim_z"]) for x in r]
    P = [float(x["R_shell_rim_z"]) for x in r]
    return r, ang, M, P
def at(ang, v, a):
    for i in range(1, len(ang)):
        if ang[i - 1] <= a + 1e-9 and ang[i] >= a - 1e-9:
            if ang[i] == ang[i - 1]:
                return v[i]
            t = (a - ang[i - 1]) / (ang[i] - ang[i - 1])
            return v[i - 1] + t * (v[i] - v[i - 1])
    return None
for d in sys.argv[1:]:
    r, ang, M, P = series(d)
    s = json.load(open(d + "/summary.json"))
    tw = [x for x in r if x["stage"] == "1"]
    its = [int(x["newton_iterations"]) for x in tw]
    cut = sum(int(x["cutbacks"]) for x in r)
    cells = []
    for a in PUB_M:
        m, p = at(ang, M, a), at(ang, P, a)
        if m is None:
            cells.append("-"); continue
        # sign: the rim reaction's moment and force as in the docs' table (magnitudes compared)
        m, p = abs(m), abs(p)
        em = "" if a == 0 else f" ({100*(m/PUB_M[a]-1):+.0f} %)"
        cells.append(f"{m:.3f}{em} / {p:.3f} ({100*(p/PUB_P[a]-1):+.1f} %)")
    print(f"| {d.split('tw_')[-1]} | " + " | ".join(cells) + f" | {sum(its)/len(its):.1f} / {max(its)} | {cut} | {s['wall_time']['total']:.0f} |")
