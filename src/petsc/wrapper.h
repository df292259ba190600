/* The PETSc headers our bindings are generated from (build.rs). */
#include <petscsnes.h>
