#!/usr/bin/env bash
# First command of the README: install what is missing, build, run the default case: the paper's
# ironing example (section 4.1) on its coarsest mesh, both bodies Q1N2, a cylinder pressed into a
# block and slid along it (4 s after the build). The run writes history.png (contact forces against
# the load) and deformed.png (the deformed bodies coloured by contact pressure) beside its results.
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/env.sh
ci/install-deps.sh
cargo build --release
./target/release/nurbs-contact run cases/ironing_2d.toml --overwrite
echo "open out/ironing_2d/results.xdmf in ParaView; history.csv and summary.json are beside it"
