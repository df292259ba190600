#!/usr/bin/env bash
# Second command of the README: the whole test suite (unit tests, then integration tests that run the
# solver on 1 and 2 MPI ranks), plus formatting and lint checks. .ci/run calls exactly this.
set -euo pipefail
# pipefail makes a failing `cargo test` fail this script even though its output is piped to tee.
cd "$(dirname "$0")/.."
source ci/env.sh
ci/install-deps.sh
# tests/slurm.rs runs a study through a throwaway single-node Slurm cluster (ci/slurm-cluster.sh); here
# Slurm is expected, so that test fails instead of skipping when the daemons are missing.
ci/slurm-cluster.sh install
export NURBS_CONTACT_SLURM=require
# the test stops its cluster itself, also when it fails; this catches a test process that was killed
trap 'ci/slurm-cluster.sh stop target/slurm-cluster' EXIT
cargo fmt --check
cargo clippy --release --all-targets -- -D warnings
log=$(mktemp)
status=0
# --no-fail-fast: one failing test binary does not hide the others' results.
cargo test --release --no-fail-fast 2>&1 | tee "$log" || status=1
# The tests that judge numbers again under other BLAS kernels (see the script).
bash ci/blas-variants.sh 2>&1 | tee -a "$log" || status=1
# One closing line for the whole suite, summed over the test binaries and BLAS variants.
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i } }
     END { printf "%d passed, %d failed\n", p, f }' "$log"
exit $status
