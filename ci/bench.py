#!/usr/bin/env python3
"""Benchmark of the solver core (docs/performance/solver.md): a Neo-Hookean hex8 block compressed in 3 load steps
at several sizes, on 1 and 2 ranks, COO vs MatSetValues assembly. Prints one markdown table row per
run, with the per-Newton-iteration split taken from PETSc's -log_view and the peak memory per rank
from /usr/bin/time. Usage: python3 ci/bench.py [SIZES...] (default 10 20 30); BIN=path runs another
binary."""
import json, os, re, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("BIN", os.path.join(ROOT, "target", "release", "nurbs-contact"))
CASE = os.path.join(ROOT, "cases", "block_compression_3d.toml")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_btl="self,vader", OPENBLAS_NUM_THREADS="1")


def event(log, name):
    """(count, max time over ranks) of a -log_view event."""
    m = re.search(r"^%s\s+(\d+)\s+\S+\s+(\S+)" % re.escape(name), log, re.M)
    return (int(m.group(1)), float(m.group(2))) if m else (0, 0.0)


def run(n, np, matsetvalues):
    out = tempfile.mkdtemp(prefix="bench")
    cmd = [BIN, "run", CASE, "--out", out, "-q", "--set", f"meshes.block.divisions=[{n},{n},{n}]",
           "--set", "stages.0.steps=3", "-log_view"]
    if matsetvalues:
        cmd.append("--matsetvalues")
    timed = ["/usr/bin/time", "-f", "maxrss_kb %M"] + cmd
    if np > 1:
        timed = ["mpirun", "--oversubscribe", "-np", str(np)] + timed
    p = subprocess.run(timed, env=ENV, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"run failed: {' '.join(cmd)}\n{p.stderr}")
    log = p.stdout + p.stderr
    s = json.load(open(os.path.join(out, "summary.json")))
    its = s["newton"]["total_iterations"]
    _, fac = event(log, "MatLUFactorNum")
    _, sym = event(log, "MatLUFactorSym")
    _, sol = event(log, "MatSolve")
    n_jac, jac = event(log, "SNESJacobianEval")
    _, fun = event(log, "SNESFunctionEval")
    _, total = event(log, "SNESSolve")
    rss = max(int(x) for x in re.findall(r"maxrss_kb (\d+)", log)) / 1024
    assembly = jac + fun
    rest = total - assembly - fac - sym - sol
    elems = s["elements"]
    return (f"| {n}^3 | {s['unknowns']} | {np} | {'MatSetValues' if matsetvalues else 'COO'} | {its} "
            f"| {assembly / its:.3f} | {(fac + sym) / its:.3f} | {sol / its:.3f} | {rest / its:.3f} "
            f"| {total / its:.3f} | {100 * assembly / total:.1f} % | {elems * n_jac / jac:.3g} | {rss:.0f} |")


if __name__ == "__main__":
    sizes = [int(a) for a in sys.argv[1:]] or [10, 20, 30]
    print("| mesh | unknowns | ranks | assembly | Newton its | assembly s/it | LU factor s/it "
          "| LU solve s/it | rest s/it | total s/it | assembly share | elements/s (Jacobian) "
          "| peak RSS/rank MB |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in sizes:
        for np in (1, 2):
            for msv in (False, True):
                print(run(n, np, msv), flush=True)
