//! `CudaSolver`: one GPU's particle state and the substep as its phases, in any pipeline
//! (`Pipeline`). The substep reads top to bottom in `CudaSolver::enqueue_substep`:
//!
//! | phase (`PhaseTimings`) | report pipeline                   | binned pipeline                          | fused pipeline (default)                     |
//! |---|---|---|---|
//! | sort        | sort by cell, every SORT_INTERVAL steps | sort by node block and cell, as often or when a particle moved a cell | as binned, every BIN_ORDER_SORT_INTERVAL steps, then the particles gathered into that order (bin_order.rs) |
//! | p2g_init    | p2g_init (mass scatter) + mirror mass   | mirror mass (the mass came with g2p2g)   | nothing (mass and momentum came with one_pass) |
//! | p2g         | p2g                                     | p2g (float), p2g_tiled (fixed point)     | nothing                                      |
//! | grid_update | mirror momentum + grid_update (all)     | mirror momentum + grid_update_blocks (touched) | mirror mass and momentum (one launch) + grid_update_blocks |
//! | g2p         | g2p                                     | g2p2g (g2p + the next substep's mass scatter) | one_pass (g2p + the next substep's whole scatter) |
//!
//! The first substep (nothing scattered yet) scatters in p2g_init: p2g_mass in the binned pipeline,
//! one_pass without its gather in the fused one. Each phase is an NVTX range and a pair of CUDA events. Each
//! kernel's arguments live in the host file beside it (`p2g.rs` beside kernels/p2g.cu, ...); the
//! buffers in `state.rs`. No pipeline has a grid-clear launch: the grid update zeroes each
//! accumulator it reads, so `grid_clear` stays 0 here.

use super::bins::{sort_interval, BinSchedule};
use super::gpu::{CudaOptions, Gpu};
use super::graph::{SubstepGraph, SubstepGraphs, SubstepKey};
use super::launch::NvtxRange;
use super::mirror_walls::MirrorQuantity;
use super::modules::Origin;
use super::one_pass::Gather;
use super::particles::{DeviceParticles, DeviceParticlesView};
use super::spawn::spawn_on_device;
use super::state::DeviceState;
use super::stats::ParticleStats;
use super::timing::PhaseEvents;
use crate::sim::colliders::ColliderFrame;
use crate::sim::flow::{FlowCounts, FlowState};
use crate::sim::Phase;
use crate::sim::{
    ExtremesTicket, Material, Params, ParticleView, Particles, PhaseTimings, Pipeline, Push, ScatterMode,
    Scene, Solver, StepExtremes, Summary, SummaryTicket,
};
use anyhow::{ensure, Context, Result};
use cudarc::driver::{CudaContext, CudaStream};
use std::sync::Arc;

pub struct CudaSolver {
    pub(super) gpu: Gpu,
    pub(super) state: DeviceState,
    options: CudaOptions,
    pipeline: Pipeline,
    /// The parameters the kernels get, as the scene wrote them (`Scene::params`) with the current dt;
    /// checked when they change (`accept`).
    pub(super) params: Params,
    schedule: BinSchedule,
    /// Binned and fused pipelines: the grid already holds the next substep's scatter at the
    /// particles' current positions, with this scatter mode: the mass (g2p2g, p2g_mass), or under the
    /// fused pipeline mass and momentum (one_pass).
    mass_scattered: Option<u32>,
    /// Particles scattered outside their tile since the solver was made (binned pipeline).
    tile_misses: u64,
    timing: PhaseEvents,
    /// Captured substeps (graph.rs); empty where graphs are off.
    graphs: SubstepGraphs,
    /// Substeps enqueued so far: the first runs without a graph (it allocates on first use).
    substeps: u64,
    /// Fused pipeline: the step of the substep before a restored state (`Solver::resume_after`),
    /// which its first scatter takes, as the uninterrupted run's last one_pass did.
    resumed_dt: Option<f32>,
}

impl CudaSolver {
    /// Spawns `scene`'s particles on the device, in the order of `Scene::spawn()`. A scene with
    /// emitters or sinks is spawned on the host (its parked slots with it) and uploaded, and so is one
    /// with colliders (the device lattice knows nothing of colliders, whose insides get no fluid).
    pub fn new(scene: &Scene, options: CudaOptions) -> Result<CudaSolver> {
        if scene.flow.is_active() || !scene.colliders.is_empty() {
            return CudaSolver::restore(scene, &scene.spawn(), None, options);
        }
        let solver = CudaSolver::allocate(scene, None, options)?;
        spawn_on_device(&solver.gpu, scene, &solver.state.particles)?;
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
        let mut solver = CudaSolver::allocate(&scene, flow, options)?;
        solver.state.particles.upload(solver.gpu.stream(), particles)?;
        Ok(solver)
    }

    /// Checks the scene against what the kernels take, opens the GPU and allocates every buffer.
    fn allocate(scene: &Scene, flow: Option<&FlowState>, options: CudaOptions) -> Result<CudaSolver> {
        DeviceState::check_scene(scene)?;
        let gpu = Gpu::open(&options)?;
        let state = DeviceState::allocate(&gpu, scene, flow, options.bin_order_for(scene.pipeline))?;
        // Binnings cost more where they also gather the particles (not where memory was short).
        let sort_interval = sort_interval(state.bin_order.is_some());
        let mut solver = CudaSolver {
            timing: PhaseEvents::new(gpu.ctx.clone()),
            gpu,
            state,
            options,
            pipeline: scene.pipeline,
            params: scene.params(),
            schedule: BinSchedule::every(sort_interval),
            mass_scattered: None,
            tile_misses: 0,
            graphs: SubstepGraphs::default(),
            substeps: 0,
            resumed_dt: None,
        };
        let params = solver.params;
        solver.check_params(&params)?;
        Ok(solver)
    }

    /// Takes `params` for the coming work, checking them once where they changed.
    pub(super) fn accept(&mut self, params: &Params) -> Result<()> {
        if bytemuck::bytes_of(params) != bytemuck::bytes_of(&self.params) {
            self.check_params(params)?;
            self.params = *params;
        }
        Ok(())
    }

    fn check_params(&mut self, params: &Params) -> Result<()> {
        let stream = self.gpu.stream();
        self.state
            .check_params(stream, params, self.pipeline, self.mass_scattered)
    }

    /// How the kernels were loaded: embedded PTX, or compiled at run time (and why).
    pub fn module_origin(&self) -> Origin {
        self.gpu.module_origin
    }

    /// The device's name, e.g. "NVIDIA H200".
    pub fn device_name(&self) -> String {
        self.gpu.name()
    }

    /// The kernel sequence this solver runs.
    pub fn pipeline(&self) -> Pipeline {
        self.pipeline
    }

    /// Particles the binned pipeline scattered past their tile (by global atomics) since the solver
    /// was made, as of the last `take_extremes`.
    pub fn tile_misses(&self) -> u64 {
        self.tile_misses
    }

    /// How often the particles were binned (sorted) since the solver was made.
    pub fn binnings(&self) -> u64 {
        self.schedule.binnings
    }

    /// The CUDA context, for registering GL buffers with it (src/cuda/interop.rs).
    pub fn context(&self) -> &Arc<CudaContext> {
        &self.gpu.ctx
    }

    /// The stream every launch of this solver goes to; interop maps and unmaps on it, so a mapped
    /// buffer is written after the step's kernels and drawn after the write.
    pub fn stream(&self) -> &Arc<CudaStream> {
        self.gpu.stream()
    }

    pub fn num_particles(&self) -> usize {
        self.state.particles.count
    }

    /// The statistics of `particles` (as many slots as this solver's, on its GPU) by its kernel,
    /// waited for: how the ranks reduce the set of every rank's own slots.
    pub fn summary_of(&mut self, material: &Material, particles: &DeviceParticles) -> Result<Summary> {
        request_stats(
            &self.gpu,
            &self.params,
            material,
            &mut self.state.stats,
            particles,
        )?;
        self.state.stats.wait()
    }

    /// The substep's work in stream order, phase by phase (`Phase::ALL`), each phase an NVTX range of
    /// its name ended by a timing event where it enqueued work (timing.rs: an empty phase reads 0).
    fn enqueue_substep(&mut self, sort: bool) -> Result<()> {
        let stream = self.gpu.stream().clone();
        self.timing.begin_step(&stream)?;
        for phase in Phase::ALL.into_iter().filter(|p| p.runs_on_gpu()) {
            let _range = NvtxRange::new(phase.name());
            let ran = match phase {
                // Folded into the grid update, which zeroes what it reads (consume-and-zero); one
                // GPU has no ranks to exchange with.
                Phase::GridClear | Phase::HaloSum | Phase::HaloFill => false,
                Phase::Sort => self.sort_phase(sort)?,
                Phase::P2gInit => {
                    let scattered = self.scatter_first()?;
                    self.mirror_before_p2g()? || scattered
                }
                Phase::P2g => self.scatter_momentum()?,
                Phase::GridUpdate => self.mirror_and_update_grid().map(|()| true)?,
                Phase::G2p => self.gather().map(|()| true)?,
            };
            self.timing.end_phase(&stream, phase, ran)?;
        }
        Ok(())
    }

    /// The sort phase: bins the particles where `sort` (the schedule's `sort_due` when the substep
    /// was enqueued), and counts the substep. Whether it enqueued work.
    pub(super) fn sort_phase(&mut self, sort: bool) -> Result<bool> {
        if sort {
            self.sort()?;
        }
        self.schedule.note_substep();
        Ok(sort)
    }

    /// Whether the coming substep sorts (`BinSchedule::due`).
    pub(super) fn sort_due(&self) -> bool {
        self.schedule.due()
    }

    /// Bins the particles in the next sort phase (ranks.rs: a migration changed which slots are
    /// live).
    pub(super) fn rebin_next(&mut self) {
        self.schedule.invalidate();
    }

    /// Drops the scatter the grid holds, so the next substep scatters again as a first one does,
    /// with `last_dt`, the step of the substep that made it (ranks.rs: after the slabs moved, a
    /// rank's partial sums may lie beyond its new ghost planes). Fixed point scatters the same units.
    pub(super) fn discard_scatter(&mut self, last_dt: f32) -> Result<()> {
        if self.mass_scattered.take().is_some() {
            self.state.grid.clear(self.gpu.stream())?;
            self.resumed_dt = Some(last_dt);
        }
        Ok(())
    }

    /// The first substep's scatter, where the grid holds none yet (the binned and fused pipelines
    /// scatter the next substep's mass in the gather; the report's every substep). Whether it ran.
    pub(super) fn scatter_first(&mut self) -> Result<bool> {
        let first = self.mass_scattered.is_none();
        if first {
            self.scatter_mass()?;
        }
        Ok(first)
    }

    pub(super) fn sort(&mut self) -> Result<()> {
        let (gpu, state) = (&self.gpu, &mut self.state);
        state.bins.rebuild(
            &gpu.kernels.bins,
            &gpu.launcher,
            &self.params,
            &state.particles.x,
            &mut state.grid.work_counts,
        )?;
        // The fused pipeline's one_pass reads a bin-ordered state without `order`: every binning
        // gathers it (`DeviceState::bin_order`).
        gpu.kernels.bin_order.launch(&gpu.launcher, state)?;
        self.schedule.note_binning();
        Ok(())
    }

    pub(super) fn scatter_mass(&mut self) -> Result<()> {
        let (k, l) = (&self.gpu.kernels, &self.gpu.launcher);
        if self.pipeline == Pipeline::Report {
            return k.p2g_init.launch(l, &self.params, &self.state);
        }
        // The substep's sort phase runs first whenever the bins are stale (`BinSchedule::due`).
        ensure!(
            self.schedule.built(),
            "the binned mass scatter walks the bins, which were never built: sort first"
        );
        match self.pipeline {
            Pipeline::Fused => {
                let dt = self.resumed_dt.take().unwrap_or(self.params.dt);
                k.one_pass
                    .launch(l, Gather::None, &Params { dt, ..self.params }, &self.state)?
            }
            _ => k.p2g_mass.launch(l, &self.params, &self.state)?,
        }
        self.mass_scattered = Some(self.params.scatter_mode);
        Ok(())
    }

    /// The walls' mirror of the mass, which p2g reads; nothing under the fused pipeline, which has
    /// no p2g and mirrors both quantities in its grid update. Whether it launched.
    pub(super) fn mirror_before_p2g(&self) -> Result<bool> {
        match self.pipeline {
            Pipeline::Fused => Ok(false),
            _ => self.mirror(MirrorQuantity::Mass),
        }
    }

    /// The grid update phase: the walls' mirror of p2g's momentum and the grid update, or under the
    /// fused pipeline the grid update adding the images of mass and momentum itself (one_pass
    /// scattered both; one launch fewer a substep, BENCHMARKS.md 0k).
    pub(super) fn mirror_and_update_grid(&mut self) -> Result<()> {
        let mirror_in_update = self.pipeline == Pipeline::Fused;
        if !mirror_in_update {
            self.mirror(MirrorQuantity::Momentum)?;
        }
        self.update_grid(mirror_in_update)
    }

    /// Whether it launched (not where the scene turns the mirror off).
    pub(super) fn mirror(&self, quantity: MirrorQuantity) -> Result<bool> {
        let (k, l) = (&self.gpu.kernels, &self.gpu.launcher);
        k.mirror_walls
            .launch(l, self.pipeline, quantity, &self.params, &self.state)
    }

    /// In the report's pipeline, and for float momentum in the binned one, p2g.cu: warp runs of one
    /// cell summed before global atomics (integers for fixed point). Fixed-point momentum in the binned
    /// pipeline goes through a shared tile (p2g_tiled.cu), and so does any scatter of a scene with a
    /// flow (p2g.cu walks the whole order, parked slots included). Each is the faster there, measured
    /// on the H200 (2026-11-23, mpm bench, p2g medians): float at bench-655k 0.097 ms by runs, 0.17 ms
    /// tiled (the L2 adds floats natively, a tile must round every contribution); fixed point 0.17 ms
    /// tiled, 0.20 ms by integer runs, 0.66 ms by unaggregated 64-bit atomics (16.8M particles: 3.48
    /// against 3.86 ms).
    /// The fused pipeline has nothing left to scatter here: one_pass scattered the momentum with the
    /// mass. Whether it launched.
    pub(super) fn scatter_momentum(&self) -> Result<bool> {
        let (k, l) = (&self.gpu.kernels, &self.gpu.launcher);
        if self.pipeline == Pipeline::Fused {
            return Ok(false);
        }
        let tiled = self.pipeline == Pipeline::Binned
            && (self.params.scatter_mode == ScatterMode::FixedPoint.code() || self.state.flow.is_some());
        if tiled {
            k.p2g_tiled.launch(l, &self.params, &self.state)?;
        } else {
            k.p2g.launch(l, &self.params, &self.state)?;
        }
        Ok(true)
    }

    /// The grid update; `mirror`: it adds the walls' images (the binned and fused pipelines' launch
    /// only), else mirror_walls did before.
    pub(super) fn update_grid(&mut self, mirror: bool) -> Result<()> {
        let (k, l) = (&self.gpu.kernels, &self.gpu.launcher);
        k.grid_update
            .launch(l, self.pipeline, mirror, &self.params, &self.state)?;
        if self.pipeline.is_binned() {
            k.grid_update
                .clear_crossing_orbits(l, mirror, &self.params, &self.state.grid)?;
        }
        Ok(())
    }

    pub(super) fn gather(&mut self) -> Result<()> {
        let (k, l) = (&self.gpu.kernels, &self.gpu.launcher);
        match self.pipeline {
            Pipeline::Report => return k.g2p.launch(l, &self.params, &self.state),
            Pipeline::Binned => k.g2p2g.launch(l, &self.params, &self.state)?,
            Pipeline::Fused => k.one_pass.launch(l, Gather::Substep, &self.params, &self.state)?,
        }
        self.mass_scattered = Some(self.params.scatter_mode);
        if let Some(flow) = self.state.flow.as_ref().filter(|f| f.num_sinks > 0) {
            k.lifecycle.settle(l, flow)?;
        }
        Ok(())
    }

    /// Captures `enqueue_substep` into a graph; its host-side notes (binning, mass scattered) are
    /// made once here, as for a substep enqueued directly.
    fn capture_substep(&mut self, sort: bool) -> Result<SubstepGraph> {
        let stream = self.gpu.stream().clone();
        let placeholders = self.timing.begin_capture()?;
        let graph = SubstepGraph::capture(&stream, &placeholders, || {
            self.enqueue_substep(sort)?;
            Ok(self.timing.captured())
        });
        self.timing.end_capture();
        graph
    }
}

impl Solver for CudaSolver {
    fn name(&self) -> &'static str {
        "cuda"
    }

    fn bind_to_thread(&self) -> Result<()> {
        self.gpu
            .ctx
            .bind_to_thread()
            .context("making the simulation's CUDA context current on the stepping thread")
    }

    /// One substep, as the table at the top of this file lists its phases: enqueued kernel by kernel
    /// (`enqueue_substep`), or as one launch of a captured graph of exactly that work (graph.rs).
    fn step(&mut self, params: &Params) -> Result<()> {
        self.accept(params)?;
        let sort = self.sort_due();
        let graphs = self.options.graphs && !self.gpu.launcher.sync_each_launch && self.substeps > 0;
        self.substeps += 1;
        if !graphs {
            let _range = NvtxRange::new("substep");
            return self.enqueue_substep(sort);
        }
        let _range = NvtxRange::new("substep (graph)");
        let key = SubstepKey {
            params: self.params,
            sort,
            mass_scattered: self.mass_scattered,
            colliders: self.state.colliders.count,
            particle_buffers: self.state.particle_buffers(),
        };
        let graph = match self.graphs.take(&key) {
            Some(graph) => {
                // What enqueue_substep's calls note on the host, for the work the graph replays.
                if sort {
                    self.schedule.note_binning();
                    self.state.swap_particle_buffers();
                }
                self.schedule.note_substep();
                graph
            }
            None => self.capture_substep(sort)?,
        };
        let launched = self
            .timing
            .begin_graphed_step(graph.recorded())
            .and_then(|events| graph.launch(events));
        self.graphs.put(key, graph);
        launched
    }

    fn resume_after(&mut self, last: &Params) {
        self.resumed_dt = Some(last.dt);
    }

    fn emit(&mut self, params: &Params, mask: u32) -> Result<()> {
        self.accept(params)?;
        let (k, l) = (&self.gpu.kernels, &self.gpu.launcher);
        k.lifecycle
            .emit(l, &self.params, mask, self.mass_scattered.is_some(), &self.state)?;
        // The new particles are in no bin yet.
        self.schedule.invalidate();
        Ok(())
    }

    fn rebin_interval(&self) -> Option<u32> {
        Some(self.schedule.interval())
    }

    fn phase_kernel(&self, phase: Phase) -> Option<&'static str> {
        (self.pipeline == Pipeline::Fused && phase == Phase::G2p)
            .then(|| self.gpu.kernels.one_pass.kernel(&self.params).name())
    }

    fn flow_counts(&mut self) -> Result<Option<FlowCounts>> {
        let Some(flow) = &self.state.flow else {
            return Ok(None);
        };
        flow.read_counts(&self.gpu).map(Some)
    }

    fn flow_state(&mut self) -> Result<Option<FlowState>> {
        let Some(flow) = &self.state.flow else {
            return Ok(None);
        };
        flow.read_state(&self.gpu).map(Some)
    }

    fn take_extremes(&mut self) -> Result<StepExtremes> {
        let ticket = self.request_extremes()?;
        self.wait_extremes(ticket)
    }

    /// Copies the counters to a pinned host slot and resets them, in stream order; nothing waits.
    fn request_extremes(&mut self) -> Result<ExtremesTicket> {
        let slot = self.state.counters.request(self.gpu.stream())?;
        Ok(ExtremesTicket::Pending(slot))
    }

    /// Waits for that slot's copy only (its own event), not for the whole stream.
    fn wait_extremes(&mut self, ticket: ExtremesTicket) -> Result<StepExtremes> {
        let slot = match ticket {
            ExtremesTicket::Ready(extremes) => return Ok(extremes),
            ExtremesTicket::Pending(slot) => slot,
        };
        let reading = self.state.counters.wait(slot, &self.params)?;
        self.schedule.rebin_requested |= reading.rebin_needed;
        self.tile_misses += reading.tile_misses;
        Ok(reading.extremes)
    }

    fn take_step_timings(&mut self) -> Result<Option<Vec<PhaseTimings>>> {
        self.timing.take_completed().map(Some)
    }

    fn set_colliders(&mut self, frame: &ColliderFrame) -> Result<()> {
        ensure!(
            frame.is_empty() || self.pipeline.is_binned(),
            "the report pipeline applies no colliders; use --pipeline fused (or solver.pipeline = \"fused\", the default)"
        );
        self.state.colliders.set(self.gpu.stream(), frame)
    }

    fn apply_push(&mut self, push: &Push) -> Result<()> {
        let (k, l) = (&self.gpu.kernels, &self.gpu.launcher);
        k.push.launch(l, push, &self.state.particles)
    }

    fn particles(&self) -> ParticleView<'_> {
        ParticleView::Device(DeviceParticlesView {
            gpu: &self.gpu,
            particles: &self.state.particles,
        })
    }

    fn read_particles(&mut self) -> Result<Particles> {
        self.state.particles.download(&self.gpu)
    }

    /// A device reduction (kernels/stats.cu): the host reads a few KiB, never the particles.
    fn summary(&mut self, material: &Material) -> Result<Summary> {
        let ticket = self.request_summary(material)?;
        self.wait_summary(ticket)
    }

    fn request_summary(&mut self, material: &Material) -> Result<SummaryTicket> {
        let state = &mut self.state;
        request_stats(
            &self.gpu,
            &self.params,
            material,
            &mut state.stats,
            &state.particles,
        )?;
        Ok(SummaryTicket::Pending)
    }

    fn wait_summary(&mut self, ticket: SummaryTicket) -> Result<Summary> {
        match ticket {
            SummaryTicket::Ready(summary) => Ok(summary),
            SummaryTicket::Pending => self.state.stats.wait(),
        }
    }
}

/// Enqueues the statistics of `particles` under `params` with `material`'s mass and density.
fn request_stats(
    gpu: &Gpu,
    params: &Params,
    material: &Material,
    stats: &mut ParticleStats,
    particles: &DeviceParticles,
) -> Result<()> {
    let params = Params {
        material: *material,
        ..*params
    };
    stats.request(&gpu.kernels.stats, &gpu.launcher, &params, particles)
}
