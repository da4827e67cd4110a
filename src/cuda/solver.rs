//! `CudaSolver`: one GPU's particle state and the substep as its phases, in any pipeline
//! (`Pipeline`). The substep reads top to bottom in `CudaSolver::enqueue_substep`: each phase of
//! `Phase::ALL` runs the launches pipelines.rs lists for it (`run_phase`), each an NVTX range of the
//! phase's name ended by a pair of CUDA events. Each kernel's arguments live in the host file beside
//! it (`p2g.rs` beside kernels/p2g.cu, ...); the buffers in `state.rs`. No pipeline has a grid-clear
//! launch: the grid update zeroes each accumulator it reads, so `grid_clear` stays 0 here.

use super::bins::{sort_interval, BinSchedule};
use super::bodies::DeviceBodies;
use super::flow::DeviceFlow;
use super::gpu::{CudaOptions, Gpu};
use super::graph::{SubstepGraph, SubstepGraphs, SubstepKey};
use super::grid::GridBox;
use super::kernels::Kernels;
use super::launch::NvtxRange;
use super::lifecycle::RankEmission;
use super::mirror_walls::MirrorQuantity;
use super::one_pass::Gather;
use super::pbmpm::PbmpmBuffers;
use super::pipelines::{launches, Launch};
use super::render::DeviceParticlesView;
use super::snapshot::SnapshotRing;
use super::state::DeviceState;
use super::stats::ParticleStats;
use super::timing::PhaseEvents;
use crate::contract::{FlowCounters, Material, MAX_MATERIALS};
use crate::sim::colliders::bodies::{BodiesState, BodyWalls, ContactFeature, RigidBody};
use crate::sim::colliders::ColliderFrame;
use crate::sim::flow::{FlowCounts, FlowState};
use crate::sim::Phase;
use crate::sim::{
    ExtremesTicket, Method, Params, ParticleSnapshot, ParticleView, Particles, PhaseTimings, Pipeline, Push,
    ScatterMode, Scene, Solver, StepExtremes, Summary, SummaryTicket,
};
use anyhow::{ensure, Context, Result};
use cudarc::driver::{sys, CudaEvent, CudaSlice, CudaStream};
use std::sync::Arc;

pub struct CudaSolver {
    pub(super) gpu: Gpu,
    pub(super) kernels: Kernels,
    pub(super) state: DeviceState,
    /// The per-frame statistics' partials and their host copy (kernels/stats.cu).
    stats: ParticleStats,
    options: CudaOptions,
    pipeline: Pipeline,
    /// The parameters the kernels get, as the scene wrote them (`Scene::params`) with the current dt;
    /// checked when they change (`accept`).
    pub(super) params: Params,
    pub(super) schedule: BinSchedule,
    /// Binned and fused pipelines: the grid already holds the next substep's scatter at the
    /// particles' current positions: the mass (g2p2g, p2g_mass), or under the fused pipeline mass
    /// and momentum (one_pass).
    mass_scattered: Option<Scattered>,
    /// Particles scattered outside their tile since the solver was made (binned pipeline).
    tile_misses: u64,
    pub(super) timing: PhaseEvents,
    /// Captured substeps (graph.rs); empty where graphs are off.
    graphs: SubstepGraphs,
    /// Substeps enqueued so far: the first runs without a graph (it allocates on first use).
    substeps: u64,
    /// Fused pipeline: the step and momentum units of the substep before a restored state
    /// (`Solver::resume_after`), which its first scatter takes, as the uninterrupted run's last
    /// one_pass did.
    resumed: Option<Params>,
    /// The material table in the kernels' constant memory (`use_materials`).
    device_materials: Option<[Material; MAX_MATERIALS as usize]>,
    /// The staging buffers of export snapshots, made at the first.
    snapshots: Option<SnapshotRing>,
    /// `solver.method = "pbmpm"`: the position-based substep's buffers (pbmpm_substep.rs steps it
    /// in place of the explicit one).
    pub(super) pbmpm: Option<PbmpmBuffers>,
    /// How the next substep's fused pass gathers: `Gather::SubstepEndingFrame` where it ends a frame
    /// (`Solver::ends_frame_next`), for that substep alone.
    gather: Gather,
    /// `Solver::pace`'s marks: an event recorded after each paced substep, the last two by turns.
    pace_marks: Vec<CudaEvent>,
    /// Substeps paced so far.
    paced: usize,
}

/// What the grid holds of a scatter made ahead of its substep: its scatter mode and the fixed-point
/// momentum units it was made in (the bits of `Params::fixed_momentum_scale`), which the grid update
/// must read it in. Part of a captured substep's key (graph.rs).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Scattered {
    pub mode: u32,
    momentum_scale_bits: u32,
}

impl Scattered {
    fn by(params: &Params) -> Scattered {
        Scattered {
            mode: params.scatter_mode,
            momentum_scale_bits: params.fixed_momentum_scale.to_bits(),
        }
    }

    fn momentum_scale(self) -> f32 {
        f32::from_bits(self.momentum_scale_bits)
    }
}

impl CudaSolver {
    /// Checks the scene against what the kernels take, opens the GPU and allocates every buffer,
    /// `places` particles' (`Scene::slots` but on a rank of several, cuda_ranks.rs).
    pub(super) fn allocate(
        scene: &Scene,
        (places, held): (usize, GridBox),
        flow: Option<&FlowState>,
        options: CudaOptions,
    ) -> Result<CudaSolver> {
        // The position-based substep keeps its particles in place, walked by the binned pipeline's
        // bins (its scatters' tiles), and sums its grid in fixed point whatever the scene's scatter.
        let position_based;
        let scene = if scene.method == Method::Pbmpm {
            let mut adjusted = scene.clone();
            adjusted.pipeline = Pipeline::Binned;
            adjusted.scatter = ScatterMode::FixedPoint;
            position_based = adjusted;
            &position_based
        } else {
            scene
        };
        DeviceState::check_scene(scene)?;
        // pbmpm.cu's grid passes walk the whole grid by its own indexing.
        ensure!(
            scene.method == Method::Explicit || held == GridBox::whole(scene.grid_res),
            "scene {}: position-based MPM runs on one rank",
            scene.source
        );
        let gpu = Gpu::open(&options)?;
        let kernels = Kernels::load(&gpu, &options)?;
        let bin_order = options.bin_order_for(scene);
        let state = DeviceState::allocate(&gpu, scene, (places, held), flow, bin_order)?;
        let pbmpm = match scene.method {
            Method::Pbmpm => Some(PbmpmBuffers::allocate(&gpu, scene, state.bin_order.is_some())?),
            Method::Explicit => None,
        };
        let stats = ParticleStats::allocate(gpu.stream())?;
        // Binnings cost more where they also gather the particles (not where memory was short).
        // The position-based substep bins every substep: its passes scatter at the substep's
        // starting positions, so each particle then lies in its tile for all of them.
        let sort_interval = match pbmpm {
            Some(_) => 1,
            None => sort_interval(state.bin_order.is_some()),
        };
        let mut params = scene.params();
        params.num_particles = places as u32;
        held.set_in(&mut params);
        let mut solver = CudaSolver {
            timing: PhaseEvents::new(gpu.ctx.clone(), options.phase_sample),
            gpu,
            kernels,
            state,
            stats,
            options,
            pipeline: scene.pipeline,
            params,
            schedule: BinSchedule::every(sort_interval),
            mass_scattered: None,
            tile_misses: 0,
            graphs: SubstepGraphs::default(),
            substeps: 0,
            resumed: None,
            device_materials: None,
            snapshots: None,
            pbmpm,
            gather: Gather::Substep,
            pace_marks: Vec::new(),
            paced: 0,
        };
        let params = solver.params;
        solver.check_params(&params)?;
        solver.use_materials(&params)?;
        Ok(solver)
    }

    /// Writes `params`' material table into the kernels' constant memory where it differs from the
    /// one there (the viewer's controls change row 0), before the work that reads it.
    fn use_materials(&mut self, params: &Params) -> Result<()> {
        if self.device_materials != Some(params.materials) {
            self.gpu
                .modules
                .write_material_table(self.gpu.stream(), &params.materials)?;
            self.device_materials = Some(params.materials);
        }
        Ok(())
    }

    /// Takes `params` for the coming work, checking them once where they changed.
    pub(super) fn accept(&mut self, params: &Params) -> Result<()> {
        // The run's parameters, on the part of the grid this GPU holds.
        let mut params = *params;
        self.state.grid.held.set_in(&mut params);
        if bytemuck::bytes_of(&params) != bytemuck::bytes_of(&self.params) {
            self.check_params(&params)?;
            self.use_materials(&params)?;
            self.params = params;
        }
        Ok(())
    }

    fn check_params(&mut self, params: &Params) -> Result<()> {
        let stream = self.gpu.stream();
        self.state
            .check_params(stream, params, self.pipeline, self.mass_scattered.map(|s| s.mode))
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

    /// The stream every launch of this solver goes to (the ranks order their exchanges on it).
    pub fn stream(&self) -> &Arc<CudaStream> {
        self.gpu.stream()
    }

    /// The substep's work in stream order, phase by phase (`Phase::ALL`), each phase an NVTX range of
    /// its name ended by a timing event where it enqueued work (timing.rs: an empty phase reads 0).
    /// One GPU has no ranks to exchange with: the halo phases are empty here.
    fn enqueue_substep(&mut self, sort: bool) -> Result<()> {
        let stream = self.gpu.stream().clone();
        self.timing.begin_step(&stream)?;
        for phase in Phase::ALL.into_iter().filter(|p| p.runs_on_gpu()) {
            let _range = NvtxRange::new(phase.name());
            let ran = self.run_phase(phase, sort)?;
            self.timing.end_phase(&stream, phase, ran)?;
        }
        self.timing.end_step(&stream)
    }

    /// The launches of `phase` in this solver's pipeline (pipelines.rs), in stream order; `sort` is
    /// the schedule's decision for this substep (`sort_due` when it was enqueued). Whether any
    /// enqueued work.
    pub(super) fn run_phase(&mut self, phase: Phase, sort: bool) -> Result<bool> {
        let mut ran = false;
        for &launch in launches(self.pipeline, phase) {
            ran |= self.run(launch, sort)?;
        }
        Ok(ran)
    }

    /// One launch of the table. Whether it enqueued work (a mirror where the scene turns the walls'
    /// mirror off, a first-substep scatter after the first substep, a sort not due, do not).
    pub(super) fn run(&mut self, launch: Launch, sort: bool) -> Result<bool> {
        if launch == Launch::ScatterVolume {
            let (k, l) = (&self.kernels, &self.gpu.launcher);
            return k.volume.scatter(l, self.pipeline, &self.params, &mut self.state);
        }
        let read = self.grid_params();
        let (k, l, p, d) = (&self.kernels, &self.gpu.launcher, &self.params, &self.state);
        let pipe = self.pipeline;
        match launch {
            Launch::SortByCell | Launch::Rebin | Launch::RebinInOrder => {
                if sort {
                    self.sort()?;
                }
                self.schedule.note_substep();
                return Ok(sort);
            }
            // The report's pipeline keeps no scatter across substeps: its mass scatter runs every one.
            Launch::P2gInit => k.p2g_init.launch(l, p, d)?,
            Launch::P2gMass | Launch::OnePassScatter => {
                if self.mass_scattered.is_some() {
                    return Ok(false);
                }
                self.scatter_mass(launch)?;
            }
            Launch::ScatterVolume => unreachable!("launched above, with the state to zero"),
            // Not where the scene turns the walls' mirror off (nor the volume's where the scene has
            // one rest density).
            Launch::MirrorVolume => return k.mirror_walls.launch(l, pipe, MirrorQuantity::Volume, p, d),
            Launch::GatherVolumeDensity => return k.volume.gather_density(l, p, d),
            Launch::MirrorMass => return k.mirror_walls.launch(l, pipe, MirrorQuantity::Mass, p, d),
            Launch::MirrorMomentum => return k.mirror_walls.launch(l, pipe, MirrorQuantity::Momentum, p, d),
            Launch::P2g => k.p2g.launch(l, p, d)?,
            Launch::P2gOrTiled => {
                if self.scatters_momentum_by_tile() {
                    k.p2g_tiled.launch(l, p, d)?;
                } else {
                    k.p2g.launch(l, p, d)?;
                }
            }
            Launch::GridUpdate => k.grid_update.launch(l, pipe, false, &read, d)?,
            Launch::GridUpdateBlocks | Launch::GridUpdateBlocksMirrored => {
                let mirror = launch == Launch::GridUpdateBlocksMirrored;
                k.grid_update.launch(l, pipe, mirror, &read, d)?;
                k.grid_update.clear_crossing_orbits(l, mirror, p, &d.grid)?;
                k.step_bodies.launch(l, p, &d.colliders)?;
            }
            Launch::G2p => k.g2p.launch(l, p, d)?,
            Launch::G2p2g | Launch::OnePass => {
                if launch == Launch::G2p2g {
                    k.g2p2g.launch(l, p, d)?;
                } else {
                    k.one_pass.launch(l, self.gather, p, d)?;
                }
                // A rank's drains are settled once every rank's are on its stack (cuda_ranks.rs).
                if let Some(flow) = d.flow.as_ref().filter(|f| f.num_sinks > 0 && !f.shared) {
                    k.lifecycle.settle(l, flow)?;
                }
                self.mass_scattered = Some(Scattered::by(&self.params));
                // A frame's end holds for the one pass that ends its last substep (the ranks launch
                // their phases without `Solver::step`).
                self.gather = Gather::Substep;
            }
        }
        Ok(true)
    }

    /// The parameters the grid update reads the node sums with: the fused pipeline's momentum was
    /// scattered by the substep before (one_pass), in that substep's fixed-point units, which a new
    /// stretch of substeps may have changed (`Simulation::momentum_scale`).
    fn grid_params(&self) -> Params {
        let mut params = self.params;
        if let Some(scattered) = self.mass_scattered.filter(|_| self.pipeline == Pipeline::Fused) {
            params.fixed_momentum_scale = scattered.momentum_scale();
        }
        params
    }

    /// Whether the binned pipeline scatters the momentum through a tile (p2g_tiled.cu) rather than
    /// by warp runs (p2g.cu): for fixed point, and for any scene with a flow (p2g.cu walks the whole
    /// order, parked slots included). Each is the faster there, measured on the H200 (2026-11-23,
    /// mpm bench, p2g medians): float at bench-655k 0.097 ms by runs, 0.17 ms tiled (the L2 adds
    /// floats natively, a tile must round every contribution); fixed point 0.17 ms tiled, 0.20 ms by
    /// integer runs, 0.66 ms by unaggregated 64-bit atomics (16.8M particles: 3.48 against 3.86 ms).
    fn scatters_momentum_by_tile(&self) -> bool {
        self.params.scatter_mode == ScatterMode::FixedPoint.code() || self.state.flow.is_some()
    }

    /// Whether the coming substep sorts (`BinSchedule::due`).
    pub(super) fn sort_due(&self) -> bool {
        self.schedule.due()
    }

    /// Room for `capacity` particles, the places past the current ones parked
    /// (`DeviceState::grow_particles`); the next sort phase bins them all.
    pub(super) fn grow_particles(&mut self, capacity: usize) -> Result<()> {
        ensure!(
            self.pbmpm.is_none(),
            "the position-based solver cannot grow its particles"
        );
        self.state.grow_particles(&self.gpu, capacity)?;
        self.params.num_particles = capacity as u32;
        // Captured substeps launch with the old buffers.
        self.graphs.clear();
        self.schedule.invalidate();
        Ok(())
    }

    /// Whether the extremes of `ticket` have reached the host, without waiting (a caller that
    /// must watch something else while it waits polls this).
    pub(super) fn extremes_ready(&self, ticket: &ExtremesTicket) -> Result<bool> {
        match ticket {
            ExtremesTicket::Ready(_) => Ok(true),
            ExtremesTicket::Pending(slot) => self.state.counters.copied(*slot),
        }
    }

    /// The places this solver's particle buffers hold, live and parked.
    pub fn capacity(&self) -> usize {
        self.state.particles.count
    }

    /// Whether each binning gathers the particles into bin order, which packs the live ones first.
    pub(super) fn keeps_bin_order(&self) -> bool {
        self.state.bin_order.is_some()
    }

    /// One emission of the emitters in `mask` (as of the parameters accepted last); on a rank,
    /// `rank` says which of the new particles are its own and where they go (cuda_ranks.rs).
    pub(super) fn emit_into(&mut self, mask: u32, rank: Option<&RankEmission>) -> Result<()> {
        let (k, l) = (&self.kernels, &self.gpu.launcher);
        // New particles join the sums the grid holds: in their momentum units (`grid_params`).
        let into = self.grid_params();
        let scattered = self.mass_scattered.is_some();
        k.lifecycle.emit(l, &into, mask, scattered, &self.state, rank)?;
        // The new particles are in no bin yet.
        self.schedule.invalidate();
        Ok(())
    }

    /// A rank's lifecycle (cuda_ranks/flow.rs): the slots its sinks pushed since its free stack was
    /// last settled, and the counters as they stand. Waits for the device.
    pub(super) fn unsettled_drains(&self) -> Result<(FlowCounters, Vec<u32>)> {
        self.rank_flow()?.unsettled(&self.gpu)
    }

    /// Puts `drained`, every rank's drains of a substep, in place of this rank's `own` (as
    /// `counters` read them) and sorts them on the free stack, as one GPU settles its own.
    pub(super) fn settle_drains(
        &mut self,
        counters: FlowCounters,
        own: usize,
        drained: &[u32],
    ) -> Result<()> {
        let stream = self.gpu.stream().clone();
        let flow = self
            .state
            .flow
            .as_mut()
            .context("a rank without the run's lifecycle")?;
        flow.replace_unsettled(&stream, counters, own, drained)?;
        self.kernels.lifecycle.settle(&self.gpu.launcher, flow)
    }

    /// This rank's look at the nozzle points of the emitters in `mask` (nozzles_blocked), its
    /// particles among its first `places`, into `looks` and back to the host.
    pub(super) fn look_at_nozzles(
        &self,
        mask: u32,
        places: usize,
        looks: &mut CudaSlice<u32>,
    ) -> Result<Vec<u32>> {
        let (k, l) = (&self.kernels.lifecycle, &self.gpu.launcher);
        k.nozzles_blocked(l, mask, self.rank_flow()?, (&self.state.particles, places), looks)?;
        self.gpu.download(looks)
    }

    /// The nozzle points of the scene's emitters.
    pub(super) fn nozzle_points(&self) -> Result<usize> {
        Ok(self.rank_flow()?.num_points as usize)
    }

    fn rank_flow(&self) -> Result<&DeviceFlow> {
        self.state
            .flow
            .as_ref()
            .context("a rank without the run's lifecycle")
    }

    /// Bins the particles in the next sort phase (cuda_ranks.rs: a migration changed which places
    /// are live).
    pub(super) fn rebin_next(&mut self) {
        self.schedule.invalidate();
    }

    pub(super) fn sort(&mut self) -> Result<()> {
        let (k, l, state) = (&self.kernels, &self.gpu.launcher, &mut self.state);
        state.bins.rebuild(
            &k.bins,
            l,
            &self.params,
            &state.particles.x,
            &mut state.grid.work_counts,
        )?;
        // The fused pipeline's one_pass reads a bin-ordered state without `order`, and the
        // position-based passes read theirs in runs: every binning gathers it
        // (`DeviceState::bin_order`).
        let bias = self.pbmpm.as_ref().and_then(PbmpmBuffers::bias_and_spare);
        if k.bin_order.launch(l, state, bias)? {
            self.swap_particle_buffers();
        }
        self.schedule.note_binning();
        Ok(())
    }

    /// Swaps in the spare particle buffers that the last binning gathered the particles into (the
    /// position-based volume biases with them); nothing where particles stay in place.
    fn swap_particle_buffers(&mut self) {
        self.state.swap_particle_buffers();
        if let Some(pbmpm) = &mut self.pbmpm {
            pbmpm.swap_bias();
        }
    }

    /// The binned and fused pipelines' scatter into a grid that holds none (`launch`: p2g_mass or
    /// one_pass without its gather), which the gathers keep up after it.
    pub(super) fn scatter_mass(&mut self, launch: Launch) -> Result<()> {
        // The substep's sort phase runs first whenever the bins are stale (`BinSchedule::due`).
        ensure!(
            self.schedule.built(),
            "the binned mass scatter walks the bins, which were never built: sort first"
        );
        let (k, l) = (&self.kernels, &self.gpu.launcher);
        let mut params = self.params;
        if launch == Launch::OnePassScatter {
            if let Some(last) = self.resumed.take() {
                params.dt = last.dt;
                params.fixed_momentum_scale = last.fixed_momentum_scale;
            }
            k.one_pass.launch(l, Gather::None, &params, &self.state)?;
        } else {
            k.p2g_mass.launch(l, &params, &self.state)?;
        }
        self.mass_scattered = Some(Scattered::by(&params));
        Ok(())
    }

    /// `Solver::step`'s work, under this substep's `gather`.
    fn enqueue_step(&mut self, params: &Params) -> Result<()> {
        self.accept(params)?;
        let sort = self.sort_due();
        // Not the first substep (it allocates on first use), nor one that scatters as a restored or
        // discarded state's first (`resumed`, which no key holds).
        let graphs = self.options.graphs
            && !self.gpu.launcher.sync_each_launch
            && self.substeps > 0
            && self.resumed.is_none();
        self.substeps += 1;
        let (enqueued, graphed) = match self.pbmpm {
            Some(_) => ("substep (pbmpm)", "substep (pbmpm, graph)"),
            None => ("substep", "substep (graph)"),
        };
        if !graphs {
            let _range = NvtxRange::new(enqueued);
            return self.enqueue_either_substep(sort);
        }
        let _range = NvtxRange::new(graphed);
        let key = SubstepKey {
            params: self.params,
            sort,
            mass_scattered: self.mass_scattered,
            colliders: self.state.colliders.count,
            particle_buffers: self.state.particle_buffers(),
            iterations: self.pbmpm.as_ref().map(|p| p.settings.iterations),
            phases_timed: self.timing.phases_next(),
            ends_frame: self.gather == Gather::SubstepEndingFrame,
        };
        let graph = match self.graphs.take(&key) {
            Some(graph) => {
                // What enqueue_substep's calls note on the host, for the work the graph replays.
                if sort {
                    self.schedule.note_binning();
                    self.swap_particle_buffers();
                }
                self.schedule.note_substep();
                self.mass_scattered = graph.scattered();
                graph
            }
            None => {
                let alike = self.graphs.take_alike(&key);
                self.capture_substep(sort, alike)?
            }
        };
        let launched = self
            .timing
            .begin_graphed_step(graph.recorded())
            .and_then(|events| graph.launch(events));
        self.graphs.put(key, graph);
        launched
    }

    /// The substep of the scene's scheme: the position-based one where the scene asks for it
    /// (pbmpm_substep.rs), the explicit one otherwise.
    fn enqueue_either_substep(&mut self, sort: bool) -> Result<()> {
        match self.pbmpm {
            Some(_) => self.enqueue_pbmpm_substep(sort),
            None => self.enqueue_substep(sort),
        }
    }

    /// Captures `enqueue_either_substep` into a graph; its host-side notes (binning, mass scattered) are
    /// made once here, as for a substep enqueued directly.
    /// `alike`: a cached graph to update to the capture ([`SubstepGraphs::take_alike`]).
    fn capture_substep(&mut self, sort: bool, alike: Option<SubstepGraph>) -> Result<SubstepGraph> {
        let stream = self.gpu.stream().clone();
        let placeholders = self.timing.begin_capture()?;
        let enqueue = || {
            self.enqueue_either_substep(sort)?;
            Ok((self.timing.captured(), self.mass_scattered))
        };
        let graph = SubstepGraph::capture(&stream, &placeholders, enqueue, alike);
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

    /// One substep, its phases' launches as pipelines.rs lists them (or the position-based
    /// substep's, pbmpm_substep.rs): enqueued kernel by kernel (`enqueue_either_substep`), or as one
    /// launch of a captured graph of exactly that work (graph.rs).
    fn step(&mut self, params: &Params) -> Result<()> {
        let stepped = self.enqueue_step(params);
        // `ends_frame_next` holds for one substep.
        self.gather = Gather::Substep;
        stepped
    }

    /// Marks the substep just enqueued and waits for the mark of the substep before it.
    fn pace(&mut self) -> Result<()> {
        if self.pace_marks.is_empty() {
            for _ in 0..2 {
                let mark = self
                    .gpu
                    .ctx
                    .new_event(Some(sys::CUevent_flags::CU_EVENT_DISABLE_TIMING))
                    .context("creating the stepping's pacing events")?;
                self.pace_marks.push(mark);
            }
        }
        let k = self.paced;
        self.pace_marks[k % 2]
            .record(self.gpu.stream())
            .context("marking a paced substep")?;
        if k > 0 {
            self.pace_marks[(k - 1) % 2]
                .synchronize()
                .context("waiting for the substep before")?;
        }
        self.paced += 1;
        Ok(())
    }

    fn ends_frame_next(&mut self) {
        self.gather = Gather::SubstepEndingFrame;
    }

    fn resume_after(&mut self, last: &Params) {
        // The position-based substep keeps no scatter from one substep to the next: nothing to resume.
        if self.pbmpm.is_none() {
            self.resumed = Some(*last);
        }
    }

    fn emit(&mut self, params: &Params, mask: u32) -> Result<()> {
        self.accept(params)?;
        self.emit_into(mask, None)
    }

    fn rebin_interval(&self) -> Option<u32> {
        Some(self.schedule.interval())
    }

    fn phase_kernel(&self, phase: Phase) -> Option<&'static str> {
        (self.pipeline == Pipeline::Fused && phase == Phase::G2p)
            .then(|| self.kernels.one_pass.kernel(&self.params).name())
    }

    fn flow_counts(&mut self) -> Result<Option<FlowCounts>> {
        self.state
            .flow
            .as_ref()
            .map(|f| f.read_counts(&self.gpu))
            .transpose()
    }

    fn flow_state(&mut self) -> Result<Option<FlowState>> {
        self.state
            .flow
            .as_ref()
            .map(|f| f.read_state(&self.gpu))
            .transpose()
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
        let fix = match self.pbmpm {
            Some(_) => super::pbmpm::OVERFLOW_FIX,
            None => super::counters::EXPLICIT_OVERFLOW_FIX,
        };
        let reading = self.state.counters.wait(slot, &self.params, fix)?;
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

    fn set_bodies(
        &mut self,
        bodies: &BodiesState,
        features: &[ContactFeature],
        walls: BodyWalls,
    ) -> Result<()> {
        // The fused pipeline's grid update alone sees a node's mass without the walls' images,
        // which the bodies' exchange counts (the binned one adds them in a launch before).
        ensure!(
            bodies.states.is_empty() || self.pipeline == Pipeline::Fused,
            "the {} pipeline moves no rigid bodies; use --pipeline fused (the default)",
            self.pipeline.name()
        );
        let uploaded = if bodies.states.is_empty() {
            None
        } else {
            Some(DeviceBodies::upload(self.gpu.stream(), bodies, features, walls)?)
        };
        self.state.colliders.set_bodies(uploaded);
        // Captured substeps launched the bodies' step over the bodies before (or none), from buffers
        // that are gone now.
        self.graphs.clear();
        Ok(())
    }

    fn bodies(&mut self) -> Result<Vec<RigidBody>> {
        match &self.state.colliders.bodies {
            Some(bodies) => bodies.read(self.gpu.stream()),
            None => Ok(Vec::new()),
        }
    }

    fn body_impulses(&mut self) -> Result<Vec<[i64; 6]>> {
        match &self.state.colliders.bodies {
            Some(bodies) => bodies.read_impulses(self.gpu.stream()),
            None => Ok(Vec::new()),
        }
    }

    fn set_iterations(&mut self, iterations: u32) -> Result<()> {
        let pbmpm = self
            .pbmpm
            .as_mut()
            .context("this CUDA solver runs the explicit scheme, which has no constraint iterations")?;
        pbmpm.settings.iterations = iterations;
        Ok(())
    }

    fn apply_push(&mut self, push: &Push) -> Result<()> {
        let (k, l) = (&self.kernels, &self.gpu.launcher);
        k.push.launch(l, push, &self.state.particles)?;
        // The fused pipeline scattered the next substep from the velocities before the push, and
        // its next pass gathers over that scatter, never reading them again: the scatter is dropped
        // and the next substep makes it anew from the pushed velocities, as a resumed run's first.
        if self.pipeline == Pipeline::Fused && self.mass_scattered.is_some() {
            self.state.grid.clear(self.gpu.stream())?;
            self.mass_scattered = None;
            self.resumed = Some(self.params);
        }
        Ok(())
    }

    fn particles(&self) -> ParticleView<'_> {
        ParticleView::Device(Box::new(DeviceParticlesView::new(
            &self.gpu,
            &self.kernels.render_attributes,
            &self.state.particles,
        )))
    }

    fn read_particles(&mut self) -> Result<Particles> {
        let mut particles = self.state.particles.download(&self.gpu)?;
        if let Some(pbmpm) = &self.pbmpm {
            particles.volume_bias = pbmpm.download_bias(&self.gpu, &self.state.particles)?;
        }
        Ok(particles)
    }

    fn snapshot_particles(&mut self) -> Result<ParticleSnapshot> {
        let ring = match &mut self.snapshots {
            Some(ring) => ring,
            None => self.snapshots.insert(SnapshotRing::new(&self.gpu)?),
        };
        ring.request(&self.gpu, &self.state.particles)
    }

    /// A device reduction (kernels/stats.cu): the host reads a few KiB, never the particles.
    fn summary(&mut self, table: &Params) -> Result<Summary> {
        let ticket = self.request_summary(table)?;
        self.wait_summary(ticket)
    }

    fn request_summary(&mut self, table: &Params) -> Result<SummaryTicket> {
        self.use_materials(table)?;
        let (k, l) = (&self.kernels, &self.gpu.launcher);
        let particles = &self.state.particles;
        self.stats.request(&k.stats, l, &self.params.kernel, particles)?;
        Ok(SummaryTicket::Pending)
    }

    fn wait_summary(&mut self, ticket: SummaryTicket) -> Result<Summary> {
        match ticket {
            SummaryTicket::Ready(summary) => Ok(summary),
            SummaryTicket::Pending => self.stats.wait(),
        }
    }
}
