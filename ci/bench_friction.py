#!/usr/bin/env python3
"""Friction benchmarks (BENCHMARKS.md, issue 10). Usage: python3 ci/bench_friction.py [cm]

cm - Cattaneo-Mindlin, 2D (cases/cattaneo_mindlin_2d.toml): the Hertz half disk pressed onto a rigid
     flat, then shifted with mu = 0.3, for Q1C1, Q1N2, Q1N2.1 at n_arc 64, 128, 256 (n_radial =
     n_arc / 4): the stick zone's half-width estimated from the point counts, c/a = stick / active
     at the last step, against c/a = sqrt(1 - Q/(mu P)) for the computed Q and P.
Times are from summary.json (wall_time)."""
import csv, json, math, os, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "nurbs-contact")
MU = 0.3


def run(case, sets=()):
    out = tempfile.mkdtemp(prefix="bench")
    cmd = [BIN, "run", os.path.join(ROOT, "cases", case), "--out", out, "-q", "--overwrite"]
    for s in sets:
        cmd += ["--set", s]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{p.stderr}")
    hist = list(csv.DictReader(open(os.path.join(out, "history.csv"))))
    return hist, json.load(open(os.path.join(out, "summary.json")))


def cm():
    print("| family | n_arc | Q/(mu P) | active points | stick | slip | c/a (stick/active) | c/a Cattaneo-Mindlin | error | shift steps (cutbacks) | Newton its (shift stage) | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for fam in ["Q1C1", "Q1N2", "Q1N2.1"]:
        for n in [64, 128, 256]:
            r, s = run("cattaneo_mindlin_2d.toml", [f"bodies.disk.element={fam}",
                                                    f"meshes.disk.n_arc={n}",
                                                    f"meshes.disk.n_radial={n // 4}"])
            x = r[-1]
            q, p = -float(x["P_cm_disk_arc_x"]), float(x["P_cm_disk_arc_y"])
            st, sl, ac = (float(x[k + "_cm_disk_arc"]) for k in ("stick", "slip", "active"))
            ratio = q / (MU * p)
            c_cm, c_a = math.sqrt(1.0 - ratio), st / ac
            sh = [y for y in r if y["stage"] == "1"]
            cut = sum(int(y["cutbacks"]) for y in sh)
            its = sum(int(y["newton_iterations"]) for y in sh)
            print(f"| {fam} | {n} | {ratio:.4f} | {int(ac)} | {int(st)} | {int(sl)} | {c_a:.4f} | "
                  f"{c_cm:.4f} | {100 * (c_a / c_cm - 1):+.1f} % | {len(sh)} ({cut}) | {its} | "
                  f"{s['wall_time']['total']:.2f} |")


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "cm"
    {"cm": cm}[what]()
