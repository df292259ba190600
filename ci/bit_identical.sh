#!/usr/bin/env bash
# Whether a refactoring changed any result: runs the same cases with two binaries (1 rank) and
# compares every history.csv byte for byte, the wall_time column left out.
#   ci/bit_identical.sh OLD_BINARY NEW_BINARY [WORKDIR]
# e.g. build the old tree into its own worktree, copy its target/release/nurbs-contact aside, then
#   ci/bit_identical.sh /tmp/nurbs-contact.old target/release/nurbs-contact
# The cases cover both contact paths of each gap mode and friction: ironing mesh 4 (Q1N2, Q1C1),
# twisting mesh 2 (with and without friction), coarse peeling and DCB, friction_block, sliding_flat
# with friction (Q1N2; element_mean), each with the paper's formulation. Results depend on the BLAS kernels (libblas.so.3 alternative):
# run both binaries on the same machine and setting. 2-rank runs are not compared: two 2-rank runs
# of one binary already differ in the last digits (MUMPS's parallel reductions).
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/env.sh
OLD=$(realpath "$1"); NEW=$(realpath "$2"); WORK=${3:-$(mktemp -d)}
CASES=$PWD/cases
# the paper's formulation where a pair's default is another (two deformable enriched surfaces under
# the penalty law, or two faceted ones in 2D without friction): what the script guards is that
# formulation, bit for bit
PAPER="--set contact.0.formulation=paper"
runs() {
  local bin=$1 root=$2
  mkdir -p "$root"
  r() { local name=$1; shift; "$bin" run -q --overwrite --out "$root/$name" "$@"; }
  r ironing4_q1n2 "$CASES/ironing_2d.toml" --set output.plots=false $PAPER
  r ironing4_q1c1 "$CASES/ironing_2d.toml" --set bodies.block.element=Q1C1 --set bodies.cylinder.element=Q1C1 --set output.plots=false $PAPER
  r twisting2 "$CASES/twisting_3d.toml" --set output.plots=false $PAPER
  r peeling_coarse "$CASES/peeling_2d.toml" --set 'meshes.strip.divisions=[40,2]' --set 'bcs.1.angle_deg=[90.0]' --set stages.0.steps=36 --set output.every=4 --set output.plots=false
  r dcb_coarse "$CASES/dcb_2d.toml" --set 'bcs.0.value=[[0.0, 9.0]]' --set stages.0.steps=90 --set output.every=30 --set output.plots=false
  r friction_block "$CASES/friction_block_2d.toml" --set output.plots=false
  r sliding_mean_fric "$CASES/sliding_flat_2d.toml" --set contact.0.mu=0.3 --set 'contact.0.friction_stages=[false, true]' --set contact.0.gap=element_mean --set steps.pseudo_steps=0 --set steps.max_cutbacks=0 --set output.plots=false
  r sliding_fric_q1n2 "$CASES/sliding_flat_2d.toml" --set contact.0.mu=0.3 --set 'contact.0.friction_stages=[false, true]' --set bodies.upper.element=Q1N2 --set bodies.lower.element=Q1N2 --set output.plots=false $PAPER
  r twisting_fric2 "$CASES/twisting_friction_3d.toml" --set output.plots=false $PAPER
}
runs "$OLD" "$WORK/old"
runs "$NEW" "$WORK/new"
strip() { awk -F, 'NR==1 { for (i = 1; i <= NF; i++) if ($i == "wall_time") w = i }
                  { out = ""; for (i = 1; i <= NF; i++) if (i != w) out = out (out == "" ? "" : ",") $i; print out }' "$1"; }
fail=0
for d in "$WORK"/old/*/; do
  n=$(basename "$d")
  if cmp -s <(strip "$d/history.csv") <(strip "$WORK/new/$n/history.csv"); then
    echo "identical  $n ($(wc -l < "$d/history.csv") rows)"
  else
    echo "DIFFERENT  $n"; fail=1
  fi
done
[ $fail = 0 ] && echo "all identical" || echo "some differ"
exit $fail
