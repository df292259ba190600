//! How big a case's generated meshes will be, computed from the generator parameters alone, so that
//! validation can refuse a problem that cannot fit before anything is allocated.
//!
//! The estimate (bytes, for the whole problem):
//! - mesh arrays, held in full by every rank (each builds the whole model): per node
//!   `24 dim + 16` (coordinates in the mesh, the model and the partitioning copy; numbering), per
//!   cell `12 n + 32` for `n` nodes per cell (three copies of the connectivity, offsets, kinds);
//! - the Jacobian: `12` bytes per stored entry (value and 32-bit column index), with `3^dim dim`
//!   entries per row of a structured mesh, plus `24` bytes per element-matrix entry
//!   (`(n dim)^2` per cell) for the COO assembly (it holds 4 bytes per element entry and about
//!   24 per matrix entry, 14 per element entry on a hex mesh: this term errs high, and the Slurm
//!   requests built on it were calibrated with it).
//!
//! - the linear solver of the route that runs (`[solver] linear`, see [`linear_solver_bytes`]):
//!   the MUMPS factors (direct), or GAMG's hierarchy and the Krylov vectors (iterative), fitted
//!   to peak memory measured on the 3D block (docs/performance/solver.md, "Direct against iterative").
//!
//! A case refused by it cannot run here.

use crate::scene::schema::{Case, Generator, MeshSpec};

/// Largest number of unknowns PETSc can index with its 32-bit `PetscInt` (the build used here).
pub const MAX_UNKNOWNS: f64 = i32::MAX as f64;

/// `[solver] linear = "auto"` takes the iterative route from this many unknowns on. Measured
/// (docs/performance/solver.md, "Direct against iterative", 1 rank): per Newton
/// iteration the iterative route is 1.5x slower than MUMPS on the hemisphere scene at 2,937
/// unknowns, 1.4x faster on the 12^3 block (6,591), and at least 2x faster from the 20^3 block
/// (27,783) on, 4x at 30^3 (89,373); between about 5e3 and 2e4 the gain is small and MUMPS is
/// the more robust, so `auto` switches at 2e4.
pub const AUTO_ITERATIVE_UNKNOWNS: f64 = 2e4;

/// Krylov vectors the iterative route may hold with contact: GMRES's restart there
/// (`-ksp_gmres_restart 400`, `CONTACT_ITERATIVE_OPTIONS` in `src/driver/options.rs`).
pub const CONTACT_KRYLOV_VECTORS: f64 = 400.0;

/// Bytes of the linear solver (whole problem) for `unknowns` unknowns in `dim` dimensions, on the
/// direct route (MUMPS: factor entries `30 n^(4/3)` in 3D by nested dissection, `12 n log2 n` in
/// 2D, 12 bytes each) or the iterative one (GAMG's hierarchy, smoothers and Galerkin products,
/// 2.5 times the fine matrix, and GMRES(100)'s vectors, about 40 per unknown in use, 8 bytes
/// each). Fitted to peaks measured on the 3D block, less the mesh, matrix and ~100 MB of
/// process: direct 20^3 and 30^3 (644 MB, 2337 MB: 480 and 440 bytes per `n^(4/3)`, taken
/// low, 360, so that the estimate stays a lower bound), iterative 20^3 to 40^3 (312 MB, 768 MB,
/// 1821 MB; docs/performance/solver.md, "Direct against iterative").
///
/// With `contact`, the iterative route's GMRES runs without restart up to 400 iterations (the
/// contact defaults of `src/driver/options.rs`), and PETSc keeps every Krylov vector it allocated:
/// the first solves of a press step take 233-283 iterations on the 3D scale scene at 1e5
/// unknowns, so the estimate counts [`CONTACT_KRYLOV_VECTORS`] vectors instead of 40.
pub fn linear_solver_bytes(dim: usize, unknowns: f64, iterative: bool, contact: bool) -> f64 {
    let n = unknowns.max(1.0);
    if iterative {
        let fine = 12.0 * n * 3f64.powi(dim as i32) * dim as f64;
        let vectors = if contact {
            CONTACT_KRYLOV_VECTORS
        } else {
            40.0
        };
        2.5 * fine + 8.0 * vectors * n
    } else if dim == 3 {
        12.0 * 30.0 * n.powf(4.0 / 3.0)
    } else {
        12.0 * 12.0 * n * n.max(2.0).log2()
    }
}

/// Node and cell counts of a generated mesh (as `f64`: the parameters may be absurdly large).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshSize {
    pub dim: usize,
    pub nodes: f64,
    pub cells: f64,
}

impl MeshSize {
    /// Exact counts of what the generator builds (tested against the generators).
    pub fn of(g: &Generator) -> MeshSize {
        let f = |n: usize| n as f64;
        let (dim, nodes, cells) = match g {
            Generator::Rectangle(p) => {
                let [nx, ny] = p.divisions.map(f);
                (2, (nx + 1.0) * (ny + 1.0), nx * ny)
            }
            Generator::Box(p) => {
                let [nx, ny, nz] = p.divisions.map(f);
                (3, (nx + 1.0) * (ny + 1.0) * (nz + 1.0), nx * ny * nz)
            }
            Generator::QuarterSphere(p) => {
                let [nu, nv, nz] = p.divisions.map(f);
                (3, (nu + 1.0) * (nv + 1.0) * (nz + 1.0), nu * nv * nz)
            }
            Generator::SphereCap(p) => {
                // the quarter mirrored: 2 n_u x 2 n_v x n_z cells
                let [nu, nv, nz] = p.divisions.map(f);
                let (mu, mv) = (2.0 * nu, 2.0 * nv);
                (3, (mu + 1.0) * (mv + 1.0) * (nz + 1.0), mu * mv * nz)
            }
            Generator::HalfDisk(p) => {
                // O-grid: core n_bot x n_side, ring n_arc x n_radial (see mesh::half_disk)
                let n_side = ((p.n_arc.saturating_add(2)) / 4).max(1);
                let n_bot = f(p.n_arc) - 2.0 * f(n_side);
                let (n_side, n_arc, n_rad) = (f(n_side), f(p.n_arc), f(p.n_radial));
                (
                    2,
                    (n_bot + 1.0) * (n_side + 1.0) + (n_arc + 1.0) * n_rad,
                    n_bot * n_side + n_arc * n_rad,
                )
            }
            Generator::Sector(p) => {
                let [nr, nt] = p.divisions.map(f);
                (2, (nr + 1.0) * (nt + 1.0), nr * nt)
            }
            Generator::Hemisphere(p) => {
                let (n, m) = (f(p.n_surface), f(p.n_thickness));
                (3, (n + 1.0) * (n + 1.0) * (m + 1.0), n * n * m)
            }
            Generator::HemisphereNurbs(p) => {
                let (n, m) = (f(p.n_surface), f(p.n_thickness));
                (3, ((n - 1.0) * (n + 1.0) + 2.0) * (m + 1.0), n * n * m)
            }
        };
        MeshSize { dim, nodes, cells }
    }

    /// Unknowns: `dim` per node.
    pub fn unknowns(&self) -> f64 {
        self.dim as f64 * self.nodes
    }

    /// Bytes of the mesh arrays that every rank holds.
    pub fn mesh_bytes(&self) -> f64 {
        let (d, n) = (self.dim as f64, (1usize << self.dim) as f64);
        self.nodes * (24.0 * d + 16.0) + self.cells * (12.0 * n + 32.0)
    }

    /// Bytes of the Jacobian and its assembly buffers (whole problem).
    pub fn matrix_bytes(&self) -> f64 {
        let d = self.dim as f64;
        let n = (1usize << self.dim) as f64;
        let nnz = self.unknowns() * 3f64.powi(self.dim as i32) * d;
        12.0 * nnz + 24.0 * self.cells * (n * d).powi(2)
    }
}

/// The size of a whole case: the sum over its bodies' generated meshes (a mesh that two bodies use
/// is built twice, so it counts twice).
#[derive(Debug, Clone, PartialEq)]
pub struct CaseSize {
    /// Node and cell totals (`dim` of the first body's mesh; all are the case's).
    pub total: MeshSize,
    /// [`MeshSize::mesh_bytes`] summed: held by every rank.
    pub mesh_bytes: f64,
    /// [`MeshSize::matrix_bytes`] summed: shared by the ranks.
    pub matrix_bytes: f64,
    /// [`linear_solver_bytes`] of the route that runs for the case's unknowns: shared by the ranks.
    pub linear_bytes: f64,
    /// That route is the iterative one.
    pub iterative: bool,
    /// The key of the largest mesh's size parameter (`meshes.block.divisions`), where a too-large
    /// case is reported.
    pub largest_key: String,
}

impl CaseSize {
    /// `None` when no body has a generated mesh (Gmsh files are sized only by reading them).
    pub fn of(case: &Case) -> Option<CaseSize> {
        let mut total: Option<CaseSize> = None;
        let mut largest = 0.0;
        for b in case.bodies.values() {
            let Some(MeshSpec::Generated(g)) = case.meshes.get(&b.mesh) else {
                continue;
            };
            let s = MeshSize::of(g);
            let key = format!("meshes.{}.{}", b.mesh, g.size_key());
            let t = total.get_or_insert_with(|| CaseSize {
                total: MeshSize {
                    dim: s.dim,
                    nodes: 0.0,
                    cells: 0.0,
                },
                mesh_bytes: 0.0,
                matrix_bytes: 0.0,
                linear_bytes: 0.0,
                iterative: false,
                largest_key: key.clone(),
            });
            if s.unknowns() > largest {
                largest = s.unknowns();
                t.largest_key = key;
            }
            t.total.nodes += s.nodes;
            t.total.cells += s.cells;
            t.mesh_bytes += s.mesh_bytes();
            t.matrix_bytes += s.matrix_bytes();
        }
        if let Some(t) = &mut total {
            let route = case.solver.linear_setting().resolve(t.total.unknowns());
            t.iterative = route == crate::scene::schema::LinearSolver::Iterative;
            t.linear_bytes = linear_solver_bytes(
                t.total.dim,
                t.total.unknowns(),
                t.iterative,
                !case.contact.is_empty(),
            );
        }
        total
    }
}

/// Physical memory of this machine in bytes (`MemTotal` of `/proc/meminfo`), if known.
pub fn machine_memory_bytes() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// `bytes` for people: `1.2 GB`.
pub fn human_bytes(bytes: f64) -> String {
    let units = ["B", "kB", "MB", "GB", "TB", "PB", "EB"];
    let mut x = bytes;
    let mut u = 0;
    while x >= 1000.0 && u + 1 < units.len() {
        x /= 1000.0;
        u += 1;
    }
    if u == 0 {
        format!("{x:.0} {}", units[u])
    } else {
        format!("{x:.1} {}", units[u])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh;
    use crate::scene::schema::*;

    /// The counts are those of the generators: a generator that changes must change them too.
    #[test]
    fn counts_match_what_the_generators_build() {
        let gens: Vec<(Generator, mesh::Mesh)> = vec![
            (
                Generator::Rectangle(RectangleParams {
                    origin: [0.0; 2],
                    size: [2.0, 1.0],
                    divisions: [5, 3],
                }),
                mesh::rectangle::rectangle([0.0; 2], [2.0, 1.0], [5, 3]).unwrap(),
            ),
            (
                Generator::Box(BoxParams {
                    origin: [0.0; 3],
                    size: [1.0; 3],
                    divisions: [2, 3, 4],
                }),
                mesh::box3d::box3d([0.0; 3], [1.0; 3], [2, 3, 4]).unwrap(),
            ),
            (
                Generator::Sector(SectorParams {
                    center: [0.0; 2],
                    r_inner: 1.0,
                    r_outer: 2.0,
                    theta0_deg: 0.0,
                    theta1_deg: 90.0,
                    divisions: [3, 7],
                }),
                mesh::sector::sector([0.0; 2], 1.0, 2.0, [0.0, 1.5], 7, 3).unwrap(),
            ),
        ];
        let mut all = gens;
        for (n_arc, n_rad) in [(4, 1), (6, 2), (9, 3), (16, 4)] {
            all.push((
                Generator::HalfDisk(HalfDiskParams {
                    center: [0.0; 2],
                    radius: 1.0,
                    n_arc,
                    n_radial: n_rad,
                }),
                mesh::half_disk::half_disk([0.0; 2], 1.0, n_arc, n_rad).unwrap(),
            ));
        }
        let shell = |n, m| HemisphereParams {
            center: [0.0; 3],
            outer_radius: 1.0,
            thickness: 0.2,
            n_surface: n,
            n_thickness: m,
        };
        for (n, m) in [(2, 1), (3, 2), (4, 2)] {
            all.push((
                Generator::Hemisphere(shell(n, m)),
                mesh::hemisphere::hemisphere([0.0; 3], 1.0, 0.2, n, m).unwrap(),
            ));
        }
        for (n, m) in [(2, 1), (4, 2), (6, 1)] {
            all.push((
                Generator::HemisphereNurbs(shell(n, m)),
                mesh::hemisphere_nurbs::hemisphere_nurbs([0.0; 3], 1.0, 0.2, n, m).unwrap(),
            ));
        }
        for (g, m) in &all {
            let s = MeshSize::of(g);
            assert_eq!(
                (s.dim, s.nodes, s.cells),
                (m.dim, m.n_nodes() as f64, m.n_cells() as f64),
                "{}",
                g.name()
            );
        }
    }

    #[test]
    fn estimates_grow_with_the_mesh_and_print_readably() {
        let b = |n: usize| {
            MeshSize::of(&Generator::Box(BoxParams {
                origin: [0.0; 3],
                size: [1.0; 3],
                divisions: [n, n, n],
            }))
        };
        let s = b(2000);
        assert_eq!(s.unknowns(), 3.0 * 2001f64.powi(3));
        assert!(s.unknowns() > MAX_UNKNOWNS);
        // 10^3 hexes: about 1.3 k nodes, a few MB in all
        let small = b(10).mesh_bytes() + b(10).matrix_bytes();
        assert!(small > 1e6 && small < 1e8, "{small}");
        assert_eq!(human_bytes(1.5e9), "1.5 GB");
        assert_eq!(human_bytes(12.0), "12 B");
        assert!(machine_memory_bytes().is_none_or(|m| m > 1e8));
    }

    #[test]
    fn the_linear_solver_estimate_follows_the_route_and_auto_switches_at_its_size() {
        use crate::scene::schema::LinearSolver;
        // 30^3 block, 89,373 unknowns: MUMPS's factors measured at about 1.8 GB, GAMG + GMRES
        // a few hundred MB
        let n = 89_373.0;
        let direct = linear_solver_bytes(3, n, false, false);
        let iterative = linear_solver_bytes(3, n, true, false);
        assert!(direct > 1.2e9 && direct < 2.0e9, "{direct}");
        assert!(iterative > 1e8 && iterative < 6e8, "{iterative}");
        // factors grow faster than the hierarchy
        let ratio = |k: f64| {
            linear_solver_bytes(3, k * n, false, false) / linear_solver_bytes(3, k * n, true, false)
        };
        assert!(ratio(8.0) > 1.5 * ratio(1.0));
        assert!(linear_solver_bytes(2, 1e4, false, false) > 0.0);
        // with contact, GMRES may keep 400 Krylov vectors instead of 40 (8 bytes each); the
        // direct route does not change
        let extra = linear_solver_bytes(3, n, true, true) - iterative;
        assert!((extra - 8.0 * 360.0 * n).abs() < 1.0, "{extra}");
        assert_eq!(linear_solver_bytes(3, n, false, true), direct);
        assert_eq!(LinearSolver::Auto.resolve(n), LinearSolver::Iterative);
        assert_eq!(
            LinearSolver::Auto.resolve(AUTO_ITERATIVE_UNKNOWNS - 1.0),
            LinearSolver::Direct
        );
        assert_eq!(LinearSolver::Direct.resolve(1e9), LinearSolver::Direct);
        assert_eq!(
            LinearSolver::Iterative.resolve(10.0),
            LinearSolver::Iterative
        );
    }
}
