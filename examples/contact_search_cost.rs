//! Cost of the global contact search against the size of the partner surface (docs/performance/contact.md):
//!
//! ```text
//! cargo run --release --example contact_search_cost -- [sizes...]   (default 16 32 64 128)
//! ```
//! For each size n, the top face of a box with n x n x 1 elements (Q1C1, and Q1N2) is the partner
//! surface; every quadrature point of a second, shifted and slightly lifted n x n surface is
//! searched for (bin grid of the partner's element boxes, nearest boxes first, Newton projection).
//! The grid is the one a run builds (`surface_grid`: element boxes from the control points).
//! Reported: building the grid, searching all points (per point), and for n <= 32 the brute force
//! (every element projected) for comparison.
use nurbs_contact::contact::projection::{
    global_search, project_on_element, surface_grid, Positions,
};
use nurbs_contact::contact::surface::{reference_positions, ContactSurface};
use nurbs_contact::model::Model;
use nurbs_contact::scene::parse_case;
use std::path::Path;
use std::time::Instant;

fn case(n: usize, family: &str) -> String {
    format!(
        r#"
[case]
name = "search"
dim = 3
[meshes.m]
generator = "box"
origin = [0.0, 0.0, -1.0]
size = [1.0, 1.0, 1.0]
divisions = [{n}, {n}, 1]
[bodies.b]
mesh = "m"
element = "{family}"
enriched_surface = "zmax"
[bodies.b.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[[stages]]
name = "s"
steps = 1
"#
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let sizes = if args.is_empty() {
        vec![16, 32, 64, 128]
    } else {
        args
    };
    println!("| family | n | elements | points | grid build ms | search us/point | brute force us/point |");
    println!("|---|---|---|---|---|---|---|");
    for family in ["Q1C1", "Q1N2"] {
        for &n in &sizes {
            let c = parse_case(&case(n, family), Path::new("search.toml"), &[])?;
            let model = Model::build(&c)?;
            let s = ContactSurface::build(&model.bodies[0].surface_body(0), "zmax", &model.coords)
                .map_err(|e| e.0)?;
            let mut pos = Positions::default();
            pos.offsets.push(0);
            for e in &s.elements {
                pos.x
                    .extend(reference_positions(&model.coords, model.dim, &e.nodes));
                pos.offsets.push(pos.x.len());
            }
            // query points: 3 x 3 per element, shifted by a third of an element and lifted by 0.1 h
            let h = 1.0 / n as f64;
            let mut pts = Vec::new();
            for j in 0..3 * n {
                for i in 0..3 * n {
                    pts.push([
                        (i as f64 + 0.5) / (3 * n) as f64 + h / 3.0,
                        (j as f64 + 0.5) / (3 * n) as f64,
                        0.1 * h,
                    ]);
                }
            }
            let dist = 2.0 * h;
            let t0 = Instant::now();
            let grid = surface_grid(&s, &pos, dist);
            let t_build = t0.elapsed().as_secs_f64();
            let mut scratch = Vec::new();
            let t1 = Instant::now();
            let mut found = 0;
            for x in &pts {
                if let Ok(Some(p)) = global_search(&s, &pos, &grid, x, &mut scratch) {
                    found += (p.dist < dist) as usize;
                }
            }
            let t_search = t1.elapsed().as_secs_f64() / pts.len() as f64;
            assert!(found > pts.len() / 2, "most points find their partner");
            let brute = if n <= 32 {
                let t2 = Instant::now();
                for x in &pts {
                    let mut best = f64::MAX;
                    for e in 0..s.elements.len() {
                        if let Some(p) = project_on_element(&s, &pos, e, x, [0.0; 2]) {
                            best = best.min(p.dist);
                        }
                    }
                    std::hint::black_box(best);
                }
                format!("{:.2}", 1e6 * t2.elapsed().as_secs_f64() / pts.len() as f64)
            } else {
                "-".to_string()
            };
            println!(
                "| {family} | {n} | {} | {} | {:.2} | {:.2} | {brute} |",
                s.elements.len(),
                pts.len(),
                1e3 * t_build,
                1e6 * t_search
            );
        }
    }
    Ok(())
}
