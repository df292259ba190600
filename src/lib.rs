pub mod assembly;
pub mod fem;
pub mod geometry;
pub mod material;
pub mod mesh;
pub mod parallel;
pub mod petsc;
pub mod solver;
