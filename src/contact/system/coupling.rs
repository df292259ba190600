//! Contact pairs as the assembler's coupling set: the seam through which contact plugs into
//! assembly beside the element sets ([`crate::assembly::CouplingSet`]). The blocks are
//! [`Coupling`]s: a half-pass's surface element and its partner element.

use super::ContactSystem;
use crate::assembly::{Augment, Block, CouplingSet, MatrixSink, SlotOf};
use std::any::Any;

impl CouplingSet for ContactSystem {
    fn nodes(&self) -> &[u32] {
        self.table()
    }

    fn deepest(&self) -> Option<(f64, String)> {
        let mut out: Option<(f64, String)> = None;
        for pair in &self.pairs {
            for pass in &pair.passes {
                let d = pass.result.max_penetration;
                if d > 0.0 && out.as_ref().is_none_or(|(m, _)| d > *m) {
                    let what = format!(
                        "contact `{}`, a point of `{}`",
                        pair.def.name, self.surfaces[pass.k].name
                    );
                    out = Some((d, what));
                }
            }
        }
        out
    }

    fn set_load(&mut self, lambda: f64) {
        ContactSystem::set_load(self, lambda);
    }

    fn update(&mut self, u: &[f64]) -> Result<(), String> {
        ContactSystem::update(self, u)
    }

    fn needed_blocks(&self) -> Vec<Block> {
        self.couplings()
    }

    fn band_blocks(&mut self, ring: usize) -> Vec<Block> {
        self.band_couplings(ring)
    }

    fn owns_block(&self, &(pass, e, _): &Block) -> bool {
        self.integrates(pass, e)
    }

    fn check_block(&self, block: &Block) -> Result<(), String> {
        ContactSystem::check_block(self, block)
    }

    fn block_dofs(&self, block: &Block) -> (Vec<i32>, Vec<i32>) {
        ContactSystem::block_dofs(self, block)
    }

    fn interface_dofs(&self) -> Vec<i32> {
        ContactSystem::interface_dofs(self)
    }

    fn evaluate(&mut self, f_local: &mut [f64], jac: Option<(&mut dyn MatrixSink, &SlotOf)>) {
        self.assemble(f_local, jac);
    }

    fn node_residual(&self) -> Option<&[f64]> {
        self.has_one_pass().then(|| self.table_residual())
    }

    fn loaded_nodes(&self) -> Vec<u32> {
        ContactSystem::loaded_nodes(self)
    }

    fn commit(&mut self) {
        ContactSystem::commit(self);
    }

    fn commit_intermediate(&mut self) {
        self.commit_warm_starts();
    }

    fn rollback(&mut self) {
        ContactSystem::rollback(self);
    }

    fn augments(&self) -> bool {
        ContactSystem::augments(self)
    }

    fn augmentation_violations(&self) -> Vec<f64> {
        ContactSystem::augmentation_violations(self)
    }

    fn places_after_solve(&self) -> bool {
        ContactSystem::places_after_solve(self)
    }

    fn augment(&mut self, violations: &[f64], rounds: usize) -> Augment {
        ContactSystem::augment(self, violations, rounds)
    }

    fn ghost_status(&self) -> [u8; 2] {
        ContactSystem::ghost_status(self)
    }

    fn reach(&self) -> Vec<f64> {
        self.ghost_reach()
    }

    fn answer(&self, reach: &[f64]) -> Vec<u32> {
        self.ghost_answer(reach)
    }

    fn adopt(&mut self, answers: &[u32], moved: bool) {
        self.adopt_ghosts(answers, moved);
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}
