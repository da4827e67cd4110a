//! Choosing and creating a backend.

use crate::sim::cpu::CpuSolver;
use crate::sim::{Scene, Solver};
use anyhow::Result;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BackendKind {
    /// The best backend this machine has.
    Auto,
    /// The single-thread CPU reference.
    Cpu,
}

/// Spawns the scene's particles on the chosen backend.
pub fn create(kind: BackendKind, scene: &Scene) -> Result<Box<dyn Solver>> {
    match kind {
        BackendKind::Auto | BackendKind::Cpu => Ok(Box::new(CpuSolver::new(scene.spawn(), scene.grid_res))),
    }
}
