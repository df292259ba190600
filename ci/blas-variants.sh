#!/usr/bin/env bash
# The tests that judge numbers (the bad-input corpus with its singular-tangent entries, Hertz and the
# contact tests, finite-difference tangents, 1 = 2 ranks) once more under other BLAS/LAPACK kernels,
# so that no result depends on the kernels of one machine (a null pivot that MUMPS found
# on one CPU and not on another):
#   1. OpenBLAS forced to its generic x86-64 kernel (OPENBLAS_CORETYPE=Prescott);
#   2. Debian's reference BLAS/LAPACK, selected through update-alternatives and restored to the
#      automatic choice afterwards, also when a test fails or the script is interrupted. This one
#      changes a system setting for the time of the run, so it runs as root only, and on a
#      developer's machine only when asked (NURBS_CONTACT_BLAS_ALTERNATIVES=1; CI sets CI=true).
# Test output goes to stdout (ci/test.sh adds its counts to the suite's closing line).
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/env.sh

TESTS=(--test corpus --test contact --test assembly_fd --test ranks --test enriched_ranks)
ARCH=$(gcc -print-multiarch 2>/dev/null || echo x86_64-linux-gnu)

status=0
run_tests() {
  cargo test --release --no-fail-fast "${TESTS[@]}" 2>&1
}

# --- 1. generic OpenBLAS kernel -------------------------------------------------------------------
if [ "$(uname -m)" = x86_64 ]; then
  core=$(OPENBLAS_VERBOSE=2 OPENBLAS_CORETYPE=Prescott ./target/release/nurbs-contact --version 2>&1 \
         | sed -n 's/^Core: //p' | head -1)
  if [ "$core" != "Prescott" ]; then
    echo "error: OPENBLAS_CORETYPE=Prescott did not select OpenBLAS's Prescott kernel (got '${core:-no OpenBLAS}')" >&2
    exit 1
  fi
  echo "== BLAS variant: OpenBLAS kernel $core (OPENBLAS_CORETYPE) =="
  OPENBLAS_CORETYPE=Prescott run_tests || status=1
else
  echo "== BLAS variant: generic OpenBLAS kernel skipped: OPENBLAS_CORETYPE=Prescott is x86-64 only =="
fi

# --- 2. reference BLAS/LAPACK ----------------------------------------------------------------------
blas=libblas.so.3-$ARCH
lapack=liblapack.so.3-$ARCH
ref_blas=/usr/lib/$ARCH/blas/libblas.so.3
ref_lapack=/usr/lib/$ARCH/lapack/liblapack.so.3
if [ "$(id -u)" -ne 0 ] || { [ "${CI:-}" != true ] && [ "${NURBS_CONTACT_BLAS_ALTERNATIVES:-}" != 1 ]; }; then
  echo "== BLAS variant: reference BLAS/LAPACK skipped: it switches the system's alternatives (runs as root with CI=true or NURBS_CONTACT_BLAS_ALTERNATIVES=1) =="
  exit $status
fi
if [ ! -e "$ref_blas" ] || [ ! -e "$ref_lapack" ]; then
  echo "error: Debian's reference BLAS/LAPACK is not installed ($ref_blas, $ref_lapack): ci/install-deps.sh installs libblas3 and liblapack3" >&2
  exit 1
fi
restore() {
  update-alternatives --quiet --auto "$blas"
  update-alternatives --quiet --auto "$lapack"
}
trap restore EXIT INT TERM
update-alternatives --quiet --set "$blas" "$ref_blas"
update-alternatives --quiet --set "$lapack" "$ref_lapack"
loaded=$(ldd ./target/release/nurbs-contact | awk '/libblas.so.3|liblapack.so.3/ { print $3 }' | xargs -r readlink -f | sort -u | tr '\n' ' ')
case "$loaded" in
  *openblas*) echo "error: the reference BLAS was selected but nurbs-contact still loads $loaded" >&2; exit 1 ;;
esac
echo "== BLAS variant: reference BLAS/LAPACK ($loaded) =="
run_tests || status=1
exit $status
