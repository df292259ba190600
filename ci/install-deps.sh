#!/usr/bin/env bash
# Installs the system packages nurbs-contact needs on Debian 12 / Ubuntu, if any is missing.
# Needs root (or sudo). Rust itself comes from rustup (Debian's rustc is too old for nalgebra 0.35).
set -euo pipefail

PKGS=(build-essential pkg-config libclang-dev petsc-dev libopenmpi-dev openmpi-bin
      libhdf5-openmpi-dev libmetis-dev hdf5-tools libopenblas0-serial libblas3 liblapack3
      fonts-dejavu-core)
# fonts-dejavu-core: the font of the study's PNG plots (rendered by resvg).
# libopenblas0-serial replaces the reference BLAS/LAPACK that petsc-dev pulls in (through Debian's
# alternatives): MUMPS factorises ~7x faster with it. Serial, so that MPI ranks do not oversubscribe cores.
# libblas3, liblapack3: Debian's reference BLAS/LAPACK, which ci/blas-variants.sh selects for a while
# to show that no test depends on OpenBLAS's kernels.

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
fi

if ! command -v cargo >/dev/null 2>&1; then
  echo "error: cargo not found. Install Rust with rustup (https://rustup.rs), then rerun." >&2
  exit 1
fi
