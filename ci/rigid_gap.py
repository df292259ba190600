#!/usr/bin/env python3
"""The weighted gap against rigid partners (docs/formulations.md, "Rigid partners"): every shipped
case with a rigid partner under the penalty law, run with its default formulation (the paper's
pointwise gap; one pass against a rigid partner) and with `contact.0.gap=weighted`, for the
case's family and Q1C1 / Q1N2. Standard library only; reads runs through ci/formulation_matrix.py's
helpers (h5dump).

    python3 ci/rigid_gap.py [--out DIR] [--only LABEL,..] [--report-only] [--mesh-dir DIR]

A run whose DIR/LABEL/FORM/FAMILY/rec.json exists is not repeated (delete it to re-run);
--report-only prints the table from the stored records. The graded meshes are made with Gmsh
(Debian: `apt-get install gmsh`) when absent.

Runs (label: case, metric):
  hertz_gmsh_s  cases/hertz_gmsh_2d.toml on the graded mesh regenerated with both sizes of
                cases/meshes/half_disk_graded.geo scaled by s = 1, 0.7071, 0.5, 0.3536
                (`gmsh -2 -format msh41`, files MESHES/hd_<s>.msh, MESHES the --mesh-dir; s = 1 is the
                shipped mesh): the
                L2-projected nominal peak against Hertz's p0 for the run's load (as tests/gmsh.rs)
                and the contact half-width a from the active contact points against Hertz's a
  hertz_2d      cases/hertz_2d.toml (uniform O-grid, n_arc 32): the same metrics
  hertz_3d      cases/hertz_3d.toml (quarter sphere, shipped [12,12,8]; also [8,8,6] and
                [16,16,11]): full load 4 P_z, nominal peak (the `surface` grid where enriched)
                against Hertz's p0, contact radius from the active contact points against Hertz's
                a; Newton iterations per load step
  cap_3d        cases/cap_press_gmsh_3d.toml: load and peak (no analytical answer)
  cm            cases/cattaneo_mindlin_2d.toml, n_arc 128: stick zone (formulation_matrix.py's cm)
  fblock        cases/friction_block_2d.toml: |P_x + mu P_y| / P_y at the end (sliding, exact 0)
  peeling       cases/peeling_2d.toml: van der Waals, `check` only (the weighted gap is penalty-only)
CPU seconds are user + system of the run (getrusage of the child).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import formulation_matrix as fm  # noqa: E402

ROOT = fm.ROOT
BIN = fm.BIN
E_STAR = 1.0 / (1.0 - 0.3 ** 2)
SIZES = ["1", "0.7071", "0.5", "0.3536"]
FORMS = {"default": [], "weighted": ["contact.0.gap=weighted"]}


def make_meshes(mesh_dir):
    """DIR/hd_<s>.msh: cases/meshes/half_disk_graded.geo with h0 and h1 scaled by s (Gmsh)."""
    os.makedirs(mesh_dir, exist_ok=True)
    with open(os.path.join(ROOT, "cases", "meshes", "half_disk_graded.geo")) as f:
        geo = f.read()
    for s in SIZES[1:]:
        msh = os.path.join(mesh_dir, f"hd_{s}.msh")
        if os.path.exists(msh):
            continue
        g = geo.replace("h0 = 0.015;", f"h0 = 0.015*{s};").replace("h1 = 0.15;", f"h1 = 0.15*{s};")
        path = os.path.join(mesh_dir, f"hd_{s}.geo")
        with open(path, "w") as f:
            f.write(g)
        subprocess.run(["gmsh", "-2", "-format", "msh41", path, "-o", msh], check=True,
                       stdout=subprocess.DEVNULL)


def runs(mesh_dir):
    out = []
    for s in SIZES:
        for fam in ("Q1N2", "Q1C1"):
            mesh = [] if s == "1" else [f"meshes.disk.file={mesh_dir}/hd_{s}.msh"]
            out.append((f"hertz_gmsh_{s}", fam, "hertz_gmsh_2d.toml",
                        [f"bodies.disk.element={fam}"] + mesh, "hertz2d"))
    for fam in ("Q1N2", "Q1C1"):
        out.append(("hertz_2d", fam, "hertz_2d.toml", [f"bodies.disk.element={fam}"], "hertz2d"))
    for fam in ("Q1N2", "Q1C1"):
        out.append(("hertz_3d", fam, "hertz_3d.toml", [f"bodies.ball.element={fam}"], "hertz3d"))
    for tag, div in (("m8", "[8,8,6]"), ("m16", "[16,16,11]")):
        for fam in ("Q1N2", "Q1C1"):
            out.append((f"hertz_3d_{tag}", fam, "hertz_3d.toml",
                        [f"bodies.ball.element={fam}", f"meshes.ball.divisions={div}"], "hertz3d"))
    for fam in ("Q1N2", "Q1C1"):
        out.append(("cap_3d", fam, "cap_press_gmsh_3d.toml", [f"bodies.block.element={fam}"], "cap"))
    for fam in ("Q1N2", "Q1C1"):
        out.append(("cm", fam, "cattaneo_mindlin_2d.toml", [f"bodies.disk.element={fam}"], "cm"))
    for fam in ("Q1C1", "Q1N2"):
        out.append(("fblock", fam, "friction_block_2d.toml", [f"bodies.block.element={fam}"], "fblock"))
    out.append(("peeling", "Q1N2.1", "peeling_2d.toml", [], "none"))
    return out


def points(d, dim):
    f = os.path.join(d, "results.h5")
    x0 = fm.h5_text(f, "/grids/contact_points/coordinates")
    u = fm.h5_last(d, "contact_points", "displacement")
    p = fm.h5_last(d, "contact_points", "contact_pressure")
    n = len(p)
    if dim == 2:
        r = [abs(x0[3 * i] + u[3 * i]) for i in range(n)]
    else:
        r = [math.hypot(x0[3 * i] + u[3 * i], x0[3 * i + 1] + u[3 * i + 1]) for i in range(n)]
    return r, p


def half_width(r, p):
    """Midway between the outermost active point and the nearest inactive one beyond it."""
    a_in = max(ri for ri, pi in zip(r, p) if pi > 0.0)
    beyond = [ri for ri, pi in zip(r, p) if pi <= 0.0 and ri > a_in]
    return 0.5 * (a_in + min(beyond)) if beyond else a_in


def peak(d):
    grid = "surface" if fm.h5_has(d, "surface") else "bulk"
    return max(fm.h5_last(d, grid, "contact_pressure_nominal"))


def m_hertz2d(d, cols):
    P = cols["P_flat_disk_arc_y"][-1]
    a = math.sqrt(4 * P / (math.pi * E_STAR))
    p0 = 2 * P / (math.pi * a)
    r, p = points(d, 2)
    return {"peak_err": peak(d) / p0 - 1.0, "a_err": half_width(r, p) / a - 1.0, "load": P}


def m_hertz3d(d, cols):
    P = 4.0 * cols["P_flat_ball_sphere_z"][-1]
    a = (3 * P / (4 * E_STAR)) ** (1.0 / 3.0)
    p0 = 3 * P / (2 * math.pi * a * a)
    r, p = points(d, 3)
    return {"peak_err": peak(d) / p0 - 1.0, "a_err": half_width(r, p) / a - 1.0, "load": P}


def m_cap(d, cols):
    k = [c for c in cols if c.startswith("P_") and c.endswith("_z")][0]
    return {"load": cols[k][-1], "peak": peak(d)}


def m_fblock(d, cols):
    px, py = cols["P_fric_block_bottom_x"][-1], cols["P_fric_block_bottom_y"][-1]
    return {"slide_err": abs(px + 0.3 * py) / py, "load": py}


METRICS = {"hertz2d": m_hertz2d, "hertz3d": m_hertz3d, "cap": m_cap, "cm": fm.m_cm,
           "fblock": m_fblock}


def shell(case, sets):
    return " ".join(["nurbs-contact run", f"cases/{case}"] + [f"--set {s}" for s in sets])


def run_one(out, label, fam, case, sets, kind, form):
    d = os.path.join(out, label, form, fam)
    rec_path = os.path.join(d, "rec.json")
    if os.path.exists(rec_path):
        with open(rec_path) as f:
            return json.load(f)
    os.makedirs(d, exist_ok=True)
    sets = sets + FORMS[form]
    rec = {"label": label, "family": fam, "form": form, "command": shell(case, sets)}
    base = [BIN, "check", os.path.join("cases", case)] + [a for s in sets for a in ("--set", s)]
    chk = subprocess.run(base, cwd=ROOT, env=fm.ENV, capture_output=True, text=True)
    if chk.returncode != 0 or kind == "none":
        msg = (chk.stderr.strip() or chk.stdout.strip()).splitlines()
        rec.update(status="refused" if chk.returncode else "checked", message=msg[-1] if msg else "")
    else:
        cmd = [BIN, "run", os.path.join("cases", case), "-q", "--out", os.path.join(d, "run"), "--set",
               "output.plots=false"] + [a for s in sets for a in ("--set", s)]
        t0 = time.monotonic()
        with open(os.path.join(d, "stderr.txt"), "w") as err:
            p = subprocess.Popen(cmd, cwd=ROOT, env=fm.ENV, stdout=subprocess.DEVNULL, stderr=err)
            _, status, ru = os.wait4(p.pid, 0)
        rec["wall_s"] = time.monotonic() - t0
        rec["cpu_s"] = ru.ru_utime + ru.ru_stime
        try:
            with open(os.path.join(d, "run", "summary.json")) as f:
                summ = json.load(f)
        except (OSError, ValueError):
            summ = {"status": "no summary"}
        steps = summ.get("steps", [])
        rec.update(unknowns=summ.get("unknowns"), status=summ.get("status"),
                   newton=[s["iterations"] for s in steps],
                   failed_its=summ.get("newton", {}).get("failed_iterations", 0),
                   cutbacks=sum(int(s.get("cutbacks", 0)) for s in steps),
                   rescued=sum(1 for s in steps if s.get("pseudo_steps", 0)))
        if os.waitstatus_to_exitcode(status) == 0 and rec["status"] == "converged":
            rd = os.path.join(d, "run")
            rec["metrics"] = METRICS[kind](rd, fm.history(rd))
    with open(rec_path, "w") as f:
        json.dump(rec, f, indent=1)
    return rec


def pct(v):
    return f"{100 * v:+.3g} %"


def cell(r):
    if r["status"] == "checked":
        return "accepted by `check` (not run)"
    if r["status"] == "refused":
        return "refused: " + r.get("message", "").strip().replace("|", "/")
    if "metrics" not in r:
        return f"failed ({r['status']})"
    m = r["metrics"]
    if "peak_err" in m:
        s = f"peak {pct(m['peak_err'])}, a {pct(m['a_err'])}, P {m['load']:.5e}"
    elif "stick_err" in m:
        s = f"c {pct(m['c_err_hertz'])} (Hertz a), c/a {pct(m['stick_err'])}"
    elif "slide_err" in m:
        s = f"abs(P_x + mu P_y) / P_y {m['slide_err']:.1e}"
    else:
        s = f"P_z {m['load']:.5e}, peak {m['peak']:.5e}"
    its = "/".join(str(i) for i in r["newton"]) if len(r["newton"]) <= 6 else str(sum(r["newton"]))
    extra = f" (+{r['failed_its']} failed), cutbacks {r['cutbacks']}" if r["cutbacks"] else ""
    return f"{s}; Newton {its}{extra}; {r['cpu_s']:.1f} s CPU"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="/tmp/rigid_gap")
    ap.add_argument("--mesh-dir", default="/tmp/rigid_gap/meshes")
    ap.add_argument("--only", default="")
    ap.add_argument("--report-only", action="store_true")
    a = ap.parse_args()
    only = set(filter(None, a.only.split(",")))
    if not a.report_only and (not only or any(o.startswith("hertz_gmsh_") for o in only)):
        make_meshes(a.mesh_dir)
    rows = []
    for label, fam, case, sets, kind in runs(a.mesh_dir):
        if only and label not in only:
            continue
        recs = {}
        for form in FORMS:
            if a.report_only:
                p = os.path.join(a.out, label, form, fam, "rec.json")
                if not os.path.exists(p):
                    continue
                with open(p) as f:
                    recs[form] = json.load(f)
            else:
                recs[form] = run_one(a.out, label, fam, case, sets, kind, form)
                print(label, fam, form, cell(recs[form]), file=sys.stderr, flush=True)
        if recs:
            rows.append((label, fam, recs))
    print("| run | family | unknowns | default (pointwise) | `gap = \"weighted\"` | command (default; "
          "the weighted run adds `--set contact.0.gap=weighted`) |")
    print("|---|---|---|---|---|---|")
    for label, fam, recs in rows:
        d, w = recs.get("default"), recs.get("weighted")
        cmd = (d or w)["command"].replace(a.mesh_dir, "MESHES")
        unk = (d or w).get("unknowns") or ""
        print(f"| {label} | {fam} | {unk} | {cell(d) if d else ''} | {cell(w) if w else ''} | `{cmd}` |")


if __name__ == "__main__":
    main()
