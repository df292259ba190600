#!/usr/bin/env python3
"""Contact benchmarks (docs/performance/contact.md, docs/verification/hertz.md). Usage: python3 ci/bench_contact.py [share|pattern|hertz|all]

share   - contact (surface gather, search, projection, contact residual and tangent) as a share of the
          solve, per Newton iteration, on the 2D ironing case at 16 block elements per unit length
          (depression + a short slide) and on the 3D hemisphere pressed onto an 8^3 block, 1 and 2 ranks
pattern - sparsity pattern strategies on ironing_2d (4 elements per unit, 1-unit slide): reserved
          side-neighbour rings 0, 1, 2: pattern rebuilds, Newton iterations, cutbacks, wall time
hertz   - the 2D Hertz case (linear elastic half disk on a rigid flat) for Q1C1, Q1N2, Q1N2.1 at four
          meshes: peak of the post-processed pressure and half-width against Hertz for the computed load;
          `hertz SET...` with further --set values (e.g. contact.0.gap=element_mean)
Times are from summary.json (slowest rank)."""
import json, math, os, re, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "nurbs-contact")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_btl="self,vader", OPENBLAS_NUM_THREADS="1")


def run(case, np=1, sets=(), extra=()):
    out = tempfile.mkdtemp(prefix="bench")
    cmd = [BIN, "run", os.path.join(ROOT, "cases", case), "--out", out, "-q", "--overwrite"]
    for s in sets:
        cmd += ["--set", s]
    cmd += list(extra)
    if np > 1:
        cmd = ["mpirun", "--oversubscribe", "-np", str(np)] + cmd
    p = subprocess.run(cmd, env=ENV, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{p.stderr}")
    return out, json.load(open(os.path.join(out, "summary.json")))


def newton(s):
    return sum(st["iterations"] for st in s["steps"])


def share():
    print("| case | unknowns | ranks | steps | Newton its | contact s | assembly s | solve s (LU, line search) | total s | contact s/it | total s/it | contact share |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    cases = [
        ("ironing_2d.toml, 16/unit", "ironing_2d.toml",
         ["meshes.block.divisions=[160,32]", "meshes.cylinder.n_arc=48", "meshes.cylinder.n_radial=12",
          "stages.1.steps=10", "bcs.1.value=[[0.0, -0.6666666666666666], [0.0625, -0.6666666666666666]]",
          "output.every=1000", "contact.0.formulation=paper"]),
        ("hemisphere_block_3d.toml, 8^3", "hemisphere_block_3d.toml",
         ["output.every=1000", "contact.0.formulation=paper"]),
    ]
    for label, case, sets in cases:
        for np in (1, 2):
            _, s = run(case, np, sets)
            w = s["wall_time"]
            n = newton(s)
            busy = w["assembly"] + w["solve"]
            print(f"| {label} | {s['unknowns']} | {np} | {len(s['steps'])} | {n} | {w['contact']:.3f} | {w['assembly']:.3f} | "
                  f"{w['solve']:.3f} | {w['total']:.2f} | {w['contact']/n:.4f} | {busy/n:.4f} | {100*w['contact']/busy:.1f} % |")


def pattern():
    print("| ring | ranks | steps | Newton its | cutbacks | pattern rebuilds | blocks outside the pattern | pattern s | contact s | total s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for ring in (0, 1, 2):
        for np in (1, 2):
            _, s = run("ironing_2d.toml", np, [f"solver.contact_pattern_ring={ring}"])
            cp, w = s["contact_pattern"], s["wall_time"]
            print(f"| {ring} | {np} | {len(s['steps'])} | {newton(s)} | {sum(st['cutbacks'] for st in s['steps'])} | "
                  f"{cp['rebuilds']} | {cp['missing_blocks']} | {w['pattern']:.3f} | {w['contact']:.3f} | {w['total']:.2f} |")


def h5(path, dataset):
    """A dataset's values, flattened (through h5dump: no Python HDF5 package needed)."""
    with tempfile.NamedTemporaryFile(suffix=".txt") as f:
        subprocess.run(["h5dump", "-m", "%.17g", "-d", dataset, "-y", "-w", "0", "-o", f.name, path],
                       capture_output=True, text=True, check=True)
        return [float(v) for v in re.split(r"[,\s]+", open(f.name).read()) if v]


def hertz_metrics(fam, n, extra=()):
    """One Hertz run: family `fam` at `n_arc = n` with further --set values. Returns the load, Hertz's
    p0 and a for it, the peaks of the current and nominal L2-projected pressures, the half-width from
    the nominal pressure's second moment, and the run's summary."""
    out, s = run("hertz_2d.toml", 1, [f"bodies.disk.element={fam}", f"meshes.disk.n_arc={n}",
                                       f"meshes.disk.n_radial={n // 4}"] + list(extra))
    hist = open(os.path.join(out, "history.csv")).read().splitlines()
    head, last = hist[0].split(","), hist[-1].split(",")
    P = float(last[head.index("P_flat_disk_arc_y")])
    f = os.path.join(out, "results.h5")
    grid = "bulk" if fam == "Q1C1" else "surface"
    steps = sorted(set(re.findall(r"/steps/(\d+)/", subprocess.run(["h5ls", "-r", f], capture_output=True, text=True).stdout)))
    p = h5(f, f"/steps/{steps[-1]}/{grid}/contact_pressure")
    pn = h5(f, f"/steps/{steps[-1]}/{grid}/contact_pressure_nominal")
    x = h5(f, f"/grids/{grid}/coordinates")
    # the arc's points below the centre (reference coordinates), left to right
    arc = sorted((x[3 * i], pn[i], p[i]) for i in range(len(p))
                 if abs(math.hypot(x[3 * i], x[3 * i + 1] - 1.0) - 1.0) < 1e-9 and x[3 * i + 1] < 0.5)
    peak, peak_n = max(v for _, _, v in arc), max(v for _, v, _ in arc)
    m0 = m2 = 0.0
    for (x0, v0, _), (x1, v1, _) in zip(arc, arc[1:]):
        # exact integrals of the linear interpolant between samples
        h = x1 - x0
        m0 += h * (v0 + v1) / 2
        m2 += h * (v0 * (3 * x0 * x0 + 2 * x0 * x1 + x1 * x1) + v1 * (x0 * x0 + 2 * x0 * x1 + 3 * x1 * x1)) / 12
    Es = 1.0 / (1 - 0.3 ** 2)
    a = math.sqrt(4 * P / (math.pi * Es))
    return dict(P=P, p0=2 * P / (math.pi * a), a=a, peak=peak, peak_n=peak_n,
                a_ours=2 * math.sqrt(m2 / m0), summary=s, hist=(head, hist[1:]))


def hertz(meshes=(64, 128, 256, 512), extra=()):
    """Hertz, 2D. The pressures are the L2-projected ones written to results.h5: `contact_pressure`
    (per current area) and `contact_pressure_nominal` (per reference area); Hertz's theory is
    geometrically linear, so the nominal pressure on the reference coordinates is the one it
    predicts. Half-width a from the second moment of the nominal pressure over the reference x
    (for Hertz's distribution int p x^2 / int p = a^2 / 4), which is insensitive to the projection's
    ripples at the contact edges."""
    print("| family | n_arc | elements across 2a | unknowns | load P | p0 (Hertz) | peak p current | error | peak p nominal | error | a (Hertz) | a (2nd moment) | error | Newton its | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    fams = os.environ.get("HERTZ_FAMILIES", "Q1C1,Q1N2,Q1N2.1").split(",")
    meshes = [int(n) for n in os.environ.get("HERTZ_MESHES", ",".join(map(str, meshes))).split(",")]
    for fam in fams:
        for n in meshes:
            m = hertz_metrics(fam, n, extra)
            P, p0, a, peak, peak_n, a_ours, s = (m[k] for k in ("P", "p0", "a", "peak", "peak_n", "a_ours", "summary"))
            across = 2 * a / (math.pi / n)
            print(f"| {fam} | {n} | {across:.1f} | {s['unknowns']} | {P:.6g} | {p0:.6g} | {peak:.6g} | {100*(peak-p0)/p0:+.2f} % | {peak_n:.6g} | {100*(peak_n-p0)/p0:+.2f} % | "
                  f"{a:.5f} | {a_ours:.5f} | {100*(a_ours-a)/a:+.2f} % | {newton(s)} | {s['wall_time']['total']:.2f} |", flush=True)


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "all"
    # further --set values, e.g. contact.0.gap=element_mean; families and meshes from the
    # environment: HERTZ_FAMILIES=Q1C1,Q1N3 HERTZ_MESHES=64,128
    if what == "hertz" and len(sys.argv) > 2:
        hertz(extra=sys.argv[2:])
        sys.exit(0)
    for name, f in (("share", share), ("pattern", pattern), ("hertz", hertz)):
        if what in (name, "all"):
            print(f"\n## {name}\n")
            f()
