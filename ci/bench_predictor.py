#!/usr/bin/env python3
"""The secant predictor against none on the shipped cases (docs/user-guide/solvers.md,
"Newton with contact"). Usage: python3 ci/bench_predictor.py [--bin BIN] [CASE.toml ...]

Runs each case (default: every case in cases/) on 1 rank with `--set solver.predictor=none` and
`=secant` one after the other and prints a markdown row per case: status, converged steps,
Newton iterations + failed ones, cutbacks, wall seconds (summary.json), and the largest relative
difference of the final reaction and contact forces (history.csv's `R_*` and `P_*` columns, last
row) between the two runs, relative to the largest of those forces over the run."""
import csv, json, os, subprocess, sys, tempfile, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_btl="self,vader", OPENBLAS_NUM_THREADS="1")


def run(binary, case, predictor):
    out = tempfile.mkdtemp(prefix="pred")
    cmd = [binary, "run", case, "--out", out, "-q", "--overwrite",
           "--set", f"solver.predictor=\"{predictor}\"", "--set", "output.plots=false"]
    t0 = time.time()
    p = subprocess.run(cmd, env=ENV, capture_output=True, text=True)
    wall = time.time() - t0
    path = os.path.join(out, "summary.json")
    if not os.path.exists(path):
        return {"status": f"no summary (exit {p.returncode}: {p.stderr.strip()[-200:]})"}, None, wall
    s = json.load(open(path))
    rows = list(csv.DictReader(open(os.path.join(out, "history.csv"))))
    return s, rows, wall


def describe(s, wall):
    if "steps" not in s:
        return s["status"]
    n = s["newton"]
    cut = sum(st.get("cutbacks", 0) for st in s["steps"])
    return (f"{s['status']}, {len(s['steps'])} steps, {n['total_iterations']} + "
            f"{n.get('failed_iterations', 0)}, {cut} cutbacks, {s['wall_time']['total']:.2f} s")


def main():
    args = sys.argv[1:]
    binary = os.path.join(ROOT, "target", "release", "nurbs-contact")
    if args[:1] == ["--bin"]:
        binary, args = args[1], args[2:]
    cases = args or sorted(os.path.join(ROOT, "cases", c) for c in os.listdir(os.path.join(ROOT, "cases"))
                           if c.endswith(".toml"))
    print("| case | none | secant | wall secant / none | final forces, max diff / largest force of the run |")
    print("|---|---|---|---|---|")
    for case in cases:
        (a, ra, wa), (b, rb, wb) = run(binary, case, "none"), run(binary, case, "secant")
        diff = "-"
        if ra and rb:
            keys = [k for k in ra[0] if k.startswith(("R_", "P_"))]
            # the scale: the largest force of the whole run (a final force may be near zero)
            scale = max([abs(float(r[k])) for r in ra for k in keys] + [1e-300])
            if keys:
                diff = f"{max(abs(float(ra[-1][k]) - float(rb[-1][k])) for k in keys) / scale:.1e}"
        ratio = "-"
        if "wall_time" in a and "wall_time" in b:
            ratio = f"{b['wall_time']['total'] / a['wall_time']['total']:.2f}"
        print(f"| `{os.path.basename(case)}` | {describe(a, wa)} | {describe(b, wb)} | {ratio} | {diff} |",
              flush=True)


main()
