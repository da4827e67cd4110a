//! The benchmarks: per-phase step times (median and p95 over per-substep samples), the CPU baseline,
//! and the scaling sweep. `mpm bench` and the `cargo bench` targets both call this module, so there
//! is one piece of code per measurement.
//!
//! What is measured, and in which state (the timings of a collapsing column drift as its particles
//! mix, so the state has to be named):
//! - **Phase tables** ([`phase_bench`]): a fresh `Simulation` steps the scene from its spawned state,
//!   frame by frame under the scene's time-step policy, exactly as `mpm run` does. The first
//!   `warmup_steps` substeps are dropped (module JIT, first-touch allocation, clocks ramping up), the
//!   next `steps` substeps are the samples. The CPU baseline runs the same loop, so both backends are
//!   timed over the same stretch of the same flow.
//! - **Scaling sweep** ([`scaling_sweep`]): each size steps from its spawned state with the substep
//!   the policy picks for the first frame, held fixed; `SWEEP_WARMUP_STEPS` are dropped and
//!   `steps` measured. This is the early, still ordered state of the column (the fastest one), so the
//!   sweep's figures sit a little below the phase tables' at the same size.
//!
//! GPU phases are timed with CUDA events (one at each phase's end that had work that substep; a phase
//! without reads 0), the CPU's and the ranks' (`--ranks`) with a host clock.

use crate::backend::{self, BackendKind};
use crate::cuda::{self, CudaOptions, CudaRanks, CudaSolver};
use crate::sim::scene::{BlockSpec, DomainSpec, SceneSpec};
use crate::sim::{
    presets, Holdings, Phase, PhaseTimings, Pipeline, ScatterMode, Scene, Simulation, Solver, Traffic,
    MAX_PENDING_STEP_TIMINGS,
};
use anyhow::{bail, ensure, Context, Result};
use serde::Serialize;
use std::fmt::Write as _;

/// The report's two scenarios: 65,536 and 655,360 particles on a 100^3 grid.
pub const REPORT_SCENES: [&str; 2] = ["bench-65k", "bench-655k"];
/// The scene of the CPU baseline (the report's CPU column).
pub const CPU_BASELINE_SCENE: &str = "bench-65k";
/// Particle counts of the scaling sweep: the report's two sizes, then doubling to 64 Mi.
pub const SWEEP_PARTICLES: [u64; 10] = [
    65_536,
    262_144,
    655_360,
    1 << 20,
    1 << 21,
    1 << 22,
    1 << 23,
    1 << 24,
    1 << 25,
    1 << 26,
];
/// The most substeps one phase table measures: each keeps a 56-byte record, so a million is 56 MB.
pub const MAX_MEASURED_STEPS: usize = 1_000_000;
/// Substeps dropped before each sweep point is measured.
pub const SWEEP_WARMUP_STEPS: usize = 20;
/// Milliseconds of one 60 Hz frame: the budget of the real-time limits.
pub const FRAME_BUDGET_MS: f64 = crate::sim::FRAME_DT as f64 * 1e3;
/// HBM3e bandwidth of the H200 (vendor figure), for the default bandwidth floor.
pub const H200_PEAK_GBS: f64 = 4800.0;

/// How the phase benchmark runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseBenchOptions {
    pub backend: BackendKind,
    /// Substeps dropped before measuring.
    pub warmup_steps: usize,
    /// Substeps measured (one sample each).
    pub steps: usize,
    /// Threads per block of the CUDA kernels; `None`: the environment's or the default.
    pub block_size: Option<u32>,
    /// One substep in this many times its phases on the GPU (`CudaOptions::phase_sample`); `None`:
    /// the environment's (`MPM_PHASE_SAMPLE`) or the default.
    pub phase_sample: Option<u32>,
    /// Overrides the scene's scatter mode.
    pub scatter: Option<ScatterMode>,
    /// Overrides the scene's GPU pipeline.
    pub pipeline: Option<Pipeline>,
    /// Splits each scene into this many ranks (`Scene::ranks`).
    pub ranks: Option<usize>,
    /// Runs the ranks on this many GPUs (`Scene::gpus`).
    pub gpus: Option<usize>,
    /// Runs one rank in this process, the others in theirs (`Scene::process`, `--processes`).
    pub process: Option<crate::dist::launch::Process>,
    /// Memory bandwidth for the traffic floor, GB/s.
    pub peak_gbs: f64,
}

impl Default for PhaseBenchOptions {
    fn default() -> Self {
        PhaseBenchOptions {
            backend: BackendKind::Cuda,
            warmup_steps: 200,
            steps: 1000,
            block_size: None,
            phase_sample: None,
            scatter: None,
            pipeline: None,
            ranks: None,
            gpus: None,
            process: None,
            peak_gbs: H200_PEAK_GBS,
        }
    }
}

/// Median, 95th percentile and mean of one phase, milliseconds per substep.
#[derive(Debug, Clone, Serialize)]
pub struct PhaseRow {
    /// `Phase::name()`, or "total".
    pub phase: String,
    /// What the phase holds on the backend measured (the kernels, on the GPU).
    pub label: String,
    pub median_ms: f64,
    pub p95_ms: f64,
    pub mean_ms: f64,
    /// Bytes the phase must move to or from device memory per substep at the least (the traffic
    /// model of [`Phase::traffic_floor`]), averaged over substeps; CUDA only.
    pub floor_bytes: Option<f64>,
    /// `floor_bytes` at the peak bandwidth, milliseconds: no implementation can beat it.
    pub floor_ms: Option<f64>,
}

/// One scenario's table.
#[derive(Debug, Clone, Serialize)]
pub struct PhaseReport {
    pub scene: String,
    pub particles: usize,
    pub grid_res: [u32; 3],
    pub backend: String,
    pub device: String,
    pub scatter: ScatterMode,
    pub pipeline: Pipeline,
    pub block_size: Option<u32>,
    pub warmup_steps: usize,
    pub steps: usize,
    /// Of `steps`, those that timed their phases: the phase rows are theirs, the total every
    /// substep's (the CUDA backend times the phases of one substep in `MPM_PHASE_SAMPLE`).
    pub phased_steps: usize,
    /// The substep range over the measured steps, s.
    pub dt_min: f32,
    pub dt_max: f32,
    /// Simulated time at the first and last measured substep's frame, s.
    pub sim_time_start: f64,
    pub sim_time_end: f64,
    /// Host clock per substep over the frames that hold the measured substeps (all of their
    /// substeps), ms: what the phases' device times leave out (the host's turns between substeps,
    /// the time-step choice, each frame's statistics) included.
    pub wall_ms_per_substep: Option<f64>,
    pub state: String,
    pub rows: Vec<PhaseRow>,
    pub total: PhaseRow,
    /// What each rank held at the end, for a run split over ranks that hold their own share.
    pub ranks: Option<Holdings>,
}

/// Nearest-rank percentile of sorted samples (q in (0, 1]); 0 for no samples.
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

fn row(
    phase: &str,
    label: String,
    mut samples: Vec<f64>,
    floor_bytes: Option<f64>,
    peak_gbs: f64,
) -> PhaseRow {
    samples.sort_by(f64::total_cmp);
    let mean = samples.iter().sum::<f64>() / samples.len().max(1) as f64;
    PhaseRow {
        phase: phase.to_string(),
        label,
        median_ms: percentile(&samples, 0.5),
        p95_ms: percentile(&samples, 0.95),
        mean_ms: mean,
        floor_bytes,
        floor_ms: floor_bytes.map(|b| b / (peak_gbs * 1e9) * 1e3),
    }
}

/// The scene with the options' overrides.
fn with_overrides(scene: &Scene, options: &PhaseBenchOptions) -> Scene {
    let mut scene = scene.clone();
    if let Some(scatter) = options.scatter {
        scene.scatter = scatter;
    }
    if let Some(pipeline) = options.pipeline {
        scene.pipeline = pipeline;
    }
    if let Some(ranks) = options.ranks {
        scene.ranks = ranks;
    }
    if let Some(gpus) = options.gpus {
        scene.gpus = gpus;
    }
    if options.process.is_some() {
        scene.process = options.process;
    }
    scene
}

/// One row per phase (`Phase::ALL`) and the total. `label` names what each phase holds on the
/// backend measured; `floor` gives each phase's traffic floor (CUDA only). The exchanges between
/// ranks have rows only where they ran (a run on several ranks).
fn phase_rows(
    samples: &[PhaseTimings],
    label: impl Fn(Phase) -> String,
    floor: Option<&dyn Fn(Phase) -> f64>,
    peak_gbs: f64,
) -> (Vec<PhaseRow>, PhaseRow) {
    // The phases of the substeps that timed them (the CUDA backend samples them, timing.rs); the
    // total of every substep.
    let phased: Vec<&PhaseTimings> = samples.iter().filter(|t| t.phased() > 0).collect();
    let rows = Phase::ALL
        .into_iter()
        .filter(|phase| !phase.is_exchange() || phased.iter().any(|t| t[*phase] > 0.0))
        .map(|phase| {
            let values = phased.iter().map(|t| t[phase]).collect();
            row(
                phase.name(),
                label(phase),
                values,
                floor.map(|f| f(phase)),
                peak_gbs,
            )
        })
        .collect();
    let total = row(
        "total",
        "total".into(),
        samples.iter().map(PhaseTimings::total).collect(),
        floor.map(|f| Phase::ALL.into_iter().map(f).sum()),
        peak_gbs,
    );
    (rows, total)
}

fn create_solver(scene: &Scene, options: &PhaseBenchOptions) -> Result<(Box<dyn Solver>, String)> {
    match options.backend {
        BackendKind::Cuda => {
            let mut cuda = CudaOptions::from_env()?;
            if let Some(block) = options.block_size {
                cuda.block_size = block;
            }
            if let Some(sample) = options.phase_sample {
                cuda.phase_sample = sample;
            }
            if scene.ranks > 1 {
                CudaRanks::check_gpus(scene)?;
                let solver = CudaRanks::spawn(scene, scene.ranks, cuda)?;
                let device = solver.device_name();
                return Ok((Box::new(solver), device));
            }
            let mut solver = CudaSolver::new(scene, cuda)?;
            // Its rigid bodies step and exchange as in a run (without them it timed them as static
            // colliders).
            backend::set_starting_bodies(&mut solver, scene)?;
            let device = solver.device_name();
            Ok((Box::new(solver), device))
        }
        BackendKind::Cpu => Ok((
            backend::create(BackendKind::Cpu, scene)?,
            if let Some(process) = scene.process {
                format!(
                    "CPU, rank {} of {}, a process each (the reference split into slabs; {})",
                    process.rank, process.size, process.launcher
                )
            } else if scene.ranks > 1 {
                format!(
                    "CPU, {} ranks of one thread each (the reference split into slabs)",
                    scene.ranks
                )
            } else {
                "CPU, single thread".to_string()
            },
        )),
        BackendKind::CpuParallel => Ok((
            backend::create(BackendKind::CpuParallel, scene)?,
            format!(
                "CPU, {} (cpu-parallel)",
                crate::text::count(
                    crate::sim::cpu_parallel::ParallelCpuSolver::threads(),
                    "thread",
                    "threads"
                )
            ),
        )),
        BackendKind::Auto => bail!("choose the benchmark's backend: --backend cuda, cpu or cpu-parallel"),
    }
}

fn check_steps(flag: &str, steps: usize) -> Result<()> {
    ensure!(
        (1..=MAX_MEASURED_STEPS).contains(&steps),
        "{flag} {steps} is outside 1..={MAX_MEASURED_STEPS}; the report's figure is 5000"
    );
    Ok(())
}

fn check_sweep_steps(steps: usize) -> Result<()> {
    // The solver keeps at most MAX_PENDING_STEP_TIMINGS unread records, and the sweep reads them
    // once per size.
    let max_steps = MAX_PENDING_STEP_TIMINGS - SWEEP_WARMUP_STEPS;
    ensure!(
        (1..=max_steps).contains(&steps),
        "--sweep-steps {steps} is outside 1..={max_steps}; 100 is the default"
    );
    Ok(())
}

/// Per-phase step times of `scene` (see the module's notes for the state measured).
pub fn phase_bench(scene: &Scene, options: &PhaseBenchOptions) -> Result<PhaseReport> {
    check_steps("--steps", options.steps)?;
    let scene = with_overrides(scene, options);
    let (solver, device) = create_solver(&scene, options)?;
    let mut sim = Simulation::new(scene.clone(), solver);
    // Not `with_capacity(steps)`: a huge --steps must run (long), not abort reserving memory.
    let mut samples: Vec<PhaseTimings> = Vec::with_capacity(options.steps.min(1 << 16));
    let mut skipped = 0usize;
    let (mut dt_min, mut dt_max) = (f32::INFINITY, 0.0f32);
    let mut sim_time_start = None;
    let (mut wall, mut wall_substeps) = (std::time::Duration::ZERO, 0usize);
    while samples.len() < options.steps {
        let time_before = sim.time();
        let started = std::time::Instant::now();
        let stats = sim.advance_frame()?;
        let frame_wall = started.elapsed();
        let records = sim.last_step_timings();
        ensure!(
            records.len() == stats.substeps as usize,
            "the {} backend returned {} timing records for {} substeps",
            sim.backend(),
            records.len(),
            stats.substeps
        );
        let measured_before = samples.len();
        for record in records {
            if skipped < options.warmup_steps {
                skipped += 1;
            } else if samples.len() < options.steps {
                sim_time_start.get_or_insert(time_before);
                dt_min = dt_min.min(stats.dt);
                dt_max = dt_max.max(stats.dt);
                samples.push(*record);
            }
        }
        if samples.len() > measured_before {
            wall += frame_wall;
            wall_substeps += records.len();
        }
    }
    let on_gpu = options.backend == BackendKind::Cuda;
    let fixed_point = scene.scatter == ScatterMode::FixedPoint;
    let ranked = scene.ranks > 1;
    let position_based = scene.method == crate::sim::Method::Pbmpm;
    // As the solver chose it: where there was no room for the bin-ordered copy, it bins as often as
    // with particles in place (the ranks' label names their migration cadence instead).
    let sort_interval = sim.solver().rebin_interval().unwrap_or(cuda::bins::SORT_INTERVAL);
    let label = |phase: Phase| match (on_gpu, ranked, phase) {
        // src/cuda/cuda_ranks.rs: the phases of every rank, timed on one rank's stream (rank 0's
        // unless MPM_TIMED_RANK names another).
        (true, true, Phase::Sort) => format!(
            "migrate + rebin (every {} substeps, or when a particle nears its rank's ghost planes)",
            crate::dist::MIGRATION_INTERVAL
        ),
        (true, true, Phase::G2p) => "one_pass + count strays (every rank)".into(),
        (true, _, _) if position_based => cuda::pbmpm::phase_label(phase, scene.pbmpm.iterations),
        (true, _, _) => {
            let label = cuda::pipelines::phase_label(scene.pipeline, phase, Some(fixed_point), sort_interval);
            match sim.solver().phase_kernel(phase) {
                Some(kernel) => format!("{label}, as {kernel}"),
                None => label,
            }
        }
        (false, _, _) => phase.cpu_label(),
    };
    let traffic = Traffic {
        particles: scene.num_particles,
        nodes: grid_nodes(scene.grid_res),
        fixed_point,
        pipeline: scene.pipeline,
        sort_interval,
    };
    let floor = |phase: Phase| phase.traffic_floor(&traffic);
    // The floors model the explicit solver's kernels; the position-based substep has none yet.
    let floor = (on_gpu && !position_based).then_some(&floor as &dyn Fn(Phase) -> f64);
    let (rows, total) = phase_rows(&samples, label, floor, options.peak_gbs);
    Ok(PhaseReport {
        scene: scene.name.clone(),
        particles: scene.num_particles,
        grid_res: scene.grid_res,
        backend: sim.backend().to_string(),
        device,
        // As the solver runs them: the position-based substep walks the binned pipeline's bins and
        // sums in fixed point whatever the scene's keys (src/cuda/solver.rs).
        scatter: if position_based {
            ScatterMode::FixedPoint
        } else {
            scene.scatter
        },
        pipeline: if position_based {
            Pipeline::Binned
        } else {
            scene.pipeline
        },
        block_size: match options.backend {
            BackendKind::Cuda => Some(options.block_size.unwrap_or(CudaOptions::from_env()?.block_size)),
            _ => None,
        },
        warmup_steps: options.warmup_steps,
        steps: samples.len(),
        phased_steps: samples.iter().filter(|t| t.phased() > 0).count(),
        dt_min,
        dt_max,
        sim_time_start: sim_time_start.unwrap_or(0.0),
        sim_time_end: sim.time(),
        wall_ms_per_substep: (wall_substeps > 0).then(|| wall.as_secs_f64() * 1e3 / wall_substeps as f64),
        ranks: sim.solver().holdings(),
        state: format!(
            "stepping from the spawned state under the scene's time-step policy (substep {}, as \
             `mpm run` does); {} warm-up substeps dropped, then {} substeps measured",
            match scene.time_step.substeps_per_choice() {
                Some(k) => format!("re-chosen every {k} substeps"),
                None => "fixed".to_string(),
            },
            options.warmup_steps,
            options.steps
        ),
        rows,
        total,
    })
}

fn grid_nodes(res: [u32; 3]) -> usize {
    res.iter().map(|&r| r as usize).product()
}

fn ms(value: f64) -> String {
    format!("{value:.4}")
}

/// The report's shape: one row per phase, then the total; milliseconds per substep.
pub fn phase_table(report: &PhaseReport) -> String {
    let mut out = String::new();
    let [rx, ry, rz] = report.grid_res;
    let _ = writeln!(
        out,
        "### {}: {} particles, grid {rx}x{ry}x{rz}, {} ({}){}",
        report.scene,
        report.particles,
        report.backend,
        report.device,
        report
            .block_size
            .map(|b| format!(
                ", {} pipeline, {} scatter, {b} threads per block",
                report.pipeline.name(),
                scatter_name(report.scatter)
            ))
            .unwrap_or_default()
    );
    let _ = writeln!(
        out,
        "\nState: {}; substep {:.3e} to {:.3e} s; simulated time {:.3} to {:.3} s.\n",
        report.state, report.dt_min, report.dt_max, report.sim_time_start, report.sim_time_end
    );
    if report.phased_steps < report.steps {
        let _ = writeln!(
            out,
            "Phases timed on {} of the {} substeps (one in MPM_PHASE_SAMPLE, {} by default: each \
             timing event lengthens the substep; MPM_PHASE_SAMPLE=1 times every one); the total \
             row is every substep's.\n",
            report.phased_steps,
            report.steps,
            cuda::PHASE_SAMPLE
        );
    }
    if let Some(wall) = report.wall_ms_per_substep {
        let _ = writeln!(
            out,
            "Wall clock: {wall:.4} ms a substep over the frames that hold the measured substeps (the \
             host's turns, the time-step choice and each frame's statistics included).\n"
        );
    }
    let with_floor = report.total.floor_bytes.is_some();
    if with_floor {
        out.push_str(
            "| phase | median (ms) | p95 (ms) | mean (ms) | traffic floor (MB) | floor (ms) | mean / floor |\n\
             |---|---:|---:|---:|---:|---:|---:|\n",
        );
    } else {
        out.push_str("| phase | median (ms) | p95 (ms) | mean (ms) |\n|---|---:|---:|---:|\n");
    }
    for (r, bold) in report
        .rows
        .iter()
        .map(|r| (r, false))
        .chain([(&report.total, true)])
    {
        let name = match bold {
            true => format!("**{}**", r.label),
            false => r.label.clone(),
        };
        let mut line = format!(
            "| {name} | {} | {} | {} |",
            ms(r.median_ms),
            ms(r.p95_ms),
            ms(r.mean_ms)
        );
        if let (Some(bytes), Some(floor_ms)) = (r.floor_bytes, r.floor_ms) {
            let ratio = if floor_ms > 0.0 {
                format!("{:.1}x", r.mean_ms / floor_ms)
            } else {
                "-".into()
            };
            let _ = write!(line, " {:.2} | {} | {ratio} |", bytes / 1e6, ms(floor_ms));
        }
        out.push_str(&line);
        out.push('\n');
    }
    if let Some(held) = &report.ranks {
        out.push_str(&ranks_table(held));
    }
    out
}

/// What each rank held at the end of a run split over ranks: its slab, particles, places, grid and
/// the memory its buffers take (a CUDA rank's on its GPU), and that per particle it owns.
fn ranks_table(held: &Holdings) -> String {
    let mut out = format!(
        "\nRanks (slabs across {}; {} migrations moved {} particles), as each held them at the end:\n\n\
         | rank | slab (node planes) | particles | particle places | grid nodes | MiB (particles, bins, grid) | bytes a particle |\n\
         |---:|---|---:|---:|---:|---:|---:|\n",
        ["x", "y", "z"][held.axis],
        held.migrations,
        held.migrated
    );
    for r in &held.ranks {
        let per_particle = match r.particles {
            0 => "-".to_string(),
            n => format!("{:.0}", r.bytes as f64 / n as f64),
        };
        let _ = writeln!(
            out,
            "| {} | {}..{} | {} | {} | {} | {:.0} | {per_particle} |",
            r.rank,
            r.slab.start,
            r.slab.end,
            r.particles,
            r.places,
            r.grid_nodes,
            r.bytes as f64 / (1024.0 * 1024.0)
        );
    }
    out
}

fn scatter_name(scatter: ScatterMode) -> &'static str {
    match scatter {
        ScatterMode::Float => "float",
        ScatterMode::FixedPoint => "fixed-point",
    }
}

/// A scene of the report's shape made to order: a column of 8 particles per cell with the proportions
/// of bench-655k's (32 x 64 x 40 cells), standing in the corner of a 1 m cube of `grid^3` nodes,
/// with bench-655k's material (c0 = 20 m/s) and CFL 0.4. The column is rounded to whole cells, so
/// the count is near, not always equal to, `particles`.
pub fn column_scene(particles: u64, grid: u32) -> Result<Scene> {
    const PARTICLES_PER_CELL: u64 = 8;
    /// bench-655k's column, in cells.
    const SHAPE: [f64; 3] = [32.0, 64.0, 40.0];
    ensure!(
        particles >= 8,
        "{particles} particles are too few: ask for at least 8"
    );
    ensure!(
        particles <= u64::from(u32::MAX),
        "{particles} particles are above the 2^32 limit of particle indices; ask for fewer"
    );
    let (grid_min, grid_max) = (8u32, 2048u32);
    ensure!(
        (grid_min..=grid_max).contains(&grid),
        "a {grid}^3 grid is outside {grid_min}..={grid_max} nodes per axis; choose a grid in that range"
    );
    let base_text = presets::get("bench-655k").context("the bench-655k preset is missing")?;
    let mut spec: SceneSpec = toml::from_str(base_text).context("parsing the bench-655k preset")?;
    let cells = particles as f64 / PARTICLES_PER_CELL as f64;
    let scale = (cells / SHAPE.iter().product::<f64>()).cbrt();
    let column = SHAPE.map(|s| (s * scale).round().max(1.0));
    // The column starts 2 cells from the walls, and must end inside the fluid region, 2 nodes short
    // of the far wall.
    let need = column.iter().fold(0.0f64, |a, &c| a.max(c)) as u32 + 4;
    ensure!(
        need <= grid,
        "{particles} particles at 8 per cell make a column {} x {} x {} cells, which does not fit a \
         {grid}^3 grid; use a grid of at least {need} nodes per axis",
        column[0],
        column[1],
        column[2]
    );
    let dx = 1.0 / f64::from(grid);
    spec.name = Some(format!("column-{particles}"));
    spec.description = Some(format!(
        "benchmark column of {:.0} x {:.0} x {:.0} cells at 8 per cell on a {grid}^3 grid",
        column[0], column[1], column[2]
    ));
    spec.domain = DomainSpec {
        size: [1.0; 3],
        resolution: [grid; 3],
    };
    spec.blocks = vec![BlockSpec {
        min: [2.0 * dx; 3],
        max: column.map(|c| (2.0 + c) * dx),
        particles_per_cell: PARTICLES_PER_CELL as u32,
        velocity: [0.0; 3],
        material: None,
    }];
    spec.spheres.clear();
    let source = format!("generated column of {particles} particles on a {grid}^3 grid");
    Ok(Scene::from_spec(&spec, &source)?)
}

/// The grid of the sweep for `particles`: grown with the particle count so that the fill (particles
/// per node) stays that of bench-655k (655,360 particles on 100^3 nodes).
pub fn sweep_grid(particles: u64) -> u32 {
    (100.0 * (particles as f64 / 655_360.0).cbrt()).round() as u32
}

/// One size of the scaling sweep.
#[derive(Debug, Clone, Serialize)]
pub struct SweepPoint {
    pub particles: usize,
    pub grid: u32,
    pub nodes: usize,
    /// Substeps per 60 Hz frame that the CFL policy asks for at the spawned state.
    pub substeps_per_frame: u32,
    pub dt: f32,
    pub median_step_ms: f64,
    pub p95_step_ms: f64,
    pub ns_per_particle_step: f64,
    /// Device memory the solver took: free memory before creating it less free memory after its
    /// measured steps (cuMemGetInfo), bytes.
    pub device_bytes: u64,
    /// GPU time of one frame's substeps at the median step: substeps_per_frame x median.
    pub frame_ms: f64,
    /// One substep fits a 60 Hz frame.
    pub one_step_per_frame: bool,
    /// A whole frame's substeps fit a 60 Hz frame: simulated time keeps up with wall time.
    pub real_time: bool,
}

/// The sweep with its two limits.
#[derive(Debug, Clone, Serialize)]
pub struct SweepReport {
    pub device: String,
    pub scatter: ScatterMode,
    pub pipeline: Pipeline,
    pub warmup_steps: usize,
    pub steps: usize,
    pub state: String,
    pub points: Vec<SweepPoint>,
    /// The largest measured count that still runs one substep within a 60 Hz frame.
    pub largest_one_step_per_frame: Option<usize>,
    /// The largest measured count that runs real time (a frame's substeps within the frame).
    pub largest_real_time: Option<usize>,
    /// Where the sweep stopped early, and why (the device could not hold the next size).
    pub stopped: Option<String>,
}

/// Steps each size of `particles` (columns in grids grown to keep the fill) on the GPU.
pub fn scaling_sweep(particles: &[u64], steps: usize, options: &PhaseBenchOptions) -> Result<SweepReport> {
    ensure!(
        options.backend == BackendKind::Cuda,
        "the scaling sweep measures the GPU; use --backend cuda"
    );
    check_sweep_steps(steps)?;
    let mut cuda_options = CudaOptions::from_env()?;
    if let Some(block) = options.block_size {
        cuda_options.block_size = block;
    }
    // Hold the device's context across the sweep, so that "free before" counts the context itself
    // out of each size's figure.
    let probe = cuda::library::MemoryProbe::new(cuda_options.device)?;
    let mut points = Vec::with_capacity(particles.len());
    let mut device = String::new();
    let mut scatter = ScatterMode::Float;
    let mut pipeline = Pipeline::default();
    let mut stopped = None;
    for &count in particles {
        let scene = with_overrides(&column_scene(count, sweep_grid(count))?, options);
        scatter = scene.scatter;
        pipeline = scene.pipeline;
        let free_before = probe.free_bytes()?;
        let solver = match CudaSolver::new(&scene, cuda_options) {
            Ok(solver) => solver,
            // A GPU smaller than the sweep's largest size: keep the sizes measured so far.
            Err(why) if !points.is_empty() => {
                stopped = Some(format!("{} particles: {why:#}", scene.num_particles));
                break;
            }
            Err(why) => return Err(why.context(format!("the sweep's {} particles", scene.num_particles))),
        };
        device = solver.device_name();
        let mut sim = Simulation::new(scene.clone(), Box::new(solver));
        let (substeps_per_frame, dt) = sim.next_frame_steps()?;
        let mut params = *sim.params();
        params.dt = dt;
        let solver = sim.solver_mut();
        for _ in 0..SWEEP_WARMUP_STEPS + steps {
            solver.step(&params)?;
        }
        // Reading the extremes waits for the device, so every timing event has completed.
        let extremes = solver.take_extremes()?;
        ensure!(
            extremes.max_speed.is_finite() && extremes.max_density.is_finite(),
            "the sweep's {} particles diverged",
            scene.num_particles
        );
        let records = solver.take_step_timings()?.unwrap_or_default();
        let free_after = probe.free_bytes()?;
        let mut totals: Vec<f64> = records
            .iter()
            .skip(SWEEP_WARMUP_STEPS)
            .map(PhaseTimings::total)
            .collect();
        ensure!(
            totals.len() == steps,
            "expected {steps} timed substeps, the backend returned {}",
            totals.len()
        );
        totals.sort_by(f64::total_cmp);
        let median = percentile(&totals, 0.5);
        let frame_ms = median * f64::from(substeps_per_frame);
        let point = SweepPoint {
            particles: scene.num_particles,
            grid: scene.grid_res[0],
            nodes: grid_nodes(scene.grid_res),
            substeps_per_frame,
            dt,
            median_step_ms: median,
            p95_step_ms: percentile(&totals, 0.95),
            ns_per_particle_step: median * 1e6 / scene.num_particles as f64,
            device_bytes: free_before.saturating_sub(free_after),
            frame_ms,
            one_step_per_frame: median <= FRAME_BUDGET_MS,
            real_time: frame_ms <= FRAME_BUDGET_MS,
        };
        eprintln!(
            "sweep: {:>10} particles, grid {:>4}^3: {:.4} ms/step, {:.3} ns/particle-step, {} substeps/frame",
            point.particles,
            point.grid,
            point.median_step_ms,
            point.ns_per_particle_step,
            point.substeps_per_frame
        );
        points.push(point);
    }
    let largest = |ok: fn(&SweepPoint) -> bool| points.iter().filter(|p| ok(p)).map(|p| p.particles).max();
    Ok(SweepReport {
        device,
        scatter,
        pipeline,
        warmup_steps: SWEEP_WARMUP_STEPS,
        steps,
        state: format!(
            "each size steps from its spawned state with the first frame's substep held fixed \
             ({SWEEP_WARMUP_STEPS} warm-up substeps dropped, {steps} measured): the column just \
             starting to fall, its most ordered (fastest) state"
        ),
        largest_one_step_per_frame: largest(|p| p.one_step_per_frame),
        largest_real_time: largest(|p| p.real_time),
        stopped,
        points,
    })
}

/// The sweep as a markdown table, with its two limits.
pub fn sweep_table(report: &SweepReport) -> String {
    let mut out = format!(
        "### Scaling sweep: {} ({} pipeline, {} scatter)\n\nState: {}. Columns of bench-655k's shape in grids grown \
         to keep its fill (0.66 particles per node); 1 m tank, so dx = 1 m / grid and the substeps \
         per frame grow with the grid (c0 = 20 m/s, CFL 0.4).\n\n\
         | particles | grid | median (ms/step) | p95 (ms/step) | ns per particle-step | device memory (MiB) | substeps per frame | GPU ms per frame |\n\
         |---:|---:|---:|---:|---:|---:|---:|---:|\n",
        report.device,
        report.pipeline.name(),
        scatter_name(report.scatter),
        report.state
    );
    for p in &report.points {
        let _ = writeln!(
            out,
            "| {} | {}^3 | {} | {} | {:.3} | {:.0} | {} | {:.2} |",
            p.particles,
            p.grid,
            ms(p.median_step_ms),
            ms(p.p95_step_ms),
            p.ns_per_particle_step,
            p.device_bytes as f64 / f64::from(1u32 << 20),
            p.substeps_per_frame,
            p.frame_ms
        );
    }
    let limit =
        |value: Option<usize>| value.map_or("none of the sizes measured".to_string(), |n| n.to_string());
    let _ = writeln!(
        out,
        "\nLargest count running one substep per 60 Hz frame ({FRAME_BUDGET_MS:.2} ms): {}.\n\
         Largest count running real time (a frame's substeps within {FRAME_BUDGET_MS:.2} ms): {}.",
        limit(report.largest_one_step_per_frame),
        limit(report.largest_real_time)
    );
    if let Some(why) = &report.stopped {
        let _ = writeln!(out, "The sweep stopped before {why}");
    }
    out
}

/// GPU/CPU speed-up of the step at one scene, from the mean totals (the report averaged frames).
pub fn speedup_line(cpu: &PhaseReport, gpu: &PhaseReport) -> String {
    format!(
        "GPU/CPU speed-up at {} ({} particles): CPU {:.3} ms / GPU {:.4} ms per substep (means) = {:.0}x; \
         medians {:.3} / {:.4} = {:.0}x",
        gpu.scene,
        gpu.particles,
        cpu.total.mean_ms,
        gpu.total.mean_ms,
        cpu.total.mean_ms / gpu.total.mean_ms,
        cpu.total.median_ms,
        gpu.total.median_ms,
        cpu.total.median_ms / gpu.total.median_ms
    )
}

/// Everything one `mpm bench` run measured, as written to --json.
#[derive(Debug, Clone, Default, Serialize)]
pub struct BenchReport {
    pub command: String,
    /// Seconds since 1970-01-01 UTC when the run started.
    pub started_unix_s: u64,
    /// Phase tables of the chosen backend, one per scene.
    pub phases: Vec<PhaseReport>,
    /// The CPU baseline (the report's CPU column), where asked for.
    pub cpu_baseline: Option<PhaseReport>,
    pub sweep: Option<SweepReport>,
}

/// What one run measures: the scenes' phase tables, then optionally the CPU baseline and the sweep.
#[derive(Debug, Clone)]
pub struct BenchPlan {
    /// The command line, recorded in the report.
    pub command: String,
    pub scenes: Vec<Scene>,
    pub options: PhaseBenchOptions,
    /// Measured substeps of the CPU baseline at [`CPU_BASELINE_SCENE`]; `None`: no baseline.
    pub cpu_baseline_steps: Option<usize>,
    /// Particle counts of the sweep and measured substeps per size; `None`: no sweep.
    pub sweep: Option<(Vec<u64>, usize)>,
}

/// Runs `plan`, printing each markdown table to `out` as it completes.
pub fn run(plan: &BenchPlan, out: &mut dyn std::io::Write) -> Result<BenchReport> {
    // Refuse bad counts before minutes of measuring, not after.
    check_steps("--steps", plan.options.steps)?;
    if let Some(steps) = plan.cpu_baseline_steps {
        check_steps("--cpu-steps", steps)?;
    }
    if let Some((_, steps)) = &plan.sweep {
        check_sweep_steps(*steps)?;
    }
    let started_unix_s = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let mut report = BenchReport {
        command: plan.command.clone(),
        started_unix_s,
        ..BenchReport::default()
    };
    let mut print = |text: &str| -> Result<()> {
        writeln!(out, "{text}").context("writing the benchmark's output")?;
        out.flush().context("writing the benchmark's output")
    };
    print(&format!(
        "command: {}
",
        plan.command
    ))?;
    for scene in &plan.scenes {
        let phases = phase_bench(scene, &plan.options)?;
        print(&phase_table(&phases))?;
        report.phases.push(phases);
    }
    if let Some(steps) = plan.cpu_baseline_steps {
        let scene = Scene::load(CPU_BASELINE_SCENE)?;
        let options = PhaseBenchOptions {
            backend: BackendKind::Cpu,
            steps,
            ..plan.options
        };
        let cpu = phase_bench(&scene, &options)?;
        print(&phase_table(&cpu))?;
        if let Some(gpu) = report
            .phases
            .iter()
            .find(|p| p.backend == "cuda" && p.scene == cpu.scene)
        {
            print(&speedup_line(&cpu, gpu))?;
            print("")?;
        }
        report.cpu_baseline = Some(cpu);
    }
    if let Some((particles, steps)) = &plan.sweep {
        let sweep = scaling_sweep(particles, *steps, &plan.options)?;
        print(&sweep_table(&sweep))?;
        report.sweep = Some(sweep);
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::RankHolding;

    #[test]
    fn the_ranks_table_gives_each_rank_s_memory_a_particle() {
        let rank = |rank, slab, particles, bytes| RankHolding {
            rank,
            slab,
            particles,
            places: particles + particles / 8 + 1024,
            grid_nodes: 1000,
            bytes,
        };
        let table = ranks_table(&Holdings {
            axis: 1,
            migrations: 3,
            migrated: 42,
            ranks: vec![
                rank(0, 0..60, 1_000_000, 226_000_000),
                rank(1, 60..64, 0, 5 << 20),
            ],
        });
        assert!(
            table.contains("slabs across y; 3 migrations moved 42 particles"),
            "{table}"
        );
        assert!(
            table.contains("| 0 | 0..60 | 1000000 | 1126024 | 1000 | 216 | 226 |"),
            "{table}"
        );
        // A rank holding no particle has no bytes a particle.
        assert!(
            table.contains("| 1 | 60..64 | 0 | 1024 | 1000 | 5 | - |"),
            "{table}"
        );
    }

    #[test]
    fn percentiles_are_nearest_rank() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 0.5), 50.0);
        assert_eq!(percentile(&v, 0.95), 95.0);
        assert_eq!(percentile(&[3.0], 0.95), 3.0);
        assert_eq!(percentile(&[], 0.5), 0.0);
    }

    #[test]
    fn sweep_grid_keeps_the_fill_of_bench_655k() {
        assert_eq!(sweep_grid(655_360), 100);
        assert_eq!(sweep_grid(1 << 24), 295);
    }

    #[test]
    fn column_scene_matches_bench_655k() {
        let scene = column_scene(655_360, 100).expect("scene");
        assert_eq!(scene.num_particles, 655_360);
        assert_eq!(scene.grid_res, [100; 3]);
    }

    #[test]
    fn absurd_sizes_are_refused_with_the_fix() {
        let err = column_scene(1 << 24, 50)
            .expect_err("too small a grid")
            .to_string();
        assert!(err.contains("use a grid of at least"), "{err}");
        let err = column_scene(1 << 40, 100).expect_err("too many").to_string();
        assert!(err.contains("2^32"), "{err}");
    }
}
