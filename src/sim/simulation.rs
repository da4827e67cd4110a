//! The frame driver: a [`Simulation`] owns a [`Solver`] and advances it frame by frame under the
//! scene's time-step policy; the runner, the viewer, the tests and the benches all drive it.

use super::colliders::bodies::{BodiesState, RigidBody};
use super::colliders::ColliderFrame;
use super::dropped::{self, DropShape, DroppedBody};
use super::flow::{self, FlowCounts};
use super::gpu_gate::GpuGate;
use super::material::MaterialTable;
use super::params::{Params, Pipeline, FRAME_DT};
use super::phase::PhaseTimings;
use super::push::Push;
use super::scene::{Scene, TimeStepPolicy, MAX_CFL};
use super::solver::{ExtremesTicket, Solver, SummaryTicket};
use super::summary::Summary;
use anyhow::{bail, ensure, Context, Result};
use glam::{DVec3, Vec3};
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// How far past the fastest particle's speed the fixed-point momentum units reach
/// ([`Simulation::momentum_scale`]): a contribution carries the affine part too (up to 1.5 dx |C| a
/// row beside |v|), and the speed may rise over the stretch whose extremes are still on their way.
/// Then the power of two above the product; a particle past it scatters through the grid's atomics.
const MOMENTUM_REACH_MARGIN: f32 = 4.0;

/// A NaN or infinity in the state: what to tell the user.
fn diverged(frame: u64) -> anyhow::Error {
    anyhow::anyhow!(
        "the simulation diverged in frame {frame} (a NaN or infinity appeared); \
         lower time_step.cfl or time_step.dt, or raise material.sound_speed"
    )
}

/// What set a frame's substep: the CFL bound's sound speed or flow speed, the materials' viscosity,
/// or the scene's fixed dt.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StepLimit {
    Acoustic,
    Advective,
    Viscous,
    Fixed,
}

impl StepLimit {
    pub fn name(self) -> &'static str {
        match self {
            StepLimit::Acoustic => "acoustic",
            StepLimit::Advective => "advective",
            StepLimit::Viscous => "viscous",
            StepLimit::Fixed => "fixed",
        }
    }
}

/// One line of the runner's output.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrameStats {
    pub frame: u64,
    /// Simulated seconds at the end of the frame.
    pub time: f64,
    pub substeps: u32,
    /// The smallest substep of the frame, s.
    pub dt: f32,
    /// max over the frame's substeps of (c(rho) + |v|) dt / dx, from the per-step extremes.
    pub max_cfl: f32,
    /// The limit that set the frame's smallest substep.
    pub limit: StepLimit,
    /// Substeps of the frame run in a stretch whose CFL number went above [`MAX_CFL`] (0 when the
    /// bound held). The step cannot be taken back, so these are counted and reported instead.
    pub substeps_over_cfl: u32,
    /// Particles the colliders' backstop put back on a collider's surface in this frame
    /// (see [`StepExtremes::backstop_pushes`](super::StepExtremes::backstop_pushes)); 0 without colliders.
    pub backstop_pushes: u64,
    #[serde(flatten)]
    pub summary: Summary,
    /// What emitters and sinks did since the run began; `None` in a scene without them.
    pub flow: Option<FlowCounts>,
    /// Emitter layers that fell due more than once in a substep since the run began (the jet could not
    /// keep its rate at that substep); 0 without emitters.
    pub late_layers: u64,
    /// Per-phase milliseconds summed over the frame's substeps, where the backend measures them.
    pub timings: Option<PhaseTimings>,
    /// The rigid bodies at the frame's end, in the order of the colliders that are bodies (a pose
    /// table a frame in `--stats`); empty, and left out of the JSON, without bodies.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub bodies: Vec<BodyPose>,
}

/// A rigid body's pose and velocities (`FrameStats::bodies`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BodyPose {
    /// Its index among the scene's colliders.
    pub collider: u32,
    /// World position of its collider's centre, m.
    pub center: [f64; 3],
    /// World-from-body rotation, a unit quaternion (x, y, z, w).
    pub orientation: [f64; 4],
    /// Of its centre of mass, m/s.
    pub velocity: [f64; 3],
    /// rad/s, world frame.
    pub angular_velocity: [f64; 3],
}

impl BodyPose {
    pub fn of(body: &RigidBody) -> BodyPose {
        BodyPose {
            collider: body.slot,
            center: body.center,
            orientation: body.orientation,
            velocity: body.velocity,
            angular_velocity: body.angular_velocity,
        }
    }
}

/// What one frame's substeps did, without the statistics pass (which copies every particle).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameSteps {
    pub substeps: u32,
    /// The smallest substep of the frame, s.
    pub dt: f32,
    pub max_cfl: f32,
    /// See [`FrameStats::limit`].
    pub limit: StepLimit,
    /// See [`FrameStats::substeps_over_cfl`].
    pub substeps_over_cfl: u32,
    /// See [`FrameStats::backstop_pushes`].
    pub backstop_pushes: u64,
    pub timings: Option<PhaseTimings>,
}

pub struct Simulation {
    /// The scene, its colliders followed by the bodies dropped into the run (`dropped`).
    scene: Scene,
    params: Params,
    solver: Box<dyn Solver>,
    /// The rigid bodies as of the last frame's end (the solver steps them).
    bodies: Vec<RigidBody>,
    /// The bodies dropped into the run ([`Simulation::drop_body`]), in order: the last of the scene's
    /// colliders and bodies.
    dropped: Vec<DroppedBody>,
    frame: u64,
    time: f64,
    /// c(max density) + max speed over the last stretch of substeps, m/s: an upper bound of every
    /// particle's signal speed, which the next substep is chosen from.
    signal_speed: f32,
    /// How much it rose over that stretch (0 if it fell): a rising trend is extrapolated one stretch on.
    signal_rise: f32,
    /// The largest particle speed of each of the last two stretches of substeps whose extremes are in,
    /// the earlier first, m/s: what the fixed-point momentum units are made for
    /// ([`Simulation::momentum_scale`]).
    flow_speeds: [f32; 2],
    /// Whether the fastest particle outran the sound speed in `signal_speed` (the advective part of
    /// the CFL bound is the larger).
    advective: bool,
    /// The largest substep the materials' viscosity allows (`MaterialTable::viscous_dt`), s.
    viscous_dt: f32,
    /// The last frame's per-substep timings, for the benches' medians.
    last_step_timings: Vec<PhaseTimings>,
    /// A frame begun by [`Simulation::step_frame_until`] and not finished yet.
    in_progress: Option<FramePart>,
    /// Set by [`Simulation::advance_frame`]: the frame's last stretch is followed by the statistics
    /// request, so they arrive with its extremes, in the frame's one wait.
    summary_wanted: bool,
    summary_ticket: Option<SummaryTicket>,
    /// See [`Simulation::overlap_frames`].
    overlap_frames: bool,
    /// See [`Simulation::share_gpu`].
    gpu_gate: Option<Arc<GpuGate>>,
    /// The last frame's last stretch of substeps (ticket, substeps, dt), left in flight by
    /// [`Simulation::overlap_frames`]: accounted in the next frame, or by `settle`.
    trailing: Option<(ExtremesTicket, u32, f32)>,
    /// What a settled trailing stretch adds to the next frame's statistics.
    settled: Option<FramePart>,
    /// See [`RunClock`].
    emitter_phases: Vec<f64>,
    late_layers: u64,
    /// Backstop pushes since the start (see [`StepExtremes::backstop_pushes`]).
    backstop_total: u64,
    /// Substeps since the start whose CFL number was above the bound: where there were none, the
    /// fused pipeline's lagging density did not cause a blow-up, and the binned advice would mislead.
    over_cfl_total: u64,
}

/// What a frame's substeps have done so far.
#[derive(Debug, Clone)]
struct FramePart {
    substeps: u32,
    smallest_dt: f32,
    max_cfl: f32,
    limit: StepLimit,
    over_cfl: u32,
    backstop_pushes: u64,
    /// Simulated seconds of the frame so far.
    simulated: f64,
    /// Timing records of the frame's substeps read so far (`None` where the backend measures none).
    /// They are read after each stretch's extremes, while the GPU runs the next stretch: read all at
    /// the frame's end, after the wait for its last substep, they kept the GPU idle for 1.3 ms a
    /// frame (dam break, H200: 75 substeps, six events each).
    step_timings: Option<Vec<PhaseTimings>>,
}

impl FramePart {
    const START: FramePart = FramePart {
        substeps: 0,
        smallest_dt: f32::INFINITY,
        max_cfl: 0.0,
        limit: StepLimit::Acoustic,
        over_cfl: 0,
        backstop_pushes: 0,
        simulated: 0.0,
        step_timings: None,
    };

    fn read_step_timings(&mut self, solver: &mut dyn Solver) -> Result<()> {
        if let Some(records) = solver.take_step_timings()? {
            self.step_timings.get_or_insert_with(Vec::new).extend(records);
        }
        Ok(())
    }
}

/// Where a run stands between frames: its clock and the time-step policy's memory. With the particles,
/// the rigid bodies, the parameters and the scene, this is all a run carries from one frame to the next (the stretches
/// whose extremes are read asynchronously are all accounted by the end of a frame), so a checkpoint
/// holds it and [`Simulation::resume`] goes on from it exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct RunClock {
    /// Frames completed.
    pub frame: u64,
    /// Simulated seconds at the end of frame `frame`.
    pub time: f64,
    /// See [`Simulation`]'s fields of the same names.
    pub signal_speed: f32,
    pub signal_rise: f32,
    pub flow_speeds: [f32; 2],
    /// Each emitter's layers owed (`flow::schedule`).
    pub emitter_phases: Vec<f64>,
    /// See [`FrameStats::late_layers`].
    pub late_layers: u64,
}

impl Simulation {
    /// Goes on from a saved state: `solver` already holds the saved particles and rigid bodies
    /// (`bodies`, whose states the frame driver keeps a copy of between frames), `params` are the
    /// parameters the run had (live changes included), `clock` where it stood. `scene` holds the
    /// bodies `dropped` into the run after its own colliders ([`dropped::add_to`]).
    pub fn resume(
        scene: Scene,
        mut solver: Box<dyn Solver>,
        params: Params,
        clock: RunClock,
        bodies: &[RigidBody],
        dropped: &[DroppedBody],
    ) -> Simulation {
        solver.resume_after(&params);
        let mut sim = Simulation::new(scene, solver);
        sim.bodies = bodies.to_vec();
        sim.dropped = dropped.to_vec();
        sim.params = params;
        sim.viscous_dt = sim.params.viscous_dt(sim.params.dx);
        sim.frame = clock.frame;
        sim.time = clock.time;
        sim.signal_speed = clock.signal_speed;
        sim.signal_rise = clock.signal_rise;
        sim.flow_speeds = clock.flow_speeds;
        sim.emitter_phases = clock.emitter_phases;
        sim.late_layers = clock.late_layers;
        sim
    }

    /// The clock between frames; `None` while a frame begun by [`Self::step_frame_until`] is unfinished
    /// (finish it with [`Self::step_frame`] first) or its last stretch is in flight
    /// ([`Self::overlap_frames`]; [`Self::settle`] first).
    pub fn clock(&self) -> Option<RunClock> {
        (self.in_progress.is_none() && self.trailing.is_none()).then_some(RunClock {
            frame: self.frame,
            time: self.time,
            signal_speed: self.signal_speed,
            signal_rise: self.signal_rise,
            flow_speeds: self.flow_speeds,
            emitter_phases: self.emitter_phases.clone(),
            late_layers: self.late_layers,
        })
    }

    pub fn new(scene: Scene, solver: Box<dyn Solver>) -> Simulation {
        let params = scene.params();
        let sound_speed = params.fastest_sound_speed();
        let signal_speed = sound_speed + scene.fastest_start();
        let advective = scene.fastest_start() > sound_speed;
        let flow_speeds = [scene.fastest_start(); 2];
        let viscous_dt = params.viscous_dt(params.dx);
        let emitter_phases = vec![0.0; scene.flow.emitters.len()];
        let bodies = scene.colliders.rigid_bodies().0;
        Simulation {
            bodies,
            dropped: Vec::new(),
            scene,
            params,
            solver,
            frame: 0,
            time: 0.0,
            signal_speed,
            signal_rise: 0.0,
            flow_speeds,
            advective,
            viscous_dt,
            last_step_timings: Vec::new(),
            in_progress: None,
            summary_wanted: false,
            summary_ticket: None,
            overlap_frames: false,
            gpu_gate: None,
            trailing: None,
            settled: None,
            emitter_phases,
            late_layers: 0,
            backstop_total: 0,
            over_cfl_total: 0,
        }
    }

    /// The scene as the run has it: its colliders are the scene file's, then the bodies dropped into
    /// the run ([`Self::drop_body`]).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }
    /// The bodies dropped into the run, in order (none at the start).
    pub fn dropped(&self) -> &[DroppedBody] {
        &self.dropped
    }
    pub fn params(&self) -> &Params {
        &self.params
    }
    pub fn backend(&self) -> &'static str {
        self.solver.name()
    }
    pub fn frame(&self) -> u64 {
        self.frame
    }
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Simulated seconds including the part of a frame begun by [`Self::step_frame_until`].
    pub fn time_stepped(&self) -> f64 {
        self.time + self.in_progress.as_ref().map_or(0.0, |part| part.simulated)
    }
    /// One timing record per substep of the last frame (empty where the backend measures none).
    pub fn last_step_timings(&self) -> &[PhaseTimings] {
        &self.last_step_timings
    }
    /// Particles the colliders' backstop put back on a collider's surface since the start.
    pub fn backstop_pushes(&self) -> u64 {
        self.backstop_total
    }
    /// The scene's colliders, as the viewer draws and drags them.
    pub fn colliders(&self) -> &super::Colliders {
        &self.scene.colliders
    }
    /// The colliders as of the last substep's end (the current simulated time), the rigid bodies
    /// as of the last frame's end.
    pub fn collider_frame(&self) -> ColliderFrame {
        let mut frame = self.scene.colliders.frame(self.time_stepped());
        frame.place_bodies(&self.bodies);
        frame
    }
    /// The rigid bodies as of the last frame's end (as the scene starts them before the first).
    pub fn bodies(&self) -> &[RigidBody] {
        &self.bodies
    }
    /// Moves collider `index` kinematically from now on: its centre is at `center` now and goes on
    /// at `velocity` (the viewer's drag). Its rotation stays as it is now.
    pub fn drag_collider(&mut self, index: usize, center: glam::DVec3, velocity: glam::DVec3) -> Result<()> {
        let now = self.time_stepped();
        let collider = self
            .scene
            .colliders
            .list
            .get_mut(index)
            .ok_or_else(|| anyhow::anyhow!("there is no collider {index}"))?;
        ensure!(
            collider.body.is_none(),
            "collider {index} is a rigid body: the water moves it, not the mouse"
        );
        ensure!(
            center.is_finite() && velocity.is_finite(),
            "a dragged collider's position and velocity must be finite"
        );
        let pose = collider.pose(now);
        collider.center = center;
        collider.rotation = pose.rotation;
        collider.motion = super::colliders::Motion::Steady {
            velocity,
            angular_velocity: glam::DVec3::ZERO,
            since: now,
        };
        self.signal_speed = self
            .signal_speed
            .max(self.params.fastest_sound_speed() + velocity.length() as f32);
        self.flow_speeds = self.flow_speeds.map(|s| s.max(velocity.length() as f32));
        Ok(())
    }
    /// Drops a rigid body into the running scene, at rest (`sim::dropped`): from the next substep on
    /// the solver moves it with the liquid and the other bodies. The bodies already there keep their
    /// states and the impulse sums their next step takes, exactly (read back from the solver, the
    /// new body appended, handed back). Refused, with what to do and nothing changed: a run split
    /// into ranks, a body [`DroppedBody::collider`] refuses, and a backend that moves no rigid bodies
    /// (cpu-parallel; the GPU's report and binned pipelines).
    pub fn drop_body(&mut self, body: DroppedBody) -> Result<()> {
        ensure!(
            self.scene.ranks == 1,
            "cannot drop a {} into a run split into {} ranks: rigid bodies run on one rank; drop --ranks \
             and --gpus",
            body.shape.name(),
            self.scene.ranks
        );
        let collider = body.collider(&self.scene)?;
        let mut colliders = self.scene.colliders.clone();
        colliders.add(collider);
        // Before the solver's state is read and replaced: the last frame's trailing stretch may
        // still be running (`overlap_frames`).
        self.settle()?;
        // The contact features of every body, the new one's after the others', and its state at the
        // start, as the scene's own bodies get theirs.
        let (start, features) = colliders.rigid_bodies();
        let mut bodies = BodiesState {
            states: self.solver.bodies()?,
            impulses: self.solver.body_impulses()?,
        };
        bodies
            .states
            .push(*start.last().expect("the collider just added is a rigid body"));
        bodies.impulses.push([0; 6]);
        self.solver
            .set_bodies(&bodies, &features, self.scene.body_walls())
            .with_context(|| format!("cannot drop a {}", body.shape.name()))?;
        self.scene.colliders = colliders;
        self.bodies = bodies.states;
        self.dropped.push(body);
        Ok(())
    }

    /// Where the viewer lets a body of `shape` go over the point (x, z) ([`dropped::drop_center`]):
    /// above the liquid under it and clear of the colliders, in the state as it is now (which this
    /// reads back, from the GPU too).
    pub fn drop_center(&mut self, shape: &DropShape, over: (f64, f64)) -> Result<DVec3> {
        let particles = self.solver.read_particles()?;
        let frame = self.collider_frame();
        Ok(dropped::drop_center(&self.scene, &particles, &frame, shape, over))
    }

    pub fn solver(&self) -> &dyn Solver {
        self.solver.as_ref()
    }
    /// Readies the calling thread to step this simulation ([`Solver::bind_to_thread`]).
    pub fn bind_to_thread(&self) -> Result<()> {
        self.solver.bind_to_thread()
    }

    /// Whether [`Self::step_frame_until`] returns as soon as a frame's last stretch of substeps is
    /// enqueued, rather than once its extremes are in: the caller (the viewer) draws the frame while
    /// the GPU finishes that stretch, and the wait moves to the next frame, after its first stretch is
    /// enqueued (BENCHMARKS.md 0f: 0.2 to 0.4 ms a draw on the H200, about one stretch's GPU time,
    /// since within a frame each choice still waits for the stretch before the last). The next
    /// frame's first stretch is then chosen without
    /// the last one's extremes, as every stretch after a frame's first already is (`steps_for`'s
    /// `unknown`), and the frame's statistics take the trailing stretch's in with the next frame's.
    /// The sequence of choices still follows the order of the stretches, not timing.
    pub fn overlap_frames(&mut self, on: bool) -> Result<()> {
        if !on {
            self.settle()?;
        }
        self.overlap_frames = on;
        Ok(())
    }

    /// Each stretch of substeps (each substep, where a stretch is a whole frame) is enqueued only
    /// while `gate` is open: the viewer closes it while it draws on the same GPU ([`GpuGate`]).
    /// `None`: nothing to wait for.
    pub fn share_gpu(&mut self, gate: Option<Arc<GpuGate>>) {
        self.gpu_gate = gate;
    }

    /// Returns once the draw that shares the GPU ([`Self::share_gpu`]) has let go of it.
    fn pass_gpu_gate(&self) {
        if let Some(gate) = &self.gpu_gate {
            gate.pass();
        }
    }

    /// Accounts the last frame's trailing stretch now ([`Self::overlap_frames`]): before anything that
    /// changes the state the next choice is made from.
    pub fn settle(&mut self) -> Result<()> {
        if let Some((ticket, n, dt)) = self.trailing.take() {
            let mut part = self.settled.take().unwrap_or(FramePart::START);
            self.account_stretch(ticket, n, dt, &mut part)?;
            self.settled = Some(part);
        }
        Ok(())
    }

    pub fn solver_mut(&mut self) -> &mut dyn Solver {
        self.solver.as_mut()
    }

    /// The fixed-point momentum scale for a stretch of substeps lasting `span` seconds
    /// ([`Scene::fixed_momentum_scale_for`]), `previous_pending` where the stretch before it is still
    /// on its way: made for the fastest particle of the stretch two before (or the scene's fastest
    /// start, an emitter's or a collider's speed) plus what gravity can add over that stretch's
    /// successor and this one (taken as long as this one), times [`MOMENTUM_REACH_MARGIN`]. Never from
    /// the stretch just before, whose extremes are in or not depending on whether frames overlap
    /// ([`Self::overlap_frames`]): the units, so the bytes, do not. A particle faster than the units
    /// are made for still scatters exactly, through the grid's atomics; the margin keeps those few.
    fn momentum_scale(&self, span: f32, previous_pending: bool) -> f32 {
        let two_before = self.flow_speeds[usize::from(previous_pending)];
        let gravity_gain = Vec3::from(self.params.gravity).length() * 2.0 * span;
        let speed = two_before.max(self.scene.fastest_start()) + gravity_gain;
        self.scene.fixed_momentum_scale_for(MOMENTUM_REACH_MARGIN * speed)
    }

    /// Substeps and substep to cover the next `span` seconds. The signal speed can grow meanwhile: by up
    /// to |g| span from gravity, and, where it was rising (an impact compressing the fluid), by as much
    /// again as it rose over the last substeps. Both are added, so the step stays safe. `unknown` is
    /// the stretch of substeps already enqueued whose extremes are not yet known (its length in
    /// seconds, or 0): the speed may grow over it too, by gravity and by one more rise.
    /// The viscous limit ([`MaterialTable::viscous_dt`]) caps the substep the CFL bound allows; the
    /// limit that set it comes with it.
    fn steps_for(&self, span: f32, unknown: f32) -> Result<(u32, f32, StepLimit)> {
        let gravity_gain = Vec3::from(self.params.gravity).length() * (span + unknown);
        let rises = if unknown > 0.0 { 2.0 } else { 1.0 };
        let expected = self.signal_speed + rises * self.signal_rise + gravity_gain;
        let fixed = matches!(self.scene.time_step, TimeStepPolicy::Fixed { .. });
        match self.scene.time_step.substeps(span, expected, self.params.dx) {
            Ok((n, dt)) if fixed => Ok((n, dt, StepLimit::Fixed)),
            Ok((n, dt)) if dt > self.viscous_dt => {
                let n = (span / self.viscous_dt).ceil().max(n as f32);
                Ok((n as u32, span / n, StepLimit::Viscous))
            }
            // A span shorter than either limit's step (the frame's last stretch) takes its own
            // length; the limit named is still the tighter of the two.
            Ok((n, dt)) if self.viscous_dt < self.scene.time_step.longest_substep(expected, self.params.dx) => {
                Ok((n, dt, StepLimit::Viscous))
            }
            Ok((n, dt)) if self.advective => Ok((n, dt, StepLimit::Advective)),
            Ok((n, dt)) => Ok((n, dt, StepLimit::Acoustic)),
            // The fused pipeline's density is a substep behind an impact that outruns the CFL
            // bound (tests/scenarios.rs, every_substep_above_the_cfl_bound_is_counted).
            Err(why) if self.scene.pipeline == Pipeline::Fused && self.over_cfl_total > 0 => bail!(
                "frame {}: {why}. {} ran above the CFL bound before this (an impact faster than \
                 the policy foresaw), and the fused pipeline's advected density lags such an impact by a \
                 substep; --pipeline binned (or solver.pipeline = \"binned\") gathers the density afresh every \
                 substep and rides out more of such impacts",
                self.frame + 1,
                crate::text::count(self.over_cfl_total, "substep", "substeps")
            ),
            Err(why) => bail!("frame {}: {why}", self.frame + 1),
        }
    }

    /// Substeps per frame and the substep the next frame starts with, as the policy sees them now.
    pub fn next_frame_steps(&self) -> Result<(u32, f32)> {
        self.steps_for(FRAME_DT, 0.0).map(|(n, dt, _)| (n, dt))
    }

    /// What a stretch of `n` substeps of `dt` tells the time-step policy once its extremes are in:
    /// the signal speed and its rise, the frame's CFL number, and the substeps run above the bound.
    fn account_stretch(
        &mut self,
        ticket: ExtremesTicket,
        n: u32,
        dt: f32,
        part: &mut FramePart,
    ) -> Result<()> {
        let extremes = self.solver.wait_extremes(ticket)?;
        // The step is chosen from the pairing of the largest density with the largest speed; the
        // CFL number reported is docs/physics.md's, each particle's own (see StepExtremes).
        let mut bound = self.params.signal_speed(extremes.max_density, extremes.max_speed);
        // A solid's wave speed follows its own state (snow hardens as it compacts), not the density
        // the liquids' bound pairs with the speed: its particles' own signal speeds bound it. (A
        // liquid's own signal, an elastoviscoplastic one's included, is never above the pairing, so
        // this changes nothing for liquids.)
        if self.params.has_deformation() && extremes.max_signal_speed > bound {
            bound = extremes.max_signal_speed;
        }
        // Emitters keep adding particles at rest density and their own speed: those particles'
        // signal speed bounds the step even while the tank holds nothing as fast (a scene that starts
        // empty ran its first emitted layers at a CFL number near 2).
        if let Some(fastest) = self.scene.flow.emitters.iter().map(|e| e.speed).reduce(f32::max) {
            bound = bound.max(self.params.fastest_sound_speed() + fastest);
        }
        self.advective = extremes.max_speed > bound - extremes.max_speed;
        self.signal_rise = (bound - self.signal_speed).max(0.0);
        self.signal_speed = bound;
        self.flow_speeds = [self.flow_speeds[1], extremes.max_speed];
        let stretch_cfl = extremes.max_signal_speed * dt / self.params.dx;
        part.max_cfl = part.max_cfl.max(stretch_cfl);
        if stretch_cfl > MAX_CFL {
            part.over_cfl += n; // the stretch's extremes are all there is: count all its substeps
            self.over_cfl_total += u64::from(n);
        }
        part.backstop_pushes += extremes.backstop_pushes;
        self.backstop_total += extremes.backstop_pushes;
        Ok(())
    }

    /// Emits what the emitters owe before a substep of `dt` (nothing in a scene without them).
    fn emit_due(&mut self, dt: f32) -> Result<()> {
        if self.emitter_phases.is_empty() {
            return Ok(());
        }
        let spacing = self.scene.lattice().spacing;
        let (mask, late) = flow::schedule(&self.scene.flow, spacing, dt, &mut self.emitter_phases);
        self.late_layers += late;
        if mask != 0 {
            self.solver.emit(&self.params, mask)?;
        }
        Ok(())
    }

    /// Advance one 60 Hz frame and return its statistics.
    pub fn advance_frame(&mut self) -> Result<FrameStats> {
        // A request left by a frame that failed part-way is of another state: never read it.
        self.summary_ticket = None;
        self.settle()?;
        self.summary_wanted = true;
        let steps = self.step_frame();
        self.summary_wanted = false;
        let steps = steps?;
        let ticket = match self.summary_ticket.take() {
            Some(ticket) => ticket,
            None => self.solver.request_summary(&self.params)?,
        };
        let summary = self.solver.wait_summary(ticket)?;
        if !summary.is_finite() {
            return Err(diverged(self.frame));
        }
        Ok(FrameStats {
            frame: self.frame,
            time: self.time,
            substeps: steps.substeps,
            dt: steps.dt,
            max_cfl: steps.max_cfl,
            limit: steps.limit,
            substeps_over_cfl: steps.substeps_over_cfl,
            backstop_pushes: steps.backstop_pushes,
            summary,
            flow: self.solver.flow_counts()?,
            late_layers: self.late_layers,
            timings: steps.timings,
            bodies: self.bodies.iter().map(BodyPose::of).collect(),
        })
    }

    /// Advance one 60 Hz frame without the statistics pass (which copies every particle to the host):
    /// what the viewer calls every frame. The substep is chosen anew every `substeps_per_choice`
    /// substeps from the extremes of the ones before, always to cover what is left of the frame, so
    /// the last choice ends exactly on it.
    pub fn step_frame(&mut self) -> Result<FrameSteps> {
        loop {
            if let Some(steps) = self.step_frame_until(None)? {
                return Ok(steps);
            }
        }
    }

    /// [`Self::step_frame`] that stops once `deadline` has passed (checked after every substep) and
    /// returns `None`; the next call goes on with the same frame. The viewer uses it so that a frame
    /// that takes seconds on a CPU never stops the window from answering for longer than a substep.
    pub fn step_frame_until(&mut self, deadline: Option<Instant>) -> Result<Option<FrameSteps>> {
        let per_choice = self.scene.time_step.substeps_per_choice();
        let mut part = self
            .in_progress
            .take()
            .or_else(|| self.settled.take())
            .unwrap_or(FramePart::START);
        let late = || deadline.is_some_and(|d| Instant::now() >= d);
        // The stretch enqueued last, whose extremes are still on their way: the next stretch is chosen
        // without waiting for them (the GPU keeps working meanwhile), from the ones before, allowing
        // for the speed to grow over it too. Which extremes a choice sees is fixed by the order of
        // the stretches, never by timing, so runs stay reproducible.
        let mut in_flight: Option<(ExtremesTicket, u32, f32)> = self.trailing.take();
        // A stretch of a whole frame (a fixed step: the position-based solver's) would fill the
        // GPU's queue with a frame of work, and a draw sharing the GPU would wait behind all of it:
        // it is paced substep by substep instead, the gate passed before each (BENCHMARKS.md M25).
        let paced = self.gpu_gate.is_some() && per_choice.is_none();
        loop {
            self.pass_gpu_gate();
            let left = f64::from(FRAME_DT) - part.simulated;
            let unknown = in_flight.map_or(0.0, |(_, n, dt)| n as f32 * dt);
            let (to_frame_end, dt, limit) = self.steps_for(left as f32, unknown)?;
            let planned = per_choice.map_or(to_frame_end, |k| to_frame_end.min(k));
            self.params.dt = dt;
            self.params.fixed_momentum_scale = self.momentum_scale(planned as f32 * dt, in_flight.is_some());
            let mut n = 0;
            while n < planned {
                if paced {
                    self.pass_gpu_gate();
                }
                self.emit_due(dt)?;
                if !self.scene.colliders.is_empty() {
                    // Each substep's boundary conditions with the colliders where the substep ends.
                    let end = self.time + part.simulated + f64::from(n + 1) * f64::from(dt);
                    self.solver.set_colliders(&self.scene.colliders.frame(end))?;
                }
                if n + 1 == to_frame_end {
                    self.solver.ends_frame_next();
                }
                self.solver.step(&self.params)?;
                if paced {
                    self.solver.pace()?;
                }
                n += 1;
                if late() {
                    break;
                }
            }
            let ticket = self.solver.request_extremes()?;
            if let Some((earlier, earlier_n, earlier_dt)) = in_flight.replace((ticket, n, dt)) {
                self.account_stretch(earlier, earlier_n, earlier_dt, &mut part)?;
                part.read_step_timings(self.solver.as_mut())?;
            }
            part.substeps += n;
            if dt < part.smallest_dt {
                part.limit = limit;
            }
            part.smallest_dt = part.smallest_dt.min(dt);
            part.simulated += f64::from(n) * f64::from(dt);
            // Decided once: a stretch left in flight when the frame pauses would lose its extremes.
            let done = n == to_frame_end;
            let pause = !done && late();
            if done && self.summary_wanted {
                self.summary_ticket = Some(self.solver.request_summary(&self.params)?);
            }
            if done || pause {
                // Overlapping frames, the frame's last stretch stays in flight (not when its
                // statistics are wanted: they wait for it anyway).
                if done && self.overlap_frames && !self.summary_wanted {
                    self.trailing = in_flight.take();
                } else if let Some((ticket, n, dt)) = in_flight.take() {
                    self.account_stretch(ticket, n, dt, &mut part)?;
                }
                part.read_step_timings(self.solver.as_mut())?;
            }
            if done {
                break;
            }
            if pause {
                self.in_progress = Some(part);
                return Ok(None);
            }
        }
        if !self.bodies.is_empty() {
            self.bodies = self.solver.bodies()?;
        }
        let FramePart {
            substeps,
            smallest_dt,
            max_cfl,
            limit,
            over_cfl,
            backstop_pushes,
            simulated,
            step_timings,
        } = part;
        self.frame += 1;
        self.time += simulated;

        let timings = step_timings.as_deref().map(PhaseTimings::sum);
        self.last_step_timings = step_timings.unwrap_or_default();
        if !self.signal_speed.is_finite() {
            return Err(diverged(self.frame));
        }
        Ok(Some(FrameSteps {
            substeps,
            dt: smallest_dt,
            max_cfl,
            limit,
            substeps_over_cfl: over_cfl,
            backstop_pushes,
            timings,
        }))
    }

    /// Gives the particles near a ray a velocity change (the viewer's mouse push). The next frame's
    /// step accounts for the speed it adds.
    pub fn apply_push(&mut self, push: &Push) -> Result<()> {
        self.settle()?;
        self.solver.apply_push(push)?;
        self.signal_speed += push.max_speed_gain();
        self.flow_speeds = self.flow_speeds.map(|s| s + push.max_speed_gain());
        Ok(())
    }

    /// The viscosity of material `row` (live control): a Newtonian liquid's mu, Pa s, the power law's
    /// and Herschel-Bulkley's consistency K, Carreau-Yasuda's mu_0 (`Material::viscosity`). Must be
    /// finite and non-negative.
    pub fn set_viscosity(&mut self, row: usize, viscosity: f32) -> Result<()> {
        ensure!(
            viscosity.is_finite() && viscosity >= 0.0,
            "viscosity must be a finite number >= 0 Pa s, not {viscosity}"
        );
        let material = self.material_row(row)?;
        material.viscosity = viscosity;
        if material.law == crate::contract::LAW_NEWTONIAN {
            material.max_viscosity = viscosity;
        }
        self.viscous_dt = self.params.viscous_dt(self.params.dx);
        Ok(())
    }

    /// Sound speed at rest c0 of material `row`, m/s (live control): sets the Tait stiffness
    /// k = rho0 c0^2 / gamma, the one quantity c0 derives from. The next frame's substep follows the
    /// new speed.
    pub fn set_sound_speed(&mut self, row: usize, sound_speed: f32) -> Result<()> {
        ensure!(
            sound_speed.is_finite() && sound_speed > 0.0,
            "sound speed must be a finite number > 0 m/s, not {sound_speed}"
        );
        self.settle()?;
        let material = self.material_row(row)?;
        let old = material.sound_speed();
        material.eos_stiffness = material.rest_density * sound_speed * sound_speed / material.eos_power;
        let new = material.sound_speed();
        // The signal speed scales with c0 (its density factor stays the same).
        self.signal_speed = (self.signal_speed + new - old).max(new);
        Ok(())
    }

    /// Row `row` of the material table, to change.
    fn material_row(&mut self, row: usize) -> Result<&mut crate::contract::Material> {
        let rows = self.params.material_count as usize;
        ensure!(
            row < rows,
            "the scene has {rows} materials: there is no row {row}"
        );
        Ok(&mut self.params.materials[row])
    }

    /// Position-based MPM's constraint iterations a substep (live control), from the next frame on:
    /// 1 to `pbmpm::MAX_ITERATIONS`. The scene's `solver.iterations` follows, for what reads the
    /// scene; a checkpoint keeps it (`Checkpoint::pbmpm`).
    pub fn set_iterations(&mut self, iterations: u32) -> Result<()> {
        ensure!(
            self.scene.method == super::Method::Pbmpm,
            "the scene runs the explicit scheme, which has no constraint iterations (solver.method = \"pbmpm\")"
        );
        ensure!(
            (1..=super::pbmpm::MAX_ITERATIONS).contains(&iterations),
            "constraint iterations must be 1 to {}, not {iterations}",
            super::pbmpm::MAX_ITERATIONS
        );
        self.settle()?;
        self.solver.set_iterations(iterations)?;
        self.scene.pbmpm.iterations = iterations;
        Ok(())
    }

    /// Position-based MPM's substeps a 60 Hz frame (live control), from the next frame on: 1 to
    /// `pbmpm::MAX_SUBSTEPS`, each 1 / (60 substeps) s. A checkpoint keeps it (`Checkpoint::pbmpm`).
    pub fn set_substeps(&mut self, substeps: u32) -> Result<()> {
        ensure!(
            self.scene.method == super::Method::Pbmpm,
            "the scene runs the explicit scheme, whose substep follows the CFL policy (solver.method = \"pbmpm\" \
             takes a number of substeps)"
        );
        ensure!(
            (1..=super::pbmpm::MAX_SUBSTEPS).contains(&substeps),
            "substeps a frame must be 1 to {}, not {substeps}",
            super::pbmpm::MAX_SUBSTEPS
        );
        self.settle()?;
        self.scene.time_step = super::scene::TimeStepPolicy::pbmpm(substeps);
        Ok(())
    }

    /// Gravity, m/s^2 (live control). Every component must be finite.
    pub fn set_gravity(&mut self, gravity: Vec3) -> Result<()> {
        ensure!(gravity.is_finite(), "gravity must be finite, not {gravity:?}");
        self.params.gravity = gravity.to_array();
        Ok(())
    }
}
