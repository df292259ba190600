#!/usr/bin/env python3
"""Section 4 metrics of Corbett & Sauer (2014) from nurbs-contact output folders (history.csv,
summary.json), as docs/verification/paper.md reports them. Standard library only.

    ci/paper_metrics.py ironing  DIR...   # eq. (22)/(23) over the sliding window s >= 1
    ci/paper_metrics.py peeling  DIR...   # end moment over the steady window theta >= 100 deg
    ci/paper_metrics.py dcb      DIR...   # pin force over the crack-growth window opening >= 8
    ci/paper_metrics.py twisting DIR...   # P_z (eq. 22) and max |M_z| over the rotation

Definitions (stated in docs/verification/paper.md):
- DeltaP (eq. 22) = max(P1, P2) - min(P1, P2) over the window, both half-passes' series together;
  DeltaP_ece (eq. 23) = max(max P1 - min P1, max P2 - min P2).
- Oscillation amplitude (peeling, DCB) = max - min of the curve minus its least-squares quadratic
  fit over the window (the slow trend removed, the element-scale oscillation kept).
- Steepest negative slope (peeling) = min over steps of dM/dtheta (per degree).
"""
import csv
import json
import os
import sys


def read(d):
    with open(os.path.join(d, "history.csv")) as f:
        rows = list(csv.DictReader(f))
    cols = {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else {}
    try:
        with open(os.path.join(d, "summary.json")) as f:
            summ = json.load(f)
    except OSError:
        summ = {}
    return cols, summ


def pick(cols, prefix, suffix=""):
    return [k for k in cols if k.startswith(prefix) and k.endswith(suffix)]


def window(cols, keep):
    idx = [i for i, lam in enumerate(cols["load_factor"]) if keep(lam)]
    return lambda k: [cols[k][i] for i in idx]


def same_sense(series):
    """The two half-passes' forces act on different bodies: the second is negated so both are
    the force on the first body, as the paper plots P_1 and P_2 over each other."""
    return [s if i == 0 else [-v for v in s] for i, s in enumerate(series)]


def eq22(series):
    vals = [v for s in series for v in s]
    return max(vals) - min(vals)


def eq23(series):
    return max(max(s) - min(s) for s in series)


def detrended_amplitude(x, y):
    # least-squares quadratic fit by the normal equations (3 x 3, Cramer's rule)
    n = len(x)
    if n < 4:
        return float("nan")
    xm = sum(x) / n
    t = [xi - xm for xi in x]
    s = [sum(ti**k for ti in t) for k in range(5)]
    b = [sum(yi * ti**k for yi, ti in zip(y, t)) for k in range(3)]
    m = [[s[0], s[1], s[2]], [s[1], s[2], s[3]], [s[2], s[3], s[4]]]

    def det(a):
        return (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
                - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
                + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))

    d = det(m)
    c = []
    for j in range(3):
        mj = [row[:] for row in m]
        for i in range(3):
            mj[i][j] = b[i]
        c.append(det(mj) / d)
    r = [yi - (c[0] + c[1] * ti + c[2] * ti * ti) for yi, ti in zip(y, t)]
    return max(r) - min(r)


def run_info(cols, summ):
    its = cols.get("newton_iterations", [])
    return {
        "steps": len(its),
        "newton_max": int(max(its)) if its else 0,
        "newton_total": int(sum(its)),
        "cutbacks": sum(int(st.get("cutbacks", 0)) for st in summ.get("steps", [])),
        "rescued_steps": sum(1 for st in summ.get("steps", []) if st.get("pseudo_steps", 0)),
        "wall_s": cols["wall_time"][-1] if cols.get("wall_time") else float("nan"),
        "status": summ.get("status", "?"),
    }


def ironing(d):
    cols, summ = read(d)
    # stage 1 slides 4 units from load 1 to 2 (docs/verification/paper.md's runs): s = 4 (lambda - 1) >= 1
    w = window(cols, lambda lam: lam >= 1.25 - 1e-9)
    out = run_info(cols, summ)
    for c in "xy":
        series = same_sense([w(k) for k in pick(cols, "P_", "_" + c)])
        out["dP" + c] = eq22(series)
        out["dP" + c + "_ece"] = eq23(series)
        if c == "y":
            out["mean_Py"] = abs(sum(sum(s) / len(s) for s in series) / len(series))
    return out


def peeling(d, theta_end=180.0, theta_min=100.0):
    cols, summ = read(d)
    th = [lam * theta_end for lam in cols["load_factor"]]
    m = cols["M_strip_right"]
    idx = [i for i, t in enumerate(th) if t >= theta_min]
    out = run_info(cols, summ)
    out["theta_reached"] = th[-1] if th else 0.0
    if len(idx) > 4:
        x = [th[i] for i in idx]
        y = [m[i] for i in idx]
        out["M_mean"] = sum(y) / len(y)
        out["amplitude"] = detrended_amplitude(x, y)
        out["min_slope_per_deg"] = min(
            (y[i + 1] - y[i]) / (x[i + 1] - x[i]) for i in range(len(x) - 1))
    return out


def dcb(d, opening_end=12.0, opening_min=8.0):
    cols, summ = read(d)
    op = [lam * opening_end for lam in cols["load_factor"]]
    f = cols["R_upper_pin_y"]
    idx = [i for i, o in enumerate(op) if o >= opening_min]
    out = run_info(cols, summ)
    out["opening_reached"] = op[-1] if op else 0.0
    if len(idx) > 4:
        x = [op[i] for i in idx]
        y = [f[i] for i in idx]
        out["F_mean"] = sum(y) / len(y)
        out["amplitude"] = detrended_amplitude(x, y)
    out["F_max"] = max(f) if f else float("nan")
    return out


def twisting(d):
    cols, summ = read(d)
    w = window(cols, lambda lam: lam > 1.0 + 1e-9)
    out = run_info(cols, summ)
    pz = same_sense([w(k) for k in pick(cols, "P_twist_", "_z")])
    out["dPz"] = eq22(pz)
    out["dPz_ece"] = eq23(pz)
    mz = [w(k) for k in pick(cols, "M_twist_", "_z")]
    out["max_abs_Mz"] = max(abs(v) for s in mz for v in s)
    its = w("newton_iterations")
    out["newton_max_twist"] = int(max(its))
    return out


def main():
    if len(sys.argv) < 3 or sys.argv[1] not in ("ironing", "peeling", "dcb", "twisting"):
        print(__doc__)
        sys.exit(2)
    f = globals()[sys.argv[1]]
    for d in sys.argv[2:]:
        try:
            r = f(d)
        except (OSError, KeyError, ValueError, IndexError) as e:
            r = {"error": repr(e)}
        print(os.path.basename(d.rstrip("/")),
              " ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                       for k, v in r.items()))


if __name__ == "__main__":
    main()
