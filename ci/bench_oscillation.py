#!/usr/bin/env python3
"""Pointwise contact pressure of the Hertz case (docs/verification/hertz.md).
Usage: python3 ci/bench_oscillation.py FAMILY:N_ARC:EPS_N[:GAP] ...  (e.g. Q1N2:128:1e4, Q1N2:128:1e4:element_mean)
Reads the grid `contact_points` of results.h5 (the law's pressure at every contact quadrature point).
Odd-even index: max of |d(x) - (d(x - h) + d(x + h)) / 2| / p0, d = p - p_Hertz, h the arc element
length, over the points with |x| + h < 0.7a (each point against the points at the same place of the
neighbouring elements)."""
import sys, os, math, re, subprocess
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_contact as b
def study(fam, n, eps, gap="pointwise"):
    out, s = b.run("hertz_2d.toml", 1, [f"bodies.disk.element={fam}", f"meshes.disk.n_arc={n}",
                   f"meshes.disk.n_radial={n//4}", f"contact.0.eps_n={eps}", f"contact.0.gap={gap}"])
    f = os.path.join(out, "results.h5")
    hist = open(os.path.join(out, "history.csv")).read().splitlines()
    head, last = hist[0].split(","), hist[-1].split(",")
    P = float(last[head.index("P_flat_disk_arc_y")])
    steps = sorted(set(re.findall(r"/steps/(\d+)/", subprocess.run(["h5ls", "-r", f], capture_output=True, text=True).stdout)))
    st = steps[-1]
    x = b.h5(f, "/grids/contact_points/coordinates")
    u = b.h5(f, f"/steps/{st}/contact_points/displacement")
    p = b.h5(f, f"/steps/{st}/contact_points/contact_pressure")
    grid = "bulk" if fam == "Q1C1" else "surface"
    pn = b.h5(f, f"/steps/{st}/{grid}/contact_pressure_nominal")
    pts = sorted((x[3*i], p[i]) for i in range(len(p)) if p[i] > 0)
    allp = sorted((x[3*i], p[i]) for i in range(len(p)) if x[3*i+1] < 0.5)
    Es = 1/(1-0.09); a = math.sqrt(4*P/(math.pi*Es)); p0 = 2*P/(math.pi*a)
    inner = [(xx, pp) for xx, pp in pts if abs(xx) < 0.7*a]
    ps = [pp for _, pp in pts]
    sd = [abs(ps[k] - 0.5*(ps[k-1]+ps[k+1])) for k in range(1, len(ps)-1) if abs(pts[k][0]) < 0.7*a]
    # odd-even index: the element-scale second difference of the deviation from Hertz, each point
    # against the points at the same place of the neighbouring elements, x -+ h (h = pi / n_arc,
    # the arc element length; reference x near the bottom of the arc), over the points whose
    # neighbours lie within |x| < 0.7a too: a wave of two elements shows at full amplitude, the
    # smooth profile and the interpolation inside an element hardly
    h = math.pi / n
    dev_at = lambda xx, pp: pp - p0 * math.sqrt(max(0, 1 - (xx / a) ** 2))
    def at(xx):
        j = min(range(len(allp)), key=lambda i: abs(allp[i][0] - xx))
        return dev_at(*allp[j]) if abs(allp[j][0] - xx) < 0.05 * h else None
    oe = [0.0]
    for xx, pp in inner:
        if abs(xx) + h < 0.7 * a:
            l, r = at(xx - h), at(xx + h)
            if l is not None and r is not None:
                oe.append(abs(dev_at(xx, pp) - 0.5 * (l + r)))
    dev = [abs(pp - p0*math.sqrt(max(0, 1-(xx/a)**2)))/p0 for xx, pp in inner]
    print(f"| {fam} | {gap} | {n} | {eps:g} | {len(pts)} | {min(pp for _,pp in inner)/p0:.3f} | {max(ps)/p0:.3f} | {100*max(dev):.1f} % | {100*max(sd)/p0:.1f} % | {100*max(oe)/p0:.1f} % | {100*(max(pn)-p0)/p0:+.2f} % | {b.newton(s)} |", flush=True)
print("| family | gap | n_arc | eps_n | points in contact | min p/p0 (|x|<0.7a) | max p/p0 | max |p - p_Hertz(x_ref)|/p0 (|x|<0.7a) | max 2nd difference /p0 | odd-even index /p0 | nominal L2 peak error | Newton its |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
for args in [a.split(":") for a in sys.argv[1:]]:
    study(args[0], int(args[1]), float(args[2]), *args[3:4])
