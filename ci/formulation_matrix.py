#!/usr/bin/env python3
"""The contact formulation matrix (docs/formulations.md): every penalty formulation (`gap` x
`algorithm`, with `augmented` where it applies) x element family
x question (row), each run through `nurbs-contact run CASE --set ...`, its metrics computed from the
run's history.csv, summary.json and results.h5 (through h5dump). Standard library only.

    python3 ci/formulation_matrix.py [--rows R,..] [--forms F,..] [--families F,..] [--jobs N]
        [--timeout S] [--out DIR] [--report-only] [--md FILE] [--csv FILE] [--list]

Each combination is first given to `nurbs-contact check`; one the solver refuses is recorded as
`refused: <message>` and not run. A run that exceeds its time limit (CPU seconds of the run, the
row's default unless --timeout; four times as many wall seconds as a backstop) is killed and
recorded as such. Every run leaves DIR/<row>/<form>/<family>/ with
the solver's output and `matrix.json` (its measured record); a later invocation reuses those
records (delete one to re-run it), so the matrix can be run in pieces and `--report-only` writes
the tables from whatever has been run. CPU time is user + system of the run (getrusage of the
child), the cost measure on a loaded machine; wall time is measured around the run.

Rows (the questions; `--list` prints the runs):
  patch2d, patch3d  contact patch test on non-matching meshes (cases/contact_patch_{2,3}d.toml):
                    relative spread (max p - min p) / mean p of the law's pressure at the active
                    contact points (grid contact_points), last step
  hertz             Hertz on cases/hertz_gmsh_2d.toml's graded mesh: peak of the L2-projected
                    nominal pressure (`contact_pressure_nominal`, as tests/gmsh.rs) and of the
                    current one against Hertz's p0 for the computed load
  cm                Cattaneo-Mindlin (cases/cattaneo_mindlin_2d.toml, n_arc 128): stick-zone
                    half-width c from the points' positions (as tests/friction.rs) against
                    Cattaneo-Mindlin's c = a sqrt(1 - Q / (mu P)) with Hertz's a for the
                    computed load, and c/a with a from the active points as the test does
  ironing4/8/16     ironing, docs/verification/paper.md 4.1's 4-unit slide on meshes 4, 8, 16: eq. (22)
                    DeltaP_x, DeltaP_y (both half-passes together) and eq. (23) DeltaP_ece (per
                    half-pass) over the sliding window s >= 1, relative to the mean P_y; the
                    cylinder's P_y range over its mean in that window; cutbacks and rescued steps
  twist2/4/8        Table 4's twist (cases/twisting_3d.toml, the meshes of
                    cases/studies/twisting_table4.toml): eq. (22) DeltaP_z and eq. (23) over the
                    rotation, max |M_z|

Formulations (`--forms`, names `ALGORITHM/GAP[+al]`): `thp` two-half-pass, `op` one-pass;
gap pointwise, element_mean, weighted, weighted_linear, weighted_mean; `+al` the augmented Lagrangian
(`augmented = { tol, max = 30 }`, tol per row below, about a tenth of the plain penalty's
penetration). The `+freeze` lines of docs/formulations.csv measured `solver.contact_freeze_after`,
a retired key (docs/formulations.md, "Retired keys"); the matrix no longer runs them.
"""
import argparse
import concurrent.futures as cf
import csv
import json
import math
import os
import re
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("NURBS_CONTACT_BIN", os.path.join(ROOT, "target", "release", "nurbs-contact"))
ENV = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")

GAPS = ["pointwise", "element_mean", "weighted", "weighted_linear", "weighted_mean"]


def formulations():
    """name -> (--set values without the row's augmented tolerance, augmented?)"""
    out = {}
    for alg, tag in (("two_half_pass", "thp"), ("one_pass", "op")):
        for gap in GAPS:
            base = [f"contact.0.algorithm={alg}", f"contact.0.gap={gap}"]
            out[f"{tag}/{gap}"] = (base, False)
            out[f"{tag}/{gap}+al"] = (base, True)
    return out


FORMS = formulations()
# the combinations a user can write; the solver's `check` decides which it accepts
DEFAULT_FORMS = [f"{a}/{g}" for a in ("thp", "op") for g in GAPS] + \
    [f"{a}/{g}+al" for a in ("thp", "op") for g in ("pointwise", "weighted", "weighted_linear", "element_mean", "weighted_mean")]

SLIDE4 = ["bcs.1.value=[[0.0, -0.6666666666666666], [4.0, -0.6666666666666666]]"]
IRON_MESH = {
    4: ["stages.1.steps=160"],
    8: ["meshes.block.divisions=[80,16]", "meshes.cylinder.n_arc=24", "meshes.cylinder.n_radial=6",
        "stages.1.steps=320"],
    16: ["meshes.block.divisions=[160,32]", "meshes.cylinder.n_arc=48", "meshes.cylinder.n_radial=12",
         "stages.1.steps=640"],
}
TWIST_MESH = {
    2: ["meshes.cube.divisions=[2,2,2]", "meshes.shell.n_surface=4", "meshes.shell.n_thickness=1"],
    4: ["meshes.cube.divisions=[4,4,4]", "meshes.shell.n_surface=8", "meshes.shell.n_thickness=2"],
    8: ["meshes.cube.divisions=[8,8,8]", "meshes.shell.n_surface=12", "meshes.shell.n_thickness=3"],
}
FAM2 = ["Q1C1", "Q1N2", "Q1N4", "Q1N2.1"]
FAM3 = ["Q1C1", "Q1N2", "Q1N4", "Q1N2.1"]


def both(a, b):
    return lambda f: [f"bodies.{a}.element={f}", f"bodies.{b}.element={f}"]


# row -> case, family sets, further sets, metric kind, augmented tol, time limit (CPU s), families
ROWS = {
    "patch2d": dict(case="contact_patch_2d.toml", fam=both("lower", "upper"), sets=[], kind="patch",
                    al_tol=1e-7, timeout=120, families=FAM2),
    "patch3d": dict(case="contact_patch_3d.toml", fam=both("lower", "upper"), sets=[], kind="patch",
                    al_tol=1e-7, timeout=300, families=FAM3),
    "hertz": dict(case="hertz_gmsh_2d.toml", fam=lambda f: [f"bodies.disk.element={f}"], sets=[],
                  kind="hertz", al_tol=1e-7, timeout=300, families=FAM2),
    "cm": dict(case="cattaneo_mindlin_2d.toml", fam=lambda f: [f"bodies.disk.element={f}"], sets=[],
               kind="cm", al_tol=1e-7, timeout=300, families=FAM2),
}
for m, t in ((4, 90), (8, 200), (16, 400)):
    ROWS[f"ironing{m}"] = dict(case="ironing_2d.toml", fam=both("block", "cylinder"),
                               sets=SLIDE4 + IRON_MESH[m] + ["output.every=100000"], kind="ironing",
                               al_tol=5e-5, timeout=t, families=FAM2)
for m, t in ((2, 120), (4, 300), (8, 600)):
    ROWS[f"twist{m}"] = dict(case="twisting_3d.toml", fam=both("cube", "shell"),
                             sets=TWIST_MESH[m] + ["output.every=100000"], kind="twist",
                             al_tol=1e-3, timeout=t, families=FAM3)
TITLES = {
    "patch2d": "Contact patch test, 2D, non-matching meshes: spread of the contact-point pressure",
    "patch3d": "Contact patch test, 3D, non-matching meshes: spread of the contact-point pressure",
    "hertz": "Hertz on the graded Gmsh mesh: peak pressure against Hertz",
    "cm": "Cattaneo-Mindlin, n_arc 128: stick zone",
    "ironing4": "Ironing, mesh 4: force oscillation over the slide",
    "ironing8": "Ironing, mesh 8: force oscillation over the slide",
    "ironing16": "Ironing, mesh 16: force oscillation over the slide",
    "twist2": "Table 4's twist, mesh 2: DeltaP_z",
    "twist4": "Table 4's twist, mesh 4: DeltaP_z",
    "twist8": "Table 4's twist, mesh 8: DeltaP_z",
}
ROW_ORDER = ["patch2d", "patch3d", "hertz", "ironing4", "twist2", "cm", "ironing8", "twist4",
             "ironing16", "twist8"]


def sets_of(row, form, fam):
    r = ROWS[row]
    base, al = FORMS[form]
    s = r["fam"](fam) + r["sets"] + base
    if al:
        s.append(f"contact.0.augmented={{ tol = {r['al_tol']:g}, max = 30 }}")
    return s


def command(verb, row, sets, out=None):
    cmd = [BIN, verb, os.path.join("cases", ROWS[row]["case"])]
    if out:
        cmd += ["--out", out, "-q", "--overwrite"]
    for s in sets:
        cmd += ["--set", s]
    return cmd


def template(row):
    """The row's command with the family F and the formulation's keys left open."""
    parts = ["nurbs-contact", "run", f"cases/{ROWS[row]['case']}"]
    for s in ROWS[row]["fam"]("F") + ROWS[row]["sets"]:
        parts += ["--set", f"'{s}'" if re.search(r"[ \[\]{}]", s) else s]
    parts += ["--set contact.0.algorithm=A --set contact.0.gap=G",
              f"[--set 'contact.0.augmented={{ tol = {ROWS[row]['al_tol']:g}, max = 30 }}']"]
    return " ".join(parts)


def shell_line(row, form, fam):
    """The command as a user would type it (quoted --set values)."""
    parts = ["nurbs-contact", "run", f"cases/{ROWS[row]['case']}"]
    for s in sets_of(row, form, fam):
        parts += ["--set", f"'{s}'" if re.search(r"[ \[\]{}]", s) else s]
    return " ".join(parts)


# ---------------------------------------------------------------- reading a run's output

def history(d):
    with open(os.path.join(d, "history.csv")) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else {}


def h5_text(path, dataset):
    t = subprocess.run(["h5dump", "-m", "%.17g", "-y", "-w", "0", "-d", dataset, path],
                       capture_output=True, text=True, check=True).stdout
    body = t[t.index("DATA {") + 6:]
    body = body[:body.index("}")]
    return [float(v) for v in re.split(r"[,\s]+", body) if v]


def h5_last(d, grid, field):
    f = os.path.join(d, "results.h5")
    names = subprocess.run(["h5ls", f + "/steps"], capture_output=True, text=True, check=True).stdout
    last = max(re.findall(r"^(\d+)\s", names, re.M), key=int)
    return h5_text(f, f"/steps/{last}/{grid}/{field}")


def h5_has(d, grid):
    t = subprocess.run(["h5ls", os.path.join(d, "results.h5") + "/grids"], capture_output=True,
                       text=True).stdout
    return re.search(rf"^{grid}\s", t, re.M) is not None


def window(cols, keep):
    idx = [i for i, lam in enumerate(cols["load_factor"]) if keep(lam)]
    return lambda k: [cols[k][i] for i in idx]


def eq22(series):
    vals = [v for s in series for v in s]
    return max(vals) - min(vals)


def eq23(series):
    return max(max(s) - min(s) for s in series)


def passes(cols, prefix, comp):
    """The half-passes' force columns `P_<pair>_<surface>_<comp>`, the second negated (it acts on
    the other body), as ci/paper_metrics.py takes them."""
    ks = [k for k in cols if k.startswith(prefix) and k.endswith("_" + comp)]
    return ks


# ---------------------------------------------------------------- metrics per kind

def m_patch(d, cols):
    p = [v for v in h5_last(d, "contact_points", "contact_pressure") if v > 0.0]
    mean = sum(p) / len(p)
    return {"spread": (max(p) - min(p)) / mean, "points": len(p), "mean_p": mean}


E_STAR = 1.0 / (1.0 - 0.3 ** 2)


def m_hertz(d, cols):
    P = cols["P_flat_disk_arc_y"][-1]
    a = math.sqrt(4 * P / (math.pi * E_STAR))
    p0 = 2 * P / (math.pi * a)
    grid = "surface" if h5_has(d, "surface") else "bulk"
    pn = max(h5_last(d, grid, "contact_pressure_nominal"))
    pc = max(h5_last(d, grid, "contact_pressure"))
    return {"peak_nominal_err": (pn - p0) / p0, "peak_current_err": (pc - p0) / p0, "load": P}


MU = 0.3


def m_cm(d, cols):
    q, p = cols["P_cm_disk_arc_x"][-1], cols["P_cm_disk_arc_y"][-1]
    ratio = -q / (MU * p)
    f = os.path.join(d, "results.h5")
    x0 = h5_text(f, "/grids/contact_points/coordinates")
    u = h5_last(d, "contact_points", "displacement")
    pp = h5_last(d, "contact_points", "contact_pressure")
    st = h5_last(d, "contact_points", "friction_state")
    pts = sorted((x0[3 * i] + u[3 * i], pp[i], st[i]) for i in range(len(st)))

    def bracket(inside):
        idx = [i for i, v in enumerate(pts) if inside(v)]
        lo, hi = idx[0], idx[-1]
        return 0.5 * (pts[hi][0] - pts[lo][0]), 0.5 * (pts[hi + 1][0] - pts[lo - 1][0])

    a_in, a_out = bracket(lambda v: v[1] > 0.0)
    c_in, c_out = bracket(lambda v: v[2] == 1.0)
    a, c = 0.5 * (a_in + a_out), 0.5 * (c_in + c_out)
    cm = math.sqrt(1.0 - ratio)
    # against Hertz's a for the computed load: the weighted gaps' interpolated pressure reaches
    # past the contact edge, which widens the active points' a (docs/verification/friction.md), so c/a from the points measures that spread as well
    a_hertz = math.sqrt(4 * p / (math.pi * E_STAR))
    return {"stick_err": (c / a) / cm - 1.0, "c_err_hertz": c / (cm * a_hertz) - 1.0,
            "a_err_hertz": a / a_hertz - 1.0, "Q_over_muP": ratio}


def m_ironing(d, cols):
    w = window(cols, lambda lam: lam >= 1.25 - 1e-9)
    out = {}
    ys = []
    for c in "xy":
        ks = passes(cols, "P_", c)
        series = [w(k) if i == 0 else [-v for v in w(k)] for i, k in enumerate(ks)]
        out["dP" + c] = eq22(series)
        out["dP" + c + "_ece"] = eq23(series)
        if c == "y":
            ys = series
    py = abs(sum(sum(s) / len(s) for s in ys) / len(ys))
    out["mean_Py"] = py
    for c in "xy":
        out[f"dP{c}/Py"] = out["dP" + c] / py
        out[f"dP{c}_ece/Py"] = out["dP" + c + "_ece"] / py
    cyl = w("P_ironing_cylinder_arc_y")
    out["cyl_Py_range/mean"] = (max(cyl) - min(cyl)) / abs(sum(cyl) / len(cyl))
    return out


def m_twist(d, cols):
    w = window(cols, lambda lam: lam > 1.0 + 1e-9)
    ks = passes(cols, "P_twist_", "z")
    series = [w(k) if i == 0 else [-v for v in w(k)] for i, k in enumerate(ks)]
    mz = [w(k) for k in cols if k.startswith("M_twist_") and k.endswith("_z")]
    return {"dPz": eq22(series), "dPz_ece": eq23(series),
            "max_abs_Mz": max(abs(v) for s in mz for v in s)}


METRICS = {"patch": m_patch, "hertz": m_hertz, "cm": m_cm, "ironing": m_ironing, "twist": m_twist}

# per kind: the columns of the table (key, header, format) and the metrics that decide "best"
# (smaller absolute value is better); `floor`: values below it count as equal (round-off)
COLUMNS = {
    "patch": [("spread", "pressure spread", "{:.2e}")],
    "hertz": [("peak_nominal_err", "peak error (nominal)", "spct"),
              ("peak_current_err", "peak error (current)", "spct")],
    "cm": [("c_err_hertz", "stick zone c error (Hertz a)", "spct"),
           ("stick_err", "c/a error (points' a)", "spct"),
           ("a_err_hertz", "points' a vs Hertz", "spct"), ("Q_over_muP", "Q / (mu P)", "{:.3f}")],
    "ironing": [("dPx/Py", "DeltaP_x / P_y", "pct"), ("dPy/Py", "DeltaP_y / P_y", "pct"),
                ("dPx_ece/Py", "DeltaP_x,ece / P_y", "pct"),
                ("dPy_ece/Py", "DeltaP_y,ece / P_y", "pct"),
                ("cyl_Py_range/mean", "cylinder P_y range / mean", "pct"),
                ("mean_Py", "mean P_y", "{:.4f}")],
    "twist": [("dPz", "DeltaP_z", "{:.3g}"), ("dPz_ece", "DeltaP_z,ece", "{:.3g}"),
              ("max_abs_Mz", "max abs M_z", "{:.3g}")],
}
DECIDE = {"patch": (["spread"], 1e-8), "hertz": (["peak_nominal_err"], 0.0),
          "cm": (["c_err_hertz", "stick_err"], 0.0),
          "ironing": (["dPx/Py", "dPy/Py", "cyl_Py_range/mean"], 0.0), "twist": (["dPz"], 0.0)}


# ---------------------------------------------------------------- running

def cpu_of(pid):
    """User + system seconds of a running process so far (/proc/PID/stat), 0 if unreadable."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return 0.0


def run_one(outdir, row, form, fam, timeout):
    d = os.path.join(outdir, row, form.replace("/", "_"), fam)
    rec_path = os.path.join(d, "matrix.json")
    if os.path.exists(rec_path):
        with open(rec_path) as f:
            return json.load(f)
    os.makedirs(d, exist_ok=True)
    sets = sets_of(row, form, fam)
    rec = {"row": row, "form": form, "family": fam, "command": shell_line(row, form, fam)}
    chk = subprocess.run(command("check", row, sets), cwd=ROOT, env=ENV, capture_output=True, text=True)
    if chk.returncode != 0:
        msg = (chk.stderr.strip() or chk.stdout.strip()).splitlines()
        msg = msg[-1] if msg else f"exit {chk.returncode}"
        msg = re.sub(r"^error: [^:]*\.toml: ", "", msg)
        rec.update(status="refused", message=msg)
    else:
        t0 = time.monotonic()
        with open(os.path.join(d, "stderr.txt"), "w") as err:
            p = subprocess.Popen(command("run", row, sets, d), cwd=ROOT, env=ENV,
                                 stdout=subprocess.DEVNULL, stderr=err, start_new_session=True)
            killed = False
            while True:
                pid, status, ru = os.wait4(p.pid, os.WNOHANG)
                if pid:
                    break
                # the limit is on the run's CPU time (the machine's load stretches wall time), with
                # four times as much wall time as a backstop
                over = cpu_of(p.pid) > timeout or time.monotonic() - t0 > 4 * timeout
                if over and not killed:
                    os.killpg(p.pid, 9)
                    killed = True
                time.sleep(0.2)
            p.returncode = os.waitstatus_to_exitcode(status)
        rec["wall_s"] = time.monotonic() - t0
        rec["cpu_s"] = ru.ru_utime + ru.ru_stime
        cols, summ = {}, {}
        try:
            cols = history(d)
        except (OSError, StopIteration, ValueError):
            pass
        try:
            with open(os.path.join(d, "summary.json")) as f:
                summ = json.load(f)
        except (OSError, ValueError):
            pass
        steps = summ.get("steps", [])
        nw = summ.get("newton", {})
        rec.update(newton=nw.get("total_iterations", int(sum(cols.get("newton_iterations", [])))),
                   newton_failed=nw.get("failed_iterations", 0),
                   steps=len(steps) or len(cols.get("load_factor", [])),
                   cutbacks=sum(int(s.get("cutbacks", 0)) for s in steps),
                   rescued=sum(1 for s in steps if s.get("pseudo_steps", 0)),
                   al_rounds=sum(int(s.get("augmentation_rounds", 0)) for s in steps),
                   unknowns=summ.get("unknowns"),
                   load=cols["load_factor"][-1] if cols.get("load_factor") else 0.0)
        if killed:
            rec.update(status="timeout", message=f"stopped at the {timeout:g} s limit at load {rec['load']:.4g}")
        elif p.returncode != 0 or summ.get("status") != "converged":
            reason = summ.get("reason") or open(os.path.join(d, "stderr.txt")).read().strip()[-300:]
            rec.update(status="failed", message=f"stopped at load {rec['load']:.4g}: {reason}")
        else:
            try:
                rec["metrics"] = METRICS[ROWS[row]["kind"]](d, cols)
                rec["status"] = "ok"
            except (OSError, KeyError, ValueError, IndexError, ZeroDivisionError,
                    subprocess.CalledProcessError) as e:
                rec.update(status="failed", message=f"metric: {e!r}")
    with open(rec_path, "w") as f:
        json.dump(rec, f, indent=1)
    return rec


# ---------------------------------------------------------------- reporting

def fmt(v, f):
    if v is None:
        return ""
    if isinstance(v, float) and (math.isnan(v) or math.isinf(v)):
        return str(v)
    if f == "pct":
        return f"{100 * v:.3g} %"
    if f == "spct":
        return f"{100 * v:+.3g} %"
    return f.format(v)


def wins(recs, kind):
    """{(form, family, metric): 'best' | 'within'} on the deciding metrics."""
    keys, floor = DECIDE[kind]
    out = {}
    for fam in sorted({r["family"] for r in recs}):
        ok = [r for r in recs if r["family"] == fam and r["status"] == "ok"]
        for k in keys:
            vals = [(max(abs(r["metrics"][k]), floor), r["form"]) for r in ok]
            if not vals:
                continue
            best = min(v for v, _ in vals)
            for v, form in vals:
                if v == best:
                    out[(form, fam, k)] = "best"
                elif v <= 1.1 * best:
                    out[(form, fam, k)] = "within"
    return out


def cell(r, kind, w):
    """One table cell: the deciding metrics (bold: best of the family's column, italic: within
    10 % of it), then the cost."""
    if r["status"] == "refused":
        return "refused"
    cost = f"{r['newton']}"
    if r.get("newton_failed"):
        cost += f" (+{r['newton_failed']})"
    cost += " its"
    if r.get("al_rounds"):
        cost += f", {r['al_rounds']} AL rounds"
    if r.get("cutbacks") or r.get("rescued"):
        cost += f", {r['cutbacks']} cutbacks, {r['rescued']} rescued"
    cost += f", {r['cpu_s']:.1f} s CPU ({r['wall_s']:.0f} wall)"
    if r["status"] == "failed":
        return f"failed at load {r['load']:.4g}; {cost}"
    if r["status"] == "timeout":
        return f"{r['message'].replace(' s limit', ' s CPU limit')}; {cost}"
    if r["status"] != "ok":
        return f"{r['status']}: {r['message'][:160]}; {cost}"
    fmts = {k: f for k, _, f in COLUMNS[kind]}
    vals = []
    for k in DECIDE[kind][0]:
        c = fmt(r["metrics"].get(k), fmts[k])
        mark = w.get((r["form"], r["family"], k))
        vals.append(f"**{c}**" if mark == "best" else (f"*{c}*" if mark == "within" else c))
    return " · ".join(vals) + "; " + cost


def table(row, recs):
    """Formulations down, families across."""
    kind = ROWS[row]["kind"]
    w = wins(recs, kind)
    fams = [f for f in ROWS[row]["families"] if any(r["family"] == f for r in recs)]
    fams += sorted({r["family"] for r in recs} - set(fams))
    forms = []
    for r in recs:
        if r["form"] not in forms:
            forms.append(r["form"])
    by = {(r["form"], r["family"]): r for r in recs}
    lines = ["| formulation | " + " | ".join(fams) + " |", "|---|" + "---|" * len(fams)]
    for form in forms:
        rs = [by.get((form, f)) for f in fams]
        if all(r is None or r["status"] == "refused" for r in rs):
            continue
        lines.append(f"| {form} | " + " | ".join(cell(r, kind, w) if r else "" for r in rs) + " |")
    return "\n".join(lines)


def report(outdir, rows, forms, families, md_path, csv_path):
    allrecs = {}
    for row in rows:
        recs = []
        for form in forms:
            for fam in families or ROWS[row]["families"]:
                p = os.path.join(outdir, row, form.replace("/", "_"), fam, "matrix.json")
                if os.path.exists(p):
                    with open(p) as f:
                        recs.append(json.load(f))
        if recs:
            allrecs[row] = recs
    md = []
    refused = {}
    for row, recs in allrecs.items():
        for r in recs:
            if r["status"] == "refused":
                refused.setdefault((r["form"], r["message"]), set()).add(row)
    if refused:
        md.append("Refused at `check` (not run):\n")
        for (form, msg), rs in sorted(refused.items()):
            md.append(f"- `{form}` ({', '.join(sorted(rs))}): {msg}")
        md.append("")
    for row, recs in allrecs.items():
        kind = ROWS[row]["kind"]
        md.append(f"### {TITLES[row]} (`{row}`)\n")
        fams_here = [f for f in ROWS[row]["families"] if any(r["family"] == f for r in recs)]
        forms_here = [f for f in DEFAULT_FORMS if any(r["form"] == f for r in recs)]
        cmd = f"nice -n 10 python3 ci/formulation_matrix.py --rows {row}"
        if fams_here != ROWS[row]["families"]:
            cmd += f" --families {','.join(fams_here)}"
        if forms_here != DEFAULT_FORMS:
            cmd += f" --forms {','.join(forms_here)}"
        md.append(f"    {cmd}\n")
        md.append("each run:\n")
        md.append(f"    {template(row)}\n")
        heads = {k: h for k, h, _ in COLUMNS[kind]}
        md.append("Cells: " + " · ".join(heads[k] for k in DECIDE[kind][0]) +
                  "; Newton iterations, CPU seconds (user + system) and wall seconds of the run.\n")
        md.append(table(row, recs))
        md.append("")
    # what wins where
    md.append("### Best or within 10 % of the best (per row, family and deciding metric)\n")
    counts = {}
    for row, recs in allrecs.items():
        for (form, fam, k), m in sorted(wins(recs, ROWS[row]["kind"]).items()):
            counts.setdefault(form, []).append(f"{row} {fam} {k}" + (" (best)" if m == "best" else ""))
    ran = []
    for recs in allrecs.values():
        for r in recs:
            if r["status"] != "refused" and r["form"] not in ran:
                ran.append(r["form"])
    for form in ran:
        md.append(f"- `{form}`: " + ("; ".join(counts[form]) if form in counts else "**none**"))
    text = "\n".join(md) + "\n"
    if md_path:
        with open(md_path, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    if csv_path:
        keys = sorted({k for recs in allrecs.values() for r in recs for k in r.get("metrics", {})})
        base = ["row", "form", "family", "status", "message", "newton", "newton_failed", "steps",
                "cutbacks", "rescued", "al_rounds", "unknowns", "cpu_s", "wall_s", "load", "command"]
        with open(csv_path, "w", newline="") as f:
            wr = csv.writer(f)
            # a metric named like a run column (hertz's `load`, the force) is prefixed
            wr.writerow(base + [f"metric_{k}" if k in base else k for k in keys])
            for recs in allrecs.values():
                for r in recs:
                    wr.writerow([r.get(k, "") for k in base] +
                                [r.get("metrics", {}).get(k, "") for k in keys])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rows", default=",".join(ROW_ORDER))
    ap.add_argument("--forms", default=",".join(DEFAULT_FORMS))
    ap.add_argument("--families", default="")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=0.0)
    ap.add_argument("--out", default=os.path.join(ROOT, "target", "formulation_matrix"))
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--md", default="")
    ap.add_argument("--csv", default="")
    ap.add_argument("--list", action="store_true")
    a = ap.parse_args()
    rows = [r for r in a.rows.split(",") if r]
    forms = [f for f in a.forms.split(",") if f]
    fams = [f for f in a.families.split(",") if f]
    for r in rows:
        if r not in ROWS:
            sys.exit(f"unknown row `{r}` (rows: {', '.join(ROW_ORDER)})")
    for f in forms:
        if f not in FORMS:
            sys.exit(f"unknown formulation `{f}` (e.g. thp/pointwise, op/weighted+al)")
    work = [(r, f, fam) for r in rows for fam in (fams or ROWS[r]["families"]) for f in forms]
    if a.list:
        for r, f, fam in work:
            print(shell_line(r, f, fam))
        return
    if not a.report_only:
        with cf.ThreadPoolExecutor(max_workers=a.jobs) as ex:
            futs = {ex.submit(run_one, a.out, r, f, fam, a.timeout or ROWS[r]["timeout"]): (r, f, fam)
                    for r, f, fam in work}
            for fu in cf.as_completed(futs):
                rec = fu.result()
                m = rec.get("metrics")
                short = " ".join(f"{k}={v:.4g}" for k, v in m.items()) if m else rec.get("message", "")
                print(f"{rec['row']} {rec['form']} {rec['family']}: {rec['status']} "
                      f"its={rec.get('newton', '')} cpu={rec.get('cpu_s', 0):.1f}s {short}", flush=True)
    report(a.out, rows, forms, fams, a.md, a.csv)


if __name__ == "__main__":
    main()
