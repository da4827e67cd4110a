//! Every buffer one GPU holds for a scene, allocated together after one memory check: the particles,
//! the grid, the bins, the step counters, the colliders and the particle lifecycle. The kernels' host
//! files (X.rs beside kernels/X.cu) take what they need from here.

use super::bin_lists::{Bins, NODE_BLOCK_EDGE};
use super::colliders::DeviceColliders;
use super::counters::CounterRing;
use super::flow::DeviceFlow;
use super::gpu::Gpu;
use super::grid::{
    DeviceGrid, GridBox, NodeBlockList, BYTES_PER_NODE, FIXED_BYTES_PER_NODE, VOLUME_BYTES_PER_NODE,
};
use super::launch::{OptionalArg, NULL_POINTER};
use super::particles::{device_bytes, state_bytes, DeviceParticles};
use crate::sim::flow::FlowState;
use crate::sim::{Method, Params, Pipeline, ScatterMode, Scene};
use anyhow::{ensure, Result};
use cudarc::driver::{CudaStream, LaunchArgs, PushKernelArg};
use std::sync::Arc;

pub struct DeviceState {
    pub particles: DeviceParticles,
    /// The fused pipeline's second set of particle buffers, which each binning gathers the particles
    /// into in bin order before the two swap (bin_order.rs); `None` where particles stay in place.
    pub bin_order: Option<BinOrder>,
    pub grid: DeviceGrid,
    /// Particle indices by cell (report) or node block (binned): the order the scatters walk.
    pub bins: Bins,
    pub counters: CounterRing,
    pub colliders: DeviceColliders,
    /// Emitters, sinks and the free slots, where the scene has them (binned pipeline only).
    pub flow: Option<DeviceFlow>,
}

impl DeviceState {
    /// What the kernels cannot run, refused before a device is opened.
    pub fn check_scene(scene: &Scene) -> Result<()> {
        scene.check_pipeline()?;
        ensure!(
            !scene.flow.is_active() || scene.pipeline.is_binned(),
            "scene {}: emitters and sinks run in the fused and binned GPU pipelines; drop \
             solver.pipeline = \"report\" (or --pipeline report), or use a CPU backend",
            scene.source
        );
        ensure!(
            !scene.has_deformation() || scene.pipeline == Pipeline::Fused || scene.method == Method::Pbmpm,
            "scene {}: solids and liquids with a shear_modulus run in the fused GPU pipeline only (the \
             binned and report pipelines carry no deformation gradient); drop solver.pipeline = \"{}\" (or \
             --pipeline), or use a CPU backend",
            scene.source,
            scene.pipeline.name()
        );
        ensure!(scene.slots() > 0, "scene {}: no particles", scene.source);
        Ok(())
    }

    /// Zeroed buffers for `places` particles of `scene` (every slot on one GPU; its particles are
    /// uploaded or spawned next) on a grid of the nodes of `held` (one GPU: the whole grid), and the
    /// lifecycle in `flow` (`None`: the scene's start) where the scene has emitters or sinks, which
    /// names the run's slots; `bin_order`: the spare particle buffers of a pipeline that keeps its
    /// particles in bin order.
    pub fn allocate(
        gpu: &Gpu,
        scene: &Scene,
        (places, held): (usize, GridBox),
        flow: Option<&FlowState>,
        bin_order: bool,
    ) -> Result<DeviceState> {
        let n = places;
        let nodes = held.nodes();
        let fixed_scatter = scene.scatter == ScatterMode::FixedPoint;
        let gathers_volume = scene.rest_densities_differ();
        let deformed = scene.has_deformation();
        let bytes = |spare| buffer_bytes(n, deformed, spare, nodes, fixed_scatter, gathers_volume);
        gpu.ensure_fits(
            bytes(false),
            &format!("scene {} ({n} particles, {nodes} grid nodes)", scene.source),
            "use a coarser domain.resolution, fewer particles, or --backend cpu-parallel",
        )?;
        // Bin order is a speed-up, not a need: a run it would not leave room for keeps its
        // particles in place rather than being refused.
        let room_for_spare = gpu.fits(bytes(true))?;
        if bin_order && !room_for_spare {
            eprintln!(
                "note: scene {}: no room on the GPU for a second copy of {n} particles' state, so they \
                 stay at their slots instead of in bin order (each substep about a tenth slower)",
                scene.source
            );
        }
        let bin_order = bin_order && room_for_spare;

        let (l, stream) = (&gpu.launcher, gpu.stream());
        let binned = scene.pipeline.is_binned();
        let bins = Bins::new(l, held.res, n, if binned { NODE_BLOCK_EDGE } else { 1 }, binned)?;
        // Allocated in the order of the solver before its restructuring: the particle passes' speed
        // depends on where the arrays land relative to each other (measured on the H200: the dam
        // break's p2g ran 4 % slower with the grid allocated before the particles).
        let colliders = DeviceColliders::allocate(stream)?;
        let node_blocks = NodeBlockList::allocate(stream, if binned { bins.num_bins() } else { 0 })?;
        let particles = DeviceParticles::allocate(stream, n, deformed)?;
        let bin_order = if bin_order {
            Some(BinOrder {
                spare: DeviceParticles::allocate(stream, n, deformed)?,
                swapped: false,
            })
        } else {
            None
        };
        let grid = DeviceGrid::allocate(stream, held, node_blocks)?;
        let counters = CounterRing::allocate(&gpu.ctx, stream)?;
        let grid = with_sums(grid, stream, fixed_scatter, gathers_volume)?;
        let flow = if scene.flow.is_active() {
            let start;
            let state = match flow {
                Some(state) => state,
                None => {
                    start = FlowState::start(&scene.flow, scene.num_particles);
                    &start
                }
            };
            let spacing = scene.lattice().spacing as f32;
            Some(DeviceFlow::new(l, &scene.flow, state, spacing)?)
        } else {
            None
        };
        Ok(DeviceState {
            particles,
            bin_order,
            grid,
            bins,
            counters,
            colliders,
            flow,
        })
    }

    /// Makes the spare particle buffers, into which the last binning gathered the particles in bin
    /// order, the particles (bin_order.rs); nothing where particles stay in place.
    pub fn swap_particle_buffers(&mut self) {
        if let Some(order) = &mut self.bin_order {
            std::mem::swap(&mut self.particles, &mut order.spare);
            order.swapped = !order.swapped;
        }
    }

    /// Room for `capacity` particles (`CudaRanks`: a rank that receives more than its spare places
    /// hold): the particles copied into larger buffers, the spare set and the bins made anew for as
    /// many. The bins list nothing until the next binning.
    pub fn grow_particles(&mut self, gpu: &Gpu, capacity: usize) -> Result<()> {
        // A rank's places grow, the run's slots do not: the lifecycle's buffers (sized by the slots)
        // stay, and `position` keeps naming the places, which the copy keeps.
        let count = self.particles.count;
        let deformed = self.particles.deformation.is_some();
        let per_particle = device_bytes(deformed);
        let copies = 1 + usize::from(self.bin_order.is_some());
        // The old buffers stay until the copies are made.
        gpu.ensure_fits(
            copies * capacity * per_particle,
            &format!("growing a rank's {count} particle places to {capacity}"),
            "run on more GPUs (--gpus), or fewer particles",
        )?;
        let stream = gpu.stream();
        self.particles = self.particles.grown(stream, capacity)?;
        if let Some(order) = &mut self.bin_order {
            order.spare = DeviceParticles::allocate(stream, capacity, deformed)?;
            order.swapped = false;
        }
        let listed = self.bins.list.is_some();
        self.bins = Bins::new(
            &gpu.launcher,
            self.grid.held.res,
            capacity,
            self.bins.edge,
            listed,
        )?;
        Ok(())
    }

    /// A grid of the nodes of `held` in place of this one (`CudaRanks`, where the slabs moved),
    /// zeroed, with the same sums allocated, and bins for it: they list nothing until the next
    /// binning. Returns the grid it replaced, whose sums the ranks carry into the new ones.
    pub fn rebox(&mut self, gpu: &Gpu, held: GridBox) -> Result<DeviceGrid> {
        let (fixed, volume) = (self.grid.has_fixed(), self.grid.has_volume());
        // The old grid stays until its sums are carried.
        gpu.ensure_fits(
            held.nodes() * node_bytes(fixed, volume),
            &format!("a rank's grid of {:?} nodes from node {:?}", held.res, held.lo),
            "run on more GPUs (--gpus), or with a coarser domain.resolution",
        )?;
        let (l, stream) = (&gpu.launcher, gpu.stream());
        let listed = self.bins.list.is_some();
        self.bins = Bins::new(l, held.res, self.particles.count, self.bins.edge, listed)?;
        let node_blocks = NodeBlockList::allocate(stream, if listed { self.bins.num_bins() } else { 0 })?;
        let grid = with_sums(
            DeviceGrid::allocate(stream, held, node_blocks)?,
            stream,
            fixed,
            volume,
        )?;
        Ok(std::mem::replace(&mut self.grid, grid))
    }

    /// Bytes its particle, bin and grid buffers take (as `allocate` counts them; the lifecycle's,
    /// the colliders' and the counters' are small).
    pub fn device_bytes(&self) -> usize {
        buffer_bytes(
            self.particles.count,
            self.particles.deformation.is_some(),
            self.bin_order.is_some(),
            self.grid.num_nodes(),
            self.grid.has_fixed(),
            self.grid.has_volume(),
        )
    }

    /// Which of its two sets of buffers holds the particles: the kernels' arguments differ, so a
    /// captured substep is for one of them (graph.rs).
    pub fn particle_buffers(&self) -> bool {
        self.bin_order.as_ref().is_some_and(|o| o.swapped)
    }

    /// Whether these buffers can run substeps with `params` in `pipeline` (`mass_scattered`: the
    /// scatter mode of the mass already on the grid, if any); allocates the fixed-point grid on first
    /// use, before any graph capture (which must not allocate).
    pub fn check_params(
        &mut self,
        stream: &Arc<CudaStream>,
        params: &Params,
        pipeline: Pipeline,
        mass_scattered: Option<u32>,
    ) -> Result<()> {
        let count = self.particles.count;
        let held = GridBox {
            lo: params.box_lo,
            res: params.box_res,
        };
        ensure!(
            params.num_particles as usize == count && held == self.grid.held,
            "Params are for {} particles on a grid of {:?} nodes from node {:?}, but this CUDA solver \
             holds {count} on {:?}",
            params.num_particles,
            held.res,
            held.lo,
            self.grid.held
        );
        ensure!(
            params.scatter_mode <= ScatterMode::FixedPoint.code(),
            "unknown scatter mode {}",
            params.scatter_mode
        );
        ensure!(
            mass_scattered.is_none_or(|mode| mode == params.scatter_mode),
            "the scatter mode cannot change in the middle of a binned-pipeline run (the grid already \
             holds the next substep's mass in the other mode)"
        );
        // The binned pipeline's tiles accumulate fixed point in either scatter mode (tiles.cuh).
        let fixed = params.scatter_mode == ScatterMode::FixedPoint.code();
        ensure!(
            !(fixed || pipeline.is_binned())
                || (params.fixed_mass_scale > 0.0 && params.fixed_momentum_scale > 0.0),
            "Params without fixed-point scales: take them from Scene::params()"
        );
        if fixed {
            self.grid.ensure_fixed(stream)?;
        }
        if params.volume_density != 0 {
            self.grid.ensure_volume(stream)?;
        }
        Ok(())
    }
}

/// Bytes the particle, bin and grid buffers take: `places` particles (`deformed`: with their
/// deformation; `spare`: with the bin order's second copy of their state) and `nodes` grid nodes
/// (`fixed`, `volume`: with the fixed-point sums, the grid's volume).
fn buffer_bytes(
    places: usize,
    deformed: bool,
    spare: bool,
    nodes: usize,
    fixed: bool,
    volume: bool,
) -> usize {
    let spare = if spare { state_bytes(deformed) } else { 0 };
    places * (device_bytes(deformed) + spare) + nodes * node_bytes(fixed, volume)
}

/// Bytes a grid node takes, with the fixed-point sums and the grid's volume where they are kept.
fn node_bytes(fixed: bool, volume: bool) -> usize {
    BYTES_PER_NODE
        + if fixed { FIXED_BYTES_PER_NODE } else { 0 }
        + if volume { VOLUME_BYTES_PER_NODE } else { 0 }
}

/// `grid` with the fixed-point sums and the grid's volume where asked.
fn with_sums(
    mut grid: DeviceGrid,
    stream: &Arc<CudaStream>,
    fixed: bool,
    volume: bool,
) -> Result<DeviceGrid> {
    if fixed {
        grid.ensure_fixed(stream)?;
    }
    if volume {
        grid.ensure_volume(stream)?;
    }
    Ok(grid)
}

/// The spare particle buffers of a pipeline that stores its particles in bin order.
pub struct BinOrder {
    pub spare: DeviceParticles,
    /// The particles are in the buffers allocated second.
    pub swapped: bool,
}

/// Argument groups several kernels take together, in the order their signatures list them, so a
/// kernel's host file names a group once instead of spelling out its buffers.
pub trait StateArgs<'a> {
    /// `x, v, c, rho`: a particle set's state arrays.
    fn particle_state(&mut self, particles: &'a DeviceParticles) -> &mut Self;
    /// `deformation`: a particle set's deformation gradients, or a null pointer where the scene has
    /// no solid.
    fn deformation(&mut self, particles: &'a DeviceParticles) -> &mut Self;
    /// `grid_acc, fixed_mass, fixed_momentum`: the scatter accumulators, float and fixed point.
    fn accumulators(&mut self, grid: &'a DeviceGrid) -> &mut Self;
    /// `order`: the bins' particle order, or a null pointer where the particles are stored in bin
    /// order (every binning gathered them, so a tiled pass reads them at their places).
    fn bin_order_or_places(&mut self, state: &'a DeviceState) -> &mut Self;
    /// `block_marks, block_list, work_counts, counters`: the node-block list a scatter appends to
    /// (`BlockMarks` in kernels/tiles.cuh), then the step counters.
    fn node_block_list(&mut self, state: &'a DeviceState) -> &mut Self;
    /// `collider_states, num_colliders, collider_sdf, body_impulses` (`Colliders` in kernels/colliders.cuh;
    /// the rigid bodies' sums null without bodies).
    fn colliders(&mut self, colliders: &'a DeviceColliders) -> &mut Self;
    /// `sinks, num_sinks, free_slots, flow`: the sinks a gather drains into and the stack of free
    /// slots; without a flow, null pointers and no sinks (never read).
    fn sinks(&mut self, flow: Option<&'a DeviceFlow>) -> &mut Self;
}

impl<'a> StateArgs<'a> for LaunchArgs<'a> {
    fn particle_state(&mut self, particles: &'a DeviceParticles) -> &mut Self {
        self.arg(&particles.x)
            .arg(&particles.v)
            .arg(&particles.c)
            .arg(&particles.rho)
    }

    fn deformation(&mut self, particles: &'a DeviceParticles) -> &mut Self {
        self.arg_or_null(particles.deformation.as_ref())
    }

    fn accumulators(&mut self, grid: &'a DeviceGrid) -> &mut Self {
        self.arg(&grid.acc)
            .arg(grid.fixed_mass())
            .arg(grid.fixed_momentum())
    }

    fn bin_order_or_places(&mut self, state: &'a DeviceState) -> &mut Self {
        match state.bin_order {
            Some(_) => self.arg(&NULL_POINTER),
            None => self.arg(&state.bins.order),
        }
    }

    fn node_block_list(&mut self, state: &'a DeviceState) -> &mut Self {
        let blocks = &state.grid.node_blocks;
        self.arg(&blocks.marks)
            .arg(&blocks.list)
            .arg(&state.grid.work_counts)
            .arg(&state.counters.device)
    }

    fn colliders(&mut self, colliders: &'a DeviceColliders) -> &mut Self {
        self.arg(&colliders.states)
            .arg(&colliders.count)
            .arg(&colliders.sdf)
            .arg_or_null(colliders.bodies.as_ref().map(|bodies| &bodies.impulses))
    }

    fn sinks(&mut self, flow: Option<&'a DeviceFlow>) -> &mut Self {
        static NO_SINKS: u32 = 0;
        match flow {
            Some(f) => self.arg(&f.sinks).arg(&f.num_sinks).arg(&f.free).arg(&f.counters),
            None => self
                .arg(&NULL_POINTER)
                .arg(&NO_SINKS)
                .arg(&NULL_POINTER)
                .arg(&NULL_POINTER),
        }
    }
}
