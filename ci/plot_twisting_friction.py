#!/usr/bin/env python3
"""M_z and P_z of the frictional twisting benchmark against the twist angle, as two SVG files,
with the published points (Sauer & De Lorenzis 2015, digitised) and FEBio's (Zimmerman & Ateshian
2018). Usage: python3 ci/plot_twisting_friction.py [--p-range LO:HI] OUT LABEL=RUNDIR [LABEL=RUNDIR ...]
OUT: a folder (OUT/twisting_friction_mz.svg and _pz.svg) or a path prefix (OUT_mz.svg, OUT_pz.svg).
RUNDIR: the output directory of a `nurbs-contact run cases/twisting_friction_3d.toml` (its
history.csv: load_factor, M_shell_rim_z, R_shell_rim_z; magnitudes are plotted)."""
import csv, os, sys

PUB = {"M": [(0, 0.002), (20, 0.146), (40, 0.267), (80, 0.395), (120, 0.403), (180, 0.401)],
       "P": [(0, 1.230), (20, 1.234), (40, 1.245), (80, 1.273), (120, 1.282), (180, 1.289)]}
FEBIO = {"M": [(20, 0.144), (40, 0.273), (80, 0.395), (120, 0.410), (180, 0.405)], "P": []}
COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"]


def series(d, col):
    r = [x for x in csv.DictReader(open(os.path.join(d, "history.csv"))) if x["stage"] == "1"]
    return [((float(x["load_factor"]) - 1) * 180, abs(float(x[col]))) for x in r]


def svg(path, title, ylab, curves, pts, ylim):
    W, H, L, R, T, B = 640, 420, 70, 170, 40, 50
    x0, x1, (y0, y1) = 0.0, 180.0, ylim
    sx = lambda x: L + (x - x0) / (x1 - x0) * (W - L - R)
    sy = lambda y: H - B - (y - y0) / (y1 - y0) * (H - T - B)
    o = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="12">',
         f'<rect width="{W}" height="{H}" fill="white"/>',
         f'<text x="{W / 2 - 60}" y="20" font-size="14">{title}</text>',
         f'<rect x="{L}" y="{T}" width="{W - L - R}" height="{H - T - B}" fill="none" stroke="black"/>']
    for i in range(7):
        x = x0 + i * 30
        o.append(f'<text x="{sx(x) - 8}" y="{H - B + 16}">{x:.0f}</text>')
    for i in range(6):
        y = y0 + i * (y1 - y0) / 5
        o.append(f'<line x1="{L}" x2="{W - R}" y1="{sy(y)}" y2="{sy(y)}" stroke="#ddd"/>')
        o.append(f'<text x="{L - 45}" y="{sy(y) + 4}">{y:.3f}</text>')
    o.append(f'<text x="{(W - R + L) / 2 - 50}" y="{H - 12}">twist angle (deg)</text>')
    o.append(f'<text x="14" y="{T + 15}">{ylab}</text>')
    ly = T + 10
    for k, (lab, s) in enumerate(curves):
        c = COLORS[k % len(COLORS)]
        d = " ".join(f"{sx(x):.1f},{sy(min(max(y, y0), y1)):.1f}" for x, y in s)
        o.append(f'<polyline points="{d}" fill="none" stroke="{c}" stroke-width="1.5"/>')
        o.append(f'<line x1="{W - R + 10}" x2="{W - R + 30}" y1="{ly}" y2="{ly}" stroke="{c}" stroke-width="2"/>')
        o.append(f'<text x="{W - R + 35}" y="{ly + 4}">{lab}</text>')
        ly += 18
    for (lab, marker), p in pts:
        for x, y in p:
            if marker == "o":
                o.append(f'<circle cx="{sx(x):.1f}" cy="{sy(y):.1f}" r="4" fill="black"/>')
            else:
                o.append(f'<rect x="{sx(x) - 4:.1f}" y="{sy(y) - 4:.1f}" width="8" height="8" fill="none" stroke="black"/>')
        if p:
            if marker == "o":
                o.append(f'<circle cx="{W - R + 20}" cy="{ly}" r="4" fill="black"/>')
            else:
                o.append(f'<rect x="{W - R + 16}" y="{ly - 4}" width="8" height="8" fill="none" stroke="black"/>')
            o.append(f'<text x="{W - R + 35}" y="{ly + 4}">{lab}</text>')
            ly += 18
    o.append("</svg>")
    open(path, "w").write("\n".join(o) + "\n")


if __name__ == "__main__":
    args = sys.argv[1:]
    p_lim = (0.9, 1.6)
    if "--p-range" in args:  # --p-range LO:HI, the P_z axis
        i = args.index("--p-range")
        p_lim = tuple(float(v) for v in args[i + 1].split(":"))
        del args[i:i + 2]
    # OUT: a folder (OUT/twisting_friction_mz.svg, ..._pz.svg) or a path prefix (OUT_mz.svg, ...)
    out, runs = args[0], [a.split("=", 1) for a in args[1:]]
    prefix = os.path.join(out, "twisting_friction") if os.path.isdir(out) else out
    svg(prefix + "_mz.svg", "Frictional twisting: M_z", "M_z",
        [(l, series(d, "M_shell_rim_z")) for l, d in runs],
        [(("published", "o"), PUB["M"]), (("FEBio", "s"), FEBIO["M"])], (0.0, 0.6))
    svg(prefix + "_pz.svg", "Frictional twisting: P_z", "P_z",
        [(l, series(d, "R_shell_rim_z")) for l, d in runs],
        [(("published", "o"), PUB["P"])], p_lim)
