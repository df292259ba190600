//! Contact that is silently not there: the control points of a half-pass's surface that lie
//! inside its rigid partner while none of the half-pass's points is active (a smooth contact
//! surface lies inside its control points and may not reach a partner that the mesh goes
//! through; nothing then holds the body there).

use super::ContactSystem;

/// The deepest control point of this rank's elements of one rigid-partner half-pass inside its
/// partner, with the half-pass's active points on this rank ([`ContactSystem::unseen_penetrations`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PassDepth {
    /// The pair's name.
    pub pair: String,
    /// The half-pass's surface, `body.face_set`.
    pub surface: String,
    /// Active points of the half-pass on this rank.
    pub n_active: usize,
    /// Depth of the deepest control point inside the partner (0: none inside), its global node
    /// and current position [3].
    pub depth: f64,
    pub node: u32,
    pub position: [f64; 3],
    /// Mean element edge length of the surface.
    pub h: f64,
}

impl ContactSystem {
    /// Per half-pass against a rigid partner (in pair and pass order, the same list on every
    /// rank): the deepest control point of this rank's surface elements inside the partner at the
    /// last evaluation, and the half-pass's active points on this rank. The caller reduces them
    /// over the ranks.
    pub fn unseen_penetrations(&self) -> Vec<PassDepth> {
        let dim = self.dim;
        let mut out = Vec::new();
        for pair in &self.pairs {
            for pass in &pair.passes {
                let Some(shape) = &pass.shape else {
                    continue;
                };
                let surface = &self.surfaces[pass.k];
                let mut d = PassDepth {
                    pair: pair.def.name.clone(),
                    surface: surface.name.clone(),
                    n_active: pass.result.n_active,
                    depth: 0.0,
                    node: u32::MAX,
                    position: [0.0; 3],
                    h: surface.h,
                };
                for oe in &pass.elems {
                    let e = oe.e as usize;
                    if !self.pos[pass.k].has(e) {
                        continue;
                    }
                    let x = self.pos[pass.k].of(e);
                    for (a, &node) in surface.elements[e].nodes.iter().enumerate() {
                        let mut p = [0.0; 3];
                        p[..dim].copy_from_slice(&x[a * dim..(a + 1) * dim]);
                        let Some(proj) = shape.project(&p) else {
                            continue;
                        };
                        let g_n: f64 = (0..3).map(|c| proj.g[c] * proj.n[c]).sum();
                        if -g_n > d.depth {
                            d.depth = -g_n;
                            d.node = node;
                            d.position = p;
                        }
                    }
                }
                out.push(d);
            }
        }
        out
    }
}
