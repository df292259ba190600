#!/usr/bin/env python3
"""Hertz, 2D, against the finite body's own converged answer (docs/verification/hertz.md). Hertz's half-space formulas differ from the finite half disk by
a few tenths of a percent, so errors of that size are measured against a reference computed here:
Q1C1 pointwise with the augmented Lagrangian (penalty-free) refined to n_arc 2048 and extrapolated.

Usage (from anywhere; runs one at a time, 1 rank, through ci/bench_contact.py's hertz_metrics, so
the mesh is n_arc = N, n_radial = N // 4 and the nominal peak and second-moment half-width are
bench_contact.py's):
  python3 ci/hertz_reference.py run SPEC...   SPEC = FAMILY:N_ARC:GAP:EPS_N[:al]
      e.g. Q1C1:512:pointwise:1e4:al Q1N2:128:weighted_mean:1e4; `al` adds
      contact.0.augmented={ tol = $AL_TOL, max = $AL_MAX } (defaults 1e-9, 50); one JSON line per
      run is appended to $HERTZ_RESULTS (default ./hertz_results.jsonl), failed runs too
  REF_R=... REF_A=... REF_P=... python3 ci/hertz_reference.py table
      prints the reference series, its Richardson extrapolations and every run's errors against
      the chosen reference (r = nominal peak / p0_Hertz(P), P the run's own load)"""
import datetime, json, math, os, sys, time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_contact import hertz_metrics, newton  # noqa: E402

AL_TOL = os.environ.get("AL_TOL", "1e-9")
AL_MAX = os.environ.get("AL_MAX", "50")
RESULTS = os.environ.get("HERTZ_RESULTS", "hertz_results.jsonl")
REF_R = float(os.environ.get("REF_R", "nan"))
REF_A = float(os.environ.get("REF_A", "nan"))
REF_P = float(os.environ.get("REF_P", "nan"))


def run_specs(specs):
    for spec in specs:
        fam, n, gap, eps, *rest = spec.split(":")
        al = bool(rest and rest[0] == "al")
        extra = [f"contact.0.eps_n={eps}", "output.plots=false"]
        if gap != "pointwise":
            extra.append(f'contact.0.gap="{gap}"')
        if al:
            extra.append(f"contact.0.augmented={{ tol = {AL_TOL}, max = {AL_MAX} }}")
        rec = dict(spec=spec, fam=fam, n=int(n), gap=gap, eps=eps, al=al,
                   al_tol=AL_TOL if al else None, al_max=AL_MAX if al else None, extra=extra,
                   started=datetime.datetime.utcnow().isoformat(timespec="seconds") + "Z")
        t0 = time.time()
        try:
            m = hertz_metrics(fam, int(n), extra)
            head, rows = m["hist"]
            last = rows[-1].split(",")
            s = m["summary"]
            rec.update(ok=True, P=m["P"], p0=m["p0"], a=m["a"], peak=m["peak"], peak_n=m["peak_n"],
                       a_ours=m["a_ours"], ratio=m["peak_n"] / m["p0"], a_ratio=m["a_ours"] / m["a"],
                       unknowns=s["unknowns"], newton=newton(s),
                       rounds=sum(st.get("augmentation_rounds", 0) for st in s["steps"]),
                       cutbacks=sum(st.get("cutbacks", 0) for st in s["steps"]),
                       penetration=float(last[head.index("penetration_flat_disk_arc")]) if "penetration_flat_disk_arc" in head else None,
                       wall=s["wall_time"]["total"])
        except (Exception, SystemExit) as e:  # a failed run is recorded as failed
            rec.update(ok=False, error=str(e)[-3000:])
        rec["elapsed"] = time.time() - t0
        with open(RESULTS, "a") as f:
            f.write(json.dumps(rec) + "\n")
        if rec.get("ok"):
            print(f"{spec}: unknowns {rec['unknowns']} P {rec['P']:.9g} peak/p0 {rec['ratio']:.7f} ({100*(rec['ratio']-1):+.3f} %) "
                  f"a/aH {rec['a_ratio']:.6f} its {rec['newton']} rounds {rec['rounds']} wall {rec['wall']:.2f}", flush=True)
        else:
            print(f"{spec}: FAILED {rec['error'][-500:]}", flush=True)


R = []


def get(fam, gap, eps, al, n, tol="1e-9"):
    c = [r for r in R if r["fam"] == fam and r["gap"] == gap and r["eps"] == eps and r["al"] == al and r["n"] == n
         and (not al or r["al_tol"] == tol)]
    return c[-1] if c else None


def rich3(f1, f2, f3):
    """coarse, medium, fine at ratio 2: observed order, extrapolated value"""
    d1, d2 = f1 - f2, f2 - f3
    if d1 * d2 <= 0:
        return float("nan"), float("nan")
    q = math.log2(d1 / d2)
    return q, f3 - d2 / (2 ** q - 1)


def rich2(f2, f3, q):
    return f3 + (f3 - f2) / (2 ** q - 1)


def extrap(series, key):
    """series: {n: rec}; returns list of (label, value)"""
    ns = sorted(series)
    out = []
    v = {n: series[n][key] for n in ns}
    for i in range(len(ns) - 2):
        q, x = rich3(v[ns[i]], v[ns[i + 1]], v[ns[i + 2]])
        out.append((f"3-level {ns[i]}/{ns[i+1]}/{ns[i+2]} (observed order {q:.2f})", x))
    for i in range(len(ns) - 1):
        for q in (1.5, 2.0):
            out.append((f"2-level {ns[i]}/{ns[i+1]}, order {q}", rich2(v[ns[i]], v[ns[i + 1]], q)))
    return out


def series(fam, gap, eps, al, ns):
    return {n: get(fam, gap, eps, al, n) for n in ns if get(fam, gap, eps, al, n) and get(fam, gap, eps, al, n)["ok"]}


def table():
    global R
    R = [json.loads(line) for line in open(RESULTS)]
    ref_s = series("Q1C1", "pointwise", "1e4", True, (128, 256, 512, 1024, 2048))
    print("## Reference series: Q1C1 pointwise, augmented Lagrangian tol 1e-9 (eps_n 1e4)\n")
    print("| n_arc | unknowns | load P | r = peak/p0_H(P) | a_2m / a_H(P) | Newton its | AL rounds | wall s |")
    print("|---|---|---|---|---|---|---|---|")
    for n, r in sorted(ref_s.items()):
        print(f"| {n} | {r['unknowns']} | {r['P']:.9g} | {r['ratio']:.7f} | {r['a_ratio']:.6f} | {r['newton']} | {r['rounds']} | {r['wall']:.1f} |")

    fine = [n for n in sorted(ref_s) if n >= 256]
    print("\n### Extrapolations of r (every consecutive triple / pair from n_arc 128)\n")
    print("| estimate | r | r - 1 |")
    print("|---|---|---|")
    ex_r = extrap({n: ref_s[n] for n in sorted(ref_s) if n >= 128}, "ratio")
    for lab, x in ex_r:
        print(f"| {lab} | {x:.6f} | {100*(x-1):+.3f} % |")
    ex_a = extrap({n: ref_s[n] for n in sorted(ref_s) if n >= 128}, "a_ratio")
    print("\n### Extrapolations of a_2m/a_H(P)\n")
    print("| estimate | a ratio | - 1 |")
    print("|---|---|---|")
    for lab, x in ex_a:
        print(f"| {lab} | {x:.6f} | {100*(x-1):+.3f} % |")

    # the reference chosen from the extrapolations above (REF_R, REF_A, REF_P)
    REF_R = float(os.environ.get("REF_R", "nan"))
    REF_A = float(os.environ.get("REF_A", "nan"))
    REF_P = float(os.environ.get("REF_P", "nan"))
    print(f"\nReference used: r_ref = {REF_R:.6f} ({100*(REF_R-1):+.3f} % vs Hertz), a_ref ratio = {REF_A:.6f}, P_ref = {REF_P:.8g}\n")

    rows = [("Q1C1", "pointwise", "1e4", False), ("Q1C1", "pointwise", "1e4", True),
            ("Q1N2", "weighted_mean", "1e4", False), ("Q1N2", "weighted", "1e4", True), ("Q1N2", "pointwise", "1e4", False),
            ("Q1N2", "weighted_mean", "1e3", False), ("Q1N2", "weighted_mean", "1e5", False), ("Q1N2", "weighted_mean", "1e6", False),
            ("Q1C1", "weighted", "1e4", True)]
    print("| family | gap | eps_n / AL | n_arc | unknowns | load P | P err vs ref | peak/p0_H vs Hertz | error vs ref | raw peak vs ref peak | half-width error vs ref | Newton its (AL rounds) | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for fam, gap, eps, al in rows:
        for n in (64, 128, 256, 512, 1024, 2048):
            r = get(fam, gap, eps, al, n)
            if not r:
                continue
            enf = f"{eps} + AL (tol {r['al_tol']})" if al else f"{eps} penalty"
            if not r["ok"]:
                print(f"| {fam} | {gap} | {enf} | {n} | | | | **failed**: {r['error'][-200:]} | | | | | |")
                continue
            e = 100 * (r["ratio"] / REF_R - 1)
            eraw = 100 * (r["ratio"] * math.sqrt(r["P"] / REF_P) / REF_R - 1)
            ea = 100 * (r["a_ratio"] / REF_A - 1)
            ep = 100 * (r["P"] / REF_P - 1)
            its = f"{r['newton']}" + (f" ({r['rounds']})" if al else "")
            print(f"| {fam} | {gap} | {enf} | {n} | {r['unknowns']} | {r['P']:.7g} | {ep:+.3f} % | {100*(r['ratio']-1):+.3f} % | "
                  f"**{e:+.3f} %** | {eraw:+.2f} % | {ea:+.2f} % | {its} | {r['wall']:.2f} |")

    print("\n### Compact: nominal-peak error vs the finite-body reference (ratio peak/p0_H(P) over r_ref), %\n")
    cols = (64, 128, 256, 512, 1024)
    print("| family, gap, enforcement | " + " | ".join(f"n_arc {n}" for n in cols) + " |")
    print("|---|" + "---|" * len(cols))
    for fam, gap, eps, al in rows:
        cells = []
        for n in cols:
            r = get(fam, gap, eps, al, n)
            cells.append("" if not r else ("failed" if not r["ok"] else f"{100*(r['ratio']/REF_R-1):+.3f}"))
        if any(cells):
            print(f"| {fam} {gap} {eps}{' + AL' if al else ''} | " + " | ".join(cells) + " |")
    def unknowns(fam, n):
        r = get(fam, "pointwise", "1e4", False, n)
        return str(r["unknowns"]) if r and r.get("ok") else "-"
    print("\nunknowns (Q1C1 / Q1N2; - where that run is not in the results): "
          + ", ".join(f"{n}: {unknowns('Q1C1', n)} / {unknowns('Q1N2', n)}" for n in cols))


if __name__ == "__main__":
    if sys.argv[1:2] == ["run"]:
        run_specs(sys.argv[2:])
    elif sys.argv[1:2] == ["table"]:
        table()
    else:
        sys.exit(__doc__)
