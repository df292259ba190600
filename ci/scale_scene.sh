#!/bin/bash
# One row of docs/performance/scale.md: runs
# cases/hemisphere_twist_scale_3d.toml at one size on one route and NP ranks under /usr/bin/time,
# then prints from summary.json the Newton and Krylov counts, seconds per Newton iteration (newton =
# solve + assembly; assembly includes contact = gather + search + projection + contact blocks, and
# the pattern rebuilds; contact_share = contact / (solve + assembly)), and the peak RSS (KiB:
# /usr/bin/time's %M, the largest single process, so per rank under mpirun; and PETSc's peak, the
# largest rank's, in MB), and each rank's own contact and assembly timers (summary.json rank_times).
# usage: ci/scale_scene.sh SIZE ROUTE NP [ARGS...]   SIZE = e4 | e4.5 | e5 | e6, ROUTE = direct | iterative
#   e.g. nice -n 19 ci/scale_scene.sh e5 iterative 2   (BIN=path: another binary; OUT=dir)
# SIZE e4 is the case file as it is (3 + 3 steps); e4.5 (cube 24^3, 54,252 unknowns, where
# GMRES(100) + GAMG first failed on the contact tangent), e5 and e6 press in PRESS (default 3) steps and
# twist in TWIST steps (default 1; e6: 4, with the penetration bound 0.01, its one command).
cd "$(dirname "$0")/.." && source ci/env.sh
size=$1 route=$2 np=$3; shift 3
case $size in
e4) sets=() ;;
e4.5) sets=(--set "meshes.cube.divisions=[24,24,24]" --set meshes.shell.n_surface=24
          --set meshes.shell.n_thickness=3 --set stages.0.steps=${PRESS:-3} --set stages.1.steps=${TWIST:-1}) ;;
e5) sets=(--set "meshes.cube.divisions=[30,30,30]" --set meshes.shell.n_surface=30
          --set meshes.shell.n_thickness=4 --set stages.0.steps=${PRESS:-3} --set stages.1.steps=${TWIST:-1}) ;;
e6) sets=(--set "meshes.cube.divisions=[66,66,66]" --set meshes.shell.n_surface=64
          --set meshes.shell.n_thickness=8 --set stages.0.steps=${PRESS:-3} --set stages.1.steps=${TWIST:-4}
          --set solver.max_penetration=0.01) ;;
*) echo "SIZE must be e4, e4.5, e5 or e6" >&2; exit 2 ;;
esac
case $route in direct | iterative) ;; *) echo "ROUTE must be direct or iterative" >&2; exit 2 ;; esac
launch=(); [ "$np" -gt 1 ] && launch=(mpirun -np "$np")
out=${OUT:-/tmp/scale-scene}/$size-$route-np$np; mkdir -p "$(dirname "$out")"
/usr/bin/time -o $out.time -f "%e %M" "${launch[@]}" ${BIN:-./target/release/nurbs-contact} run \
    cases/hemisphere_twist_scale_3d.toml "${sets[@]}" --set solver.linear=$route \
    --set output.plots=false --out $out -q --overwrite "$@" > $out.log 2>&1
python3 - $out <<'PY'
import json, sys
o = sys.argv[1]
t = open(o + '.time').read().split()
try:
    s = json.load(open(o + '/summary.json'))
except Exception:
    print(o, 'no summary', open(o + '.log').read()[-300:]); sys.exit()
n = s['newton']; w = s['wall_time']
its = max(n['total_iterations'] + n['failed_iterations'], 1)
print(f"{o.rsplit('/', 1)[1]:20s} n={s['unknowns']} ranks={s['ranks']} status={s['status']} "
      f"steps={n['steps']} newton={n['total_iterations']}+{n['failed_iterations']} "
      f"kry/newton={n['linear_iterations'] / its:.1f} fallbacks={n['linear_fallbacks']} "
      f"newton/it={(w['solve'] + w['assembly']) / its:.3f}s solve/it={w['solve'] / its:.3f}s "
      f"asm/it={w['assembly'] / its:.3f}s contact/it={w['contact'] / its:.3f}s "
      f"pattern/it={w['pattern'] / its:.3f}s contact_share={w['contact'] / (w['solve'] + w['assembly']):.3f} "
      f"total={w['total']:.1f}s wall={t[0]}s peakKB={t[1]} petsc_peakMB={s['peak_memory_mb']:.0f}")
r = s.get('rank_times')
if r:
    f = lambda k: '/'.join(f"{v:.2f}" for v in r[k])
    print(f"  per rank (s): contact {f('contact')} = update {f('contact_update')} + evaluate "
          f"{f('contact_evaluate')} + refresh {f('contact_refresh')} + gathers and waits; residual {f('residual')} jacobian "
          f"{f('jacobian')} pattern {f('pattern')}")
PY
