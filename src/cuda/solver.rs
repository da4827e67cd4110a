//! `CudaSolver`: the particle state on the device and one substep as its phases, in either pipeline
//! (`Pipeline`). The substep reads top to bottom in [`CudaSolver::step`]:
//!
//! | slot (`PhaseTimings`) | report pipeline                         | binned pipeline (default)                    |
//! |---|---|---|
//! | sort                  | sort by cell, every SORT_INTERVAL steps | sort by node block and cell, as often or when a particle moved a cell |
//! | p2g_init              | p2g_init (mass scatter) + mirror mass   | mirror mass (the mass came with g2p2g)       |
//! | p2g                   | p2g                                     | p2g (float), p2g_tiled (fixed point)         |
//! | grid_update           | mirror momentum + grid_update (all)     | mirror momentum + grid_update_blocks (touched) |
//! | g2p                   | g2p                                     | g2p2g (g2p + the next substep's mass scatter) |
//!
//! Each phase is an NVTX range and a pair of CUDA events. Both pipelines run the same per-particle
//! and per-node code (kernels/common.cuh). Neither has a grid-clear launch: the grid update zeroes
//! each accumulator it reads, so `PhaseTimings::grid_clear` stays 0 on the GPU.

use super::bins::{self, BinKernels, Bins, NODE_BLOCK_EDGE, WORK_COUNTS, WORK_NODE_BLOCKS};
use super::graph::{SubstepGraph, SubstepGraphs, SubstepKey};
use super::launch::{Kernel, Launcher, NvtxRange};
use super::library;
use super::lifecycle::{DeviceFlow, LifecycleKernels};
use super::modules::{LoadedModules, Origin};
use super::spawn::{self, SpawnBody};
use super::stats::ParticleStats;
use super::timing::PhaseEvents;
use crate::sim::colliders::{ColliderFrame, ColliderState, MAX_COLLIDERS};
use crate::sim::flow::{FlowCounts, FlowState};
use crate::sim::params::{Pipeline, ScatterMode};
use crate::sim::{
    ColourBy, ExtremesTicket, Material, Params, Particles, PhaseTimings, Push, Scene, Solver, StepExtremes,
    Summary, SummaryTicket,
};
use anyhow::{anyhow, bail, ensure, Context, Result};
use cudarc::driver::{
    CudaContext, CudaEvent, CudaSlice, CudaStream, DeviceRepr, LaunchConfig, PinnedHostSlice, PushKernelArg,
};
use glam::{Mat3, Vec3};
use std::sync::Arc;

// SAFETY: `Params` is `#[repr(C)]` and Pod; kernels/common.cuh mirrors it with static_asserts.
unsafe impl DeviceRepr for Params {}
// SAFETY: `Push` is `#[repr(C)]` and Pod; kernels/render.cu mirrors it with a static_assert.
unsafe impl DeviceRepr for Push {}
// SAFETY: `ColliderState` is `#[repr(C)]` and Pod; kernels/colliders.cuh mirrors it with a static_assert.
unsafe impl DeviceRepr for ColliderState {}
// SAFETY: every field is a u32 or f32, for which all-zero bits are valid.
unsafe impl cudarc::driver::ValidAsZeroBits for ColliderState {}

/// Where and how to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CudaOptions {
    /// CUDA device ordinal.
    pub device: usize,
    /// Threads per block of the particle and grid kernels: a multiple of 32 (the kernels reduce per
    /// warp with full-mask shuffles), at most 1024.
    pub block_size: u32,
    /// Each substep as one CUDA graph launch (graph.rs) rather than a launch per kernel.
    pub graphs: bool,
}

impl Default for CudaOptions {
    fn default() -> Self {
        CudaOptions {
            device: 0,
            block_size: 128,
            graphs: true,
        }
    }
}

impl CudaOptions {
    /// The defaults, overridden by `MPM_CUDA_DEVICE`, `MPM_CUDA_BLOCK_SIZE` and `MPM_CUDA_GRAPHS` where
    /// set.
    pub fn from_env() -> Result<CudaOptions> {
        let mut options = CudaOptions::default();
        if let Ok(text) = std::env::var("MPM_CUDA_DEVICE") {
            options.device = text
                .trim()
                .parse()
                .map_err(|_| anyhow!("MPM_CUDA_DEVICE={text:?} is not a device number (0, 1, ...)"))?;
        }
        if let Ok(text) = std::env::var("MPM_CUDA_BLOCK_SIZE") {
            options.block_size = text.trim().parse().map_err(|_| {
                anyhow!("MPM_CUDA_BLOCK_SIZE={text:?} is not a number; use 128 (or 64, 256, ...)")
            })?;
        }
        if let Ok(text) = std::env::var("MPM_CUDA_GRAPHS") {
            options.graphs = match text.trim() {
                "1" => true,
                "0" => false,
                _ => bail!("MPM_CUDA_GRAPHS={text:?}: use 1 (substeps as CUDA graphs, the default) or 0"),
            };
        }
        options.validate()?;
        Ok(options)
    }

    fn validate(&self) -> Result<()> {
        ensure!(
            self.block_size >= 32 && self.block_size <= 1024 && self.block_size % 32 == 0,
            "block size {} must be a multiple of 32 between 32 and 1024 (128 is the default)",
            self.block_size
        );
        Ok(())
    }
}

/// What the kernels count and reduce between substep choices; mirrors `StepCounters` in
/// kernels/common.cuh.
const COUNTERS: usize = 8;
const COUNTER_MAX_DENSITY: usize = 0;
const COUNTER_MAX_SPEED: usize = 1;
const COUNTER_FIXED_OVERFLOWS: usize = 2;
const COUNTER_MAX_SIGNAL: usize = 3;
const COUNTER_REBIN_NEEDED: usize = 4;
const COUNTER_TILE_MISSES: usize = 5;
const COUNTER_BACKSTOP_PUSHES: usize = 6;
/// Host copies of the counters in the ring: more than the two requests `Solver` allows outstanding.
const COUNTER_COPIES: usize = 3;

/// Fixed-point accumulators, allocated on first use of the fixed-point scatter.
struct FixedGrid {
    mass: CudaSlice<u64>,
    /// Three per node, interleaved.
    momentum: CudaSlice<u64>,
}

/// Substeps between particle sorts, in both pipelines. Particles move well under a cell per substep,
/// so an order a few substeps old is nearly as good as a fresh one; but the warp-aggregated scatters
/// merge only lanes of one cell that sit side by side, and an older order has fewer of them. Measured
/// on the H200 (binned pipeline, means per substep), sorting every 64 / 16 / 8 / 4 substeps: bench-655k
/// 0.245 / 0.237 / 0.228 / 0.230 ms, a 16.8M-particle column 4.16 / 4.03 / 4.01 / 4.06 ms. The binned
/// pipeline also rebins sooner when the kernels flag a particle that moved a cell (tiles.cuh), learnt
/// at each substep choice; stale bins are never wrong, only slower.
pub const SORT_INTERVAL: u32 = 8;
/// Tile nodes (TILE_NODES in kernels/tiles.cuh), threads per node block (NODE_BLOCK_NODES) and per
/// block of a tiled pass (TILE_THREADS, which the kernels' launch bounds are compiled for).
const TILE_NODES: u32 = 1000;
const NODE_BLOCK_NODES: u32 = 64;
const TILE_THREADS: u32 = 128;

/// What `mirror_walls` mirrors: the codes of kernels/mirror_walls.cu.
#[derive(Clone, Copy)]
enum MirrorQuantity {
    Mass = 0,
    Momentum = 1,
}

struct Kernels {
    bins: BinKernels,
    p2g_init: Kernel,
    p2g: Kernel,
    grid_update: Kernel,
    g2p: Kernel,
    p2g_mass: Kernel,
    p2g_tiled: Kernel,
    grid_update_blocks: Kernel,
    g2p2g: Kernel,
    mirror_walls: Kernel,
    spawn_count: Kernel,
    spawn_write: Kernel,
    render_attributes: Kernel,
    push_particles: Kernel,
    lifecycle: LifecycleKernels,
}

impl Kernels {
    fn load(modules: &LoadedModules) -> Result<Kernels> {
        let k = |module: &str, name: &'static str| Kernel::load(modules, module, name);
        Ok(Kernels {
            bins: BinKernels::load(modules)?,
            p2g_init: k("p2g_init", "p2g_init")?,
            p2g: k("p2g", "p2g")?,
            grid_update: k("grid_update", "grid_update")?,
            g2p: k("g2p", "g2p")?,
            p2g_mass: k("g2p2g", "p2g_mass")?,
            p2g_tiled: k("p2g_tiled", "p2g_tiled")?,
            grid_update_blocks: k("grid_update", "grid_update_blocks")?,
            g2p2g: k("g2p2g", "g2p2g")?,
            mirror_walls: k("mirror_walls", "mirror_walls")?,
            spawn_count: k("spawn", "spawn_count")?,
            spawn_write: k("spawn", "spawn_write")?,
            render_attributes: k("render", "render_attributes")?,
            push_particles: k("render", "push_particles")?,
            lifecycle: LifecycleKernels::load(modules)?,
        })
    }
}

/// The colliders on the device (kernels/colliders.cuh): the states of the current substep, uploaded
/// when they change (every substep for moving colliders, once for static ones), and the mesh
/// colliders' distance samples, uploaded once.
struct DeviceColliders {
    states: CudaSlice<ColliderState>,
    count: u32,
    /// What `states` holds, to skip uploads of an unchanged frame.
    uploaded: Vec<ColliderState>,
    sdf: CudaSlice<f32>,
    /// The host buffer `sdf` was copied from.
    sdf_source: Option<Arc<[f32]>>,
}

/// The binned pipeline's list of touched node blocks (kernels/tiles.cuh): a mark per block and the
/// list the scatters append to; its length is `work_counts[WORK_NODE_BLOCKS]`.
struct NodeBlockList {
    marks: CudaSlice<u32>,
    list: CudaSlice<u32>,
}

pub struct CudaSolver {
    ctx: Arc<CudaContext>,
    launcher: Launcher,
    kernels: Kernels,
    module_origin: Origin,
    options: CudaOptions,
    pipeline: Pipeline,
    num_particles: usize,
    grid_res: [u32; 3],
    /// x, y, z, unused: one float4 per particle (a layout a GL vertex buffer can share).
    x: CudaSlice<f32>,
    /// vx, vy, vz, unused.
    v: CudaSlice<f32>,
    /// C as three float4 arrays of N (columns 0, 1, 2).
    c: CudaSlice<f32>,
    rho: CudaSlice<f32>,
    /// Particle indices by cell (report) or node block (binned): the order the scatters walk.
    bins: Bins,
    bins_built: bool,
    /// Binnings since the solver was made.
    binnings: u64,
    steps_since_binning: u32,
    /// The kernels flagged a particle that moved past its bin's reach (read at a substep choice).
    rebin_requested: bool,
    /// Device-side list lengths (WORK_BINS, WORK_NODE_BLOCKS in kernels/tiles.cuh).
    work_counts: CudaSlice<u32>,
    node_blocks: NodeBlockList,
    /// Binned pipeline: the grid already holds the mass of the particles' current positions (g2p2g
    /// scattered it), with this scatter mode.
    mass_scattered: Option<u32>,
    /// Scatter accumulators, float4 per node: momentum xyz, mass w. Zeroed by the grid update.
    grid_acc: CudaSlice<f32>,
    /// Node velocity xyz and mass w, written by the grid update, read by g2p.
    grid_vel: CudaSlice<f32>,
    fixed: Option<FixedGrid>,
    /// Passed for the fixed-point pointers when the float scatter runs (never dereferenced).
    unused_fixed: CudaSlice<u64>,
    counters: CudaSlice<u32>,
    /// Pinned host copies of `counters`, one per outstanding `request_extremes` (a ring), each with
    /// the event recorded after its copy. (cudarc's pinned slices carry an event of their own, but
    /// record it only where cudarc tracks events between streams, which this one-stream solver turns
    /// off: waiting on it returned before the copy had landed.)
    counter_copies: Vec<(PinnedHostSlice<u32>, CudaEvent)>,
    next_counter_copy: usize,
    /// Particles scattered outside their tile since the solver was made (binned pipeline).
    tile_misses: u64,
    fixed_mass_scale: f32,
    fixed_momentum_scale: f32,
    timing: PhaseEvents,
    /// Captured substeps (graph.rs); empty where graphs are off.
    graphs: SubstepGraphs,
    /// Substeps enqueued so far: the first runs without a graph (it allocates on first use).
    substeps: u64,
    stats: ParticleStats,
    /// Device scratch of the host-copy render path (allocated on first use, kept).
    render_scratch: Option<CudaSlice<f32>>,
    colliders: DeviceColliders,
    /// Emitters, sinks and the free slots, where the scene has them (binned pipeline only).
    flow: Option<DeviceFlow>,
}

/// x.w of a parked particle slot (PARKED_W in kernels/common.cuh).
const PARKED_W: f32 = 1.0;

/// Bytes on the device per particle (x, v as float4; C as 3 float4; rho; order, bin key and rank)
/// and per node (two float4, the report sort's cell count; the binned pipeline's per-block lists
/// are far smaller).
pub const BYTES_PER_PARTICLE: usize = 4 * (4 + 4 + 12 + 1 + 3);
pub const BYTES_PER_NODE: usize = 4 * (4 + 4 + 1);
/// Added per node by the fixed-point scatter: mass and three momentum components as u64.
pub const FIXED_BYTES_PER_NODE: usize = 8 * 4;

impl CudaSolver {
    /// Spawns `scene`'s particles on the device, in the order of `Scene::spawn()`. A scene with
    /// emitters or sinks is spawned on the host (its parked slots with it) and uploaded.
    pub fn new(scene: &Scene, options: CudaOptions) -> Result<CudaSolver> {
        if scene.flow.is_active() {
            return CudaSolver::restore(scene, &scene.spawn(), None, options);
        }
        let mut solver = CudaSolver::allocate(scene, options)?;
        if scene.colliders.is_empty() {
            solver.spawn_on_device(scene)?;
        } else {
            // The device lattice knows nothing of colliders, whose insides get no fluid.
            solver.upload(&scene.spawn())?;
        }
        Ok(solver)
    }

    /// Uploads `particles` (for tests: any state, not only a spawned one) into a solver for `scene`'s
    /// grid, material and pipeline.
    pub fn from_particles(scene: &Scene, particles: &Particles, options: CudaOptions) -> Result<CudaSolver> {
        CudaSolver::restore(scene, particles, None, options)
    }

    /// Uploads a saved state: `particles` (every slot) and, for a scene with emitters or sinks, the
    /// lifecycle's `flow` state (`None`: the scene's start).
    pub fn restore(
        scene: &Scene,
        particles: &Particles,
        flow: Option<&FlowState>,
        options: CudaOptions,
    ) -> Result<CudaSolver> {
        let mut scene = scene.clone();
        if scene.flow.is_active() {
            ensure!(
                particles.len() == scene.slots(),
                "{} particle slots for a scene of {}",
                particles.len(),
                scene.slots()
            );
        } else {
            scene.num_particles = particles.len();
            scene.flow.capacity = particles.len();
        }
        let mut solver = CudaSolver::allocate(&scene, options)?;
        solver.upload(particles)?;
        if scene.flow.is_active() {
            let start;
            let state = match flow {
                Some(state) => state,
                None => {
                    start = FlowState::start(&scene.flow, scene.num_particles);
                    &start
                }
            };
            let spacing = scene.lattice().spacing as f32;
            solver.flow = Some(DeviceFlow::new(&solver.launcher, &scene.flow, state, spacing)?);
        }
        Ok(solver)
    }

    fn allocate(scene: &Scene, options: CudaOptions) -> Result<CudaSolver> {
        options.validate()?;
        scene.check_pipeline()?;
        library::ensure_driver()?;
        let ctx = CudaContext::new(options.device).map_err(|e| {
            anyhow!(
                "cannot open CUDA device {}: {e} (no NVIDIA GPU, or the driver is not working)",
                options.device
            )
        })?;
        // One stream, so cudarc's cross-stream event tracking only costs time.
        // SAFETY: called before any allocation in this context.
        unsafe { ctx.disable_event_tracking() };
        let stream = ctx.new_stream().context("creating a CUDA stream")?;
        let modules = LoadedModules::load(&ctx)?;
        let kernels = Kernels::load(&modules)?;
        let multiprocessors = ctx
            .attribute(cudarc::driver::sys::CUdevice_attribute::CU_DEVICE_ATTRIBUTE_MULTIPROCESSOR_COUNT)
            .context("reading the multiprocessor count")?;

        ensure!(
            !scene.flow.is_active() || scene.pipeline == Pipeline::Binned,
            "scene {}: emitters and sinks run in the binned GPU pipeline; drop solver.pipeline = \
             \"report\" (or --pipeline report), or use a CPU backend",
            scene.source
        );
        let n = scene.slots();
        ensure!(n > 0, "scene {}: no particles", scene.source);
        let nodes: usize = scene.grid_res.iter().map(|&r| r as usize).product();
        let fixed_scatter = scene.scatter == ScatterMode::FixedPoint;
        let needed = n * BYTES_PER_PARTICLE
            + nodes * (BYTES_PER_NODE + if fixed_scatter { FIXED_BYTES_PER_NODE } else { 0 });
        let (free, total) = ctx.mem_get_info().context("cuMemGetInfo")?;
        // Leave room for the context, the modules and the spawn scratch.
        if needed + (64 << 20) > free {
            bail!(
                "scene {} needs {:.2} GiB of GPU memory ({} particles, {} grid nodes) but device {} ({}) \
                 has {:.2} GiB free of {:.2} GiB; use a coarser domain.resolution, fewer particles, or \
                 --backend cpu",
                scene.source,
                gib(needed),
                n,
                nodes,
                options.device,
                ctx.name().unwrap_or_default(),
                gib(free),
                gib(total)
            );
        }

        let launcher = Launcher {
            stream,
            block_size: options.block_size,
            multiprocessors: multiprocessors.max(1) as u32,
            sync_each_launch: std::env::var("MPM_CUDA_SYNC").is_ok_and(|v| v == "1"),
        };
        let stream = &launcher.stream;
        let alloc_f32 = |len: usize, what: &str| {
            stream
                .alloc_zeros::<f32>(len)
                .with_context(|| format!("allocating {what} ({len} floats)"))
        };
        let alloc_u32 = |len: usize, what: &str| {
            stream
                .alloc_zeros::<u32>(len.max(1))
                .with_context(|| format!("allocating {what} ({len} values)"))
        };
        let (fixed_mass_scale, fixed_momentum_scale) = fixed_point_scales(scene);
        let bin_edge = match scene.pipeline {
            Pipeline::Report => 1,
            Pipeline::Binned => NODE_BLOCK_EDGE,
        };
        let bins = Bins::new(
            &launcher,
            scene.grid_res,
            n,
            bin_edge,
            scene.pipeline == Pipeline::Binned,
        )?;
        let num_node_blocks = match scene.pipeline {
            Pipeline::Report => 0,
            Pipeline::Binned => bins.num_bins(),
        };
        let colliders = DeviceColliders {
            states: stream
                .alloc_zeros::<ColliderState>(MAX_COLLIDERS)
                .context("allocating the collider states")?,
            count: 0,
            uploaded: Vec::new(),
            sdf: stream
                .alloc_zeros::<f32>(1)
                .context("allocating the collider SDF")?,
            sdf_source: None,
        };
        let mut solver = CudaSolver {
            bins,
            bins_built: false,
            binnings: 0,
            steps_since_binning: 0,
            rebin_requested: false,
            work_counts: alloc_u32(WORK_COUNTS, "work counts")?,
            node_blocks: NodeBlockList {
                marks: alloc_u32(num_node_blocks, "node block marks")?,
                list: alloc_u32(num_node_blocks, "the node block list")?,
            },
            mass_scattered: None,
            x: alloc_f32(4 * n, "particle positions")?,
            v: alloc_f32(4 * n, "particle velocities")?,
            c: alloc_f32(12 * n, "particle affine matrices")?,
            rho: alloc_f32(n, "particle densities")?,
            grid_acc: alloc_f32(4 * nodes, "grid accumulators")?,
            grid_vel: alloc_f32(4 * nodes, "grid velocities")?,
            fixed: None,
            unused_fixed: stream.alloc_zeros::<u64>(1).context("allocating a placeholder")?,
            counters: alloc_u32(COUNTERS, "step counters")?,
            counter_copies: (0..COUNTER_COPIES)
                .map(|_| {
                    // SAFETY: each copy is written by a device copy before it is read (wait_extremes).
                    let copy = unsafe { ctx.alloc_pinned::<u32>(COUNTERS) }?;
                    Ok((copy, ctx.new_event(None)?))
                })
                .collect::<Result<_, cudarc::driver::DriverError>>()
                .context("allocating pinned memory for the step counters")?,
            next_counter_copy: 0,
            tile_misses: 0,
            timing: PhaseEvents::new(ctx.clone()),
            graphs: SubstepGraphs::default(),
            substeps: 0,
            stats: ParticleStats::new(Kernel::load(&modules, "stats", "particle_stats")?, &launcher)?,
            ctx,
            launcher,
            kernels,
            module_origin: modules.origin,
            options,
            pipeline: scene.pipeline,
            num_particles: n,
            grid_res: scene.grid_res,
            fixed_mass_scale,
            fixed_momentum_scale,
            render_scratch: None,
            colliders,
            flow: None,
        };
        if fixed_scatter {
            solver.ensure_fixed_grid()?;
        }
        Ok(solver)
    }

    /// How the kernels were loaded: embedded PTX, or compiled at run time (and why).
    pub fn module_origin(&self) -> Origin {
        self.module_origin
    }

    /// The device's name, e.g. "NVIDIA H200".
    pub fn device_name(&self) -> String {
        self.ctx.name().unwrap_or_else(|_| "unknown CUDA device".into())
    }

    /// The kernel sequence this solver runs.
    pub fn pipeline(&self) -> Pipeline {
        self.pipeline
    }

    /// The fixed-point scales this solver fills into `Params` (units per kg, units per kg m/s).
    pub fn fixed_point_scales(&self) -> (f32, f32) {
        (self.fixed_mass_scale, self.fixed_momentum_scale)
    }

    /// Particles the binned pipeline scattered past their tile (by global atomics) since the solver
    /// was made, as of the last `take_extremes`.
    pub fn tile_misses(&self) -> u64 {
        self.tile_misses
    }

    /// How often the particles were binned (sorted) since the solver was made.
    pub fn binnings(&self) -> u64 {
        self.binnings
    }

    fn ensure_fixed_grid(&mut self) -> Result<()> {
        if self.fixed.is_none() {
            let nodes = self.num_nodes();
            let stream = &self.launcher.stream;
            self.fixed = Some(FixedGrid {
                mass: stream
                    .alloc_zeros::<u64>(nodes)
                    .context("allocating fixed-point mass")?,
                momentum: stream
                    .alloc_zeros::<u64>(3 * nodes)
                    .context("allocating fixed-point momentum")?,
            });
        }
        Ok(())
    }

    fn num_nodes(&self) -> usize {
        self.grid_res.iter().map(|&r| r as usize).product()
    }

    /// The Params the kernels get: the caller's, with this solver's fixed-point scales.
    fn device_params(&mut self, params: &Params) -> Result<Params> {
        ensure!(
            params.num_particles as usize == self.num_particles && params.grid_res == self.grid_res,
            "Params are for {} particles on a {:?} grid, but this CUDA solver holds {} on {:?}",
            params.num_particles,
            params.grid_res,
            self.num_particles,
            self.grid_res
        );
        ensure!(
            params.scatter_mode <= ScatterMode::FixedPoint.code(),
            "unknown scatter mode {}",
            params.scatter_mode
        );
        if let Some(mode) = self.mass_scattered {
            ensure!(
                mode == params.scatter_mode,
                "the scatter mode cannot change in the middle of a binned-pipeline run (the grid \
                 already holds the next substep's mass in the other mode)"
            );
        }
        let mut device = *params;
        if params.scatter_mode == ScatterMode::FixedPoint.code() {
            self.ensure_fixed_grid()?;
        }
        // The binned pipeline's tiles accumulate fixed point in either scatter mode (tiles.cuh).
        if params.scatter_mode == ScatterMode::FixedPoint.code() || self.pipeline == Pipeline::Binned {
            device.fixed_mass_scale = self.fixed_mass_scale;
            device.fixed_momentum_scale = self.fixed_momentum_scale;
        }
        Ok(device)
    }

    /// Whether the next substep rebuilds the bins: every SORT_INTERVAL substeps, and in the binned
    /// pipeline sooner where a particle moved past its bin's reach.
    fn binning_due(&self) -> bool {
        !self.bins_built || self.rebin_requested || self.steps_since_binning >= SORT_INTERVAL
    }

    /// Rebuilds the particle order by bin (kernels/bins.cu): by cell for the report's pipeline, by
    /// node block (with the list of bins that hold particles) for the binned one.
    pub fn sort_particles(&mut self, params: &Params) -> Result<()> {
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("sort");
        self.bins.rebuild(
            &self.kernels.bins,
            &self.launcher,
            &params,
            &self.x,
            &mut self.work_counts,
        )?;
        self.note_binning();
        Ok(())
    }

    fn note_binning(&mut self) {
        self.bins_built = true;
        self.binnings += 1;
        self.rebin_requested = false;
        self.steps_since_binning = 0;
    }

    fn fixed_grid(&self) -> (&CudaSlice<u64>, &CudaSlice<u64>) {
        match &self.fixed {
            Some(f) => (&f.mass, &f.momentum),
            None => (&self.unused_fixed, &self.unused_fixed),
        }
    }

    /// The binned pipeline's list of bin chunks, which its tiled passes walk.
    fn bin_list(&self) -> Result<&CudaSlice<u32>> {
        self.bins
            .list
            .as_ref()
            .context("only the binned pipeline lists its bins")
    }

    /// A tiled pass over the listed bins: a block per bin, a thread per particle, and `channels`
    /// 32-bit accumulators per tile node (kernels/tiles.cuh).
    fn tiled_pass(&self, channels: u32) -> LaunchConfig {
        self.launcher
            .over_list(self.bins.list_capacity(), TILE_THREADS, channels * TILE_NODES * 4)
    }

    /// Mass scatter, m_i += w m_p: the report's p2g_init, or the binned pipeline's tiled p2g_mass
    /// (which g2p2g does as its second half on every substep after the first).
    pub fn p2g_init(&mut self, params: &Params) -> Result<()> {
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("p2g_init");
        let (fixed_mass, _) = self.fixed_grid();
        let (l, k) = (&self.launcher, &self.kernels);
        match self.pipeline {
            Pipeline::Report => {
                // SAFETY: the arguments match p2g_init in kernels/p2g_init.cu; buffers are sized for params.
                unsafe {
                    k.p2g_init.launch(l, l.cover(self.num_particles), |a| {
                        a.arg(&params)
                            .arg(&self.x)
                            .arg(&self.bins.order)
                            .arg(&self.grid_acc)
                            .arg(fixed_mass)
                            .arg(&self.counters);
                    })
                }
            }
            Pipeline::Binned => {
                if !self.bins_built {
                    self.sort_particles(&params)?;
                }
                let (fixed_mass, _) = self.fixed_grid();
                let (l, k) = (&self.launcher, &self.kernels);
                let list = self.bin_list()?;
                let config = self.tiled_pass(1);
                // SAFETY: the arguments match p2g_mass in kernels/g2p2g.cu; the bin list, order and
                // node-block list are sized for this grid and these particles.
                unsafe {
                    k.p2g_mass.launch(l, config, |a| {
                        a.arg(&params)
                            .arg(list)
                            .arg(&self.bins.order)
                            .arg(&self.x)
                            .arg(&self.grid_acc)
                            .arg(fixed_mass)
                            .arg(&self.node_blocks.marks)
                            .arg(&self.node_blocks.list)
                            .arg(&self.work_counts)
                            .arg(&self.counters);
                    })?;
                }
                self.mass_scattered = Some(params.scatter_mode);
                Ok(())
            }
        }
    }

    /// The walls' image mass, between the mass scatter and p2g (kernels/mirror_walls.cu).
    pub fn mirror_mass(&mut self, params: &Params) -> Result<()> {
        self.mirror_walls(params, MirrorQuantity::Mass)
    }

    /// The walls' image momentum, wall-normal component reflected, between p2g and the grid update.
    pub fn mirror_momentum(&mut self, params: &Params) -> Result<()> {
        self.mirror_walls(params, MirrorQuantity::Momentum)
    }

    /// All three axes' images in one launch, one thread per reflection orbit (kernels/mirror_walls.cu).
    fn mirror_walls(&mut self, params: &Params, quantity: MirrorQuantity) -> Result<()> {
        if params.wall_mirror_lo == 0 {
            return Ok(());
        }
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("mirror_walls");
        // Each thread takes the fluid-side nodes of both walls of one axis within their reach, across
        // the other two axes; the two walls' reaches must not meet (the kernel tells them apart).
        let res = self.grid_res;
        let mut threads = 0usize;
        for a in 0..3 {
            let (lo, hi) = (params.wall_mirror_lo, params.wall_mirror_hi[a]);
            let (lo_reach, hi_reach) = (lo.min(res[a] - 1 - lo), hi.min(res[a] - 1 - hi));
            ensure!(
                lo + lo_reach < hi - hi_reach,
                "the grid is too small for the wall mirror: {} nodes along axis {a}; use at least {}",
                res[a],
                2 * (lo + lo_reach + 1)
            );
            let across = res[(a + 1) % 3] as usize * res[(a + 2) % 3] as usize;
            threads += (lo_reach + hi_reach + 2) as usize * across;
        }
        let (fixed_mass, fixed_momentum) = self.fixed_grid();
        let (l, k) = (&self.launcher, &self.kernels);
        // The report's pipeline visits every orbit (null marks); the binned one skips untouched blocks.
        let null: u64 = 0;
        let binned = self.pipeline == Pipeline::Binned;
        let quantity_code = quantity as u32;
        // SAFETY: the arguments match mirror_walls; the marks, list and counts are this grid's (or null
        // pointers, which the kernel checks, for the report's pipeline).
        unsafe {
            k.mirror_walls.launch(l, l.cover(threads), |a| {
                a.arg(&params)
                    .arg(&quantity_code)
                    .arg(&self.grid_acc)
                    .arg(fixed_mass)
                    .arg(fixed_momentum);
                if binned {
                    a.arg(&self.node_blocks.marks)
                        .arg(&self.node_blocks.list)
                        .arg(&self.work_counts);
                } else {
                    a.arg(&null).arg(&null).arg(&null);
                }
            })
        }
    }

    /// Density from the grid mass, pressure and stress, momentum scatter. In the report's pipeline,
    /// and for float momentum in the binned one, p2g.cu: warp runs of one cell summed before global
    /// atomics (integers for fixed point). Fixed-point momentum in the binned pipeline goes through a
    /// shared tile (p2g_tiled.cu). Each is the faster there, measured on the H200 (2026-11-23, mpm
    /// bench, p2g medians): float at bench-655k 0.097 ms by runs, 0.17 ms tiled (the L2 adds floats
    /// natively, a tile must round every contribution); fixed point 0.17 ms tiled, 0.20 ms by
    /// integer runs, 0.66 ms by unaggregated 64-bit atomics (16.8M particles: 3.48 against 3.86 ms).
    pub fn p2g(&mut self, params: &Params) -> Result<()> {
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("p2g");
        let (fixed_mass, fixed_momentum) = self.fixed_grid();
        let (l, k) = (&self.launcher, &self.kernels);
        // Scenes with a flow take the tiled pass in either mode: p2g.cu walks the whole order, parked
        // slots included.
        let tiled = self.pipeline == Pipeline::Binned
            && (params.scatter_mode == ScatterMode::FixedPoint.code() || self.flow.is_some());
        if !tiled {
            // SAFETY: the arguments match p2g in kernels/p2g.cu; buffers are sized for params. In the
            // binned pipeline, g2p2g marked every node block these stencils cover (same positions).
            return unsafe {
                k.p2g.launch(l, l.cover(self.num_particles), |a| {
                    a.arg(&params)
                        .arg(&self.x)
                        .arg(&self.bins.order)
                        .arg(&self.v)
                        .arg(&self.c)
                        .arg(&self.rho)
                        .arg(&self.grid_acc)
                        .arg(fixed_mass)
                        .arg(fixed_momentum)
                        .arg(&self.counters);
                })
            };
        }
        let list = self.bin_list()?;
        let config = self.tiled_pass(3);
        // SAFETY: the arguments match p2g_tiled in kernels/p2g_tiled.cu; as in p2g_init.
        unsafe {
            k.p2g_tiled.launch(l, config, |a| {
                a.arg(&params)
                    .arg(list)
                    .arg(&self.bins.order)
                    .arg(&self.x)
                    .arg(&self.v)
                    .arg(&self.c)
                    .arg(&self.rho)
                    .arg(&self.grid_acc)
                    .arg(fixed_mass)
                    .arg(fixed_momentum)
                    .arg(&self.node_blocks.marks)
                    .arg(&self.node_blocks.list)
                    .arg(&self.work_counts)
                    .arg(&self.counters);
            })
        }
    }

    /// Momentum to velocity, gravity, boundary band; zeroes the accumulators. The report's pipeline
    /// walks the whole grid; the binned one the node blocks this substep touched.
    pub fn grid_update(&mut self, params: &Params) -> Result<()> {
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("grid_update");
        let (fixed_mass, fixed_momentum) = self.fixed_grid();
        let (l, k) = (&self.launcher, &self.kernels);
        match self.pipeline {
            // SAFETY: the arguments match grid_update in kernels/grid_update.cu.
            Pipeline::Report => unsafe {
                k.grid_update.launch(l, l.cover(self.num_nodes()), |a| {
                    a.arg(&params)
                        .arg(&self.grid_acc)
                        .arg(&self.grid_vel)
                        .arg(fixed_mass)
                        .arg(fixed_momentum)
                        .arg(&self.counters);
                })
            },
            Pipeline::Binned => {
                let config = l.over_list(self.bins.num_bins(), NODE_BLOCK_NODES, 0);
                // SAFETY: the arguments match grid_update_blocks; one thread per node of a block.
                unsafe {
                    k.grid_update_blocks.launch(l, config, |a| {
                        a.arg(&params)
                            .arg(&self.node_blocks.list)
                            .arg(&self.work_counts)
                            .arg(&self.node_blocks.marks)
                            .arg(&self.grid_acc)
                            .arg(&self.grid_vel)
                            .arg(fixed_mass)
                            .arg(fixed_momentum)
                            .arg(&self.counters)
                            .arg(&self.colliders.states)
                            .arg(&self.colliders.count)
                            .arg(&self.colliders.sdf);
                    })?;
                }
                // Every listed block was visited and unmarked: the list starts empty again.
                self.launcher
                    .stream
                    .memset_zeros(&mut self.work_counts.slice_mut(WORK_NODE_BLOCKS..WORK_NODE_BLOCKS + 1))
                    .context("clearing the node block list")?;
                Ok(())
            }
        }
    }

    /// Velocity and C from the grid, soft wall, advection, clamp: the report's g2p, or the binned
    /// pipeline's g2p2g, which also scatters the mass of the new positions for the next substep.
    pub fn g2p(&mut self, params: &Params) -> Result<()> {
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("g2p");
        let (fixed_mass, _) = self.fixed_grid();
        let (l, k) = (&self.launcher, &self.kernels);
        match self.pipeline {
            // SAFETY: the arguments match g2p in kernels/g2p.cu.
            Pipeline::Report => unsafe {
                k.g2p.launch(l, l.cover(self.num_particles), |a| {
                    a.arg(&params)
                        .arg(&self.x)
                        .arg(&self.v)
                        .arg(&self.c)
                        .arg(&self.grid_vel)
                        .arg(&self.rho)
                        .arg(&self.counters);
                })
            },
            Pipeline::Binned => {
                let list = self.bin_list()?;
                let config = self.tiled_pass(1);
                let null: u64 = 0;
                let num_sinks = self.flow.as_ref().map_or(0, |f| f.num_sinks);
                // SAFETY: the arguments match g2p2g in kernels/g2p2g.cu; as in p2g_init. Without a
                // flow the sink and free-slot pointers are null and never read (no sinks).
                unsafe {
                    k.g2p2g.launch(l, config, |a| {
                        a.arg(&params)
                            .arg(list)
                            .arg(&self.bins.order)
                            .arg(&self.x)
                            .arg(&self.v)
                            .arg(&self.c)
                            .arg(&self.grid_vel)
                            .arg(&self.rho)
                            .arg(&self.grid_acc)
                            .arg(fixed_mass)
                            .arg(&self.node_blocks.marks)
                            .arg(&self.node_blocks.list)
                            .arg(&self.work_counts)
                            .arg(&self.counters)
                            .arg(&self.colliders.states)
                            .arg(&self.colliders.count)
                            .arg(&self.colliders.sdf);
                        match &self.flow {
                            Some(flow) => a
                                .arg(&flow.sinks)
                                .arg(&num_sinks)
                                .arg(&flow.free)
                                .arg(&flow.counters),
                            None => a.arg(&null).arg(&num_sinks).arg(&null).arg(&null),
                        };
                    })?;
                }
                self.mass_scattered = Some(params.scatter_mode);
                Ok(())
            }
        }
    }

    /// The substep's work, kernel by kernel, in stream order.
    fn enqueue_substep(&mut self, params: &Params, sort: bool) -> Result<()> {
        let stream = self.launcher.stream.clone();
        self.timing.begin_step(&stream)?;
        if sort {
            self.sort_particles(params)?;
        }
        self.steps_since_binning += 1;
        self.timing.mark(&stream, 1)?;
        if self.mass_scattered.is_none() {
            self.p2g_init(params)?;
        }
        self.mirror_mass(params)?;
        self.timing.mark(&stream, 2)?;
        self.p2g(params)?;
        self.timing.mark(&stream, 3)?;
        self.mirror_momentum(params)?;
        self.grid_update(params)?;
        self.timing.mark(&stream, 4)?;
        self.g2p(params)?;
        if let Some(flow) = self.flow.as_ref().filter(|f| f.num_sinks > 0) {
            flow.settle(&self.kernels.lifecycle, &self.launcher)?;
        }
        self.timing.mark(&stream, 5)?;
        Ok(())
    }

    /// Captures `enqueue_substep` into a graph; its host-side notes (binning, mass scattered) are
    /// made once here, as for a substep enqueued directly.
    fn capture_substep(&mut self, params: &Params, sort: bool) -> Result<SubstepGraph> {
        // Whatever a first use allocates (the fixed-point grid) must exist before the capture.
        self.device_params(params)?;
        let stream = self.launcher.stream.clone();
        let placeholders = self.timing.begin_capture()?;
        let graph = SubstepGraph::capture(&stream, &placeholders, || self.enqueue_substep(params, sort));
        self.timing.end_capture();
        graph
    }

    /// The scatter accumulators as the CPU reference's `Grid` holds them after p2g: mass and momentum
    /// per node (converted from fixed point where that scatter ran). Waits for the device.
    pub fn read_grid_accumulators(&mut self, params: &Params) -> Result<(Vec<f32>, Vec<Vec3>)> {
        let nodes = self.num_nodes();
        if params.scatter_mode == ScatterMode::FixedPoint.code() {
            let fixed = self
                .fixed
                .as_ref()
                .context("the fixed-point scatter has not run")?;
            let mass = self.download(&fixed.mass)?;
            let momentum = self.download(&fixed.momentum)?;
            let (ms, ps) = (1.0 / self.fixed_mass_scale, 1.0 / self.fixed_momentum_scale);
            let value = |q: u64, inv: f32| (q as i64) as f32 * inv;
            Ok((
                mass.iter().map(|&q| value(q, ms)).collect(),
                (0..nodes)
                    .map(|i| {
                        Vec3::new(
                            value(momentum[3 * i], ps),
                            value(momentum[3 * i + 1], ps),
                            value(momentum[3 * i + 2], ps),
                        )
                    })
                    .collect(),
            ))
        } else {
            let acc = self.download(&self.grid_acc)?;
            Ok(split_float4(&acc))
        }
    }

    /// The particle order of the last binning (identity before the first). Waits for the device.
    pub fn read_order(&mut self) -> Result<Vec<u32>> {
        self.download(&self.bins.order)
    }

    /// The binned pipeline's bin list: (bin, start, count) per chunk of a bin that holds particles,
    /// in the order the last binning listed them. Waits for the device.
    pub fn read_bin_list(&mut self) -> Result<Vec<[u32; 3]>> {
        let list = self
            .bins
            .list
            .as_ref()
            .context("only the binned pipeline lists its bins")?;
        let counts = self.download(&self.work_counts)?;
        let entries = self.download(list)?;
        Ok(entries
            .chunks_exact(bins::BIN_ENTRY_WORDS)
            .take(counts[bins::WORK_BINS] as usize)
            .map(|e| [e[0], e[1], e[2]])
            .collect())
    }

    /// Node mass and velocity as the grid update left them. Waits for the device.
    pub fn read_grid_velocity(&mut self) -> Result<(Vec<f32>, Vec<Vec3>)> {
        let vel = self.download(&self.grid_vel)?;
        Ok(split_float4(&vel))
    }

    fn download<T: DeviceRepr + Default + Clone>(&self, buffer: &CudaSlice<T>) -> Result<Vec<T>> {
        let mut host = vec![T::default(); buffer.len()];
        let stream = &self.launcher.stream;
        stream
            .memcpy_dtoh(buffer, &mut host)
            .context("copying from the GPU (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
        stream
            .synchronize()
            .context("waiting for the GPU (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
        Ok(host)
    }

    /// The CUDA context, for registering GL buffers with it (src/cuda/interop.rs).
    pub fn context(&self) -> &Arc<CudaContext> {
        &self.ctx
    }

    /// The stream every launch of this solver goes to; interop maps and unmaps on it, so a mapped
    /// buffer is written after the step's kernels and drawn after the write.
    pub fn stream(&self) -> &Arc<CudaStream> {
        &self.launcher.stream
    }

    pub fn num_particles(&self) -> usize {
        self.num_particles
    }

    /// Writes one float4 per particle (position, `colour_by` value) to device memory at `out`, which
    /// must hold `16 * num_particles()` bytes: a mapped GL buffer (`interop::MappedBuffer`), so the
    /// renderer draws the state without a host round trip. Asynchronous on `stream()`.
    ///
    /// # Safety
    /// `out` must be a live device allocation of at least `16 * num_particles()` bytes in this context.
    pub unsafe fn write_render_attributes_raw(
        &mut self,
        out: cudarc::driver::sys::CUdeviceptr,
        colour_by: ColourBy,
        rest_density: f32,
    ) -> Result<()> {
        let n = self.num_particles as u32;
        let code = colour_by.code();
        let inv_rest_density = 1.0 / rest_density;
        let l = &self.launcher;
        // SAFETY: the arguments match kernels/render.cu; the caller vouches for `out`.
        unsafe {
            self.kernels
                .render_attributes
                .launch(l, l.cover(self.num_particles), |a| {
                    a.arg(&self.x)
                        .arg(&self.v)
                        .arg(&self.rho)
                        .arg(&n)
                        .arg(&code)
                        .arg(&inv_rest_density)
                        .arg(&out);
                })
        }
    }

    /// The same attributes into a device buffer of this solver's (the host-copy path copies it out).
    pub fn write_render_attributes(
        &mut self,
        out: &mut CudaSlice<f32>,
        colour_by: ColourBy,
        rest_density: f32,
    ) -> Result<()> {
        ensure!(
            out.len() >= 4 * self.num_particles,
            "render attribute buffer holds {} floats, needs {}",
            out.len(),
            4 * self.num_particles
        );
        let stream = self.launcher.stream.clone();
        let (ptr, _guard) = cudarc::driver::DevicePtrMut::device_ptr_mut(out, &stream);
        // SAFETY: `out` is a live allocation of this context, large enough (checked above).
        unsafe { self.write_render_attributes_raw(ptr, colour_by, rest_density) }
    }

    fn upload(&mut self, particles: &Particles) -> Result<()> {
        let n = particles.len();
        ensure!(
            n == self.num_particles,
            "{n} particles for a solver of {}",
            self.num_particles
        );
        let float4 = |v: &[Vec3]| -> Vec<f32> { v.iter().flat_map(|p| [p.x, p.y, p.z, 0.0]).collect() };
        // x.w marks a parked slot (PARKED_W in kernels/common.cuh).
        let positions: Vec<f32> = particles
            .x
            .iter()
            .zip(&particles.live)
            .flat_map(|(p, &live)| [p.x, p.y, p.z, if live { 0.0 } else { PARKED_W }])
            .collect();
        let mut c = Vec::with_capacity(12 * n);
        for col in 0..3 {
            c.extend(particles.c.iter().flat_map(|m| {
                let v = m.col(col);
                [v.x, v.y, v.z, 0.0]
            }));
        }
        let stream = &self.launcher.stream;
        stream
            .memcpy_htod(&positions, &mut self.x)
            .context("uploading positions")?;
        stream
            .memcpy_htod(&float4(&particles.v), &mut self.v)
            .context("uploading velocities")?;
        stream.memcpy_htod(&c, &mut self.c).context("uploading C")?;
        stream
            .memcpy_htod(&particles.rho, &mut self.rho)
            .context("uploading densities")?;
        stream.synchronize().context("uploading particles")?;
        Ok(())
    }

    /// kernels/spawn.cu: count pass, prefix sum of the per-block counts here, write pass.
    fn spawn_on_device(&mut self, scene: &Scene) -> Result<()> {
        let _range = NvtxRange::new("spawn");
        let (table, candidates) = spawn::body_table(scene)?;
        let block = self.options.block_size;
        let blocks_u64 = candidates.div_ceil(u64::from(block));
        ensure!(
            blocks_u64 <= u64::from(i32::MAX as u32),
            "scene {}: {candidates} lattice candidates are too many to spawn on the device",
            scene.source
        );
        let blocks = blocks_u64 as u32;
        let config = LaunchConfig {
            grid_dim: (blocks, 1, 1),
            block_dim: (block, 1, 1),
            shared_mem_bytes: 0,
        };
        let stream = self.launcher.stream.clone();
        let bodies: CudaSlice<SpawnBody> = stream.clone_htod(&table).context("uploading bodies")?;
        let num_bodies = table.len() as u32;
        let spacing = scene.lattice().spacing;
        let counts = stream
            .alloc_zeros::<u32>(blocks as usize)
            .context("spawn counts")?;
        let l = &self.launcher;
        // SAFETY: arguments match spawn_count in kernels/spawn.cu; `counts` has one slot per block.
        unsafe {
            self.kernels.spawn_count.launch(l, config, |a| {
                a.arg(&bodies)
                    .arg(&num_bodies)
                    .arg(&spacing)
                    .arg(&candidates)
                    .arg(&counts);
            })?;
        }

        let block_counts = self.download(&counts)?;
        let mut offsets = Vec::with_capacity(block_counts.len());
        let mut total = 0u64;
        for &count in &block_counts {
            offsets.push(total as u32);
            total += u64::from(count);
        }
        ensure!(
            total == self.num_particles as u64,
            "device spawn made {total} particles but scene {} has {} (the device and host lattices disagree)",
            scene.source,
            self.num_particles
        );
        let offsets = stream.clone_htod(&offsets).context("uploading spawn offsets")?;
        let rest_density = scene.material.rest_density;
        let n = self.num_particles as u32;
        let l = &self.launcher;
        // SAFETY: as above; every output holds `n` particles.
        unsafe {
            self.kernels.spawn_write.launch(l, config, |a| {
                a.arg(&bodies)
                    .arg(&num_bodies)
                    .arg(&spacing)
                    .arg(&candidates)
                    .arg(&offsets)
                    .arg(&rest_density)
                    .arg(&n)
                    .arg(&self.x)
                    .arg(&self.v)
                    .arg(&self.c)
                    .arg(&self.rho);
            })?;
        }
        stream.synchronize().context("spawning particles on the GPU")?;
        Ok(())
    }
}

impl Solver for CudaSolver {
    fn name(&self) -> &'static str {
        "cuda"
    }

    /// One substep, as the table at the top of this file lists its phases: enqueued kernel by kernel
    /// (`enqueue_substep`), or as one launch of a captured graph of exactly that work (graph.rs).
    fn step(&mut self, params: &Params) -> Result<()> {
        let sort = self.binning_due();
        let graphs = self.options.graphs && !self.launcher.sync_each_launch && self.substeps > 0;
        self.substeps += 1;
        if !graphs {
            let _range = NvtxRange::new("substep");
            return self.enqueue_substep(params, sort);
        }
        let _range = NvtxRange::new("substep (graph)");
        let key = SubstepKey {
            params: *params,
            sort,
            mass_scattered: self.mass_scattered,
            colliders: self.colliders.count,
        };
        let graph = match self.graphs.take(&key) {
            Some(graph) => {
                // What enqueue_substep's calls note on the host, for the work the graph replays.
                if sort {
                    self.note_binning();
                }
                self.steps_since_binning += 1;
                graph
            }
            None => self.capture_substep(params, sort)?,
        };
        let launched = self
            .timing
            .begin_graphed_step()
            .and_then(|events| graph.launch(events));
        self.graphs.put(key, graph);
        launched
    }

    fn emit(&mut self, params: &Params, mask: u32) -> Result<()> {
        let params = self.device_params(params)?;
        let scatter_mass = u32::from(self.mass_scattered.is_some());
        let flow = self.flow.as_ref().context("this CUDA solver has no emitters")?;
        let (fixed_mass, _) = self.fixed_grid();
        let l = &self.launcher;
        // SAFETY: arguments match emit_particles in kernels/lifecycle.cu; the point buffers hold
        // num_points entries, the particle buffers every slot, `free` the capacity.
        unsafe {
            self.kernels
                .lifecycle
                .emit
                .launch(l, DeviceFlow::one_block(), |a| {
                    a.arg(&params)
                        .arg(&mask)
                        .arg(&flow.points)
                        .arg(&flow.num_points)
                        .arg(&flow.velocities)
                        .arg(&flow.clearance_sq)
                        .arg(&flow.emits)
                        .arg(&flow.last)
                        .arg(&flow.free)
                        .arg(&flow.counters)
                        .arg(&self.x)
                        .arg(&self.v)
                        .arg(&self.c)
                        .arg(&self.rho)
                        .arg(&scatter_mass)
                        .arg(&self.grid_acc)
                        .arg(fixed_mass)
                        .arg(&self.node_blocks.marks)
                        .arg(&self.node_blocks.list)
                        .arg(&self.work_counts)
                        .arg(&self.counters);
                })?;
        }
        // The new particles are in no bin yet.
        self.bins_built = false;
        Ok(())
    }

    fn flow_counts(&mut self) -> Result<Option<FlowCounts>> {
        let Some(flow) = &self.flow else { return Ok(None) };
        let counters = self.download(&flow.counters)?;
        Ok(Some(DeviceFlow::counts(&counters, flow.capacity)))
    }

    fn flow_state(&mut self) -> Result<Option<FlowState>> {
        let Some(flow) = &self.flow else { return Ok(None) };
        let counters = self.download(&flow.counters)?;
        let free = self.download(&flow.free)?;
        let mut last = self.download(&flow.last)?;
        last.truncate(flow.num_points as usize);
        Ok(Some(DeviceFlow::state(&counters, &free, last, flow.capacity)))
    }

    fn take_extremes(&mut self) -> Result<StepExtremes> {
        let ticket = self.request_extremes()?;
        self.wait_extremes(ticket)
    }

    /// Copies the counters to a pinned host slot and resets them, both in stream order behind the
    /// substeps enqueued so far; nothing waits.
    fn request_extremes(&mut self) -> Result<ExtremesTicket> {
        let slot = self.next_counter_copy;
        self.next_counter_copy = (slot + 1) % COUNTER_COPIES;
        let stream = &self.launcher.stream;
        let (copy, copied) = &mut self.counter_copies[slot];
        stream
            .memcpy_dtoh(&self.counters, copy)
            .context("copying the step counters (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
        copied.record(stream).context("recording the counters' copy")?;
        stream
            .memset_zeros(&mut self.counters)
            .context("resetting the step counters")?;
        Ok(ExtremesTicket::Pending(slot))
    }

    /// Waits for that slot's copy only (its own event), not for the whole stream.
    fn wait_extremes(&mut self, ticket: ExtremesTicket) -> Result<StepExtremes> {
        let slot = match ticket {
            ExtremesTicket::Ready(extremes) => return Ok(extremes),
            ExtremesTicket::Pending(slot) => slot,
        };
        let (copy, copied) = self
            .counter_copies
            .get(slot)
            .context("an extremes ticket of another solver")?;
        let waited = copied.synchronize().and_then(|()| copy.as_slice());
        let counters = waited
            .context("waiting for the step counters (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?
            .to_vec();
        let overflows = counters[COUNTER_FIXED_OVERFLOWS];
        if overflows > 0 {
            bail!(
                "the fixed-point scatter overflowed {overflows} times since the last frame (a grid \
                 contribution or sum left the 64-bit range at {:.3e} units/kg, {:.3e} units/(kg m/s)); \
                 the fluid is moving far faster than expected, or blowing up. Lower the CFL number; \
                 the report pipeline's float scatter (solver.pipeline = \"report\", solver.scatter = \
                 \"float\") has no such bound",
                self.fixed_mass_scale,
                self.fixed_momentum_scale
            );
        }
        self.rebin_requested |= counters[COUNTER_REBIN_NEEDED] != 0;
        self.tile_misses += u64::from(counters[COUNTER_TILE_MISSES]);
        Ok(StepExtremes {
            max_density: f32::from_bits(counters[COUNTER_MAX_DENSITY]),
            max_speed: f32::from_bits(counters[COUNTER_MAX_SPEED]),
            max_signal_speed: f32::from_bits(counters[COUNTER_MAX_SIGNAL]),
            backstop_pushes: u64::from(counters[COUNTER_BACKSTOP_PUSHES]),
        })
    }

    fn take_step_timings(&mut self) -> Result<Option<Vec<PhaseTimings>>> {
        self.timing.take_completed().map(Some)
    }

    /// Uploads the states where they changed, and the mesh samples once (in stream order, so the
    /// substeps already enqueued keep the states they were launched with).
    fn set_colliders(&mut self, frame: &ColliderFrame) -> Result<()> {
        ensure!(
            frame.is_empty() || self.pipeline == Pipeline::Binned,
            "the report pipeline applies no colliders; use --pipeline binned (or solver.pipeline = \"binned\")"
        );
        ensure!(
            frame.states.len() <= MAX_COLLIDERS,
            "{} colliders, more than the {MAX_COLLIDERS} the kernels take",
            frame.states.len()
        );
        let stream = self.launcher.stream.clone();
        let device = &mut self.colliders;
        let sdf_is_new = device
            .sdf_source
            .as_ref()
            .is_none_or(|source| !Arc::ptr_eq(source, &frame.sdf));
        if sdf_is_new && !frame.sdf.is_empty() {
            device.sdf = stream
                .clone_htod(&frame.sdf[..])
                .context("uploading the mesh colliders' distance fields")?;
            device.sdf_source = Some(frame.sdf.clone());
        }
        if device.uploaded != frame.states {
            if !frame.states.is_empty() {
                stream
                    .memcpy_htod(
                        &frame.states[..],
                        &mut device.states.slice_mut(0..frame.states.len()),
                    )
                    .context("uploading the collider states")?;
            }
            device.uploaded.clone_from(&frame.states);
            device.count = frame.states.len() as u32;
        }
        Ok(())
    }

    fn apply_push(&mut self, push: &Push) -> Result<()> {
        let n = self.num_particles as u32;
        let l = &self.launcher;
        // SAFETY: the arguments match kernels/render.cu; x and v hold n float4.
        unsafe {
            self.kernels
                .push_particles
                .launch(l, l.cover(self.num_particles), |a| {
                    a.arg(push).arg(&n).arg(&self.x).arg(&self.v);
                })
        }
    }

    /// Launches the attribute kernel into a scratch buffer and copies that to the host.
    fn render_attributes(
        &mut self,
        colour_by: ColourBy,
        rest_density: f32,
        out: &mut Vec<[f32; 4]>,
    ) -> Result<()> {
        let mut scratch = match self.render_scratch.take() {
            Some(scratch) => scratch,
            None => self
                .launcher
                .stream
                .alloc_zeros::<f32>(4 * self.num_particles)
                .context("allocating render attributes")?,
        };
        let written = self.write_render_attributes(&mut scratch, colour_by, rest_density);
        let flat = written.and_then(|()| self.download(&scratch));
        self.render_scratch = Some(scratch);
        let flat = flat?;
        out.clear();
        out.extend(flat.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]));
        Ok(())
    }

    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }

    fn read_particles(&mut self) -> Result<Particles> {
        let n = self.num_particles;
        let x = self.download(&self.x)?;
        let v = self.download(&self.v)?;
        let c = self.download(&self.c)?;
        let rho = self.download(&self.rho)?;
        let vec3 = |a: &[f32], i: usize| Vec3::new(a[4 * i], a[4 * i + 1], a[4 * i + 2]);
        Ok(Particles {
            x: (0..n).map(|i| vec3(&x, i)).collect(),
            v: (0..n).map(|i| vec3(&v, i)).collect(),
            c: (0..n)
                .map(|i| Mat3::from_cols(vec3(&c, i), vec3(&c, n + i), vec3(&c, 2 * n + i)))
                .collect(),
            rho,
            live: (0..n).map(|i| x[4 * i + 3] == 0.0).collect(),
        })
    }

    /// A device reduction (kernels/stats.cu): the host reads a few KiB, never the particles.
    fn summary(&mut self, material: &Material) -> Result<Summary> {
        let ticket = self.request_summary(material)?;
        self.wait_summary(ticket)
    }

    fn request_summary(&mut self, material: &Material) -> Result<SummaryTicket> {
        let params = Params {
            material: *material,
            grid_res: self.grid_res,
            num_particles: self.num_particles as u32,
            ..bytemuck::Zeroable::zeroed()
        };
        self.stats
            .request(&self.launcher, &params, &self.x, &self.v, &self.rho)?;
        Ok(SummaryTicket::Pending)
    }

    fn wait_summary(&mut self, ticket: SummaryTicket) -> Result<Summary> {
        match ticket {
            SummaryTicket::Ready(summary) => Ok(summary),
            SummaryTicket::Pending => self.stats.wait(),
        }
    }
}

/// Fixed-point scales from the scene: a grid node at rest holds one cell's mass, rho0 dx^3, so that
/// maps to 2^40 units; momentum maps one cell's mass at the reference speed to 2^40 units. The speed is
/// the largest of the sound speed, the free-fall speed over the domain height and the bodies' speeds:
/// a bound the fluid does not pass while the CFL policy holds. Contributions then sit near 2^37, far
/// under the 2^52 per-contribution limit, and the rounding step (2^-40 of a cell's mass) is far finer
/// than f32 resolves.
pub fn fixed_point_scales(scene: &Scene) -> (f32, f32) {
    let dx = f64::from(scene.dx);
    let cell_mass = f64::from(scene.material.rest_density) * dx * dx * dx;
    let height = f64::from(scene.grid_res.iter().copied().max().unwrap_or(1)) * dx;
    let free_fall = (2.0 * f64::from(scene.gravity.length()) * height).sqrt();
    let body_speed = f64::from(scene.fastest_start());
    let speed = f64::from(scene.material.sound_speed())
        .max(free_fall)
        .max(body_speed)
        .max(1e-3);
    let units = (1u64 << 40) as f64;
    ((units / cell_mass) as f32, (units / (cell_mass * speed)) as f32)
}

fn split_float4(values: &[f32]) -> (Vec<f32>, Vec<Vec3>) {
    values
        .chunks_exact(4)
        .map(|q| (q[3], Vec3::new(q[0], q[1], q[2])))
        .unzip()
}

fn gib(bytes: usize) -> f64 {
    bytes as f64 / (1u64 << 30) as f64
}
