//! The viewer's stepping: each draw hands the simulation to a worker thread that steps the next
//! draw's frames while the main thread builds the panel, draws and presents (the module above says
//! why); the next draw takes in what it did. What the drawing needs of the simulation meanwhile is
//! read before the worker has it. The export, where one runs, goes along: the worker hands it each
//! frame it completes.

use super::export::ExportSession;
use super::ViewerApp;
use crate::render::clock::Pacing;
use crate::sim::{PhaseTimings, Push, Simulation};
use anyhow::{Context, Result};
use glam::Vec2;
use std::sync::mpsc::{channel, Receiver, Sender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The stepping thread, one for the viewer's life: a draw hands it the simulation and the frames to
/// step ([`Stepper::start`]) and takes both back before its end ([`Stepper::finish`]). One thread
/// rather than one a draw, so that no draw waits for a thread to start and end around its stepping.
pub(super) struct Stepper {
    jobs: Option<Sender<Job>>,
    done: Receiver<Job>,
    thread: Option<JoinHandle<()>>,
}

/// What the stepping thread is handed and hands back: the simulation, the export it feeds, the
/// frames to step; back, what was stepped.
struct Job {
    sim: Simulation,
    export: Option<ExportSession>,
    frames: u32,
    stepped: Option<Stepped>,
}

impl Stepper {
    pub(super) fn new() -> Result<Stepper> {
        let (jobs, inbox) = channel::<Job>();
        let (outbox, done) = channel();
        let thread = std::thread::Builder::new()
            .name("mpm-stepping".into())
            .spawn(move || {
                for mut job in inbox {
                    job.stepped = Some(step_frames(&mut job.sim, &mut job.export, job.frames));
                    if outbox.send(job).is_err() {
                        break;
                    }
                }
            })
            .context("starting the viewer's stepping thread")?;
        Ok(Stepper {
            jobs: Some(jobs),
            done,
            thread: Some(thread),
        })
    }

    /// Hands `sim` to the thread to step `frames` 60 Hz frames ([`step_frames`]), and `export`
    /// to hand them to.
    pub(super) fn start(&mut self, sim: Simulation, export: Option<ExportSession>, frames: u32) {
        let job = Job {
            sim,
            export,
            frames,
            stepped: None,
        };
        let handed = match &self.jobs {
            Some(jobs) => jobs.send(job).is_ok(),
            None => false,
        };
        if !handed {
            self.resume_panic();
        }
    }

    /// Takes the simulation and the export back once the frames handed over are stepped, with
    /// what was stepped.
    pub(super) fn finish(&mut self) -> (Simulation, Option<ExportSession>, Stepped) {
        match self.done.recv() {
            Ok(Job {
                sim,
                export,
                stepped: Some(stepped),
                ..
            }) => (sim, export, stepped),
            _ => self.resume_panic(),
        }
    }

    /// The thread ended early, which only a panic on it does: resumed here, on the viewer's thread.
    fn resume_panic(&mut self) -> ! {
        self.jobs = None;
        match self.thread.take().map(JoinHandle::join) {
            Some(Err(panic)) => std::panic::resume_unwind(panic),
            _ => panic!("the viewer's stepping thread ended without a panic"),
        }
    }
}

impl Drop for Stepper {
    fn drop(&mut self) {
        self.jobs = None; // its loop ends with the channel
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// Wall time a draw may spend stepping before it draws what it has: a frame that costs more is
/// split over several draws (the simulation keeps its place), so the window keeps answering.
pub(super) const STEP_DEADLINE: Duration = Duration::from_millis(50);

/// What a draw shows of the simulation besides the particles, read before the stepping thread
/// takes it.
#[derive(Clone, Copy)]
pub(super) struct SimGlance {
    pub(super) backend: &'static str,
    /// `None` in a scene without colliders.
    pub(super) backstop_pushes: Option<u64>,
    /// A frame is partly stepped (split over draws).
    pub(super) frame_in_progress: bool,
    pub(super) time: f64,
}

impl SimGlance {
    pub(super) fn of(sim: &Simulation) -> SimGlance {
        SimGlance {
            backend: sim.backend(),
            backstop_pushes: (!sim.colliders().is_empty()).then(|| sim.backstop_pushes()),
            frame_in_progress: sim.time_stepped() > sim.time(),
            time: sim.time(),
        }
    }
}

/// What the stepping thread did in one draw (see [`step_frames`]).
pub(super) struct Stepped {
    completed: u32,
    /// Simulated seconds it advanced: whole frames, or part of one that outlasted the deadline.
    simulated: f64,
    /// Wall time it took.
    pub(super) took: Duration,
    /// When the stepping thread began and ended it: against when the simulation was handed over
    /// and taken back, the handover's cost.
    pub(super) began: Instant,
    pub(super) ended: Instant,
    /// Substeps, smallest dt and largest CFL number of the last frame it completed.
    last_steps: Option<(u32, f32, f32)>,
    over_cfl: u64,
    /// The last completed frame's phase timings.
    timings: Option<PhaseTimings>,
    /// The phase timings' milliseconds of the frames completed, summed, and how many frames.
    timed_ms: (f64, u32),
    error: Option<anyhow::Error>,
}

impl ViewerApp {
    /// 60 Hz frames to complete beside this draw: as the pacing says, or the one that N
    /// owes while paused. A frame that outlasts STEP_DEADLINE goes on in the next draw.
    pub(super) fn frames_to_step(&mut self, wall_dt: f64) -> u32 {
        // Recording fixes one 60 Hz frame per image, so the sequence plays back at real speed.
        self.clock.pacing = if self.recording.is_some() {
            Pacing::Fixed { frames_per_draw: 1 }
        } else if self.controls.fixed_pacing {
            Pacing::Fixed {
                frames_per_draw: self.controls.frames_per_draw.max(1),
            }
        } else {
            Pacing::RealTime {
                max_frames_per_draw: 4,
            }
        };
        if self.controls.paused {
            self.step_owed |= std::mem::take(&mut self.step_requested);
            return u32::from(self.step_owed);
        }
        self.step_requested = false;
        self.step_owed = false;
        match self.clock.pacing {
            Pacing::Fixed { frames_per_draw } => {
                if self.fixed_owed == 0 {
                    self.fixed_owed = frames_per_draw;
                }
                self.fixed_owed
            }
            Pacing::RealTime { .. } => self.clock.frames_for(wall_dt),
        }
    }

    /// Takes in what the stepping thread did; returns how many frames it completed. A failed step
    /// pauses the viewer with the reason shown, rather than closing it.
    pub(super) fn account_step(&mut self, stepped: Stepped, wall_dt: f64) -> u32 {
        if !self.controls.paused {
            self.clock.record(stepped.simulated, wall_dt);
        }
        self.clock
            .record_cost(stepped.completed, stepped.took.as_secs_f64());
        self.longest_step = self.longest_step.max(stepped.took);
        if let Some(last) = stepped.last_steps {
            self.last_steps = last;
        }
        self.over_cfl += stepped.over_cfl;
        self.step_costs.add(stepped.timed_ms.0, stepped.timed_ms.1);
        if stepped.timings.is_some() {
            self.last_timings = stepped.timings;
        }
        if stepped.completed > 0 {
            self.step_owed = false;
        }
        if let Some(e) = stepped.error {
            self.controls.paused = true;
            self.message = Some(format!("{e:#} (press R to reset)"));
            let time = self.sim.as_ref().map_or(0.0, Simulation::time_stepped);
            self.step_error = Some((time, format!("{e:#}")));
        }
        stepped.completed
    }

    /// Hands the mouse's push and a held collider's drag to the simulation, before `frames` frames
    /// are stepped.
    pub(super) fn prepare_step(&mut self, frames: u32) {
        let scene_cursor = self.scene_cursor();
        let Some(sim) = &mut self.sim else { return };
        if let (Some(held), Some((cursor, size))) = (self.mouse.collider_drag, scene_cursor) {
            if let Err(e) = held.follow(sim, &self.camera, cursor, size, frames) {
                self.message = Some(format!("drag failed: {e:#}"));
            }
        }
        let drag = std::mem::take(&mut self.mouse.push_drag);
        if drag != Vec2::ZERO {
            if let Some((cursor, size)) = scene_cursor {
                let (origin, direction) = self.camera.ray(cursor, size);
                // The drag in world units, along the camera's right and up axes.
                let view = self.camera.view();
                let right = view.row(0).truncate();
                let up = view.row(1).truncate();
                let delta_v = (drag.x * right - drag.y * up) * self.controls.push_strength;
                let (lo, hi) = self.scene.fluid_region();
                let radius = self.controls.push_radius * (hi - lo).as_vec3().max_element();
                let push = Push::new(origin, direction, radius, delta_v.clamp_length_max(10.0));
                if let Err(e) = sim.apply_push(&push) {
                    self.message = Some(format!("push failed: {e:#}"));
                }
            }
        }
    }
}

/// Completes up to `frames` 60 Hz frames of `sim` on the calling thread (the viewer's stepping
/// thread), handing each to `export` as it completes: at the frame's boundary, before the next
/// frame's substeps are enqueued (on the GPU the particles' copy to the host goes on the stream
/// between the two). It stops at STEP_DEADLINE, where a frame in progress keeps its place for the
/// next draw, and at the first error.
pub(super) fn step_frames(sim: &mut Simulation, export: &mut Option<ExportSession>, frames: u32) -> Stepped {
    let started = Instant::now();
    let deadline = started + STEP_DEADLINE;
    let time_before = sim.time_stepped();
    let mut stepped = Stepped {
        completed: 0,
        simulated: 0.0,
        took: Duration::ZERO,
        began: started,
        ended: started,
        last_steps: None,
        over_cfl: 0,
        timings: None,
        timed_ms: (0.0, 0),
        error: sim.bind_to_thread().err(),
    };
    while stepped.error.is_none() && stepped.completed < frames {
        match sim.step_frame_until(Some(deadline)) {
            Ok(Some(steps)) => {
                if let Some(export) = export {
                    export.export_frame(sim);
                }
                stepped.completed += 1;
                stepped.last_steps = Some((steps.substeps, steps.dt, steps.max_cfl));
                stepped.over_cfl += u64::from(steps.substeps_over_cfl);
                if let Some(t) = steps.timings.filter(|t| t.steps > 0) {
                    stepped.timed_ms.0 += t.total();
                    stepped.timed_ms.1 += 1;
                    stepped.timings = Some(t);
                }
            }
            Ok(None) => break, // the deadline passed; the frame goes on next draw
            Err(e) => stepped.error = Some(e),
        }
        if Instant::now() >= deadline {
            break;
        }
    }
    stepped.simulated = sim.time_stepped() - time_before;
    stepped.ended = Instant::now();
    stepped.took = stepped.ended - started;
    stepped
}
