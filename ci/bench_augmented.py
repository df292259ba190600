#!/usr/bin/env python3
"""Augmented Lagrangian against the plain penalty on the 2D Hertz case (docs/verification/hertz.md, "Augmented Lagrangian").
Usage: python3 ci/bench_augmented.py [FAMILY:N_ARC[:EPS,EPS...] ...] (default Q1C1:128 Q1N2:128,
penalties 1e2 1e3 1e4 1e5 1e6)

For each family and mesh, the penalty eps_n over 1e2 ... 1e6, each plain and with
`augmented = { tol = 1e-8, max = 100 }` (tol and max from the environment's AL_TOL and AL_MAX if set;
further --set values for every run from BENCH_SETS): load P, the L2-projected nominal peak pressure against
Hertz's p0 for that load (as in `ci/bench_contact.py hertz`), the largest penetration of the last
step, Newton iterations, augmentation rounds and wall time (summary.json)."""
import os, sys
from bench_contact import hertz_metrics, newton

# the tolerance (a penetration) can be changed with AL_TOL=...
AL = "contact.0.augmented={ tol = %s, max = %s }" % (os.environ.get("AL_TOL", "1e-8"), os.environ.get("AL_MAX", "100"))
# further --set values for every run, e.g. BENCH_SETS="contact.0.gap=weighted"
SETS = os.environ.get("BENCH_SETS", "").split()


def main(rows):
    print("| family | n_arc | eps_n | enforcement | load P | peak p nominal | error vs Hertz | penetration | Newton its | rounds | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        fam, n, *eps_list = row.split(":")
        for eps in (eps_list[0].split(",") if eps_list else ("1e2", "1e3", "1e4", "1e5", "1e6")):
            for al in (False, True):
                extra = [f"contact.0.eps_n={eps}", "output.plots=false"] + ([AL] if al else []) + SETS
                m = hertz_metrics(fam, int(n), extra)
                head, rows_ = m["hist"]
                last = rows_[-1].split(",")
                pen = float(last[head.index("penetration_flat_disk_arc")])
                s = m["summary"]
                rounds = sum(st.get("augmentation_rounds", 0) for st in s["steps"])
                err = 100 * (m["peak_n"] - m["p0"]) / m["p0"]
                print(f"| {fam} | {n} | {eps} | {'augmented' if al else 'penalty'} | {m['P']:.7g} | {m['peak_n']:.6g} | "
                      f"{err:+.2f} % | {pen:.2e} | {newton(s)} | {rounds} | {s['wall_time']['total']:.2f} |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or ["Q1C1:128", "Q1N2:128"])
