//! Choosing and creating a backend.

use crate::cuda::{CudaOptions, CudaRanks, CudaSolver};
use crate::dist::CpuRanks;
use crate::sim::cpu::CpuSolver;
use crate::sim::cpu_parallel::ParallelCpuSolver;
use crate::sim::flow::{FlowState, Lifecycle};
use crate::sim::{Particles, Scene, Solver};
use anyhow::{bail, ensure, Result};

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

impl BackendKind {
    /// The backend a solver of this [`Solver::name`] is, `None` for an unknown name.
    pub fn of_solver(name: &str) -> Option<BackendKind> {
        match name {
            "cpu" => Some(BackendKind::Cpu),
            "cpu-parallel" => Some(BackendKind::CpuParallel),
            "cuda" => Some(BackendKind::Cuda),
            _ => None,
        }
    }
}

impl BackendKind {
    /// `Auto` made concrete for a caller that needs to know which backend runs (`mpm bench`): CUDA
    /// where a device works, else cpu-parallel, saying why on stderr; any other kind as it is.
    pub fn resolve(self) -> BackendKind {
        if self != BackendKind::Auto {
            return self;
        }
        match crate::cuda::library::device_available() {
            Ok(()) => BackendKind::Cuda,
            Err(why) => {
                eprintln!(
                    "note: no usable CUDA device ({why:#}); timing the CPU on {} (cpu-parallel)",
                    crate::text::count(ParallelCpuSolver::threads(), "thread", "threads")
                );
                BackendKind::CpuParallel
            }
        }
    }
}

/// Spawns the scene's particles on the chosen backend. `Auto` falls back to the multi-threaded CPU
/// backend with a one-line notice on stderr when CUDA is unavailable; `Cuda` reports why it is.
pub fn create(kind: BackendKind, scene: &Scene) -> Result<Box<dyn Solver>> {
    create_with(kind, scene, None)
}

/// [`create`] with `particles` and the emitters' and sinks' state (a checkpoint's) in place of the
/// scene's start.
pub fn restore(
    kind: BackendKind,
    scene: &Scene,
    particles: &Particles,
    flow: Option<&FlowState>,
) -> Result<Box<dyn Solver>> {
    create_with(kind, scene, Some((particles, flow)))
}

fn create_with(
    kind: BackendKind,
    scene: &Scene,
    state: Option<(&Particles, Option<&FlowState>)>,
) -> Result<Box<dyn Solver>> {
    if matches!(kind, BackendKind::Cuda | BackendKind::Auto) {
        // Refused here rather than falling back to the CPU: the user asked for the report's kernels.
        scene.check_pipeline()?;
    }
    let initial = || state.map_or_else(|| scene.spawn(), |(p, _)| p.clone());
    if scene.ranks > 1 {
        return create_ranks(kind, scene, initial);
    }
    // The emitters' and sinks' state: a checkpoint's, or a fresh run's start.
    let lifecycle = || {
        scene.flow.is_active().then(|| {
            let flow_state = match state {
                Some((_, Some(flow_state))) => flow_state.clone(),
                _ => FlowState::start(&scene.flow, scene.num_particles),
            };
            Lifecycle::new(scene, flow_state)
        })
    };
    let parallel = || -> Box<dyn Solver> {
        Box::new(ParallelCpuSolver::new(initial(), scene.grid_res).with_lifecycle(lifecycle()))
    };
    let cuda = |options: CudaOptions| match state {
        Some((particles, flow)) => CudaSolver::restore(scene, particles, flow, options),
        None => CudaSolver::new(scene, options),
    };
    match kind {
        BackendKind::Cpu => Ok(Box::new(
            CpuSolver::new(initial(), scene.grid_res).with_lifecycle(lifecycle()),
        )),
        BackendKind::CpuParallel => Ok(parallel()),
        BackendKind::Cuda => Ok(Box::new(cuda(CudaOptions::from_env()?)?)),
        BackendKind::Auto => match CudaOptions::from_env().and_then(cuda) {
            Ok(solver) => Ok(Box::new(solver)),
            Err(why) => {
                let why = format!("{why:#}");
                let first_line = why.lines().next().unwrap_or_default();
                eprintln!(
                    "note: CUDA backend unavailable ({first_line}); using the CPU on {} (cpu-parallel)",
                    crate::text::count(ParallelCpuSolver::threads(), "thread", "threads")
                );
                Ok(parallel())
            }
        },
    }
}

/// A run split into `scene.ranks` ranks (`crate::dist`) of `particles`: CUDA solvers (on one device,
/// or one per GPU with `scene.gpus`; `auto` asks for them too, with no CPU fallback) or the CPU
/// reference's thread ranks.
fn create_ranks(
    kind: BackendKind,
    scene: &Scene,
    particles: impl FnOnce() -> Particles,
) -> Result<Box<dyn Solver>> {
    let ranks = scene.ranks;
    ensure!(
        scene.gpus <= 1 || matches!(kind, BackendKind::Cuda | BackendKind::Auto),
        "--gpus {}: several GPUs run the CUDA backend; use --backend cuda, or split the CPU \
         reference with --ranks",
        scene.gpus
    );
    match kind {
        BackendKind::Cuda | BackendKind::Auto => {
            let options = CudaOptions::from_env()?;
            CudaRanks::check_gpus(scene)?;
            Ok(Box::new(CudaRanks::new(scene, particles(), ranks, options)?))
        }
        BackendKind::Cpu => Ok(Box::new(CpuRanks::new(scene, particles(), ranks)?)),
        BackendKind::CpuParallel => bail!(
            "--ranks {ranks}: the cpu-parallel backend runs on one rank; drop --ranks, or split the \
             single-thread reference (--backend cpu) or the CUDA backend (--backend cuda)"
        ),
    }
}
