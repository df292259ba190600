//! Generates Rust bindings for the system PETSc with `bindgen` and links it.
//!
//! PETSc is found, in this order:
//! 1. `PETSC_DIR` (+ optional `PETSC_ARCH`): a cluster's own build, headers in
//!    `$PETSC_DIR/include` and `$PETSC_DIR/$PETSC_ARCH/include`, library in `$PETSC_DIR/$PETSC_ARCH/lib`;
//! 2. `pkg-config` for `PETSc` (Debian's `petsc-dev`) or `petsc` (PETSc's own install), which honours
//!    `PKG_CONFIG_PATH`.
//!
//! `PETSc.pc` does not carry MPI's include directories, so they come from `mpicc --showme:incdirs`
//! (Open MPI), `mpicc -show` (MPICH), or `pkg-config ompi`/`mpich`.
//! When PETSc, MPI or libclang is missing the build stops with a message naming the package to install.

use std::env;
use std::path::PathBuf;
use std::process::Command;

const APT_HINT: &str =
    "on Debian/Ubuntu: apt-get install -y build-essential pkg-config libclang-dev \
petsc-dev libopenmpi-dev openmpi-bin libhdf5-openmpi-dev libmetis-dev";

fn fail(msg: &str) -> ! {
    // cargo shows build-script stderr on failure; make the first line say what to do.
    eprintln!("\nerror: {msg}\n  ({APT_HINT})\n");
    std::process::exit(1);
}

struct Petsc {
    include_dirs: Vec<PathBuf>,
}

fn find_petsc() -> Petsc {
    println!("cargo:rerun-if-env-changed=PETSC_DIR");
    println!("cargo:rerun-if-env-changed=PETSC_ARCH");
    println!("cargo:rerun-if-env-changed=PKG_CONFIG_PATH");
    if let Ok(dir) = env::var("PETSC_DIR") {
        let dir = PathBuf::from(dir);
        let arch = env::var("PETSC_ARCH").unwrap_or_default();
        let arch_dir = if arch.is_empty() {
            dir.clone()
        } else {
            dir.join(&arch)
        };
        let include_dirs = vec![dir.join("include"), arch_dir.join("include")];
        if !include_dirs[0].join("petsc.h").exists() {
            fail(&format!(
                "PETSC_DIR={} has no include/petsc.h: point PETSC_DIR/PETSC_ARCH at a PETSc build",
                dir.display()
            ));
        }
        let lib = arch_dir.join("lib");
        println!("cargo:rustc-link-search=native={}", lib.display());
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
        let name = if lib.join("libpetsc_real.so").exists() {
            "petsc_real"
        } else {
            "petsc"
        };
        println!("cargo:rustc-link-lib=dylib={name}");
        return Petsc { include_dirs };
    }
    for name in ["PETSc", "petsc"] {
        if let Ok(lib) = pkg_config::Config::new().probe(name) {
            return Petsc {
                include_dirs: lib.include_paths,
            };
        }
    }
    fail("PETSc not found: neither PETSC_DIR is set nor does pkg-config know `PETSc`/`petsc` (package petsc-dev)");
}

fn mpi_include_dirs() -> Vec<PathBuf> {
    // Open MPI
    if let Ok(out) = Command::new("mpicc").arg("--showme:incdirs").output() {
        if out.status.success() {
            let dirs: Vec<PathBuf> = String::from_utf8_lossy(&out.stdout)
                .split_whitespace()
                .map(PathBuf::from)
                .collect();
            if !dirs.is_empty() {
                return dirs;
            }
        }
    }
    // MPICH and derivatives
    if let Ok(out) = Command::new("mpicc").arg("-show").output() {
        if out.status.success() {
            let dirs: Vec<PathBuf> = String::from_utf8_lossy(&out.stdout)
                .split_whitespace()
                .filter_map(|a| a.strip_prefix("-I").map(PathBuf::from))
                .collect();
            if !dirs.is_empty() {
                return dirs;
            }
        }
    }
    for name in ["ompi", "mpich", "mpi"] {
        if let Ok(lib) = pkg_config::Config::new().cargo_metadata(false).probe(name) {
            return lib.include_paths;
        }
    }
    fail("MPI headers not found: no `mpicc` on PATH and no pkg-config entry for ompi/mpich (package libopenmpi-dev)");
}

/// Records `git describe` of the source tree for run summaries (absent outside a git checkout).
/// Watches the checkout's own HEAD and index as git names them (in a worktree `.git` is a file and
/// they live under the main repository's `.git/worktrees/`; a watched path that does not exist
/// would rerun this script on every build).
fn git_revision() {
    for what in ["HEAD", "index"] {
        if let Ok(out) = Command::new("git")
            .args(["rev-parse", "--git-path", what])
            .output()
        {
            let path = String::from_utf8_lossy(&out.stdout).trim().to_string();
            if out.status.success() && std::path::Path::new(&path).exists() {
                println!("cargo:rerun-if-changed={path}");
            }
        }
    }
    if let Ok(out) = Command::new("git")
        .args(["describe", "--always", "--dirty"])
        .output()
    {
        if out.status.success() {
            let rev = String::from_utf8_lossy(&out.stdout).trim().to_string();
            println!("cargo:rustc-env=NURBS_CONTACT_GIT_REV={rev}");
        }
    }
}

fn main() {
    git_revision();
    println!("cargo:rerun-if-changed=src/petsc/wrapper.h");
    println!("cargo:rerun-if-changed=build.rs");
    let petsc = find_petsc();
    let mut incs = petsc.include_dirs;
    incs.extend(mpi_include_dirs());
    // petscsys.h pulls in HDF5 headers when PETSc was built with HDF5.
    if let Ok(lib) = pkg_config::Config::new()
        .cargo_metadata(false)
        .probe("hdf5-openmpi")
    {
        incs.extend(lib.include_paths);
    }

    if !incs.iter().any(|d| d.join("petscsnes.h").exists()) {
        fail("PETSc headers (petscsnes.h) not found in the include directories PETSc reported");
    }

    let mut builder = bindgen::Builder::default()
        .header("src/petsc/wrapper.h")
        .allowlist_function("(Petsc|Mat|Vec|KSP|SNES|PC|IS)[A-Za-z0-9_]*")
        .allowlist_type("(Petsc|Mat|Vec|KSP|SNES|PC|IS|Insert|Scatter|Norm)[A-Za-z0-9_]*")
        .allowlist_var("(PETSC|MAT|VEC|KSP|SNES|PC|IS)[A-Za-z0-9_]*")
        // rsmpi's MPI_Comm is a #[repr(transparent)] newtype; reuse it so communicators cross
        // between rsmpi and PETSc without casts.
        .blocklist_type("MPI_Comm|ompi_communicator_t")
        .raw_line("pub use mpi::ffi::MPI_Comm;")
        .default_enum_style(bindgen::EnumVariation::NewType {
            is_bitfield: false,
            is_global: false,
        })
        .generate_cstr(true)
        .layout_tests(false)
        .derive_default(true)
        .parse_callbacks(Box::new(bindgen::CargoCallbacks::new()));
    for d in &incs {
        builder = builder.clang_arg(format!("-I{}", d.display()));
    }

    // bindgen loads libclang at run time and panics if it is absent: turn that into a clear message.
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| builder.generate()));
    let bindings = match result {
        Ok(Ok(b)) => b,
        Ok(Err(e)) => fail(&format!("bindgen could not parse the PETSc headers: {e}")),
        Err(_) => fail("bindgen could not load libclang (package libclang-dev)"),
    };
    let out =
        PathBuf::from(env::var("OUT_DIR").unwrap_or_else(|_| fail("OUT_DIR not set by cargo")));
    if let Err(e) = bindings.write_to_file(out.join("petsc_bindings.rs")) {
        fail(&format!("cannot write bindings to {}: {e}", out.display()));
    }
}
