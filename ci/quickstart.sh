#!/usr/bin/env bash
# First command of the README: install what is missing, build, run the default case.
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/env.sh
ci/install-deps.sh
cargo build --release
./target/release/nurbs-contact run cases/block_compression_3d.toml
echo "open out/block_compression_3d/results.xdmf in ParaView; history.csv and summary.json are beside it"
