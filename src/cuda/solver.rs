//! `CudaSolver`: the particle state on the device and one substep as four kernel launches.
//!
//! Phases, in step order (each an NVTX range and a pair of CUDA events):
//!   [sort, every SORT_INTERVAL substeps] -> p2g_init -> p2g -> grid_update (also the grid clear:
//!   consume-and-zero) -> g2p
//! The sort (kernels/sort.cu) only rewrites an index buffer, `order`, that the scatter kernels walk;
//! its time has its own slot, `PhaseTimings::sort` (near 0 on the substeps it does not run).
//! The grid clear has no launch of its own: grid_update zeroes each accumulator after reading it, so
//! `PhaseTimings::grid_clear` stays 0 and its cost is inside grid_update.

use super::library;
use super::modules::{LoadedModules, Origin};
use super::spawn::{self, SpawnBody};
use super::timing::PhaseEvents;
use crate::sim::params::ScatterMode;
use crate::sim::{ColourBy, Params, Particles, PhaseTimings, Push, Scene, Solver, StepExtremes};
use anyhow::{anyhow, bail, ensure, Context, Result};
use cudarc::driver::{
    CudaContext, CudaFunction, CudaSlice, CudaStream, DeviceRepr, LaunchConfig, PushKernelArg,
};
use glam::{Mat3, Vec3};
use std::sync::Arc;

// SAFETY: `Params` is `#[repr(C)]` and Pod; kernels/common.cuh mirrors it with static_asserts.
unsafe impl DeviceRepr for Params {}
// SAFETY: `Push` is `#[repr(C)]` and Pod; kernels/render.cu mirrors it with a static_assert.
unsafe impl DeviceRepr for Push {}

/// Where and how to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CudaOptions {
    /// CUDA device ordinal.
    pub device: usize,
    /// Threads per block of the particle and grid kernels: a multiple of 32 (the kernels reduce per
    /// warp with full-mask shuffles), at most 1024.
    pub block_size: u32,
}

impl Default for CudaOptions {
    fn default() -> Self {
        CudaOptions {
            device: 0,
            block_size: 128,
        }
    }
}

impl CudaOptions {
    /// The defaults, overridden by `MPM_CUDA_DEVICE` and `MPM_CUDA_BLOCK_SIZE` where set.
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

/// What the kernels count and reduce during a frame; mirrors `StepCounters` in kernels/common.cuh.
const COUNTERS: usize = 4;
const COUNTER_MAX_DENSITY: usize = 0;
const COUNTER_MAX_SPEED: usize = 1;
const COUNTER_FIXED_OVERFLOWS: usize = 2;
const COUNTER_MAX_SIGNAL: usize = 3;

/// Fixed-point accumulators, allocated on first use of the fixed-point scatter.
struct FixedGrid {
    mass: CudaSlice<u64>,
    /// Three per node, interleaved.
    momentum: CudaSlice<u64>,
}

/// Substeps between particle sorts. Particles move well under a cell per substep, so an order a few
/// substeps old is nearly as good as a fresh one, and the sort's cost (a few small launches) is shared.
pub const SORT_INTERVAL: u32 = 8;
/// Values each thread of `scan_tiles` scans (SCAN_ITEMS_PER_THREAD in kernels/sort.cu).
const SCAN_ITEMS_PER_THREAD: usize = 8;

/// The counting sort's scratch: per-particle key and rank, and the per-cell counts with the tile
/// sums of each level of the scan above them.
struct SortBuffers {
    key: CudaSlice<u32>,
    rank: CudaSlice<u32>,
    /// levels[0]: one count (then start) per node; levels[i + 1]: the tile sums of levels[i]. The
    /// last level fits one tile; `top` takes its (unused) total.
    levels: Vec<CudaSlice<u32>>,
    top: CudaSlice<u32>,
}

/// What `mirror_walls` mirrors: the codes of kernels/mirror_walls.cu.
#[derive(Clone, Copy)]
enum MirrorQuantity {
    Mass = 0,
    Momentum = 1,
}

struct Kernels {
    sort_count: CudaFunction,
    scan_tiles: CudaFunction,
    scan_add: CudaFunction,
    sort_scatter: CudaFunction,
    p2g_init: CudaFunction,
    p2g: CudaFunction,
    grid_update: CudaFunction,
    g2p: CudaFunction,
    mirror_walls: CudaFunction,
    spawn_count: CudaFunction,
    spawn_write: CudaFunction,
    render_attributes: CudaFunction,
    push_particles: CudaFunction,
}

impl Kernels {
    fn load(modules: &LoadedModules) -> Result<Kernels> {
        Ok(Kernels {
            sort_count: modules.function("sort", "sort_count")?,
            scan_tiles: modules.function("sort", "scan_tiles")?,
            scan_add: modules.function("sort", "scan_add")?,
            sort_scatter: modules.function("sort", "sort_scatter")?,
            p2g_init: modules.function("p2g_init", "p2g_init")?,
            p2g: modules.function("p2g", "p2g")?,
            grid_update: modules.function("grid_update", "grid_update")?,
            g2p: modules.function("g2p", "g2p")?,
            mirror_walls: modules.function("mirror_walls", "mirror_walls")?,
            spawn_count: modules.function("spawn", "spawn_count")?,
            spawn_write: modules.function("spawn", "spawn_write")?,
            render_attributes: modules.function("render", "render_attributes")?,
            push_particles: modules.function("render", "push_particles")?,
        })
    }
}

pub struct CudaSolver {
    ctx: Arc<CudaContext>,
    stream: Arc<CudaStream>,
    kernels: Kernels,
    module_origin: Origin,
    options: CudaOptions,
    num_particles: usize,
    grid_res: [u32; 3],
    /// x, y, z, unused: one float4 per particle (a layout a GL vertex buffer can share).
    x: CudaSlice<f32>,
    /// vx, vy, vz, unused.
    v: CudaSlice<f32>,
    /// C as three float4 arrays of N (columns 0, 1, 2).
    c: CudaSlice<f32>,
    rho: CudaSlice<f32>,
    /// Particle indices in cell order: p2g_init and p2g walk particles through it.
    order: CudaSlice<u32>,
    sort: SortBuffers,
    steps_since_sort: u32,
    /// Scatter accumulators, float4 per node: momentum xyz, mass w. Zeroed by grid_update.
    grid_acc: CudaSlice<f32>,
    /// Node velocity xyz and mass w, written by grid_update, read by g2p.
    grid_vel: CudaSlice<f32>,
    fixed: Option<FixedGrid>,
    /// Passed for the fixed-point pointers when the float scatter runs (never dereferenced).
    unused_fixed: CudaSlice<u64>,
    counters: CudaSlice<u32>,
    fixed_mass_scale: f32,
    fixed_momentum_scale: f32,
    timing: PhaseEvents,
    /// Device scratch of the host-copy render path (allocated on first use, kept).
    render_scratch: Option<CudaSlice<f32>>,
    /// `MPM_CUDA_SYNC=1`: wait after every launch, so an asynchronous fault names its kernel.
    sync_each_launch: bool,
}

/// Bytes on the device per particle (x, v as float4; C as 3 float4; rho; order, sort key and rank)
/// and per node (two float4, the sort's cell count).
pub const BYTES_PER_PARTICLE: usize = 4 * (4 + 4 + 12 + 1 + 3);
pub const BYTES_PER_NODE: usize = 4 * (4 + 4 + 1);
/// Added per node by the fixed-point scatter: mass and three momentum components as u64.
pub const FIXED_BYTES_PER_NODE: usize = 8 * 4;

impl CudaSolver {
    /// Spawns `scene`'s particles on the device, in the order of `Scene::spawn()`.
    pub fn new(scene: &Scene, options: CudaOptions) -> Result<CudaSolver> {
        let mut solver = CudaSolver::allocate(scene, options)?;
        solver.spawn_on_device(scene)?;
        Ok(solver)
    }

    /// Uploads `particles` (for tests: any state, not only a spawned one) into a solver for `scene`'s
    /// grid and material.
    pub fn from_particles(scene: &Scene, particles: &Particles, options: CudaOptions) -> Result<CudaSolver> {
        let mut scene = scene.clone();
        scene.num_particles = particles.len();
        let mut solver = CudaSolver::allocate(&scene, options)?;
        solver.upload(particles)?;
        Ok(solver)
    }

    fn allocate(scene: &Scene, options: CudaOptions) -> Result<CudaSolver> {
        options.validate()?;
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

        let n = scene.num_particles;
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

        let alloc_f32 = |len: usize, what: &str| {
            stream
                .alloc_zeros::<f32>(len)
                .with_context(|| format!("allocating {what} ({len} floats)"))
        };
        let (fixed_mass_scale, fixed_momentum_scale) = fixed_point_scales(scene);
        let alloc_u32 = |len: usize, what: &str| {
            stream
                .alloc_zeros::<u32>(len)
                .with_context(|| format!("allocating {what} ({len} values)"))
        };
        let tile = options.block_size as usize * SCAN_ITEMS_PER_THREAD;
        let mut levels = vec![alloc_u32(nodes, "the sort's cell counts")?];
        let mut level_len = nodes;
        while level_len > tile {
            level_len = level_len.div_ceil(tile);
            levels.push(alloc_u32(level_len, "the sort's scan")?);
        }
        let identity: Vec<u32> = (0..n as u32).collect();
        let mut solver = CudaSolver {
            order: stream
                .clone_htod(&identity)
                .context("allocating the particle order")?,
            sort: SortBuffers {
                key: alloc_u32(n, "sort keys")?,
                rank: alloc_u32(n, "sort ranks")?,
                levels,
                top: alloc_u32(1, "the sort's scan")?,
            },
            steps_since_sort: 0,
            x: alloc_f32(4 * n, "particle positions")?,
            v: alloc_f32(4 * n, "particle velocities")?,
            c: alloc_f32(12 * n, "particle affine matrices")?,
            rho: alloc_f32(n, "particle densities")?,
            grid_acc: alloc_f32(4 * nodes, "grid accumulators")?,
            grid_vel: alloc_f32(4 * nodes, "grid velocities")?,
            fixed: None,
            unused_fixed: stream.alloc_zeros::<u64>(1).context("allocating a placeholder")?,
            counters: stream
                .alloc_zeros::<u32>(COUNTERS)
                .context("allocating step counters")?,
            timing: PhaseEvents::new(ctx.clone()),
            ctx,
            stream,
            kernels,
            module_origin: modules.origin,
            options,
            num_particles: n,
            grid_res: scene.grid_res,
            fixed_mass_scale,
            fixed_momentum_scale,
            render_scratch: None,
            sync_each_launch: std::env::var("MPM_CUDA_SYNC").is_ok_and(|v| v == "1"),
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

    /// The fixed-point scales this solver fills into `Params` (units per kg, units per kg m/s).
    pub fn fixed_point_scales(&self) -> (f32, f32) {
        (self.fixed_mass_scale, self.fixed_momentum_scale)
    }

    fn ensure_fixed_grid(&mut self) -> Result<()> {
        if self.fixed.is_none() {
            let nodes = self.num_nodes();
            self.fixed = Some(FixedGrid {
                mass: self
                    .stream
                    .alloc_zeros::<u64>(nodes)
                    .context("allocating fixed-point mass")?,
                momentum: self
                    .stream
                    .alloc_zeros::<u64>(3 * nodes)
                    .context("allocating fixed-point momentum")?,
            });
        }
        Ok(())
    }

    fn num_nodes(&self) -> usize {
        self.grid_res.iter().map(|&r| r as usize).product()
    }

    /// 1D launch covering `count` items (the kernels loop grid-stride, so any count fits).
    fn launch_config(&self, count: usize) -> LaunchConfig {
        let blocks = count.div_ceil(self.options.block_size as usize).clamp(1, 1 << 20) as u32;
        LaunchConfig {
            grid_dim: (blocks, 1, 1),
            block_dim: (self.options.block_size, 1, 1),
            shared_mem_bytes: 0,
        }
    }

    fn after_launch(&self, kernel: &str, launched: Result<(), cudarc::driver::DriverError>) -> Result<()> {
        launched.with_context(|| format!("launching kernel `{kernel}`"))?;
        if self.sync_each_launch {
            self.stream
                .synchronize()
                .with_context(|| format!("kernel `{kernel}` failed while running"))?;
        }
        Ok(())
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
        let mut device = *params;
        if params.scatter_mode == ScatterMode::FixedPoint.code() {
            self.ensure_fixed_grid()?;
            device.fixed_mass_scale = self.fixed_mass_scale;
            device.fixed_momentum_scale = self.fixed_momentum_scale;
        }
        Ok(device)
    }

    /// Rewrites `order` so that particles of one cell are consecutive (kernels/sort.cu).
    pub fn sort_particles(&mut self, params: &Params) -> Result<()> {
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("sort");
        self.stream
            .memset_zeros(&mut self.sort.levels[0])
            .context("clearing the sort's cell counts")?;
        let sort = &self.sort;
        let cfg = self.launch_config(self.num_particles);
        let mut launch = self.stream.launch_builder(&self.kernels.sort_count);
        launch
            .arg(&params)
            .arg(&self.x)
            .arg(&sort.levels[0])
            .arg(&sort.key)
            .arg(&sort.rank);
        // SAFETY: arguments match kernels/sort.cu; levels[0] has one count per node.
        let launched = unsafe { launch.launch(cfg) }.map(drop);
        self.after_launch("sort_count", launched)?;

        // Exclusive scan of the counts: scan each level's tiles (their totals go one level up), then
        // add the scanned totals back down.
        let block = self.options.block_size;
        let tile = block as usize * SCAN_ITEMS_PER_THREAD;
        let tiles_of = |len: usize| LaunchConfig {
            grid_dim: (len.div_ceil(tile) as u32, 1, 1),
            block_dim: (block, 1, 1),
            shared_mem_bytes: block * 4,
        };
        let lens: Vec<u32> = sort.levels.iter().map(|l| l.len() as u32).collect();
        for (level, (counts, &len)) in sort.levels.iter().zip(&lens).enumerate() {
            let sums = sort.levels.get(level + 1).unwrap_or(&sort.top);
            let mut launch = self.stream.launch_builder(&self.kernels.scan_tiles);
            launch.arg(counts).arg(&len).arg(sums);
            // SAFETY: as above; `sums` has one slot per tile of this level.
            let launched = unsafe { launch.launch(tiles_of(len as usize)) }.map(drop);
            self.after_launch("scan_tiles", launched)?;
        }
        for level in (0..sort.levels.len() - 1).rev() {
            let mut launch = self.stream.launch_builder(&self.kernels.scan_add);
            launch
                .arg(&sort.levels[level])
                .arg(&lens[level])
                .arg(&sort.levels[level + 1]);
            // SAFETY: as above.
            let launched = unsafe { launch.launch(tiles_of(lens[level] as usize)) }.map(drop);
            self.after_launch("scan_add", launched)?;
        }

        let n = self.num_particles as u32;
        let mut launch = self.stream.launch_builder(&self.kernels.sort_scatter);
        launch
            .arg(&n)
            .arg(&sort.key)
            .arg(&sort.rank)
            .arg(&sort.levels[0])
            .arg(&self.order);
        // SAFETY: as above; every start + rank is below n.
        let launched = unsafe { launch.launch(cfg) }.map(drop);
        self.after_launch("sort_scatter", launched)
    }

    /// Mass scatter: m_i += w m_p.
    pub fn p2g_init(&mut self, params: &Params) -> Result<()> {
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("p2g_init");
        let cfg = self.launch_config(self.num_particles);
        let fixed_mass = self.fixed.as_ref().map_or(&self.unused_fixed, |f| &f.mass);
        let mut launch = self.stream.launch_builder(&self.kernels.p2g_init);
        launch
            .arg(&params)
            .arg(&self.x)
            .arg(&self.order)
            .arg(&self.grid_acc)
            .arg(fixed_mass)
            .arg(&self.counters);
        // SAFETY: the arguments match the kernel's signature; buffers are sized for params.
        let launched = unsafe { launch.launch(cfg) }.map(drop);
        self.after_launch("p2g_init", launched)
    }

    /// The walls' image mass, between p2g_init and p2g (kernels/mirror_walls.cu).
    pub fn mirror_mass(&mut self, params: &Params) -> Result<()> {
        self.mirror_walls(params, MirrorQuantity::Mass)
    }

    /// The walls' image momentum, wall-normal component reflected, between p2g and grid_update.
    pub fn mirror_momentum(&mut self, params: &Params) -> Result<()> {
        self.mirror_walls(params, MirrorQuantity::Momentum)
    }

    /// One launch per axis, x, y, z in turn: each axis's images must include the previous axes'.
    fn mirror_walls(&mut self, params: &Params, quantity: MirrorQuantity) -> Result<()> {
        if params.wall_mirror_lo == 0 {
            return Ok(());
        }
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("mirror_walls");
        let (fixed_mass, fixed_momentum) = match &self.fixed {
            Some(f) => (&f.mass, &f.momentum),
            None => (&self.unused_fixed, &self.unused_fixed),
        };
        let res = self.grid_res.map(|r| r as usize);
        for axis in 0..3u32 {
            let lines = res[(axis as usize + 1) % 3] * res[(axis as usize + 2) % 3];
            let quantity_code = quantity as u32;
            let mut launch = self.stream.launch_builder(&self.kernels.mirror_walls);
            launch
                .arg(&params)
                .arg(&axis)
                .arg(&quantity_code)
                .arg(&self.grid_acc)
                .arg(fixed_mass)
                .arg(fixed_momentum);
            // SAFETY: as in p2g_init.
            let launched = unsafe { launch.launch(self.launch_config(lines)) }.map(drop);
            self.after_launch("mirror_walls", launched)?;
        }
        Ok(())
    }

    /// Density from the grid mass, pressure and stress, momentum scatter.
    pub fn p2g(&mut self, params: &Params) -> Result<()> {
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("p2g");
        let cfg = self.launch_config(self.num_particles);
        let (fixed_mass, fixed_momentum) = match &self.fixed {
            Some(f) => (&f.mass, &f.momentum),
            None => (&self.unused_fixed, &self.unused_fixed),
        };
        let mut launch = self.stream.launch_builder(&self.kernels.p2g);
        launch
            .arg(&params)
            .arg(&self.x)
            .arg(&self.order)
            .arg(&self.v)
            .arg(&self.c)
            .arg(&self.rho)
            .arg(&self.grid_acc)
            .arg(fixed_mass)
            .arg(fixed_momentum)
            .arg(&self.counters);
        // SAFETY: as in p2g_init.
        let launched = unsafe { launch.launch(cfg) }.map(drop);
        self.after_launch("p2g", launched)
    }

    /// Momentum to velocity, gravity, boundary band; zeroes the accumulators.
    pub fn grid_update(&mut self, params: &Params) -> Result<()> {
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("grid_update");
        let cfg = self.launch_config(self.num_nodes());
        let (fixed_mass, fixed_momentum) = match &self.fixed {
            Some(f) => (&f.mass, &f.momentum),
            None => (&self.unused_fixed, &self.unused_fixed),
        };
        let mut launch = self.stream.launch_builder(&self.kernels.grid_update);
        launch
            .arg(&params)
            .arg(&self.grid_acc)
            .arg(&self.grid_vel)
            .arg(fixed_mass)
            .arg(fixed_momentum)
            .arg(&self.counters);
        // SAFETY: as in p2g_init.
        let launched = unsafe { launch.launch(cfg) }.map(drop);
        self.after_launch("grid_update", launched)
    }

    /// Velocity and C from the grid, soft wall, advection, clamp.
    pub fn g2p(&mut self, params: &Params) -> Result<()> {
        let params = self.device_params(params)?;
        let _range = NvtxRange::new("g2p");
        let cfg = self.launch_config(self.num_particles);
        let mut launch = self.stream.launch_builder(&self.kernels.g2p);
        launch
            .arg(&params)
            .arg(&self.x)
            .arg(&self.v)
            .arg(&self.c)
            .arg(&self.grid_vel)
            .arg(&self.rho)
            .arg(&self.counters);
        // SAFETY: as in p2g_init.
        let launched = unsafe { launch.launch(cfg) }.map(drop);
        self.after_launch("g2p", launched)
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

    /// The particle order of the last sort (identity before the first). Waits for the device.
    pub fn read_order(&mut self) -> Result<Vec<u32>> {
        self.download(&self.order)
    }

    /// Node mass and velocity as grid_update left them. Waits for the device.
    pub fn read_grid_velocity(&mut self) -> Result<(Vec<f32>, Vec<Vec3>)> {
        let vel = self.download(&self.grid_vel)?;
        Ok(split_float4(&vel))
    }

    fn download<T: DeviceRepr + Default + Clone>(&self, buffer: &CudaSlice<T>) -> Result<Vec<T>> {
        let mut host = vec![T::default(); buffer.len()];
        self.stream
            .memcpy_dtoh(buffer, &mut host)
            .context("copying from the GPU (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
        self.stream
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
        &self.stream
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
        let _range = NvtxRange::new("render_attributes");
        let cfg = self.launch_config(self.num_particles);
        let n = self.num_particles as u32;
        let code = colour_by.code();
        let inv_rest_density = 1.0 / rest_density;
        let mut launch = self.stream.launch_builder(&self.kernels.render_attributes);
        launch
            .arg(&self.x)
            .arg(&self.v)
            .arg(&self.rho)
            .arg(&n)
            .arg(&code)
            .arg(&inv_rest_density)
            .arg(&out);
        // SAFETY: the arguments match kernels/render.cu; the caller vouches for `out`.
        let launched = unsafe { launch.launch(cfg) }.map(drop);
        self.after_launch("render_attributes", launched)
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
        let stream = self.stream.clone();
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
        let mut c = Vec::with_capacity(12 * n);
        for col in 0..3 {
            c.extend(particles.c.iter().flat_map(|m| {
                let v = m.col(col);
                [v.x, v.y, v.z, 0.0]
            }));
        }
        self.stream
            .memcpy_htod(&float4(&particles.x), &mut self.x)
            .context("uploading positions")?;
        self.stream
            .memcpy_htod(&float4(&particles.v), &mut self.v)
            .context("uploading velocities")?;
        self.stream.memcpy_htod(&c, &mut self.c).context("uploading C")?;
        self.stream
            .memcpy_htod(&particles.rho, &mut self.rho)
            .context("uploading densities")?;
        self.stream.synchronize().context("uploading particles")?;
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
        let cfg = LaunchConfig {
            grid_dim: (blocks, 1, 1),
            block_dim: (block, 1, 1),
            shared_mem_bytes: 0,
        };
        let bodies: CudaSlice<SpawnBody> = self.stream.clone_htod(&table).context("uploading bodies")?;
        let num_bodies = table.len() as u32;
        let spacing = scene.lattice().spacing;
        let mut counts = self
            .stream
            .alloc_zeros::<u32>(blocks as usize)
            .context("spawn counts")?;

        let mut launch = self.stream.launch_builder(&self.kernels.spawn_count);
        launch
            .arg(&bodies)
            .arg(&num_bodies)
            .arg(&spacing)
            .arg(&candidates)
            .arg(&mut counts);
        // SAFETY: arguments match kernels/spawn.cu; `counts` has one slot per block.
        let launched = unsafe { launch.launch(cfg) }.map(drop);
        self.after_launch("spawn_count", launched)?;

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
        let offsets = self
            .stream
            .clone_htod(&offsets)
            .context("uploading spawn offsets")?;
        let rest_density = scene.material.rest_density;
        let n = self.num_particles as u32;
        let mut launch = self.stream.launch_builder(&self.kernels.spawn_write);
        launch
            .arg(&bodies)
            .arg(&num_bodies)
            .arg(&spacing)
            .arg(&candidates)
            .arg(&offsets)
            .arg(&rest_density)
            .arg(&n)
            .arg(&mut self.x)
            .arg(&mut self.v)
            .arg(&mut self.c)
            .arg(&mut self.rho);
        // SAFETY: as above; every output holds `n` particles.
        let launched = unsafe { launch.launch(cfg) }.map(drop);
        self.after_launch("spawn_write", launched)?;
        self.stream
            .synchronize()
            .context("spawning particles on the GPU")?;
        Ok(())
    }
}

impl Solver for CudaSolver {
    fn name(&self) -> &'static str {
        "cuda"
    }

    fn step(&mut self, params: &Params) -> Result<()> {
        let _range = NvtxRange::new("substep");
        self.timing.begin_step(&self.stream)?;
        if self.steps_since_sort == 0 {
            self.sort_particles(params)?;
        }
        self.steps_since_sort = (self.steps_since_sort + 1) % SORT_INTERVAL;
        self.timing.mark(&self.stream, 1)?;
        self.p2g_init(params)?;
        self.mirror_mass(params)?;
        self.timing.mark(&self.stream, 2)?;
        self.p2g(params)?;
        self.timing.mark(&self.stream, 3)?;
        self.mirror_momentum(params)?;
        self.grid_update(params)?;
        self.timing.mark(&self.stream, 4)?;
        self.g2p(params)?;
        self.timing.mark(&self.stream, 5)?;
        Ok(())
    }

    fn take_extremes(&mut self) -> Result<StepExtremes> {
        let counters = self.download(&self.counters)?;
        self.stream
            .memset_zeros(&mut self.counters)
            .context("resetting the step counters")?;
        let overflows = counters[COUNTER_FIXED_OVERFLOWS];
        if overflows > 0 {
            bail!(
                "the fixed-point scatter overflowed {overflows} times since the last frame (a grid \
                 contribution or sum left the 64-bit range at {:.3e} units/kg, {:.3e} units/(kg m/s)); \
                 the fluid is moving far faster than expected, or blowing up. Use solver.scatter = \"float\", \
                 or lower the CFL number",
                self.fixed_mass_scale,
                self.fixed_momentum_scale
            );
        }
        Ok(StepExtremes {
            max_density: f32::from_bits(counters[COUNTER_MAX_DENSITY]),
            max_speed: f32::from_bits(counters[COUNTER_MAX_SPEED]),
            max_signal_speed: f32::from_bits(counters[COUNTER_MAX_SIGNAL]),
        })
    }

    fn take_step_timings(&mut self) -> Result<Option<Vec<PhaseTimings>>> {
        self.timing.take_completed().map(Some)
    }

    fn apply_push(&mut self, push: &Push) -> Result<()> {
        let _range = NvtxRange::new("push");
        let cfg = self.launch_config(self.num_particles);
        let n = self.num_particles as u32;
        let mut launch = self.stream.launch_builder(&self.kernels.push_particles);
        launch.arg(push).arg(&n).arg(&self.x).arg(&self.v);
        // SAFETY: the arguments match kernels/render.cu; x and v hold n float4.
        let launched = unsafe { launch.launch(cfg) }.map(drop);
        self.after_launch("push_particles", launched)
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
        })
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
    let body_speed = scene
        .bodies
        .iter()
        .map(|b| f64::from(b.velocity.length()))
        .fold(0.0, f64::max);
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

/// An NVTX range for the lifetime of the value: shows as a named span in Nsight Systems, and costs
/// almost nothing when no profiler is attached.
pub struct NvtxRange(());

impl NvtxRange {
    pub fn new(name: &str) -> NvtxRange {
        nvtx::range_push!("{name}");
        NvtxRange(())
    }
}

impl Drop for NvtxRange {
    fn drop(&mut self) {
        nvtx::range_pop!();
    }
}
