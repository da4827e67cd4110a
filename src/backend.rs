//! Choosing and creating a backend.

use crate::cuda::{CudaOptions, CudaSolver};
use crate::sim::cpu::CpuSolver;
use crate::sim::cpu_parallel::ParallelCpuSolver;
use crate::sim::{Scene, Solver};
use anyhow::Result;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BackendKind {
    /// The best backend this machine has: CUDA when a device works, else the multi-threaded CPU.
    Auto,
    /// The single-thread CPU reference (the baseline and the tests' oracle).
    Cpu,
    /// The CPU reference's math on every core (rayon; RAYON_NUM_THREADS sets the thread count).
    CpuParallel,
    /// The CUDA kernels (an NVIDIA GPU and driver needed).
    Cuda,
}

/// Spawns the scene's particles on the chosen backend. `Auto` falls back to the multi-threaded CPU
/// backend with a one-line notice on stderr when CUDA is unavailable; `Cuda` reports why it is.
pub fn create(kind: BackendKind, scene: &Scene) -> Result<Box<dyn Solver>> {
    if matches!(kind, BackendKind::Cuda | BackendKind::Auto) {
        // Refused here rather than falling back to the CPU: the user asked for the report's kernels.
        scene.check_pipeline()?;
    }
    let parallel = || -> Box<dyn Solver> { Box::new(ParallelCpuSolver::new(scene.spawn(), scene.grid_res)) };
    match kind {
        BackendKind::Cpu => Ok(Box::new(CpuSolver::new(scene.spawn(), scene.grid_res))),
        BackendKind::CpuParallel => Ok(parallel()),
        BackendKind::Cuda => Ok(Box::new(CudaSolver::new(scene, CudaOptions::from_env()?)?)),
        BackendKind::Auto => match CudaOptions::from_env().and_then(|o| CudaSolver::new(scene, o)) {
            Ok(solver) => Ok(Box::new(solver)),
            Err(why) => {
                let why = format!("{why:#}");
                let first_line = why.lines().next().unwrap_or_default();
                eprintln!(
                    "note: CUDA backend unavailable ({first_line}); using the CPU on {} threads \
                     (cpu-parallel)",
                    ParallelCpuSolver::threads()
                );
                Ok(parallel())
            }
        },
    }
}
