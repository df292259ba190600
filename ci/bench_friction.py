#!/usr/bin/env python3
"""Friction benchmarks (docs/verification/friction.md).
Usage: python3 ci/bench_friction.py [--families F1,F2,...] [cm] [SET ...]

cm - Cattaneo-Mindlin, 2D (cases/cattaneo_mindlin_2d.toml): the Hertz half disk pressed onto a
     rigid flat, then shifted with mu = 0.3, for every 2D family (or those of --families) at
     n_arc 64, 128, 256 (n_radial = n_arc / 4): the stick zone's half-width estimated from the
     point counts, c/a = stick / active at the last step, against c/a = sqrt(1 - Q/(mu P)) for
     the computed Q and P; and from the points' positions in results.h5 (grid contact_points,
     read with h5dump): on each side, a midway between the last active and the first inactive
     point, c midway between the last sticking and the first slipping point, both sides averaged;
     the shear traction at the active points against Cattaneo-Mindlin's distribution for the
     measured a and P, Q (RMS and largest deviation relative to mu p0); and what the point spacing
     resolves: the brackets of a and c (between the half-width through the last point in and
     through the first point out) and whether Cattaneo-Mindlin's c for some a in a's bracket lies
     in c's bracket.
Times are from summary.json (wall_time)."""
import csv, json, math, os, re, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "nurbs-contact")
MU = 0.3
E_STAR = 1.0 / (1.0 - 0.3**2)  # cases/cattaneo_mindlin_2d.toml: E = 1, nu = 0.3


def run(case, sets=()):
    out = tempfile.mkdtemp(prefix="bench")
    cmd = [BIN, "run", os.path.join(ROOT, "cases", case), "--out", out, "-q", "--overwrite"]
    for s in sets:
        cmd += ["--set", s]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{p.stderr}")
    hist = list(csv.DictReader(open(os.path.join(out, "history.csv"))))
    return hist, json.load(open(os.path.join(out, "summary.json"))), out


def h5(out, path):
    """A dataset of results.h5 as a flat list (h5dump text output)."""
    t = subprocess.run(["h5dump", "-y", "-w", "0", "-d", path, os.path.join(out, "results.h5")],
                       capture_output=True, text=True, check=True).stdout
    body = t[t.index("DATA {") + 6:]
    body = body[:body.index("}")]
    return [float(v) for v in re.split(r"[,\s]+", body) if v]


def last_step(out):
    t = subprocess.run(["h5dump", "-n", os.path.join(out, "results.h5")], capture_output=True,
                       text=True, check=True).stdout
    return max(re.findall(r"/steps/(\d{6})\s", t))


def positions(out, q, p_total):
    """(a, c, RMS and max shear deviation / (mu p0)) from the contact points of the last step."""
    k = last_step(out)
    g = lambda f: h5(out, f"/steps/{k}/contact_points/{f}")
    X, u = h5(out, "/grids/contact_points/coordinates"), g("displacement")
    x = [X[3 * i] + u[3 * i] for i in range(len(X) // 3)]
    p, st, tt = g("contact_pressure"), g("friction_state"), g("tangential_traction")
    pts = sorted(zip(x, p, st, tt[0::3]))
    act = [i for i, v in enumerate(pts) if v[1] > 0.0]
    lo, hi = act[0], act[-1]
    a = 0.5 * ((pts[hi][0] + pts[hi + 1][0]) / 2 - (pts[lo][0] + pts[lo - 1][0]) / 2)
    stick = [i for i in act if pts[i][2] == 1.0]
    s_lo, s_hi = stick[0], stick[-1]
    c = 0.5 * ((pts[s_hi][0] + pts[s_hi + 1][0]) / 2 - (pts[s_lo][0] + pts[s_lo - 1][0]) / 2)
    # Cattaneo-Mindlin shear traction (on the disk: opposite to the shift, negative here)
    p0 = 2.0 * p_total / (math.pi * a)
    cq = a * math.sqrt(1.0 - q / (MU * p_total))
    x0 = 0.5 * ((pts[hi][0] + pts[hi + 1][0]) / 2 + (pts[lo][0] + pts[lo - 1][0]) / 2)
    dev = []
    for i in act:
        xi = pts[i][0] - x0
        t = MU * p0 * math.sqrt(max(0.0, 1.0 - (xi / a) ** 2))
        if abs(xi) < cq:
            t -= (cq / a) * MU * p0 * math.sqrt(1.0 - (xi / cq) ** 2)
        dev.append((-pts[i][3] - t) / (MU * p0))
    rms = math.sqrt(sum(d * d for d in dev) / len(dev))
    # what the point spacing can resolve: the half-widths lie between the innermost and the
    # outermost estimate the point states allow (the last point in / the first point out)
    a_br = (0.5 * (pts[hi][0] - pts[lo][0]), 0.5 * (pts[hi + 1][0] - pts[lo - 1][0]))
    c_br = (0.5 * (pts[s_hi][0] - pts[s_lo][0]), 0.5 * (pts[s_hi + 1][0] - pts[s_lo - 1][0]))
    return a, c, rms, max(abs(d) for d in dev), a_br, c_br


def cm():
    print("| family | n_arc | Q/(mu P) | active points | stick | slip | c/a (stick/active) | c/a from positions | c/a Cattaneo-Mindlin | error (counts) | error (positions) | shear RMS / max dev. (of mu p0) | shift steps (cutbacks) | Newton its (shift stage) | wall s | c / c_CM(Hertz a) | c bracket | C-M c for the a bracket | consistent |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for fam in FAMILIES:
        for n in [64, 128, 256]:
            r, s, out = run("cattaneo_mindlin_2d.toml", [f"bodies.disk.element={fam}",
                                                         f"meshes.disk.n_arc={n}",
                                                         f"meshes.disk.n_radial={n // 4}"] + EXTRA)
            x = r[-1]
            q, p = -float(x["P_cm_disk_arc_x"]), float(x["P_cm_disk_arc_y"])
            st, sl, ac = (float(x[k + "_cm_disk_arc"]) for k in ("stick", "slip", "active"))
            ratio = q / (MU * p)
            c_cm, c_a = math.sqrt(1.0 - ratio), st / ac
            sh = [y for y in r if y["stage"] == "1"]
            cut = sum(int(y["cutbacks"]) for y in sh)
            its = sum(int(y["newton_iterations"]) for y in sh)
            a, c, rms, mx, a_br, c_br = positions(out, q, p)
            # Cattaneo-Mindlin's c for any a the points allow; consistent if it meets c's bracket
            cm_br = (c_cm * a_br[0], c_cm * a_br[1])
            ok = "yes" if cm_br[0] <= c_br[1] and c_br[0] <= cm_br[1] else "no"
            a_hertz = math.sqrt(4.0 * p * 1.0 / (math.pi * E_STAR))
            print(f"| {fam} | {n} | {ratio:.4f} | {int(ac)} | {int(st)} | {int(sl)} | {c_a:.4f} | "
                  f"{c / a:.4f} | {c_cm:.4f} | {100 * (c_a / c_cm - 1):+.1f} % | "
                  f"{100 * (c / a / c_cm - 1):+.1f} % | {rms:.3f} / {mx:.3f} | {len(sh)} ({cut}) | "
                  f"{its} | {s['wall_time']['total']:.2f} | "
                  f"{100 * (c / (a_hertz * c_cm) - 1):+.1f} % (a {100 * (a / a_hertz - 1):+.1f} %) | "
                  f"{c_br[0]:.4f}..{c_br[1]:.4f} | {cm_br[0]:.4f}..{cm_br[1]:.4f} | {ok} |",
                  flush=True)


EXTRA = []
FAMILIES = ["Q1C1", "Q1N2", "Q1N3", "Q1N4", "Q1N2.1", "Q1N2.2", "Q1N3.1", "Q1C2", "Q1CH"]

if __name__ == "__main__":
    args = sys.argv[1:]
    if "--families" in args:  # --families Q1C1,Q1N2 (default: every 2D family)
        i = args.index("--families")
        FAMILIES = args[i + 1].split(",")
        del args[i:i + 2]
    what = args[0] if args else "cm"
    EXTRA = args[1:]  # further --set values, e.g. contact.0.eps_t=1e3
    {"cm": cm}[what]()
