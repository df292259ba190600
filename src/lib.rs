//! # nurbs-contact
//!
//! Large-deformation contact between deformable solids with the NURBS-enriched contact elements of
//! Corbett & Sauer (CMAME 2014): linear bulk elements, a NURBS contact surface of order p on the layer
//! of elements at each declared contact surface, PETSc SNES + MUMPS for Newton, METIS for
//! partitioning, MPI through rsmpi, HDF5/XDMF for results.
//!
//! ## Map of the modules and the flow of one run
//! ```text
//! case.toml --scene--> Case (typed, validated) --model--> Model: meshes (mesh), bodies, BCs, ties
//! Model --parallel::partition (METIS)--> cell ranks --assembly::DofMap--> contiguous rows per rank, ghosts
//! Model + ranks --fem::sets--> element sets (kernels from fem, material from material, bases from
//!                              fem/geometry) --assembly::Assembler--> F(u), J(u) on PETSc (petsc)
//! solver::run_load_steps: per load step, SNES (newtonls + MUMPS) on the Assembler; cutback on failure
//! driver: observer per converged step -> io (results.h5/.xdmf, history.csv, summary.json)
//! ```
//! - [`petsc`]: the only `unsafe` code: bindgen bindings and their safe RAII wrappers.
//! - [`assembly`]: numbering, restriction, sinks, Dirichlet rows, the nonlinear system, and the two
//!   seams everything else plugs into: [`assembly::ElementSet`] (a batch of elements of one family,
//!   implemented in `fem::sets`) and [`assembly::CouplingSet`] (blocks joining elements that no cell
//!   holds, implemented by [`contact::ContactSystem`]). Assembly imports nothing from `contact`,
//!   `fem` or `model`.
//! - [`fem`], [`material`]: element kernels (total Lagrangian, Q1E4, enriched bases) and the
//!   Neo-Hookean law; nothing in them knows about MPI or PETSc.
//! - [`geometry`]: knot vectors, B-splines, NURBS, Bezier extraction, refinement, exact conics.
//! - [`mesh`]: the mesh type, structured generators with named sets, the Gmsh reader.
//! - [`contact`]: contact surfaces, search, projection, laws, rigid partners and the contact
//!   residual/tangent of each half-pass, plugged into the assembler as its coupling set.
//! - [`scene`], [`model`]: case files and what is built from them (including the enriched layer of a
//!   body's contact surface, `model::enrich`); [`solver`], [`driver`], [`io`].
//! - [`study`]: `nurbs-contact study`, refinement studies over many runs of one case, with metrics,
//!   tables and plots.
//! - [`reference`]: `nurbs-contact reference`, the generated reference pages (the case file's JSON
//!   Schema, its keys, the command line) in `docs/reference/`.
//!
//! ## Where the paper's concepts live (Corbett & Sauer 2014)
//! | concept | where |
//! | --- | --- |
//! | enriched contact elements Q1Np, Q1Cp, Q1CH (section 3.1) | `fem::enriched`, the enriched layer `model::enrich` |
//! | NURBS / Bezier extraction of the contact surface (section 2.2) | `geometry`, face bases `contact::basis` |
//! | contact surface as plain data | [`contact::surface`] |
//! | closest-point projection, eq. (3) | [`contact::projection`], global search [`contact::search`] |
//! | penalty, van der Waals, cohesive laws, eqs. (5)-(7) | [`contact::law`] |
//! | contact residual and consistent tangent at a point (section 3.2) | [`contact::kernel`] |
//! | two-half-pass / one-pass, one pass over a surface's points | [`contact::half_pass`] |
//! | gap modes (pointwise, element mean) | `contact::half_pass::gap` |
//! | Coulomb friction (Sauer & De Lorenzis 2015) | return mapping in [`contact::kernel`], anchors in `contact::half_pass::friction` |
//! | rigid partners | [`contact::rigid`] |
//! | a pair's formulation (passes, pressure distribution, enforcement, law) | [`contact::formulation`], composed by `model::formulation` |
//! | a pair's declaration (formulation, partners, friction) | [`contact::pair`] |
//! | pair state on a rank, commit/rollback, coupling pattern, L2 pressure (Sauer 2013) | [`contact::system`] |
//! | contact in the global residual and tangent (the seam) | [`assembly::CouplingSet`], implemented in `contact::system::coupling` |
//! | Neo-Hookean bulk, eq. (21) | [`material`] |

pub mod assembly;
pub mod checkpoint;
pub mod contact;
pub mod driver;
pub mod fem;
pub mod geometry;
pub mod interrupt;
pub mod io;
pub mod material;
pub mod mesh;
pub mod model;
pub mod parallel;
pub mod petsc;
pub mod reference;
pub mod scene;
pub mod solver;
pub mod study;
