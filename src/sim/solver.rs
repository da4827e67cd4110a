//! The step API of a backend: a [`Solver`] (CPU reference, cpu-parallel or CUDA) takes one substep
//! and answers what the frame driver (`simulation.rs`) and the readers of its particles ask of it.

use super::colliders::bodies::{BodiesState, BodyWalls, ContactFeature, RigidBody};
use super::colliders::ColliderFrame;
use super::flow::{FlowCounts, FlowState};
use super::params::Params;
use super::phase::{Phase, PhaseTimings};
use super::push::Push;
use super::scene::Particles;
use super::summary::Summary;
use super::view::ParticleView;
use anyhow::{bail, ensure, Result};
use serde::Serialize;

/// What the ranks of this process hold ([`Solver::holdings`]): the benchmark's table of ranks.
#[derive(Debug, Clone, Serialize)]
pub struct Holdings {
    /// The axis the slabs cut (0 for x).
    pub axis: usize,
    /// Migrations since the run began, and the particles they moved.
    pub migrations: u64,
    pub migrated: u64,
    pub ranks: Vec<RankHolding>,
}

/// One rank's share, as of its last migration.
#[derive(Debug, Clone, Serialize)]
pub struct RankHolding {
    pub rank: usize,
    /// The node planes across the slab axis it owns.
    pub slab: std::ops::Range<u32>,
    /// Its live particles.
    pub particles: usize,
    /// The particle places it allocated: its particles and room for arrivals.
    pub places: usize,
    /// The grid nodes it holds: its slab and ghost planes.
    pub grid_nodes: usize,
    /// What its particle, bin and grid buffers take, bytes: device memory for a CUDA rank, host
    /// memory for a CPU rank.
    pub bytes: usize,
}

/// The largest values any particle reached over the substeps since they were last taken.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepExtremes {
    pub max_density: f32,
    pub max_speed: f32,
    /// max_p (c(rho_p) + |v_p|), m/s: docs/physics.md's CFL number is this times dt / dx. The substep is
    /// chosen from c(max density) + max speed instead, an upper bound of it: at an impact the densest
    /// particles are the ones that just stopped, so the bound leaves headroom for the next impact.
    pub max_signal_speed: f32,
    /// Particles the colliders' backstop put back on a collider's surface (they had ended a substep
    /// inside it), summed over the substeps.
    pub backstop_pushes: u64,
}

impl StepExtremes {
    /// Takes in another rank's extremes: maxima and an integer sum, the same in any order.
    pub fn merge(&mut self, other: &StepExtremes) {
        self.max_density = self.max_density.max(other.max_density);
        self.max_speed = self.max_speed.max(other.max_speed);
        self.max_signal_speed = self.max_signal_speed.max(other.max_signal_speed);
        self.backstop_pushes += other.backstop_pushes;
    }
}

/// Per-substep timing records a backend keeps until they are taken; beyond that the oldest are
/// dropped (a caller that never takes timings must not grow memory without bound).
pub const MAX_PENDING_STEP_TIMINGS: usize = 1 << 14;

/// Keeps one more substep's record, dropping the oldest beyond [`MAX_PENDING_STEP_TIMINGS`]: the CPU
/// backends' pending timings.
pub fn push_step_timing(pending: &mut Vec<PhaseTimings>, record: PhaseTimings) {
    if pending.len() >= MAX_PENDING_STEP_TIMINGS {
        pending.remove(0);
    }
    pending.push(record);
}

/// Export snapshots a backend holds at once ([`Solver::snapshot_particles`]): one being written
/// while the next is copied.
pub const SNAPSHOTS_IN_FLIGHT: usize = 2;

/// A request for the extremes (see [`Solver::request_extremes`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ExtremesTicket {
    Ready(StepExtremes),
    /// The backend's own handle of a read still on its way.
    Pending(usize),
}

/// A request for the statistics (see [`Solver::request_summary`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SummaryTicket {
    Ready(Summary),
    /// A device reduction still on its way to the host.
    Pending,
}

/// The particles on their way to the host for export ([`Solver::snapshot_particles`]): [`Self::wait`]
/// gives them, on any thread, so that the copy and its reordering cost the stepping thread nothing.
pub enum ParticleSnapshot {
    Ready(Particles),
    Pending(Box<dyn PendingParticles>),
}

/// A backend's copy of the particles still on its way (the CUDA backend's pinned staging buffers).
pub trait PendingParticles: Send {
    /// Waits for the copy; the particles in slot order.
    fn wait(self: Box<Self>) -> Result<Particles>;
    /// How long the request waited for a staging copy held by an earlier snapshot.
    fn waited_for_buffers(&self) -> std::time::Duration {
        std::time::Duration::ZERO
    }
}

impl ParticleSnapshot {
    pub fn wait(self) -> Result<Particles> {
        match self {
            ParticleSnapshot::Ready(particles) => Ok(particles),
            ParticleSnapshot::Pending(pending) => pending.wait(),
        }
    }
}

/// A backend that advances the particles by one substep.
pub trait Solver: Send {
    fn name(&self) -> &'static str;
    /// Readies the calling thread to drive this solver: a CUDA context is current per thread, so a
    /// thread that takes the solver over (the viewer steps on a worker thread while its main thread
    /// draws) makes the solver's context current first. Nothing to do on the host backends.
    fn bind_to_thread(&self) -> Result<()> {
        Ok(())
    }
    /// One substep of `params.dt`: its phases (`Phase::ALL`) in step order.
    ///
    /// Under the fused pipeline's density rule (`DensityRule::Advected`) a substep's momentum is
    /// scattered at the end of the substep before it, so its stress impulse (which is linear in the
    /// step) is scattered with that substep's dt: where the time-step policy changes the step between
    /// two substeps, the first of the new step still kicks with the old one. Every backend does so
    /// (the first substep a solver takes uses its own dt, or [`Self::resume_after`]'s).
    fn step(&mut self, params: &Params) -> Result<()>;
    /// Called after each substep of a long stretch: waits until the device has run every substep
    /// but the one enqueued last. How a stepping thread that shares its GPU with a draw (`GpuGate`)
    /// keeps the queue short, so that the draw's work waits behind a substep rather than a whole
    /// frame's, while the next substep is enqueued before the device runs dry. Nothing to wait for
    /// where steps are synchronous.
    fn pace(&mut self) -> Result<()> {
        Ok(())
    }
    /// Says that the next substep is its frame's last, after which a checkpoint may be taken. A
    /// solver that scatters ahead of the next substep (the GPU's fused pass) makes that scatter as
    /// the first substep of a run resumed there makes it, so the resumed run goes on with the same
    /// bits: a plastic solid's stress taken from its stored deformation, not from the pass's return
    /// mapping (docs/checkpoints.md). Nothing to do where every scatter is made so.
    fn ends_frame_next(&mut self) {}
    /// Tells a solver restored from a checkpoint the parameters of the run's last substep before it,
    /// so that its first substep scatters as the uninterrupted run did (see [`Self::step`]).
    fn resume_after(&mut self, last: &Params);
    /// The extremes since the last call, then reset.
    fn take_extremes(&mut self) -> Result<StepExtremes>;
    /// `take_extremes` without waiting for the device: the extremes of the substeps enqueued so far
    /// are on their way to the host (and reset), and [`Self::wait_extremes`] gives them. A backend
    /// whose steps are synchronous answers at once. At most two requests may be outstanding.
    fn request_extremes(&mut self) -> Result<ExtremesTicket> {
        Ok(ExtremesTicket::Ready(self.take_extremes()?))
    }
    /// The extremes of a request, waiting for them where they are still on their way.
    fn wait_extremes(&mut self, ticket: ExtremesTicket) -> Result<StepExtremes> {
        match ticket {
            ExtremesTicket::Ready(extremes) => Ok(extremes),
            ExtremesTicket::Pending(_) => bail!("the {} backend issued no pending extremes", self.name()),
        }
    }
    /// One record per substep completed since the last call (each with `steps == 1`), oldest first,
    /// then reset; `None` where timings are not measured. The benches take medians of these.
    fn take_step_timings(&mut self) -> Result<Option<Vec<PhaseTimings>>>;
    /// The phase timings since the last call summed, then reset (drains the same records as
    /// [`Self::take_step_timings`]).
    fn take_timings(&mut self) -> Result<Option<PhaseTimings>> {
        Ok(self.take_step_timings()?.map(|steps| PhaseTimings::sum(&steps)))
    }
    /// A host copy of the particle state.
    fn read_particles(&mut self) -> Result<Particles>;
    /// The particle state after the substeps enqueued so far, for export: without C (`Particles::c`
    /// empty; no export writes it) and, where the backend can, without waiting for the device (the
    /// CUDA backend copies into pinned staging buffers on a stream of its own). At most
    /// [`SNAPSHOTS_IN_FLIGHT`] snapshots are held at once: a request beyond them waits until one is
    /// waited on or dropped.
    fn snapshot_particles(&mut self) -> Result<ParticleSnapshot> {
        let mut particles = self.read_particles()?;
        particles.c = Vec::new();
        Ok(ParticleSnapshot::Ready(particles))
    }
    /// Adds `push.velocity_change(x)` to every particle's velocity (the viewer's mouse push).
    fn apply_push(&mut self, push: &Push) -> Result<()>;
    /// Position-based MPM's constraint iterations a substep, from the next substep on (a live
    /// control; `Simulation::set_iterations` checks the count). The explicit solvers refuse.
    fn set_iterations(&mut self, _iterations: u32) -> Result<()> {
        anyhow::bail!(
            "the {} backend's solver here is the explicit one, which has no constraint iterations",
            self.name()
        )
    }
    /// The colliders the next substeps apply (their pose at the end of the substep): [`Simulation`](super::Simulation)
    /// sets them before every substep of a scene that has colliders. A backend without colliders
    /// refuses them.
    fn set_colliders(&mut self, frame: &ColliderFrame) -> Result<()> {
        ensure!(
            frame.is_empty(),
            "the {} backend does not apply colliders",
            self.name()
        );
        Ok(())
    }
    /// Takes over the scene's rigid bodies (their states at the start, or a checkpoint's) with their
    /// contact features and the walls that hold them: from the next substep on, the solver moves
    /// them with the liquid. A backend that cannot refuses.
    fn set_bodies(
        &mut self,
        bodies: &BodiesState,
        _features: &[ContactFeature],
        _walls: BodyWalls,
    ) -> Result<()> {
        ensure!(
            bodies.states.is_empty(),
            "the {} backend does not move rigid bodies (colliders with a density or mass); use --backend \
             cpu or cuda",
            self.name()
        );
        Ok(())
    }
    /// The rigid bodies as they are after the substeps run so far (none where the scene has none).
    fn bodies(&mut self) -> Result<Vec<RigidBody>> {
        Ok(Vec::new())
    }
    /// [`BodiesState::impulses`] as they are after the substeps run so far: with [`Self::bodies`],
    /// what a checkpoint holds of the bodies.
    fn body_impulses(&mut self) -> Result<Vec<[i64; 6]>> {
        Ok(Vec::new())
    }
    /// Where the particles are, for a reader (the renderer) that can use them in place: as of the
    /// last [`Self::publish_particles`] where the backend keeps them apart from the state it steps.
    fn particles(&self) -> ParticleView<'_>;
    /// Brings what [`Self::particles`] shows up to the substeps run so far, where a backend keeps it
    /// apart from the state it steps (the ranks gather their own particles into one set): a reader
    /// calls it before it reads (the render feed, once a frame); a run that nothing reads pays
    /// nothing for it.
    fn publish_particles(&mut self) -> Result<()> {
        Ok(())
    }
    /// The run has ended: where the ranks run one per process, rank 0 says so to the others, which
    /// go on sending it their particles for its last outputs until it does. Nothing elsewhere.
    fn finish(&mut self) -> Result<()> {
        Ok(())
    }
    /// Emits a layer from each emitter whose bit is set in `mask` (`sim::flow`), before the next
    /// substep. Only a solver made with the scene's emitters can.
    fn emit(&mut self, _params: &Params, mask: u32) -> Result<()> {
        ensure!(mask == 0, "the {} backend has no emitters", self.name());
        Ok(())
    }
    /// Substeps between two binnings of the particles when none asks for one sooner, where the
    /// solver bins them on a schedule (the GPU's binned and fused pipelines); `None` otherwise.
    fn rebin_interval(&self) -> Option<u32> {
        None
    }
    /// The kernel that runs `phase` for the current scene, where the backend chooses among several
    /// (the GPU's one_pass, by scatter mode and size), for a label that names it; `None` otherwise.
    fn phase_kernel(&self, _phase: Phase) -> Option<&'static str> {
        None
    }
    /// What each rank holds, for a run split over slabs whose ranks hold their own share (the CUDA
    /// ranks); `None` otherwise.
    fn holdings(&self) -> Option<Holdings> {
        None
    }
    /// What emitters and sinks did so far; `None` without them.
    fn flow_counts(&mut self) -> Result<Option<FlowCounts>> {
        Ok(None)
    }
    /// The lifecycle's state for a checkpoint; `None` without emitters and sinks.
    fn flow_state(&mut self) -> Result<Option<FlowState>> {
        Ok(None)
    }
    /// Statistics of the current state. Backends that can reduce in place override this copy.
    /// `table`: the materials as they are now (the viewer may have changed them since the solver
    /// last stepped).
    fn summary(&mut self, table: &Params) -> Result<Summary> {
        let particles = self.read_particles()?;
        Ok(Summary::of(&particles, table))
    }
    /// Starts the statistics of the state after the substeps enqueued so far, in stream order;
    /// [`Self::wait_summary`] gives them. A backend whose steps are synchronous answers at once. One
    /// request at a time.
    fn request_summary(&mut self, table: &Params) -> Result<SummaryTicket> {
        Ok(SummaryTicket::Ready(self.summary(table)?))
    }
    fn wait_summary(&mut self, ticket: SummaryTicket) -> Result<Summary> {
        match ticket {
            SummaryTicket::Ready(summary) => Ok(summary),
            SummaryTicket::Pending => bail!("the {} backend issued no pending statistics", self.name()),
        }
    }
}
