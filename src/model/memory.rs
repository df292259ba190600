//! The expected peak memory of a run, from the built model: what `check` prints.
//!
//! [`crate::scene::size`] bounds a case from its generator parameters alone, before anything is
//! built, and refuses what cannot fit; it counts the mesh, a structured Jacobian and the linear
//! solver, and stays below the peak. Once the model is built, its cells, enriched layers and
//! contact surfaces are known, and the peak can be estimated instead of bounded. The terms (bytes,
//! whole problem; a run on `R` ranks holds the process, mesh and model terms on every rank and
//! shares the rest):
//! - the process: code, MPI, PETSc and HDF5 before any data ([`PROCESS_BYTES`]);
//! - the mesh arrays ([`crate::scene::size::MeshSize::mesh_bytes`]) and the model's own data:
//!   element tabulations per cell, and per contact surface element the tangle check's samples,
//!   the output sampling grid and the contact points ([`CELL_BYTES`], [`SURFACE_ELEMENT_BYTES`];
//!   a pass integrated over 3D segments holds more points, [`SEGMENT_ELEMENT_BYTES`]);
//! - the Jacobian: [`COO_ENTRY_BYTES`] per entry of the COO pattern (PETSc's matrix, its COO maps
//!   and the assembler's index and value arrays), which holds each matrix entry that the cells
//!   reach once (per node, the nodes sharing a cell with it, times `dim^2`) and the contact
//!   band's distinct entries; [`CELL_MAP_BYTES`] per entry of the cells' element matrices
//!   `(n_nodes dim)^2` (where each goes in the pattern); and [`PATTERN_COLUMN_BYTES`] per column
//!   of the contact rows' column patterns (a node's rows share one: the distinct entries over the
//!   dimension);
//! - the linear solver of the route that runs ([`linear_bytes`]);
//! - the heap terms times [`ALLOCATOR_FACTOR`] (allocator slack and pages freed but kept).
//!
//! The contact band assumes every element of a pair's surfaces within reach of its partner (the
//! pattern reserves the blocks of points that approach). Its regions (one per element of an
//! integrated surface: the union of its blocks' rows times the union of their columns): for a
//! pass with a pointwise gap, the element's rows times the partner's unknowns in one ring of
//! elements around a partner element (`q + 2` nodes per surface direction for `q` per element),
//! scaled by the ratio of the two surfaces' element lengths, and the weighted gaps of two
//! half-passes add the columns of the element's own neighbours. A one-pass weighted gap's region
//! also holds the rows of the partner elements of its points, and the columns of every element
//! within its control points' supports (`2q - 1` elements per direction) and of their points'
//! partners ([`one_pass_region_nodes`]). Neighbouring regions share most entries; the pattern holds
//! each matrix entry once ([`DISTINCT_TWO_HALF_PASS`], [`DISTINCT_ONE_PASS`]).
//!
//! The constants are fitted to peaks measured on this kind of machine (the performance pages'
//! memory table, `ci/memory_estimate.py`); the fit's residuals are asserted in the tests below.

use crate::contact::pair::Partner;
use crate::contact::surface::ContactSurface;
use crate::model::Model;
use crate::scene::size::MeshSize;

/// Resident memory of a process before it builds anything: its code, MPI, PETSc and HDF5 (measured
/// on the smallest cases, 58-62 MB without pictures).
pub const PROCESS_BYTES: f64 = 60e6;

/// Model data per cell: its element kernel's tabulated basis and the partition's copies.
pub const CELL_BYTES: f64 = 2.2e3;

/// Model data per contact surface element: the tangle check's samples of its enriched cell, the
/// output's sampling grid and the contact quadrature points.
pub const SURFACE_ELEMENT_BYTES: f64 = 50e3;

/// Model data per element of a pass integrated over 3D segments: the points its placements need
/// beyond the element's own rule, with their partner bases (the peak with segments less the peak
/// without, per integrated element: 176 kB on the scale scene's e4, 129 kB on
/// `hemisphere_block_3d`, 86 kB on `twisting_3d`).
pub const SEGMENT_ELEMENT_BYTES: f64 = 150e3;

/// Bytes per entry of the COO pattern: PETSc's matrix and COO maps and the assembler's arrays.
pub const COO_ENTRY_BYTES: f64 = 24.0;

/// Bytes per entry of the cells' element matrices: the COO entry each adds into (the cells' COO
/// pattern holds one entry per matrix entry; neighbouring cells share theirs).
pub const CELL_MAP_BYTES: f64 = 4.0;

/// Bytes per column of the contact rows' column patterns (its global column and its place in the
/// row's run of COO entries). The rows of a node share a pattern, so there are about the band's
/// distinct entries over the dimension (the scale scene's e4: 98,799 with the paper's formulation,
/// 300,027 with the one-pass weighted gap, `contact_pattern.run_columns` of summary.json).
pub const PATTERN_COLUMN_BYTES: f64 = 8.0;

/// Region entries per distinct matrix entry of the contact band, two half-passes (measured on the
/// scale scene's size e4: 1,042,146 region entries, about 0.30e6 distinct contact entries).
pub const DISTINCT_TWO_HALF_PASS: f64 = 3.5;

/// The same for a one-pass weighted gap (the scale scene's e4: 17,989,560 region entries, about
/// 1.11e6 distinct).
pub const DISTINCT_ONE_PASS: f64 = 16.0;

/// MUMPS's memory at the factorisation per `n^(4/3)` in 3D (factor entries about 42 `n^(4/3)`,
/// 12.5 bytes each with MUMPS's work arrays).
pub const MUMPS_3D_BYTES: f64 = 520.0;

/// Heap terms are multiplied by this: the allocator's slack and pages freed but kept resident.
pub const ALLOCATOR_FACTOR: f64 = 1.2;

/// The expected peak of a run, by term (bytes; see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeakEstimate {
    /// Per rank: the process, the mesh arrays and the model's data.
    pub per_rank: f64,
    /// Shared by the ranks: the Jacobian's COO pattern (cells and contact band).
    pub matrix: f64,
    /// Of which the contact band.
    pub contact: f64,
    /// Shared by the ranks: the linear solver.
    pub linear: f64,
    /// The route is the iterative one.
    pub iterative: bool,
}

impl PeakEstimate {
    /// The estimate for `model` with `unknowns` unknowns on the route `iterative`.
    pub fn of(model: &Model, unknowns: f64, iterative: bool) -> PeakEstimate {
        let dim = model.dim;
        let cells = model.n_cells();
        let mesh = MeshSize {
            dim,
            nodes: model.n_nodes() as f64,
            cells: cells as f64,
        };
        let surface_elements: usize = model
            .contact_surfaces
            .iter()
            .map(|s| s.elements.len())
            .sum();
        let segmented: usize = model
            .contact_pairs
            .iter()
            .flat_map(|pair| {
                pair.passes
                    .iter()
                    .map(move |(k, partner)| (pair, *k, partner))
            })
            .filter(|(pair, _, partner)| {
                dim == 3 && crate::contact::system::segmented(pair, dim, partner)
            })
            .map(|(_, k, _)| model.contact_surfaces[k].elements.len())
            .sum();
        let data = CELL_BYTES * cells as f64
            + SURFACE_ELEMENT_BYTES * surface_elements as f64
            + SEGMENT_ELEMENT_BYTES * segmented as f64;
        let element_entries: f64 = model
            .cell_offsets
            .windows(2)
            .map(|w| ((w[1] - w[0]) * dim) as f64)
            .map(|n| n * n)
            .sum();
        let cells_coo =
            COO_ENTRY_BYTES * distinct_cell_entries(model) + CELL_MAP_BYTES * element_entries;
        let band = contact_band_entries(model);
        let contact =
            COO_ENTRY_BYTES * band.distinct + PATTERN_COLUMN_BYTES * band.distinct / dim as f64;
        PeakEstimate {
            per_rank: PROCESS_BYTES + mesh.mesh_bytes() + ALLOCATOR_FACTOR * data,
            matrix: ALLOCATOR_FACTOR * (cells_coo + contact),
            contact: ALLOCATOR_FACTOR * contact,
            linear: ALLOCATOR_FACTOR
                * linear_bytes(dim, unknowns, iterative, !model.contact_pairs.is_empty()),
            iterative,
        }
    }

    /// The peak of one rank of a run on `ranks` ranks (the shared terms split evenly).
    pub fn per_rank_peak(&self, ranks: usize) -> f64 {
        self.per_rank + (self.matrix + self.linear) / ranks.max(1) as f64
    }
}

/// Bytes of the linear solver (whole problem) for `unknowns` unknowns: MUMPS's factorisation
/// (3D [`MUMPS_3D_BYTES`] per `n^(4/3)`; 2D `144 n log2 n`, as [`crate::scene::size`]), or GAMG's
/// hierarchy with the Krylov basis ([`crate::scene::size::linear_solver_bytes`]).
pub fn linear_bytes(dim: usize, unknowns: f64, iterative: bool, contact: bool) -> f64 {
    let n = unknowns.max(1.0);
    if !iterative && dim == 3 {
        return MUMPS_3D_BYTES * n.powf(4.0 / 3.0);
    }
    crate::scene::size::linear_solver_bytes(dim, n, iterative, contact)
}

/// Distinct matrix entries that the cells reach (the cells' part of the COO pattern): per node,
/// the nodes that share a cell with it, times `dim^2`.
fn distinct_cell_entries(model: &Model) -> f64 {
    let n = model.n_nodes();
    let (offsets, nodes) = (&model.cell_offsets, &model.cell_nodes);
    // the cells of each node
    let mut start = vec![0usize; n + 1];
    for &v in nodes {
        start[v as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut cells_of = vec![0usize; start[n]];
    for c in 0..offsets.len().saturating_sub(1) {
        for &v in &nodes[offsets[c]..offsets[c + 1]] {
            cells_of[fill[v as usize]] = c;
            fill[v as usize] += 1;
        }
    }
    // each node's neighbours, counted once with a marker
    let mut counted = vec![usize::MAX; n];
    let mut pairs = 0usize;
    for v in 0..n {
        for &c in &cells_of[start[v]..start[v + 1]] {
            for &w in &nodes[offsets[c]..offsets[c + 1]] {
                if counted[w as usize] != v {
                    counted[w as usize] = v;
                    pairs += 1;
                }
            }
        }
    }
    (pairs * model.dim * model.dim) as f64
}

/// Entries of the contact band, every pair's surfaces wholly within reach (module docs): its
/// regions' entries and the distinct matrix entries they hold.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Band {
    regions: f64,
    distinct: f64,
}

fn contact_band_entries(model: &Model) -> Band {
    let dim = model.dim;
    let surfaces = &model.contact_surfaces;
    let mut band = Band {
        regions: 0.0,
        distinct: 0.0,
    };
    for pair in &model.contact_pairs {
        let nodal = pair.formulation.pressure.is_nodal();
        for (k, partner) in &pair.passes {
            let own = &surfaces[*k];
            let n_el = own.elements.len() as f64;
            if let (true, true, Partner::Surface(l)) = (pair.formulation.one_pass(), nodal, partner)
            {
                let (rows, cols) = one_pass_region_nodes(own, &surfaces[*l]);
                let regions = n_el * (dim * dim) as f64 * rows * cols;
                band.regions += regions;
                band.distinct += regions / DISTINCT_ONE_PASS;
                continue;
            }
            let rows = mean_nodes(own) * dim as f64;
            let cols = match partner {
                Partner::Rigid(..) => rows,
                Partner::Surface(l) => {
                    let other = &surfaces[*l];
                    let ratio = (own.h / other.h).max(1.0).powi(dim as i32 - 1);
                    let ring = (nodes_per_direction(other) + 2.0).powi(dim as i32 - 1);
                    dim as f64 * ring * ratio
                }
            };
            let weighted = if nodal {
                dim as f64 * (2.0 * nodes_per_direction(own) - 1.0).powi(dim as i32 - 1)
            } else {
                0.0
            };
            let regions = n_el * rows * (cols + weighted);
            band.regions += regions;
            band.distinct += regions / DISTINCT_TWO_HALF_PASS;
        }
    }
    band
}

/// Nodes of the rows and of the columns of a one-pass weighted gap's region for an element of
/// `own` against `other` (module docs): per surface direction, `E + m - 1` nodes span `E` elements
/// of `m` nodes; an element's points meet `ceil(r) + 2` partner elements (`r` the ratio of the
/// element lengths, one ring around), its control points' supports span `S = 2q - 1` own elements
/// and `ceil(S r) + 2` partner elements. Capped at the surfaces' own sizes.
fn one_pass_region_nodes(own: &ContactSurface, other: &ContactSurface) -> (f64, f64) {
    let d = (own.dim as i32 - 1).max(1);
    let (q, m) = (nodes_per_direction(own), nodes_per_direction(other));
    let r = own.h / other.h.max(1e-300);
    let side = |s: &ContactSurface| (s.elements.len() as f64).powf(1.0 / d as f64);
    let (own_side, other_side) = (side(own) + q - 1.0, side(other) + m - 1.0);
    let partner = |elements: f64| ((elements + m - 1.0).min(other_side)).powi(d);
    let support = 2.0 * q - 1.0;
    let rows = q.powi(d) + partner((r).ceil() + 2.0);
    let cols = ((support + q - 1.0).min(own_side)).powi(d) + partner((support * r).ceil() + 2.0);
    (rows, cols)
}

/// Mean nodes per element of a surface.
fn mean_nodes(s: &ContactSurface) -> f64 {
    if s.elements.is_empty() {
        return 0.0;
    }
    s.elements
        .iter()
        .map(|e| e.basis.n_nodes() as f64)
        .sum::<f64>()
        / s.elements.len() as f64
}

/// Nodes per surface direction of a surface's elements (`n^(1/(dim-1))` of their mean count).
fn nodes_per_direction(s: &ContactSurface) -> f64 {
    mean_nodes(s).powf(1.0 / (s.dim as f64 - 1.0).max(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// Peak resident sets measured on this kind of machine (2 cores, 24 GiB, 1 rank, pictures off;
    /// `ci/memory_estimate.py` and `ci/scale_scene.sh`, /usr/bin/time's %M in KiB): the estimate
    /// lies within 25 % of each. The scale scene's e4.5 size is cube 24^3, shell 24 x 24 x 3; the
    /// scale scene names the paper's formulation, `twisting_3d` and `hemisphere_block_3d` run the
    /// default (the one-pass weighted gap over 3D segments), and so does the scale scene's row with
    /// `weighted_gap`.
    #[test]
    fn the_peak_estimate_is_within_a_quarter_of_the_measured_peaks() {
        let e45 = [
            "meshes.cube.divisions=[24,24,24]",
            "meshes.shell.n_surface=24",
            "meshes.shell.n_thickness=3",
        ];
        let weighted_gap = ["contact.0.formulation=\"weighted_gap\""];
        let rows: [(&str, &[&str], &str, f64); 8] = [
            ("contact_patch_3d.toml", &[], "direct", 63_860.0),
            ("twisting_3d.toml", &[], "direct", 66_704.0),
            ("hemisphere_block_3d.toml", &[], "direct", 143_396.0),
            ("hemisphere_twist_scale_3d.toml", &[], "direct", 347_652.0),
            (
                "hemisphere_twist_scale_3d.toml",
                &[],
                "iterative",
                204_892.0,
            ),
            (
                "hemisphere_twist_scale_3d.toml",
                &weighted_gap,
                "iterative",
                307_224.0,
            ),
            (
                "hemisphere_twist_scale_3d.toml",
                &e45,
                "iterative",
                617_340.0,
            ),
            (
                "hemisphere_twist_scale_3d.toml",
                &e45,
                "direct",
                1_693_392.0,
            ),
        ];
        for (file, sets, route, peak_kib) in rows {
            let path = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("cases")
                .join(file);
            let mut sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            sets.push(format!("solver.linear=\"{route}\""));
            let case = crate::scene::load_case(&path, &sets).expect("case");
            let model = Model::build(&case).expect("model");
            let part = vec![0u32; model.n_cells()];
            let dofs = crate::assembly::DofMap::new(
                model.dim,
                model.n_nodes(),
                &model.cell_offsets,
                &model.cell_nodes,
                &part,
                &model.ties,
                1,
                0,
            )
            .expect("numbering");
            let unknowns = dofs.n_global() as f64;
            let est = PeakEstimate::of(&model, unknowns, route == "iterative");
            let peak = peak_kib * 1024.0;
            let ratio = est.per_rank_peak(1) / peak;
            assert!(
                (0.75..=1.25).contains(&ratio),
                "{file} {sets:?}: estimate {:.1} MB, measured {:.1} MB",
                est.per_rank_peak(1) / 1e6,
                peak / 1e6
            );
        }
    }

    /// The contact band's regions against the region entries of the scale scene's pattern
    /// (`contact_pattern.region_entries` of summary.json; `ci/scale_scene.sh e4 iterative 1`, and
    /// with `--set contact.0.formulation=weighted_gap` and `NURBS_CONTACT_SEGMENTS_3D=0`):
    /// 1,042,146 for two half-passes, 17,989,560 for the one-pass weighted gap.
    #[test]
    fn the_contact_bands_regions_are_the_order_of_the_patterns() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/hemisphere_twist_scale_3d.toml");
        for (sets, measured) in [
            (vec![], 1_042_146.0),
            (
                vec!["contact.0.formulation=\"weighted_gap\"".to_string()],
                17_989_560.0,
            ),
        ] {
            let case = crate::scene::load_case(&path, &sets).expect("case");
            let model = Model::build(&case).expect("model");
            let band = contact_band_entries(&model);
            let ratio = band.regions / measured;
            assert!((0.7..1.3).contains(&ratio), "{sets:?}: {band:?}");
            assert!(band.distinct < band.regions, "{band:?}");
        }
    }
}
