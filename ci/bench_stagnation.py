#!/usr/bin/env python3
"""Stopping stagnant Newton solves (docs/user-guide/solvers.md): each run with `solver.stagnation_window` = 0
(off: a failing attempt runs to the iteration limit, 30) and the values given, one after the other
with one binary. Prints one table row per run: steps (rescued), cutbacks, Newton iterations of the
converged attempts and of the failed ones, their sum (the work), user CPU seconds (getrusage of the
child), and the run's metrics (ci/paper_metrics.py for the paper cases).

Usage: python3 ci/bench_stagnation.py [WINDOW...] [--only LABEL...]   (default windows: 10;
NURBS_CONTACT_BIN=PATH picks the binary, default target/release/nurbs-contact)
"""
import json, os, resource, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("NURBS_CONTACT_BIN", os.path.join(ROOT, "target", "release", "nurbs-contact"))
SLIDE4 = ["bcs.1.value=[[0.0, -0.6666666666666666], [4.0, -0.6666666666666666]]", "stages.1.steps=160"]


def ironing(f):
    return ("ironing_2d.toml", [f"bodies.block.element={f}", f"bodies.cylinder.element={f}"] + SLIDE4, "ironing")


RUNS = [
    ("ironing mesh 4, Q1N2", *ironing("Q1N2")),
    ("ironing mesh 4, Q1C1", *ironing("Q1C1")),
    ("ironing mesh 4, Q1N2.1", *ironing("Q1N2.1")),
    ("ironing mesh 4, Q1N2.2", *ironing("Q1N2.2")),
    ("ironing mesh 4, Q1CH", *ironing("Q1CH")),
    ("ironing mesh 4, Q1C2", *ironing("Q1C2")),
    ("DCB, Q1C1", "dcb_2d.toml", ["bodies.upper.element=Q1C1", "bodies.lower.element=Q1C1"], "dcb"),
    ("peeling mesh 8, Q1N2", "peeling_2d.toml", ["bodies.strip.element=Q1N2"], "peeling"),
    ("twisting mesh 4, Q1C1", "twisting_3d.toml",
     ["bodies.cube.element=Q1C1", "bodies.shell.element=Q1C1", "meshes.cube.divisions=[4,4,4]",
      "meshes.shell.n_surface=8", "meshes.shell.n_thickness=2"], "twisting"),
    ("frictional twisting mesh 4, Q1N2", "twisting_friction_3d.toml",
     ["meshes.cube.divisions=[4,4,4]", "meshes.shell.n_surface=8", "meshes.shell.n_thickness=2"], None),
]


def run(case, sets, window):
    out = tempfile.mkdtemp(prefix="stag")
    cmd = [BIN, "run", os.path.join(ROOT, "cases", case), "--out", out, "-q", "--overwrite",
           "--set", f"solver.stagnation_window={window}"]
    for s in sets:
        cmd += ["--set", s]
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    p = subprocess.run(cmd, capture_output=True, text=True)
    cpu = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - before
    s = json.load(open(os.path.join(out, "summary.json")))
    return out, s, cpu, p.returncode


def metrics(kind, out):
    if kind is None:
        return ""
    p = subprocess.run([sys.executable, os.path.join(ROOT, "ci", "paper_metrics.py"), kind, out],
                       capture_output=True, text=True)
    line = p.stdout.strip().splitlines()[-1] if p.stdout.strip() else p.stderr.strip()
    keep = ("dPx=", "dPy=", "mean_Py=", "amplitude", "min_slope", "dPz", "Mz", "F_mean", "M_mean")
    return " ".join(w for w in line.split() if w.startswith(keep))


def main():
    args = sys.argv[1:]
    only = []
    if "--only" in args:
        i = args.index("--only")
        only, args = args[i + 1:], args[:i]
    windows = [0] + [int(a) for a in args] if args else [0, 10]
    print("| run | window | steps (rescued) | cutbacks | Newton its converged + failed = work | user CPU s | metrics |")
    print("|---|---|---|---|---|---|---|")
    for label, case, sets, kind in RUNS:
        if only and not any(o in label for o in only):
            continue
        for w in windows:
            out, s, cpu, rc = run(case, sets, w)
            st = s["steps"]
            rescued = sum(1 for x in st if x.get("pseudo_steps", 0) > 0)
            cut = sum(x["cutbacks"] for x in st)
            conv = s["newton"]["total_iterations"]
            failed = s["newton"].get("failed_iterations", 0)
            status = "" if s["status"] == "converged" else f" **{s['status']}: {s.get('reason', '')[:80]}**"
            print(f"| {label} | {w} | {len(st)} ({rescued}) | {cut} | {conv} + {failed} = {conv + failed} | "
                  f"{cpu:.1f} | {metrics(kind, out)}{status} |", flush=True)


if __name__ == "__main__":
    main()
