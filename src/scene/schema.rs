//! The typed case schema: what a TOML case file may hold, with documented defaults.
//!
//! Every table denies unknown keys. Tables whose fields depend on a tag (`generator` of a mesh, `kind`
//! of a boundary condition) are dispatched by hand on the tag and then deserialised into the variant's
//! own struct, so that errors still carry the full key path (serde's internally tagged enums lose it).

use crate::scene::element_family::ElementFamily;
use crate::scene::keypath::{nest_message, split_toml_error};
use schemars::JsonSchema;
use serde::de::{self, DeserializeOwned, Deserializer};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A whole case: `[case]`, `[meshes.*]`, `[bodies.*]`, `[[bcs]]`, `[[ties]]`, `[[stages]]`, `[steps]`,
/// `[solver]`, `[output]`, `[[contact]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// The case file this was read from (not part of the TOML); error messages and relative mesh
    /// paths refer to it.
    #[serde(skip)]
    pub file: PathBuf,
    pub case: CaseInfo,
    /// Meshes by name.
    pub meshes: BTreeMap<String, MeshSpec>,
    /// Bodies by name; each refers to one mesh.
    pub bodies: BTreeMap<String, BodySpec>,
    /// Dirichlet conditions. Default: none.
    #[serde(default)]
    pub bcs: Vec<BcSpec>,
    /// Periodic ties. Default: none.
    #[serde(default)]
    pub ties: Vec<TieSpec>,
    /// Contact pairs, `[[contact]]`. Default: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub contact: Vec<crate::scene::contact_spec::ContactSpec>,
    /// Load stages, applied in order; at least one.
    pub stages: Vec<StageSpec>,
    /// Step size control, `[steps]`. Default: the defaults of its keys.
    #[serde(default)]
    pub steps: StepControl,
    #[serde(default)]
    pub solver: SolverOptions,
    #[serde(default)]
    pub output: OutputSpec,
}

impl Case {
    /// Keeps the first `n` stages: `stages` and every per-stage list (those documented
    /// `[n_stages]...` on their fields: displacement values, rotation angles and translations,
    /// friction switches, rigid partners' motions). A restart compares cases truncated to the
    /// stages its checkpoint has started. A per-stage field added to the schema belongs here.
    pub fn truncate_stages(&mut self, n: usize) {
        self.stages.truncate(n);
        for bc in &mut self.bcs {
            match bc {
                BcSpec::Fixed(_) | BcSpec::Radial(_) | BcSpec::Sliding(_) => {}
                BcSpec::Displacement(d) => d.value.truncate(n),
                BcSpec::Rotation(r) => {
                    r.angle_deg.truncate(n);
                    r.translation.truncate(n);
                }
            }
        }
        for c in &mut self.contact {
            c.friction_stages.truncate(n);
            if let Some(r) = &mut c.rigid {
                r.translation.truncate(n);
                r.rotation_deg.truncate(n);
            }
        }
    }

    /// Writes the formulation that a contact pair naming none gets
    /// ([`ContactSpec::default_formulation`](crate::scene::contact_spec::ContactSpec::default_formulation))
    /// into its `formulation`, so that the resolved case stored beside the results, and a
    /// checkpoint's, says which formulation ran.
    pub fn name_default_formulations(&mut self) {
        let bodies = &self.bodies;
        let dim = self.case.dim;
        for c in &mut self.contact {
            if let Some(f) = c.default_formulation(dim, |b| bodies.get(b).map(|s| s.element)) {
                c.formulation = Some(f);
            }
        }
    }

    /// The resolved case (after overrides) as TOML, to be stored beside the results.
    pub fn to_toml_string(&self) -> Result<String, crate::scene::SceneError> {
        Ok(toml::to_string(self)?)
    }

    /// A path from the case file (e.g. a mesh `file`), made relative to the case file's directory.
    pub fn resolve_path(&self, p: &Path) -> PathBuf {
        if p.is_absolute() {
            return p.to_path_buf();
        }
        match self.file.parent() {
            Some(dir) => dir.join(p),
            None => p.to_path_buf(),
        }
    }
}

/// `[case]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CaseInfo {
    /// Name of the case: the default output directory is `out/<name>/`.
    pub name: String,
    /// Free text. Default: empty.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    /// Spatial dimension, 2 or 3.
    #[schemars(range(min = 2, max = 3))]
    pub dim: usize,
}

/// `[meshes.<name>]`: exactly one of `generator = "..."` (with that generator's parameters) or `file`.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum MeshSpec {
    Generated(Generator),
    File(FileMesh),
}

/// A mesh read from disk.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FileMesh {
    /// Gmsh 4.1 `.msh`, relative to the case file (see [`Case::resolve_path`]).
    pub file: PathBuf,
}

/// A structured mesh generator and its parameters, tagged by `generator`.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "generator", rename_all = "snake_case")]
pub enum Generator {
    Rectangle(RectangleParams),
    HalfDisk(HalfDiskParams),
    Sector(SectorParams),
    Box(BoxParams),
    Hemisphere(HemisphereParams),
    HemisphereNurbs(HemisphereParams),
    QuarterSphere(QuarterSphereParams),
    SphereCap(QuarterSphereParams),
}

impl Generator {
    /// Names accepted for `generator`.
    pub const NAMES: [&'static str; 8] = [
        "rectangle",
        "half_disk",
        "sector",
        "box",
        "hemisphere",
        "hemisphere_nurbs",
        "quarter_sphere",
        "sphere_cap",
    ];

    /// The spatial dimension of the mesh this generator builds.
    pub fn dim(&self) -> usize {
        match self {
            Generator::Rectangle(_) | Generator::HalfDisk(_) | Generator::Sector(_) => 2,
            Generator::Box(_)
            | Generator::Hemisphere(_)
            | Generator::HemisphereNurbs(_)
            | Generator::QuarterSphere(_)
            | Generator::SphereCap(_) => 3,
        }
    }

    /// The `generator = "..."` name.
    pub fn name(&self) -> &'static str {
        match self {
            Generator::Rectangle(_) => "rectangle",
            Generator::HalfDisk(_) => "half_disk",
            Generator::Sector(_) => "sector",
            Generator::Box(_) => "box",
            Generator::Hemisphere(_) => "hemisphere",
            Generator::HemisphereNurbs(_) => "hemisphere_nurbs",
            Generator::QuarterSphere(_) => "quarter_sphere",
            Generator::SphereCap(_) => "sphere_cap",
        }
    }

    /// The key holding the main cell count (where a too-large mesh is reported).
    pub fn size_key(&self) -> &'static str {
        match self {
            Generator::Rectangle(_)
            | Generator::Box(_)
            | Generator::Sector(_)
            | Generator::QuarterSphere(_)
            | Generator::SphereCap(_) => "divisions",
            Generator::HalfDisk(_) => "n_arc",
            Generator::Hemisphere(_) | Generator::HemisphereNurbs(_) => "n_surface",
        }
    }
}

/// `generator = "rectangle"`: axis-aligned `size[0] x size[1]` from `origin`, `divisions[0] x divisions[1]` quads.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RectangleParams {
    /// Default: `[0, 0]`.
    #[serde(default)]
    #[schemars(extend("x-unit" = "length"))]
    pub origin: [f64; 2],
    /// `[width, height]`.
    #[schemars(extend("x-unit" = "length"))]
    pub size: [f64; 2],
    /// `[n_x, n_y]`: elements along x and y.
    pub divisions: [usize; 2],
}

/// `generator = "half_disk"`: the lower half disk (flat side up) of `radius` around `center`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HalfDiskParams {
    /// `[x, y]`: centre of the disk.
    #[schemars(extend("x-unit" = "length"))]
    pub center: [f64; 2],
    /// Radius (> 0).
    #[schemars(extend("x-unit" = "length"))]
    pub radius: f64,
    /// Elements along the arc.
    pub n_arc: usize,
    /// Elements from the centre to the arc.
    pub n_radial: usize,
}

/// `generator = "sector"`: annular sector `r_inner..r_outer`, `theta0_deg..theta1_deg` around `center`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SectorParams {
    /// `[x, y]`: centre of the annulus.
    #[schemars(extend("x-unit" = "length"))]
    pub center: [f64; 2],
    /// Inner radius.
    #[schemars(extend("x-unit" = "length"))]
    pub r_inner: f64,
    /// Outer radius (> `r_inner`).
    #[schemars(extend("x-unit" = "length"))]
    pub r_outer: f64,
    /// Start angle, in degrees from the x axis.
    #[schemars(extend("x-unit" = "degrees"))]
    pub theta0_deg: f64,
    /// End angle, in degrees from the x axis (> `theta0_deg`).
    #[schemars(extend("x-unit" = "degrees"))]
    pub theta1_deg: f64,
    /// `[n_r, n_theta]`.
    pub divisions: [usize; 2],
}

/// `generator = "box"`: axis-aligned brick from `origin`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BoxParams {
    /// Default: `[0, 0, 0]`.
    #[serde(default)]
    #[schemars(extend("x-unit" = "length"))]
    pub origin: [f64; 3],
    /// `[size_x, size_y, size_z]`.
    #[schemars(extend("x-unit" = "length"))]
    pub size: [f64; 3],
    /// `[n_x, n_y, n_z]`: elements along x, y and z.
    pub divisions: [usize; 3],
}

/// `generator = "hemisphere"`: hollow lower hemisphere (opening up) of `outer_radius` and wall
/// `thickness` around `center` (section 4.4). `generator = "hemisphere_nurbs"` takes the same
/// parameters and builds the shell from the exact NURBS outer surface (`n_surface` even: elements
/// per parametric direction, i.e. along a half great circle; see `crate::mesh::hemisphere_nurbs`),
/// whose `outer` face set carries the exact geometry for an enriched layer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HemisphereParams {
    /// `[x, y, z]`: centre of the sphere.
    #[schemars(extend("x-unit" = "length"))]
    pub center: [f64; 3],
    /// Outer radius (> 0).
    #[schemars(extend("x-unit" = "length"))]
    pub outer_radius: f64,
    /// Wall thickness, in (0, `outer_radius`).
    #[schemars(extend("x-unit" = "length"))]
    pub thickness: f64,
    /// `hemisphere`: elements along a side of the square parametrisation; `hemisphere_nurbs`:
    /// elements per parametric direction (even).
    pub n_surface: usize,
    /// Elements through the wall.
    pub n_thickness: usize,
}

/// `generator = "quarter_sphere"`: the quarter (x >= cx, y >= cy) of the lowest cap of the ball of
/// `radius` around `center`, between the exact spherical patch `sphere` and the plane z = cz (a
/// sphere pressed on a flat with two symmetry planes; see `crate::mesh::quarter_sphere`).
/// `generator = "sphere_cap"` takes the same keys and builds the whole cap: that quarter mirrored
/// across x = cx and y = cy (4 x the cells, `divisions` and `grading` per quadrant, one patch
/// over the four quadrants; node sets `xmid`, `ymid` on the mirror planes, `axis`, and `xmin` ...
/// `ymax` on the four far sides).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct QuarterSphereParams {
    /// `[x, y, z]`: centre of the ball.
    #[schemars(extend("x-unit" = "length"))]
    pub center: [f64; 3],
    /// Radius of the ball (> 0).
    #[schemars(extend("x-unit" = "length"))]
    pub radius: f64,
    /// How far the patch reaches from the symmetry planes (x - cx on y = cy, y - cy on x = cx),
    /// in (0, radius).
    #[schemars(extend("x-unit" = "length"))]
    pub extent: f64,
    /// `[n_u, n_v, n_z]`: cells along the arc from the lowest point, around the x axis, and from
    /// the sphere up to the plane.
    pub divisions: [usize; 3],
    /// `[g_u, g_v, g_z]`: the last cell of each direction over the first (geometric; > 1 refines
    /// towards the lowest point and the sphere). Default `[1, 1, 1]` (equal cells).
    #[serde(default = "unit_grading")]
    pub grading: [f64; 3],
}

fn unit_grading() -> [f64; 3] {
    [1.0; 3]
}

/// `[bodies.<name>]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Name of a `[meshes.*]` table.
    pub mesh: String,
    pub element: ElementFamily,
    /// Face set carrying the enrichment: required for Q1N/Q1C2/Q1CH, ignored by Q1C1/Q1E4 (so one
    /// case file runs every family through `--set bodies.<name>.element=...`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub enriched_surface: Option<String>,
    /// The element of the cells below an enriched layer (enriched families only): `Q1C1`
    /// (default) or `Q1E4` (2D: enhanced assumed strain against bending locking, as the peeling
    /// case of section 4.2 needs; the enriched layer itself gets no enhancement).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bulk: Option<ElementFamily>,
    /// Geometry of the enriched surface (Q1Np / Q1Np.t only): `"exact"` (default, the paper's
    /// choice) or `"smooth"` (a C^{p-1} B-spline fit of the exact surface, see
    /// [`EnrichedGeometry`]). Needs `enriched_surface`; ignored, like it, by linear families, and
    /// ignored with a note by Q1C2 and Q1CH.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub enriched_geometry: Option<EnrichedGeometry>,
    /// The material law and its parameters.
    pub material: MaterialSpec,
    /// Node sets selected from the mesh by position, by name (see [`NodeSelection`]), added to the
    /// mesh's own sets. Default: none.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub node_sets: BTreeMap<String, NodeSelection>,
}

/// `bodies.<name>.enriched_geometry`: which geometry a Q1Np(.t) enriched layer interpolates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum EnrichedGeometry {
    /// `"exact"` (default): the exact NURBS of the surface (line, circular arc, plane, or the
    /// generator's exact surface) refined to the family. Exact, but C^0 at the joints of its
    /// rational pieces (e.g. the lowest point of a half circle, the pole of the hemisphere).
    #[default]
    Exact,
    /// `"smooth"`: a polynomial B-spline of order p with one span per enriched element and single
    /// interior knots (C^{p-1} everywhere), least-squares fitted to the exact surface with its
    /// ends/corners interpolated, then elevated `t` times; its largest distance from the exact
    /// surface is printed by `check` and `run`. A surface without C^0 joints (a line, a plane, an
    /// arc of one piece) is smooth already and kept exact.
    Smooth,
}

/// `[bodies.<name>.node_sets.<set>]`: the nodes of the reference mesh chosen by position, among
/// the nodes of the set `within` (a node or face set of the mesh; default: all nodes):
/// either those inside the box `min`..`max` (each `[dim]`, bounds included), or the one node
/// nearest to `nearest` (`[dim]`). E.g. the base nodes on the plane x = 0:
/// `base_x0 = { within = "zmin", min = [-1e-9, -9, -9], max = [1e-9, 9, 9] }`; the midpoint of
/// a strip's end: `pin = { within = "right", nearest = [20.0, 0.5] }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NodeSelection {
    /// A node or face set of the mesh to choose from. Default: all nodes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub within: Option<String>,
    /// `[dim]`: lower corner of the box (with `max`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length"))]
    pub min: Option<Vec<f64>>,
    /// `[dim]`: upper corner of the box (with `min`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length"))]
    pub max: Option<Vec<f64>>,
    /// `[dim]`: choose the one node nearest to this point (instead of a box).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length"))]
    pub nearest: Option<Vec<f64>>,
}

/// `[bodies.<name>.material]`.
#[allow(non_snake_case)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// The material law.
    pub model: MaterialModel,
    /// Young's modulus, > 0.
    #[schemars(extend("x-unit" = "stress", "exclusiveMinimum" = 0))]
    pub E: f64,
    /// Poisson's ratio, in (-1, 0.5).
    #[schemars(extend("exclusiveMinimum" = -1, "exclusiveMaximum" = 0.5))]
    pub nu: f64,
}

/// Material laws, both parametrised by `E` and `nu`; a model with other parameters would turn
/// [`MaterialSpec`] into a tagged table like [`Generator`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MaterialModel {
    /// `"neo_hookean"`: the compressible Neo-Hookean law of eq. (21) of Corbett & Sauer 2014.
    NeoHookean,
    /// `"linear_elastic"`: small-strain, geometrically linear Hooke law
    /// `sigma = lambda tr(eps) I + 2 mu eps`, `eps = sym(grad u)` (plane strain in 2D), for
    /// validation against classical solutions such as Hertz contact.
    LinearElastic,
}

/// A displacement component name.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Component {
    X,
    Y,
    Z,
}

impl Component {
    /// 0, 1, 2.
    pub fn index(self) -> usize {
        self as usize
    }

    /// All components of a `dim`-dimensional problem.
    pub fn all(dim: usize) -> &'static [Component] {
        &[Component::X, Component::Y, Component::Z][..dim.min(3)]
    }
}

/// `[[bcs]]`: a Dirichlet condition on a node set of a body, tagged by `kind`.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum BcSpec {
    Fixed(FixedBc),
    Displacement(DisplacementBc),
    Rotation(RotationBc),
    Radial(RadialBc),
    Sliding(SlidingBc),
}

impl BcSpec {
    /// Names accepted for `kind`.
    pub const KINDS: [&'static str; 5] = ["fixed", "displacement", "rotation", "radial", "sliding"];

    pub fn body(&self) -> &str {
        match self {
            BcSpec::Fixed(b) => &b.body,
            BcSpec::Displacement(b) => &b.body,
            BcSpec::Rotation(b) => &b.body,
            BcSpec::Radial(b) => &b.body,
            BcSpec::Sliding(b) => &b.body,
        }
    }

    /// The node set the condition applies to.
    pub fn set(&self) -> &str {
        match self {
            BcSpec::Fixed(b) => &b.set,
            BcSpec::Displacement(b) => &b.set,
            BcSpec::Rotation(b) => &b.set,
            BcSpec::Radial(b) => &b.set,
            BcSpec::Sliding(b) => &b.set,
        }
    }
}

/// `kind = "fixed"`: zero displacement of `components`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FixedBc {
    /// Name of a `[bodies.*]` table.
    pub body: String,
    /// A node set (or the nodes of a face set) of the body.
    pub set: String,
    /// Default: all components.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub components: Option<Vec<Component>>,
}

impl FixedBc {
    /// The constrained components (all of `dim` when not given).
    pub fn components(&self, dim: usize) -> Vec<Component> {
        self.components
            .clone()
            .unwrap_or_else(|| Component::all(dim).to_vec())
    }
}

/// `kind = "displacement"`: prescribed displacement of `components`, linear in each stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DisplacementBc {
    /// Name of a `[bodies.*]` table.
    pub body: String,
    /// A node set (or the nodes of a face set) of the body.
    pub set: String,
    /// Default: all components.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub components: Option<Vec<Component>>,
    /// `[n_stages][n_components]`: the displacement reached at the end of each stage.
    #[schemars(extend("x-unit" = "length"))]
    pub value: Vec<Vec<f64>>,
}

impl DisplacementBc {
    /// The prescribed components (all of `dim` when not given).
    pub fn components(&self, dim: usize) -> Vec<Component> {
        self.components
            .clone()
            .unwrap_or_else(|| Component::all(dim).to_vec())
    }
}

/// `kind = "rotation"`: rigid rotation of the set about `center` (and `axis` in 3D); all components.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RotationBc {
    /// Name of a `[bodies.*]` table.
    pub body: String,
    /// A node set (or the nodes of a face set) of the body.
    pub set: String,
    /// Rotation axis, 3D only (2D rotates in the plane); need not be normalised, must be non-zero.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// `[dim]`: a point on the axis (3D) / the centre of rotation (2D).
    #[schemars(extend("x-unit" = "length"))]
    pub center: Vec<f64>,
    /// `[n_stages]`: total rotation angle in degrees reached at the end of each stage.
    #[schemars(extend("x-unit" = "degrees"))]
    pub angle_deg: Vec<f64>,
    /// `[n_stages][dim]`: rigid translation reached at the end of each stage (linear in a stage),
    /// applied with the rotation: `x = center + t + R (X - center)`, so the axis moves with the
    /// set (a rim pressed down, then twisted). Default: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    #[schemars(extend("x-unit" = "length"))]
    pub translation: Vec<Vec<f64>>,
    /// The rotation is prescribed but the translation is free: the set moves rigidly, as a rigid
    /// end loaded by a pure moment (the peeling strip's end, which must lift as the strip peels).
    /// Its nodes share the unknowns of one node; the reaction force on the set is zero and its
    /// reaction moment is the applied moment. Excludes `translation`. Default: false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub free_translation: bool,
}

/// `kind = "radial"`: the nodes move radially and along an axis, never around it: the
/// circumferential component of their displacement about `axis` through `center` is zero (a skew
/// condition, `e_theta . u = 0` at each node, in every stage). A base that may expand about its
/// centre but neither turn nor (with the other nodes) translate. Nodes on the axis are left free.
/// Combine with `fixed` on the axial component to stop the set moving along the axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RadialBc {
    /// Name of a `[bodies.*]` table.
    pub body: String,
    /// A node set (or the nodes of a face set) of the body.
    pub set: String,
    /// The axis, 3D only (2D: the out-of-plane axis); need not be normalised, must be non-zero.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// `[dim]`: a point on the axis.
    #[schemars(extend("x-unit" = "length"))]
    pub center: Vec<f64>,
}

/// `kind = "sliding"`: the nodes slide on a plane with normal `normal`: their displacement along
/// it is zero (a skew condition, `n . u = 0`, in every stage; a roller on an inclined support).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SlidingBc {
    /// Name of a `[bodies.*]` table.
    pub body: String,
    /// A node set (or the nodes of a face set) of the body.
    pub set: String,
    /// `[dim]`: the normal; need not be normalised, must be non-zero.
    pub normal: Vec<f64>,
}

/// `[[ties]]`: periodic tie of a slave node set to a master node set of one body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TieSpec {
    /// Name of a `[bodies.*]` table.
    pub body: String,
    /// The master node set (or the nodes of a face set).
    pub master: String,
    /// The slave node set (or the nodes of a face set), tied to the master one.
    pub slave: String,
    /// `[dim]`: slave node `x_s` matches master node `x_m` where `x_s - offset == x_m`.
    #[schemars(extend("x-unit" = "length"))]
    pub offset: Vec<f64>,
    /// Absolute matching tolerance on coordinates. Default: 1e-8.
    #[serde(default = "default_tie_tolerance")]
    #[schemars(extend("x-unit" = "length"))]
    pub tolerance: f64,
}

fn default_tie_tolerance() -> f64 {
    1e-8
}

/// `[[stages]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StageSpec {
    /// Name of the stage, used in messages about it.
    pub name: String,
    /// Number of equal load increments in this stage, > 0 (cutback may subdivide them).
    #[schemars(range(min = 1))]
    pub steps: usize,
}

/// `[steps]`: cutback control.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StepControl {
    /// Halvings of one increment before the run fails. Default: 8.
    #[serde(default = "default_max_cutbacks")]
    pub max_cutbacks: u32,
    /// Factor (>= 1) by which a cut increment grows back after an easy step. Default: 1.5.
    #[serde(default = "default_growth")]
    #[schemars(range(min = 1))]
    pub growth: f64,
    /// A step converging in at most this many Newton iterations is easy. Default: 4.
    #[serde(default = "default_easy_iterations")]
    pub easy_iterations: u32,
    /// Pseudo-transient rescue of a step that fails at the smallest increment (a snap-through, e.g.
    /// a peeling front jumping): at that load, up to this many damped solves (a viscous term
    /// `c D (u - u_prev)`, `D` the diagonal of the element stiffness) let the state flow towards
    /// the next equilibrium; an undamped Newton solve is tried once the flow slows down past the
    /// snap (or has nearly stopped), and the step is accepted only when an undamped solve
    /// converges, so accepted states are equilibria. 0 disables it.
    /// Default: 200.
    #[serde(default = "default_pseudo_steps")]
    pub pseudo_steps: u32,
}

fn default_max_cutbacks() -> u32 {
    8
}
fn default_growth() -> f64 {
    1.5
}
fn default_easy_iterations() -> u32 {
    4
}
fn default_pseudo_steps() -> u32 {
    200
}

impl Default for StepControl {
    fn default() -> Self {
        StepControl {
            max_cutbacks: default_max_cutbacks(),
            growth: default_growth(),
            easy_iterations: default_easy_iterations(),
            pseudo_steps: default_pseudo_steps(),
        }
    }
}

/// `[solver]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SolverOptions {
    /// Passed verbatim to the PETSc options database after the code's defaults (newtonls + MUMPS), so
    /// these win. Default: empty.
    #[serde(default)]
    pub petsc_options: String,
    /// Contact: the sparsity pattern reserves, around each contact point's partner element, the
    /// elements this many side-neighbour steps away, and is rebuilt (between Newton solves) only
    /// when a point needs an element outside it. 0 reserves exactly the current couplings. Default: 1.
    #[serde(default = "default_contact_pattern_ring")]
    pub contact_pattern_ring: usize,
    /// Stop a Newton solve early when its best residual norm has not fallen by 10 % within this
    /// many iterations (a solve cycling at the kink of a penalty law, or creeping): the step is cut
    /// back at once instead of after the iteration limit (30). 0 disables it. Default: 10
    /// (docs/user-guide/solvers.md, "Newton with contact").
    #[serde(default = "default_stagnation_window")]
    pub stagnation_window: usize,
    /// The linear solver of the Newton iterations: `"direct"` (MUMPS LU), `"iterative"` (GMRES
    /// preconditioned by PETSc's algebraic multigrid GAMG, with each body's rigid-body modes; a
    /// Krylov solve that fails retries the step with MUMPS) or `"auto"` (iterative from
    /// [`crate::scene::size::AUTO_ITERATIVE_UNKNOWNS`] unknowns on, direct below). Default:
    /// `"direct"`. Not given, the `-ksp_type`/`-pc_type` options decide as before (no
    /// contradiction is checked); given, they must agree with it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear: Option<LinearSolver>,
    /// How the cells are split between MPI ranks (METIS k-way on the cells' face graph):
    /// `"contact"` balances the cells and the contact quadrature points of the cells whose contact
    /// surfaces face a partner (within the pair's search distance in the reference
    /// configuration; every point when none does), where the contact work is, and joins facing
    /// cells, so that facing pieces stay on one rank where the balance allows;
    /// `"points"` balances cells and contact points without the joins; `"cells"` balances the
    /// cells alone. Measured in docs/performance/contact.md, "Contact data per rank". Results agree to round-off on every one. Default: `"contact"`.
    #[serde(default)]
    pub partition: PartitionKind,
    /// Contact: a state in which a contact point penetrates its partner by more than this length
    /// is outside the problem's domain, like an inverted element: Newton's line search shortens a
    /// step that goes deeper (the first iterate of a press step, which lifts the whole increment
    /// into the partner before any contact force acts), and a step whose converged state would be
    /// deeper is cut back. Choose it several times the penetration the penalty gives at the
    /// solution. Default: none (docs/user-guide/solvers.md, "Newton with contact").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length"))]
    pub max_penetration: Option<f64>,
    /// The iterative route: a Krylov solve stopped by its iteration limit (`-ksp_max_it`) whose
    /// true residual `|b - A x|` is at most this fraction of `|b|` is taken as an inexact Newton
    /// direction (forcing term) instead of a failed linear solve (which retries the attempt with
    /// MUMPS); Newton's own residual still decides convergence. 0 disables it (every solve that
    /// reaches the limit fails). In [0, 1). Default: 1e-3 (docs/user-guide/solvers.md,
    /// "Iterative linear solver").
    #[serde(default = "default_krylov_accept")]
    #[schemars(range(min = 0), extend("exclusiveMaximum" = 1))]
    pub krylov_accept: f64,
    /// Where Newton starts a load step: `"none"` (the last converged state; its first iteration
    /// lifts the new boundary values into the interior through the tangent) or `"secant"` (the
    /// last converged state extrapolated along the last step of the same stage, `u_n + r (u_n -
    /// u_{n-1})`, `r` the ratio of the increments; a predicted start that fails is retried from
    /// the converged state at the same increment, not cut back; once more than a fifth of at
    /// least 8 predicted starts of a stage have failed, the rest of the stage starts from the
    /// converged state). It pays in steady sliding,
    /// where each step moves the deformed state along (ironing at mesh 16, one-pass weighted gap: 16 %
    /// less time; peeling 36 %); where the pressure oscillates from step to step (two-half-pass
    /// pointwise Q1N2 at mesh 4) predicted starts fail every few steps and the stage gives it up
    /// (docs/user-guide/solvers.md, "Newton with contact"). The first
    /// step of a stage starts from the converged state; a restart continues the predictor
    /// exactly (checkpoints keep the state before the last). Default: `"secant"`.
    #[serde(default, skip_serializing_if = "Predictor::is_default")]
    #[schemars(extend("default" = "secant"))]
    pub predictor: Predictor,
    /// The fraction of the first Newton update of each solve (each attempt of a load step) that
    /// is taken, in (0, 1]; the later updates are taken whole (after the line search). From the
    /// last converged state a press step's first update carries the new boundary values into
    /// the body with only the contact points already in contact stiff, so every point that the
    /// rigidly moved surface would pass enters contact; against a curved partner that set is
    /// too large (a quadratic profile's interpenetration covers about twice the contact area of
    /// a sphere's Hertz contact), and a stiff penalty gives the excess back about one ring of
    /// points per iteration. Half the first update starts from a set near the converged one:
    /// with `predictor = "none"` the 3D Hertz case takes 4 / 5 / 5 Newton iterations instead of
    /// 9 / 10 / 9 (docs/verification/hertz.md, "Newton iterations per load step"); the 2D Hertz
    /// and ironing cases take more. The converged state is the same to the solver's tolerance.
    /// Default: 1 (the whole update).
    #[serde(default = "default_first_update")]
    #[schemars(extend("exclusiveMinimum" = 0), range(max = 1))]
    pub first_update: f64,
    /// The iterative route's preconditioner: `"gamg"` (PETSc's algebraic multigrid, or what the
    /// `-pc_type` option chooses), `"gamg_interface"` (GAMG, then an exact MUMPS solve on the
    /// unknowns of the contact interface: both sides of every surface element with a point on
    /// or near its partner and that partner element, and one layer of their neighbours; the
    /// same as `"gamg"` without contact) or `"gamg_interface_symmetric"` (the same, then GAMG
    /// once more on the residual left). Ignored by the direct route. Default: `"gamg"`
    /// (docs/performance/scale.md, "Preconditioners on the contact tangent").
    #[serde(default, skip_serializing_if = "Preconditioner::is_default")]
    #[schemars(extend("default" = "gamg"))]
    pub preconditioner: Preconditioner,
}

/// `[solver] preconditioner`: the iterative route's preconditioner.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Preconditioner {
    /// The PC the options choose (`-pc_type gamg` by default).
    #[default]
    Gamg,
    /// GAMG followed by an exact solve on the contact interface's unknowns.
    GamgInterface,
    /// As `GamgInterface`, then GAMG once more on the residual left (the symmetric form).
    GamgInterfaceSymmetric,
}

impl Preconditioner {
    fn is_default(&self) -> bool {
        *self == Preconditioner::default()
    }
}

/// `[solver] predictor`: where Newton starts a load step.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Predictor {
    /// The last converged state.
    None,
    /// The last converged state extrapolated along the last step of the stage.
    #[default]
    Secant,
}

impl Predictor {
    fn is_default(&self) -> bool {
        *self == Predictor::default()
    }
}

/// `[solver] partition`: what METIS balances and keeps together.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum PartitionKind {
    /// Cells and contact points balanced; facing contact cells joined in the graph.
    #[default]
    Contact,
    /// Cells and contact points balanced on the face graph alone.
    Points,
    /// Cells balanced on the face graph alone.
    Cells,
}

impl PartitionKind {
    /// The name in the case file.
    pub fn name(self) -> &'static str {
        match self {
            PartitionKind::Contact => "contact",
            PartitionKind::Points => "points",
            PartitionKind::Cells => "cells",
        }
    }
}

impl SolverOptions {
    /// `linear`, or its default `"direct"`.
    pub fn linear_setting(&self) -> LinearSolver {
        self.linear.unwrap_or_default()
    }
}

/// `[solver] linear`: which linear solver the Newton iterations use.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum LinearSolver {
    /// MUMPS LU (`-ksp_type preonly -pc_type lu`).
    #[default]
    Direct,
    /// GMRES + GAMG with the rigid-body modes as near-null space; MUMPS as fallback.
    Iterative,
    /// Iterative from [`crate::scene::size::AUTO_ITERATIVE_UNKNOWNS`] unknowns on, else direct.
    Auto,
}

impl LinearSolver {
    /// The route that runs for `unknowns` unknowns: `Direct` or `Iterative` (never `Auto`).
    pub fn resolve(self, unknowns: f64) -> LinearSolver {
        match self {
            LinearSolver::Auto if unknowns >= crate::scene::size::AUTO_ITERATIVE_UNKNOWNS => {
                LinearSolver::Iterative
            }
            LinearSolver::Auto => LinearSolver::Direct,
            r => r,
        }
    }

    /// The name in the case file.
    pub fn name(self) -> &'static str {
        match self {
            LinearSolver::Direct => "direct",
            LinearSolver::Iterative => "iterative",
            LinearSolver::Auto => "auto",
        }
    }
}

fn default_contact_pattern_ring() -> usize {
    1
}

fn default_stagnation_window() -> usize {
    10
}

fn default_krylov_accept() -> f64 {
    1e-3
}

fn default_first_update() -> f64 {
    1.0
}

impl Default for SolverOptions {
    fn default() -> Self {
        SolverOptions {
            petsc_options: String::new(),
            contact_pattern_ring: default_contact_pattern_ring(),
            stagnation_window: default_stagnation_window(),
            linear: None,
            partition: PartitionKind::default(),
            max_penetration: None,
            krylov_accept: default_krylov_accept(),
            predictor: Predictor::default(),
            first_update: default_first_update(),
            preconditioner: Preconditioner::default(),
        }
    }
}

/// `[output]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Write every n-th converged step (> 0); the last step is always written. Default: 1.
    #[serde(default = "default_every")]
    #[schemars(range(min = 1))]
    pub every: usize,
    /// Fields written to results.h5. Default: `["displacement"]`.
    #[serde(default = "default_fields")]
    pub fields: Vec<OutputField>,
    /// Node sets whose reaction force sums go to history.csv. Default: none.
    #[serde(default)]
    pub reactions: Vec<ReactionSpec>,
    /// Pictures of the run beside its results (`history.png`, `moments.png` with moments,
    /// `deformed.png`; SVG sources too), made from history.csv and results.h5 when the run ends
    /// (see `crate::io::plots`). Default: true.
    #[serde(default = "default_plots")]
    pub plots: bool,
}

fn default_plots() -> bool {
    true
}

fn default_every() -> usize {
    1
}
fn default_fields() -> Vec<OutputField> {
    vec![OutputField::Displacement]
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            every: default_every(),
            fields: default_fields(),
            reactions: Vec::new(),
            plots: default_plots(),
        }
    }
}

/// Known output fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
pub enum OutputField {
    /// Point field, `[n_nodes][3]`.
    #[serde(rename = "displacement")]
    Displacement,
    /// Cell field: first stress invariant `tr(sigma) / E` averaged over the cell (as in the paper's figures).
    #[serde(rename = "I1")]
    I1,
    /// Cell field: von Mises stress averaged over the cell.
    #[serde(rename = "von_mises")]
    VonMises,
    /// Cell field: owning MPI rank.
    #[serde(rename = "rank")]
    Rank,
}

impl OutputField {
    /// The name used in the case file and as the dataset name.
    pub fn name(self) -> &'static str {
        match self {
            OutputField::Displacement => "displacement",
            OutputField::I1 => "I1",
            OutputField::VonMises => "von_mises",
            OutputField::Rank => "rank",
        }
    }
}

/// `{ body = "...", set = "..." }` in `output.reactions`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ReactionSpec {
    /// Name of a `[bodies.*]` table.
    pub body: String,
    /// A node set (or the nodes of a face set) of the body whose reaction forces are summed.
    pub set: String,
    /// `[dim]`: also report the moment of the reaction forces about this point (2D: about the z
    /// axis through it; 3D: the moment vector), from the nodes' current positions: the peeling
    /// moment at a rotated end, the torque on a twisted rim. Default: no moment.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-unit" = "length"))]
    pub moment_about: Option<Vec<f64>>,
}

/// Deserialise `T` from a table taken out of a tagged table, carrying the inner key path up in the
/// message (see [`crate::scene::keypath`]).
fn from_table<T: DeserializeOwned, E: de::Error>(table: toml::Table) -> Result<T, E> {
    T::deserialize(toml::Value::Table(table)).map_err(|e| {
        let (message, path) = split_toml_error(&e);
        E::custom(nest_message(&message, path.as_deref()))
    })
}

/// Remove the string tag `tag` from `table`; `what` lists the accepted names for the error.
fn take_tag<E: de::Error>(table: &mut toml::Table, tag: &str, what: &[&str]) -> Result<String, E> {
    match table.remove(tag) {
        Some(toml::Value::String(s)) => Ok(s),
        Some(other) => Err(E::custom(nest_message(
            &format!(
                "invalid type: {}, expected a string, one of {}",
                other.type_str(),
                what.join(", ")
            ),
            Some(tag),
        ))),
        None => Err(E::custom(format!("missing field `{tag}`"))),
    }
}

impl<'de> Deserialize<'de> for MeshSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut table = toml::Table::deserialize(d)?;
        match (table.contains_key("generator"), table.contains_key("file")) {
            (true, true) => Err(de::Error::custom(
                "give exactly one of `generator` or `file`, not both",
            )),
            (false, false) => Err(de::Error::custom(
                "missing field `generator` (or `file`): give exactly one of them",
            )),
            (false, true) => from_table(table).map(MeshSpec::File),
            (true, false) => {
                let name = take_tag(&mut table, "generator", &Generator::NAMES)?;
                let g = match name.as_str() {
                    "rectangle" => Generator::Rectangle(from_table(table)?),
                    "half_disk" => Generator::HalfDisk(from_table(table)?),
                    "sector" => Generator::Sector(from_table(table)?),
                    "box" => Generator::Box(from_table(table)?),
                    "hemisphere" => Generator::Hemisphere(from_table(table)?),
                    "hemisphere_nurbs" => Generator::HemisphereNurbs(from_table(table)?),
                    "quarter_sphere" => Generator::QuarterSphere(from_table(table)?),
                    "sphere_cap" => Generator::SphereCap(from_table(table)?),
                    other => {
                        return Err(de::Error::custom(nest_message(
                            &format!(
                                "unknown generator `{other}`, expected one of {}",
                                Generator::NAMES.join(", ")
                            ),
                            Some("generator"),
                        )))
                    }
                };
                Ok(MeshSpec::Generated(g))
            }
        }
    }
}

impl<'de> Deserialize<'de> for BcSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut table = toml::Table::deserialize(d)?;
        let kind = take_tag(&mut table, "kind", &BcSpec::KINDS)?;
        match kind.as_str() {
            "fixed" => from_table(table).map(BcSpec::Fixed),
            "displacement" => from_table(table).map(BcSpec::Displacement),
            "rotation" => from_table(table).map(BcSpec::Rotation),
            "radial" => from_table(table).map(BcSpec::Radial),
            "sliding" => from_table(table).map(BcSpec::Sliding),
            other => Err(de::Error::custom(nest_message(
                &format!(
                    "unknown kind `{other}`, expected one of {}",
                    BcSpec::KINDS.join(", ")
                ),
                Some("kind"),
            ))),
        }
    }
}
