//! Assembly cost per element (residual + tangent) of the linear Q1C1 elements and of the enriched
//! elements of the half-cylinder case (docs/performance/contact.md):
//!
//! ```text
//! cargo run --release --example enriched_assembly_cost -- [n_arc] [repeats]
//! ```
//! For each family the case's model is built with `n_arc` (default 64) elements along the arc, and
//! every element of the body is evaluated `repeats` (default 200) times at a small displacement;
//! the mean time per evaluation is reported separately for linear and enriched cells.
use nurbs_contact::model::Model;
use nurbs_contact::scene::load_case;
use std::path::Path;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let n_arc: usize = args.get(1).map_or(Ok(64), |s| s.parse())?;
    let repeats: usize = args.get(2).map_or(Ok(200), |s| s.parse())?;
    let case_file = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/half_cylinder_press_2d.toml");
    println!("family   cell kind  nodes  qp  elements  us/element (residual + tangent)");
    for family in ["Q1C1", "Q1N2", "Q1N2.1", "Q1N3", "Q1C2", "Q1CH"] {
        let sets = [
            format!("bodies.disk.element={family}"),
            format!("meshes.disk.n_arc={n_arc}"),
            format!("meshes.disk.n_radial={}", (n_arc / 4).max(1)),
        ];
        let case = load_case(&case_file, &sets)?;
        let model = Model::build(&case)?;
        let mut el_sets = model.element_sets(&case.file, &vec![0; model.n_cells()], 0)?;
        let body = &model.bodies[0];
        for enriched in [false, true] {
            let (mut time, mut count, mut nodes, mut nqp) = (0.0, 0usize, 0, 0);
            for s in el_sets.iter_mut() {
                for e in 0..s.len() {
                    let (_, cell) = s.cell_id(e);
                    if body.enriched_cell(cell).is_some() != enriched {
                        continue;
                    }
                    let nd = s.nodes(e).len() * model.dim;
                    let u: Vec<f64> = (0..nd)
                        .map(|i| 1e-3 * ((i * 7 % 11) as f64 - 5.0))
                        .collect();
                    let (mut r, mut k) = (vec![0.0; nd], vec![0.0; nd * nd]);
                    let t0 = Instant::now();
                    for _ in 0..repeats {
                        s.evaluate(e, &u, &mut r, Some(&mut k))?;
                    }
                    time += t0.elapsed().as_secs_f64();
                    count += repeats;
                    nodes = s.nodes(e).len();
                    nqp = body
                        .enriched_cell(cell)
                        .map_or(4, |c| c.quadrature_counts().iter().product());
                }
            }
            if count > 0 {
                println!(
                    "{family:<8} {:<10} {nodes:>5} {nqp:>3} {:>9} {:>10.3}",
                    if enriched { "enriched" } else { "linear" },
                    count / repeats,
                    1e6 * time / count as f64
                );
            }
        }
    }
    Ok(())
}
