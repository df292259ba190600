#!/usr/bin/env bash
# summary.json `contact_data` on 1, 2 and 4 ranks for the hemisphere pressed onto the block at
# several sizes (docs/performance/contact.md, "Contact data per rank"). Usage: ci/contact_data.sh [n ...]
# (default 4 8 16 24); one Markdown row per run (table nodes and ghost elements per rank, refreshes
# of the ghost layer, surface / point / received kB per rank, evaluations, facing contact cell
# pairs cut by the partition / all). PARTITION=cells runs `[solver] partition = "cells"` (default
# "contact"). Output folders under ${OUT:-/tmp/contact-data}.
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/env.sh
out=${OUT:-/tmp/contact-data}
partition=${PARTITION:-contact}
mkdir -p "$out"
for n in "${@:-4 8 16 24}"; do
  for n1 in $n; do
    t=$(( n1 / 4 < 2 ? 2 : n1 / 4 ))
    for np in 1 2 4; do
      d=$out/$n1-$np
      mpirun --oversubscribe -np "$np" ./target/release/nurbs-contact run cases/hemisphere_block_3d.toml \
        --out "$d" -q --overwrite --set "meshes.block.divisions=[$n1,$n1,$n1]" \
        --set meshes.shell.n_surface="$n1" --set meshes.shell.n_thickness="$t" --set stages.0.steps=1 \
        --set "bcs.1.value=[[0.0,0.0,-0.05]]" --set solver.linear=iterative --set output.plots=false --set solver.partition="$partition" \
        --set 'output.fields=["displacement"]' --set contact.0.formulation=paper > "$d.log" 2>&1
      python3 - "$d" "$n1" "$np" <<'PY'
import json, sys
d, n, np = sys.argv[1:]
s = json.load(open(d + "/summary.json"))
c = s["contact_data"]
kb = lambda v: ", ".join(f"{x / 1000:,.1f}" for x in v)
each = lambda v: ", ".join(f"{x:,}" for x in v)
print(f"| {n} | {s['unknowns']:,} | {np} | {each(c['table_nodes'])} | {each(c['ghost_elements'])} | "
      f"{c['refreshes'][0]} | {kb(c['surface_bytes'])} | {kb(c['point_bytes'])} | "
      f"{kb(c['received_bytes_per_evaluation'])} | {c['evaluations']} | "
      + (f"{p['cut_facing_pairs']:,} / {p['facing_pairs']:,} |" if (p := s.get("partition")) else "- |"))
PY
    done
  done
done
