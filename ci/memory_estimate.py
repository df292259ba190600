#!/usr/bin/env python3
"""`check`'s peak-memory estimate against the measured peak of the same runs.

For each row: `nurbs-contact check CASE SETS` (its "estimated peak memory X on 1 rank") and
`/usr/bin/time -f %M nurbs-contact run CASE SETS --set output.plots=false` (the peak resident set
of the process), on 1 rank; prints a Markdown table with the ratio estimate / measured.

usage: python3 ci/memory_estimate.py [ROW ...]     (no ROW: every row but the large ones)
       python3 ci/memory_estimate.py --list
The binary is ./target/release/nurbs-contact (BIN=path for another); runs go to /tmp/memory-estimate.
"""
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("BIN", os.path.join(ROOT, "target/release/nurbs-contact"))
OUT = "/tmp/memory-estimate"

E45 = ["meshes.cube.divisions=[24,24,24]", "meshes.shell.n_surface=24",
       "meshes.shell.n_thickness=3", "stages.0.steps=3", "stages.1.steps=1"]
E5 = ["meshes.cube.divisions=[30,30,30]", "meshes.shell.n_surface=30",
      "meshes.shell.n_thickness=4", "stages.0.steps=3", "stages.1.steps=1"]

# name: (case, sets, large)
ROWS = {
    "contact_patch_2d": ("contact_patch_2d.toml", [], False),
    "hertz_2d": ("hertz_2d.toml", [], False),
    "ironing_2d": ("ironing_2d.toml", ["contact.0.formulation=paper"], False),
    "contact_patch_3d": ("contact_patch_3d.toml", [], False),
    "hemisphere_block_3d": ("hemisphere_block_3d.toml", ["contact.0.formulation=paper"], False),
    "twisting_3d": ("twisting_3d.toml", ["contact.0.formulation=paper"], False),
    "cap_press_gmsh_3d": ("cap_press_gmsh_3d.toml", [], False),
    "block_20": ("block_compression_3d.toml", ["meshes.block.divisions=[20,20,20]"], False),
    "scale_e4_direct": ("hemisphere_twist_scale_3d.toml", ["solver.linear=direct"], False),
    "scale_e4_iterative": ("hemisphere_twist_scale_3d.toml", ["solver.linear=iterative"], False),
    "scale_e4.5_direct": ("hemisphere_twist_scale_3d.toml", E45 + ["solver.linear=direct"], True),
    "scale_e4.5_iterative": ("hemisphere_twist_scale_3d.toml", E45 + ["solver.linear=iterative"], True),
    "scale_e5_iterative": ("hemisphere_twist_scale_3d.toml", E5 + ["solver.linear=iterative"], True),
}


def sets_args(sets):
    out = []
    for s in sets:
        out += ["--set", s]
    return out


def human(mb):
    return f"{mb:.0f} MB" if mb < 1000 else f"{mb / 1000:.2f} GB"


def to_mb(text):
    v, unit = text.split()
    return float(v) * {"B": 1e-6, "kB": 1e-3, "MB": 1.0, "GB": 1e3, "TB": 1e6}[unit]


def row(name):
    case, sets, _ = ROWS[name]
    path = os.path.join(ROOT, "cases", case)
    env = dict(os.environ)
    chk = subprocess.run([BIN, "check", path] + sets_args(sets), capture_output=True, text=True,
                         env=env)
    m = re.search(r"estimated peak memory ([0-9.]+ [kMGT]?B) on 1 rank", chk.stdout)
    if not m:
        return f"| {name} | check failed: {(chk.stderr or chk.stdout).strip()[-120:]} | | | |"
    est = to_mb(m.group(1))
    unknowns = re.search(r"([0-9]+) unknowns", chk.stdout).group(1)
    out = os.path.join(OUT, name)
    os.makedirs(OUT, exist_ok=True)
    run = subprocess.run(["/usr/bin/time", "-f", "%M", BIN, "run", path] + sets_args(sets)
                         + ["--set", "output.plots=false", "--out", out, "--overwrite", "-q"],
                         capture_output=True, text=True, env=env)
    peak_kb = float(run.stderr.strip().splitlines()[-1])
    peak = peak_kb * 1024 / 1e6
    status = "" if run.returncode == 0 else " (run failed)"
    return (f"| {name} | {unknowns} | {human(est)} | {human(peak)}{status} | "
            f"{est / peak:.2f} |")


def main():
    args = sys.argv[1:]
    if args == ["--list"]:
        print("\n".join(ROWS))
        return
    names = args or [n for n, r in ROWS.items() if not r[2]]
    print("| row | unknowns | `check` estimate | measured peak RSS | estimate / measured |")
    print("|---|---|---|---|---|")
    for n in names:
        print(row(n), flush=True)


if __name__ == "__main__":
    main()
