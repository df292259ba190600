#!/usr/bin/env python3
"""The contact set at every law evaluation of a run, from a `NURBS_CONTACT_DEBUG_POINTS=1` trace
(stderr of a 1-rank run; lines `POINT load pass X q partner xi free x y g_n p n_x n_y f_x f_y`, see
`HalfPass::trace_point` in src/contact/half_pass.rs). Standard library only.

    NURBS_CONTACT_DEBUG_POINTS=1 nurbs-contact run CASE ... -- -snes_linesearch_type basic 2> trace.txt
    ci/active_set_trace.py trace.txt [GAP]

One line per evaluation of the contact residual: the load, the points evaluated, the active ones
(pressure > 0), how many entered and left since the previous evaluation at the same load with the
range of their gaps g_n there, and how many points lie within GAP (default 1e-6) of zero gap. An
evaluation ends where a point (pass, q) of the same load comes again. With full Newton steps
(`-snes_linesearch_type basic`) each Newton iterate is one evaluation (a line search adds its trial
evaluations), so the lines of a load are its iterates, and one more line evaluates the converged
state again.
"""
import sys


def evaluations(path):
    out = []
    seen = None
    for line in open(path):
        if not line.startswith("POINT "):
            continue
        v = line.split()
        lam, key = float(v[1]), (int(v[2]), int(v[4]))
        if not out or out[-1][0] != lam or key in seen:
            out.append((lam, {}))
            seen = set()
        seen.add(key)
        out[-1][1][key] = (float(v[10]), float(v[11]))
    return out


def span(gs):
    return "[%.2e, %.2e]" % (min(gs), max(gs)) if gs else ""


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    near = float(sys.argv[2]) if len(sys.argv) > 2 else 1e-6
    prev, prev_lam = None, None
    print("load points active | entered [g_n] | left [g_n] | |g_n| < %g" % near)
    for lam, pts in evaluations(sys.argv[1]):
        act = {k for k, (_, p) in pts.items() if p > 0.0}
        row = "%.6f %d %d" % (lam, len(pts), len(act))
        if prev is not None and prev_lam == lam:
            ent, lft = act - prev, prev - act
            row += " | %d %s | %d %s" % (
                len(ent),
                span([pts[k][0] for k in ent]),
                len(lft),
                span([pts[k][0] for k in lft if k in pts]),
            )
        else:
            row += " | - | -"
        row += " | %d" % sum(1 for g, _ in pts.values() if abs(g) < near)
        print(row)
        prev, prev_lam = act, lam


if __name__ == "__main__":
    main()
