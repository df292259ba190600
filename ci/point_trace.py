#!/usr/bin/env python3
"""Per-step resultants of each half-pass from a `NURBS_CONTACT_DEBUG_POINTS=1` trace (stderr of a
1-rank run; lines `POINT load pass X q partner xi free x y g_n p n_x n_y f_x f_y`, see
`HalfPass::trace_point` in src/contact/half_pass.rs). The last line of a point at a load is its
converged state. Standard library only.

    NURBS_CONTACT_DEBUG_POINTS=1 nurbs-contact run CASE ... 2> trace.txt
    ci/point_trace.py trace.txt H D0 [EDGE]

For every load of the slide (load > 1) and both half-passes: P_x (sum of f_x of the active points),
its part from the points farther than EDGE (default 0.6) from the contact centre x = D0 + (load - 1)
* H, where H is the slide per unit load (the ironing slide: `bcs.1.value`'s end x), the lateral
penalty stiffness K = eps_n sum n_x^2 w J over the active points (w J = |f| / p; EPS_N from the
environment, default 1000), the offset P_x / K, active points, and the partner switches and edge
(bound) projections of active points between consecutive loads.
"""
import collections
import os
import sys


def load(path):
    last = collections.OrderedDict()
    with open(path) as f:
        for line in f:
            if not line.startswith("POINT "):
                continue
            v = line.split()
            key = (float(v[1]), int(v[2]), int(v[4]))
            last[key] = dict(
                le=int(v[5]), xi=float(v[6]), free=int(v[7]), x=float(v[8]), y=float(v[9]),
                g=float(v[10]), p=float(v[11]), nx=float(v[12]), ny=float(v[13]),
                fx=float(v[14]), fy=float(v[15]),
            )
    steps = collections.defaultdict(dict)
    for (lam, pas, q), r in last.items():
        steps[(lam, pas)][q] = r
    return steps


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    steps = load(sys.argv[1])
    H, D0 = float(sys.argv[2]), float(sys.argv[3])
    edge = float(sys.argv[4]) if len(sys.argv) > 4 else 0.6
    eps = float(os.environ.get("EPS_N", "1000"))
    lams = sorted({l for l, _ in steps if l > 1.0 - 1e-9})
    passes = sorted({p for _, p in steps})
    print("load, then per half-pass: P_x, P_x of |x - c| > EDGE, K, P_x/K, active")
    for lam in lams:
        c = D0 + (lam - 1.0) * H
        out = ["%.4f" % lam]
        for pas in passes:
            act = [r for r in steps[(lam, pas)].values() if r["p"] > 0]
            P = sum(r["fx"] for r in act)
            E = sum(r["fx"] for r in act if abs(r["x"] - c) > edge)
            K = sum(eps * r["nx"] ** 2 * (r["fx"] ** 2 + r["fy"] ** 2) ** 0.5 / r["p"] for r in act)
            out.append("| %d: %+.3e %+.3e %.0f %+.2e %d" % (pas, P, E, K, P / K if K else 0.0, len(act)))
        print(" ".join(out))
    switches, bound, far = 0, 0, 0.0
    for pas in passes:
        prev = {}
        for lam in lams:
            for q, r in steps[(lam, pas)].items():
                if r["p"] > 0 and not r["free"]:
                    bound += 1
                o = prev.get(q)
                if o and o["le"] != r["le"] and (r["p"] > 0 or o["p"] > 0):
                    switches += 1
                    far = max(far, 1.0 - abs(o["xi"]), 1.0 - abs(r["xi"]))
            prev = steps[(lam, pas)]
    print("partner switches of active points: %d, largest 1 - |xi| at a switch: %.3f; "
          "bound (edge) projections of active points: %d" % (switches, far, bound))


if __name__ == "__main__":
    main()
