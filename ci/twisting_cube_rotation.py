#!/usr/bin/env python3
"""Rotation of the cube's top face about the vertical axis in a twisting run (twisting_3d /
twisting_friction_3d): for every output step of DIR/results.h5, the mean angle (degrees) by which
the bulk nodes of the plane z = 0 (the cube's top in the reference configuration) turned about
the z axis, in three rings of reference radius, beside the step's load factor (twist angle =
(load - 1) * 180 for the 180-degree twist of twisting_friction_3d). Compared with the rim's twist it
tells how far the contact slides (rim minus cube top) and whether the cube turns with the shell.

Usage: python3 ci/twisting_cube_rotation.py DIR
"""
import importlib.util
import os
import re
import subprocess
import sys

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location("bench_friction", os.path.join(here, "bench_friction.py"))
bf = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bf)

RINGS = [(0.1, 0.4), (0.4, 0.8), (0.8, 1.5)]


def main(out):
    X = np.array(bf.h5(out, "/grids/bulk/coordinates")).reshape(-1, 3)
    top = np.abs(X[:, 2]) < 1e-12
    r = np.hypot(X[:, 0], X[:, 1])
    t = subprocess.run(["h5dump", "-n", os.path.join(out, "results.h5")], capture_output=True,
                       text=True, check=True).stdout
    steps = sorted(set(re.findall(r"/steps/(\d{6})\s", t)))
    print("| output step | load | cube top rotation, r < 0.4 | 0.4 < r < 0.8 | r > 0.8 |")
    print("|---|---|---|---|---|")
    for s in steps:
        u = np.array(bf.h5(out, f"/steps/{s}/bulk/displacement")).reshape(-1, 3)
        x = X + u
        cells = []
        for lo, hi in RINGS:
            sel = top & (r > lo) & (r < hi)
            a = np.degrees(np.arctan2(x[sel, 1], x[sel, 0]) - np.arctan2(X[sel, 1], X[sel, 0]))
            cells.append(f"{((a + 180) % 360 - 180).mean():.2f}")
        lf = subprocess.run(["h5dump", "-a", f"/steps/{s}/load_factor", os.path.join(out, "results.h5")],
                            capture_output=True, text=True).stdout
        m = re.search(r"\(0\): ([-\d.e+]+)", lf)
        print(f"| {s} | {m.group(1) if m else '?'} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
