#!/usr/bin/env bash
# Second command of the README: the whole test suite (unit tests, then integration tests that run the
# solver on 1 and 2 MPI ranks), plus formatting and lint checks. .ci/run calls exactly this.
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/env.sh
ci/install-deps.sh
cargo fmt --check
cargo clippy --release --all-targets -- -D warnings
cargo test --release
