//! Example case files: templates for users and fixtures for the tests of this module.

/// 3D block compressed by a prescribed top displacement, bottom fixed.
pub const BLOCK_COMPRESSION_3D: &str = r#"
[case]
name = "block_compression_3d"
description = "Unit cube, bottom fixed, top pushed down by 20 %"
dim = 3

[meshes.block]
generator = "box"
origin = [0.0, 0.0, 0.0]
size = [1.0, 1.0, 1.0]
divisions = [4, 4, 4]

[bodies.block]
mesh = "block"
element = "Q1C1"
[bodies.block.material]
model = "neo_hookean"
E = 1.0
nu = 0.3

[[bcs]]
body = "block"
set = "zmin"
kind = "fixed"

[[bcs]]
body = "block"
set = "zmax"
kind = "displacement"
components = ["z"]
value = [[-0.2]]

[[stages]]
name = "compress"
steps = 5

[solver]
petsc_options = "-snes_rtol 1e-10 -snes_atol 1e-12"

[output]
every = 1
fields = ["displacement", "I1", "von_mises", "rank"]
reactions = [{ body = "block", set = "zmin" }]
"#;

/// 2D cantilever strip with Q1E4 elements, clamped left, bent by a rotation of its free right end.
pub const STRIP_BENDING_2D: &str = r#"
[case]
name = "strip_bending_2d"
description = "Strip 20 x 1, clamped at x = 0, right end rotated by 90 degrees in two stages"
dim = 2

[meshes.strip]
generator = "rectangle"
origin = [0.0, 0.0]
size = [20.0, 1.0]
divisions = [40, 2]

[bodies.strip]
mesh = "strip"
element = "Q1E4"
[bodies.strip.material]
model = "neo_hookean"
E = 1.0
nu = 0.2

[[bcs]]
body = "strip"
set = "xmin"
kind = "fixed"
components = ["x", "y"]

[[bcs]]
body = "strip"
set = "xmax"
kind = "rotation"
center = [20.0, 0.5]
angle_deg = [45.0, 90.0]

[[stages]]
name = "bend_half"
steps = 10

[[stages]]
name = "bend_full"
steps = 10

[steps]
max_cutbacks = 6

[output]
fields = ["displacement", "I1"]
reactions = [{ body = "strip", set = "xmax" }]
"#;

/// Ironing skeleton (section 4.1 of Corbett & Sauer 2014): a Q1N2.1-enriched half cylinder pressed
/// into a periodic block, then slid. Contact pairs are not in the schema yet.
pub const IRONING_2D: &str = r#"
[case]
name = "ironing_2d"
description = "Half cylinder (E1 = 3 E0) pressed 2/3 L0 into a periodic block (E2 = E0), then slid"
dim = 2

[meshes.block]
generator = "rectangle"
origin = [0.0, 0.0]
size = [10.0, 2.0]
divisions = [40, 8]

[meshes.cylinder]
generator = "half_disk"
center = [2.0, 3.0]
radius = 1.0
n_arc = 16
n_radial = 4

[bodies.block]
mesh = "block"
element = "Q1N2"
enriched_surface = "ymax"
[bodies.block.material]
model = "neo_hookean"
E = 1.0
nu = 0.3

[bodies.cylinder]
mesh = "cylinder"
element = "Q1N2.1"
enriched_surface = "arc"
[bodies.cylinder.material]
model = "neo_hookean"
E = 3.0
nu = 0.3

[[bcs]]
body = "block"
set = "ymin"
kind = "fixed"

[[bcs]]
body = "cylinder"
set = "top"
kind = "displacement"
value = [[0.0, -1.6666666666666667], [6.0, -1.6666666666666667]]

[[ties]]
body = "block"
master = "xmin"
slave = "xmax"
offset = [10.0, 0.0]

[[stages]]
name = "press"
steps = 10

[[stages]]
name = "slide"
steps = 60

[output]
every = 2
fields = ["displacement", "I1", "rank"]
reactions = [{ body = "cylinder", set = "top" }, { body = "block", set = "ymin" }]
"#;
