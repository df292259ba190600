# Environment for running nurbs-contact under MPI here; sourced by the other scripts.
# OpenMPI refuses to run as root without these (CI runs as root).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# Tests start several mpiruns at once on few cores: yield instead of busy-polling.
export OMPI_MCA_mpi_yield_when_idle=1
# Keep Open MPI from probing network interfaces that a sandbox may not have.
export OMPI_MCA_btl=self,vader
export HDF5_DIR=/usr/lib/x86_64-linux-gnu/hdf5/openmpi
