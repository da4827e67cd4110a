//! Choosing and creating a backend.

use crate::checkpoint::ParticlesInFile;
use crate::cuda::{CudaOptions, CudaRanks, CudaSolver};
use crate::dist::{CpuRanks, Start};
use crate::sim::colliders::bodies::{BodiesState, ContactFeature};
use crate::sim::cpu::CpuSolver;
use crate::sim::cpu_parallel::ParallelCpuSolver;
use crate::sim::flow::{FlowState, Lifecycle};
use crate::sim::pbmpm::{self, PbmpmSolver};
use crate::sim::{Method, Particles, Scene, Solver};
use anyhow::{bail, ensure, Result};
use std::borrow::Cow;

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
                    "note: no usable CUDA device ({}); timing the CPU on {} (cpu-parallel)",
                    no_cuda_reason(&why),
                    crate::text::count(ParallelCpuSolver::threads(), "thread", "threads")
                );
                BackendKind::CpuParallel
            }
        }
    }
}

/// Why CUDA is not usable, without the advice the CUDA module adds ("use --backend cpu-parallel"):
/// the notes that quote it already say what runs instead, and a refusal gives its own advice.
pub fn no_cuda_reason(why: &anyhow::Error) -> String {
    let text = format!("{why:#}");
    let line = text.lines().next().unwrap_or_default();
    line.split_once(". ")
        .map_or(line, |(first, _)| first)
        .trim_end_matches('.')
        .to_string()
}

/// `--ranks` and `--gpus` with `kind`, refused where they cannot run on this machine, with advice
/// that does run here: whether a CUDA device is usable decides which backends the advice names.
/// Checked before any work (`mpm bench` asks before its first table).
pub fn check_ranks(kind: BackendKind, ranks: usize, gpus: usize) -> Result<()> {
    if ranks <= 1 && gpus <= 1 {
        return Ok(());
    }
    let cuda = crate::cuda::library::device_available();
    let name = command_line_name(kind);
    let on_gpu = matches!(kind, BackendKind::Cuda | BackendKind::Auto);
    match (&cuda, on_gpu, gpus > 1) {
        (Ok(()), false, true) => bail!(
            "--gpus {gpus}: several GPUs run the CUDA backend; use --backend cuda, or split the CPU \
             reference with --backend cpu --ranks {gpus} in place of --gpus"
        ),
        (Err(why), _, true) => bail!(
            "--gpus {gpus}: several GPUs run the CUDA backend, and this machine has no usable CUDA \
             device ({}); {}, or split the CPU reference into thread ranks with --backend cpu \
             --ranks {gpus} in place of --gpus",
            no_cuda_reason(why),
            match kind {
                BackendKind::Cpu | BackendKind::CpuParallel => {
                    format!("drop --gpus to run the {name} backend as it is")
                }
                BackendKind::Auto => "drop --gpus to run on the CPU (cpu-parallel)".to_string(),
                BackendKind::Cuda => "run on the CPU with --backend cpu-parallel and no --gpus".to_string(),
            }
        ),
        (Err(why), true, false) => bail!(
            "--ranks {ranks} with the {name} backend splits the CUDA solver, and this machine has no \
             usable CUDA device ({}); split the CPU reference with --backend cpu --ranks {ranks}, or \
             drop --ranks{} to run on the CPU (cpu-parallel)",
            no_cuda_reason(why),
            if kind == BackendKind::Cuda {
                " and --backend cuda"
            } else {
                ""
            }
        ),
        (_, false, false) if kind == BackendKind::CpuParallel => bail!(
            "--ranks {ranks}: the cpu-parallel backend runs on one rank; drop --ranks, or split the \
             single-thread reference with --backend cpu --ranks {ranks}{}",
            if cuda.is_ok() {
                " or the CUDA backend with --backend cuda --ranks N"
            } else {
                ""
            }
        ),
        _ => Ok(()),
    }
}

/// The name the command line takes for `kind` (clap's, from the variant), so advice spells it as
/// typed.
fn command_line_name(kind: BackendKind) -> String {
    let value = clap::ValueEnum::to_possible_value(&kind).expect("every backend has a command-line name");
    value.get_name().to_string()
}

/// `--processes` (a rank in each of `processes` processes) with `kind`, refused where it cannot run
/// here, with advice that does: a CUDA rank each (`cuda`, or `auto` with a usable device), or the
/// CPU reference's (`cpu`); cpu-parallel steps one rank.
pub fn check_processes(kind: BackendKind, processes: usize) -> Result<()> {
    let name = command_line_name(kind);
    match kind {
        BackendKind::Cpu => Ok(()),
        BackendKind::CpuParallel => bail!(
            "--processes runs a rank in each process, and the {name} backend steps one rank: use \
             --backend cuda for a GPU each, or --backend cpu for the CPU reference's ranks"
        ),
        BackendKind::Cuda | BackendKind::Auto => match crate::cuda::library::device_available() {
            Ok(()) => Ok(()),
            Err(why) => bail!(
                "--processes with --backend {name} runs a CUDA rank in each process, and this \
                 machine has no usable CUDA device ({}); run the CPU reference's ranks as these \
                 processes with --backend cpu, or as threads of one process (no launcher) with \
                 --backend cpu --ranks {processes}",
                no_cuda_reason(&why)
            ),
        },
    }
}

/// Spawns the scene's particles on the chosen backend. `Auto` falls back to the multi-threaded CPU
/// backend with a one-line notice on stderr when CUDA is unavailable; `Cuda` reports why it is.
pub fn create(kind: BackendKind, scene: &Scene) -> Result<Box<dyn Solver>> {
    create_with(kind, scene, None)
}

/// What a solver restored from a checkpoint starts from in place of the scene's start.
#[derive(Debug, Clone, Copy)]
pub struct SavedState<'a> {
    pub particles: SavedParticles<'a>,
    /// The emitters' and sinks' state, where the scene has them.
    pub flow: Option<&'a FlowState>,
    /// The rigid bodies (none where the scene has none).
    pub bodies: &'a BodiesState,
}

/// A checkpoint's particles: read whole, or left in its file, from which the process of a rank
/// reads only its share (`Checkpoint::open`).
#[derive(Debug, Clone, Copy)]
pub enum SavedParticles<'a> {
    Read(&'a Particles),
    InFile(&'a ParticlesInFile),
}

impl<'a> SavedParticles<'a> {
    /// What ranks start from.
    fn start(self) -> &'a dyn Start {
        match self {
            SavedParticles::Read(particles) => particles,
            SavedParticles::InFile(particles) => particles,
        }
    }

    /// Every particle: a solver of one rank holds them all.
    fn whole(self) -> Result<Cow<'a, Particles>> {
        Ok(match self {
            SavedParticles::Read(particles) => Cow::Borrowed(particles),
            SavedParticles::InFile(particles) => Cow::Owned(particles.read_all()?),
        })
    }
}

/// What a solver of one rank starts from: every particle of a checkpoint's `state`, or `scene`'s spawn.
fn starting_particles(scene: &Scene, state: Option<SavedState>) -> Result<Particles> {
    match state {
        Some(saved) => Ok(saved.particles.whole()?.into_owned()),
        None => Ok(scene.spawn()),
    }
}

/// [`create`] with a checkpoint's state in place of the scene's start.
pub fn restore(kind: BackendKind, scene: &Scene, saved: SavedState) -> Result<Box<dyn Solver>> {
    create_with(kind, scene, Some(saved))
}

fn create_with(kind: BackendKind, scene: &Scene, state: Option<SavedState>) -> Result<Box<dyn Solver>> {
    if scene.method == Method::Pbmpm {
        return create_pbmpm(kind, scene, state);
    }
    if matches!(kind, BackendKind::Cuda | BackendKind::Auto) {
        // Refused here rather than falling back to the CPU: the user asked for the report's kernels.
        scene.check_pipeline()?;
    }
    let initial = || starting_particles(scene, state);
    // The emitters' and sinks' state: a checkpoint's, or a fresh run's start.
    let lifecycle = || {
        scene.flow.is_active().then(|| {
            let flow_state = match state.and_then(|saved| saved.flow) {
                Some(flow_state) => flow_state.clone(),
                None => FlowState::start(&scene.flow, scene.num_particles),
            };
            Lifecycle::new(scene, flow_state)
        })
    };
    if scene.ranks > 1 {
        ensure!(
            scene.colliders.num_bodies() == 0,
            "--ranks {}: scene {} has rigid bodies (colliders with a density or mass), which run on one rank; \
             drop --ranks and --gpus",
            scene.ranks,
            scene.source
        );
        return create_ranks(kind, scene, state, lifecycle());
    }
    let parallel = || -> Result<Box<dyn Solver>> {
        Ok(Box::new(
            ParallelCpuSolver::new(initial()?, scene.grid_res).with_lifecycle(lifecycle()),
        ))
    };
    let cuda = |options: CudaOptions| match state {
        Some(saved) => CudaSolver::restore(scene, &*saved.particles.whole()?, saved.flow, options),
        None => CudaSolver::new(scene, options),
    };
    // The bodies' contact features are the scene's; their states the checkpoint's, or the start.
    let (start, features) = scene.colliders.rigid_bodies();
    let bodies = match state {
        Some(saved) => saved.bodies.clone(),
        None => BodiesState::at_start(start),
    };
    let reference = || -> Result<Box<dyn Solver>> {
        Ok(Box::new(
            CpuSolver::new(initial()?, scene.grid_res).with_lifecycle(lifecycle()),
        ))
    };
    let mut solver: Box<dyn Solver> = match kind {
        BackendKind::Cpu => reference()?,
        BackendKind::CpuParallel => parallel()?,
        BackendKind::Cuda => Box::new(cuda(CudaOptions::from_env()?)?),
        BackendKind::Auto => match CudaOptions::from_env().and_then(cuda) {
            Ok(solver) => Box::new(solver),
            // The rigid bodies' sums are the reference's alone among the CPU backends.
            Err(why) if !bodies.states.is_empty() => {
                eprintln!(
                    "note: CUDA backend unavailable ({}); using the CPU reference on one thread (cpu): \
                     the scene has rigid bodies",
                    no_cuda_reason(&why)
                );
                reference()?
            }
            Err(why) => {
                eprintln!(
                    "note: CUDA backend unavailable ({}); using the CPU on {} (cpu-parallel)",
                    no_cuda_reason(&why),
                    crate::text::count(ParallelCpuSolver::threads(), "thread", "threads")
                );
                parallel()?
            }
        },
    };
    set_bodies(solver.as_mut(), scene, &bodies, &features)?;
    Ok(solver)
}

/// A solver for a scene of `solver.method = "pbmpm"`: the position-based substep on CUDA
/// (src/cuda/pbmpm_substep.rs), or its single-thread CPU reference (`sim::pbmpm`) on `--backend cpu`
/// and on `auto` where CUDA is unavailable (which says so). The cpu-parallel backend refuses it
/// before any work starts, as does a scene the solver does not run yet (`Scene::check_method`).
fn create_pbmpm(kind: BackendKind, scene: &Scene, state: Option<SavedState>) -> Result<Box<dyn Solver>> {
    scene.check_method()?;
    let particles = || starting_particles(scene, state);
    let reference = || -> Result<Box<dyn Solver>> {
        Ok(Box::new(PbmpmSolver::new(
            particles()?,
            scene.grid_res,
            scene.pbmpm,
        )))
    };
    let cuda = |options: CudaOptions| match state {
        Some(saved) => CudaSolver::restore(scene, &*saved.particles.whole()?, None, options),
        None => CudaSolver::new(scene, options),
    };
    Ok(match kind {
        BackendKind::CpuParallel => bail!("{}", pbmpm::NOT_CPU_PARALLEL),
        BackendKind::Cpu => reference()?,
        BackendKind::Cuda => Box::new(cuda(CudaOptions::from_env()?)?),
        BackendKind::Auto => match CudaOptions::from_env().and_then(cuda) {
            Ok(solver) => Box::new(solver),
            Err(why) => {
                eprintln!(
                    "note: CUDA backend unavailable ({}); solver.method = \"pbmpm\" runs on the CPU reference \
                     on one thread (cpu)",
                    no_cuda_reason(&why)
                );
                reference()?
            }
        },
    })
}

/// Gives `solver` the scene's rigid bodies (`features` its contact features) in the state `bodies`:
/// the start, or a checkpoint's. Nothing for a scene without.
fn set_bodies(
    solver: &mut dyn Solver,
    scene: &Scene,
    bodies: &BodiesState,
    features: &[ContactFeature],
) -> Result<()> {
    if bodies.states.is_empty() {
        return Ok(());
    }
    solver.set_bodies(bodies, features, scene.body_walls())
}

/// Gives a solver made outside [`create`] (the benchmark's) the scene's rigid bodies at their start.
pub fn set_starting_bodies(solver: &mut dyn Solver, scene: &Scene) -> Result<()> {
    let (start, features) = scene.colliders.rigid_bodies();
    set_bodies(solver, scene, &BodiesState::at_start(start), &features)
}

/// A run split into `scene.ranks` ranks (`crate::dist`), from a checkpoint's `state` or the scene's
/// start, with the emitters' and sinks' `lifecycle` where the scene has them: CUDA solvers (on one
/// device, or one per GPU with `scene.gpus`, or this process's with `scene.process`, which spawns
/// or reads its share alone; `auto` asks for them too, with no CPU fallback) or the CPU
/// reference's ranks.
fn create_ranks(
    kind: BackendKind,
    scene: &Scene,
    state: Option<SavedState>,
    lifecycle: Option<Lifecycle>,
) -> Result<Box<dyn Solver>> {
    let ranks = scene.ranks;
    check_ranks(kind, ranks, scene.gpus)?;
    match kind {
        BackendKind::Cuda | BackendKind::Auto => {
            let options = CudaOptions::from_env()?;
            CudaRanks::check_gpus(scene)?;
            let flow = lifecycle.map(|lifecycle| lifecycle.state);
            // A process of one rank starts from its share alone (read from a checkpoint's file, or
            // spawned: `CudaRanks::spawn`); one process of every rank from the whole run.
            Ok(Box::new(match (state, scene.process) {
                (Some(saved), Some(_)) => {
                    CudaRanks::new(scene, saved.particles.start(), flow.as_ref(), ranks, options)?
                }
                (Some(saved), None) => {
                    let whole = saved.particles.whole()?;
                    CudaRanks::new(scene, &*whole, flow.as_ref(), ranks, options)?
                }
                (None, _) => CudaRanks::spawn(scene, ranks, options)?,
            }))
        }
        BackendKind::Cpu => {
            let particles = starting_particles(scene, state)?;
            Ok(Box::new(
                CpuRanks::new(scene, particles, ranks)?.with_lifecycle(lifecycle),
            ))
        }
        // check_ranks refused it already, with the advice.
        BackendKind::CpuParallel => bail!("--ranks {ranks}: the cpu-parallel backend runs on one rank"),
    }
}
