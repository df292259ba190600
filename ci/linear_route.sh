#!/bin/bash
# One row of docs/performance/solver.md, "Direct against iterative": runs CASE with one --set and further
# arguments under /usr/bin/time, then prints Newton and Krylov counts, solve and assembly seconds per
# Newton iteration (summary.json) and the peak RSS (KiB).
# usage: ci/linear_route.sh TAG CASE SET [ARGS...]   e.g.
#   ci/linear_route.sh b30 cases/block_compression_3d.toml "meshes.block.divisions=[30,30,30]" \
#       --set solver.linear=iterative --set stages.0.steps=1
cd "$(dirname "$0")/.." && source ci/env.sh
tag=$1; shift; case=$1; shift; set1=$1; shift
out=${OUT:-/tmp/linear-route}/run-$tag; mkdir -p "$(dirname "$out")"
/usr/bin/time -o $out.time -f "%e %M" ./target/release/nurbs-contact run $case --set "$set1" --out $out -q "$@" > $out.log 2>&1
python3 - $out <<'PY'
import json,sys
o=sys.argv[1]
t=open(o+'.time').read().split()
try:
    s=json.load(open(o+'/summary.json'))
except Exception as e:
    print(o, 'no summary', open(o+'.log').read()[-300:]); sys.exit()
n=s['newton']; w=s['wall_time']
its=n['total_iterations']+n['failed_iterations']
print(f"{o.split('run-')[1]:28s} {s['linear_solver']:9s} n={s['unknowns']} status={s['status']} newton={n['total_iterations']}+{n['failed_iterations']} kry/newton={n['linear_iterations']/max(its,1):.1f} fallbacks={n['linear_fallbacks']} solve/it={w['solve']/max(its,1):.3f}s asm/it={w['assembly']/max(its,1):.3f}s total={w['total']:.1f}s peakKB={t[1]}")
PY
