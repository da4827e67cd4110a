//! How many 60 Hz simulation frames to step per drawn frame.
//!
//! Real time: simulated time follows wall time, but at most `max_frames_per_draw` frames are stepped
//! per draw, and no more than fit in a draw budget at the measured cost of a frame; wall time beyond
//! that is dropped, so a slow machine shows slow motion rather than falling ever further behind.
//! A frame that costs more than a draw's budget is split over several draws by the viewer
//! (`Simulation::step_frame_until`), so the window keeps answering. Fixed: a set number per draw
//! (for recording, where each image must be the same simulated time apart).
//!
//! The speed (simulated over wall seconds) comes from what was actually stepped ([`SimClock::record`]).

use crate::sim::FRAME_DT;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pacing {
    RealTime { max_frames_per_draw: u32 },
    Fixed { frames_per_draw: u32 },
}

#[derive(Debug, Clone)]
pub struct SimClock {
    pub pacing: Pacing,
    /// Wall seconds not yet simulated.
    debt: f64,
    /// Exponentially decayed sums of simulated and wall seconds: their ratio is the speed, smooth
    /// even when draws alternate between stepping 0 and 2 frames.
    sim_sum: f64,
    wall_sum: f64,
    /// Smoothed wall seconds that stepping one 60 Hz frame takes here (0 until measured).
    frame_cost: f64,
}

/// Wall seconds of stepping a draw may take before it steps fewer frames (about 20 draws/s).
const STEP_BUDGET: f64 = 0.05;

impl SimClock {
    pub fn new(pacing: Pacing) -> SimClock {
        SimClock {
            pacing,
            debt: 0.0,
            sim_sum: 0.0,
            wall_sum: 0.0,
            frame_cost: 0.0,
        }
    }

    /// Tells the clock how long the last `frames` frames took to step.
    pub fn record_cost(&mut self, frames: u32, seconds: f64) {
        if frames > 0 {
            let per_frame = seconds / f64::from(frames);
            self.frame_cost = if self.frame_cost == 0.0 {
                per_frame
            } else {
                0.8 * self.frame_cost + 0.2 * per_frame
            };
        }
    }

    /// Frames to step for a draw `wall_dt` seconds after the last one.
    pub fn frames_for(&mut self, wall_dt: f64) -> u32 {
        let frame_dt = f64::from(FRAME_DT);
        match self.pacing {
            Pacing::Fixed { frames_per_draw } => frames_per_draw,
            Pacing::RealTime { max_frames_per_draw } => {
                self.debt += wall_dt;
                let due = (self.debt / frame_dt).floor().max(0.0) as u32;
                let affordable = if self.frame_cost > 0.0 {
                    ((STEP_BUDGET / self.frame_cost).floor() as u32).max(1)
                } else {
                    1
                };
                let frames = due.min(max_frames_per_draw).min(affordable);
                self.debt -= f64::from(frames) * frame_dt;
                // Behind by more than the cap: forget it (slow motion instead of catching up).
                self.debt = self.debt.min(frame_dt);
                frames
            }
        }
    }

    /// Records a draw: `simulated` seconds were stepped (whole frames or parts of one) over `wall_dt`
    /// wall seconds. The speed comes from these, not from the frames asked for, so a frame split
    /// over several draws counts as it goes.
    pub fn record(&mut self, simulated: f64, wall_dt: f64) {
        if wall_dt > 0.0 {
            self.sim_sum = 0.97 * self.sim_sum + simulated;
            self.wall_sum = 0.97 * self.wall_sum + wall_dt;
        }
    }

    /// Simulated seconds per wall second, smoothed: below 1 means slow motion.
    pub fn speed(&self) -> f64 {
        if self.wall_sum > 0.0 {
            self.sim_sum / self.wall_sum
        } else {
            1.0
        }
    }

    pub fn reset(&mut self) {
        self.debt = 0.0;
        self.sim_sum = 0.0;
        self.wall_sum = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn real_time_keeps_up_on_a_fast_machine() {
        let mut clock = SimClock::new(Pacing::RealTime {
            max_frames_per_draw: 4,
        });
        let draw = |clock: &mut SimClock, wall_dt: f64| {
            let frames = clock.frames_for(wall_dt);
            clock.record(f64::from(frames) * f64::from(FRAME_DT), wall_dt);
            frames
        };
        let total: u32 = (0..600).map(|_| draw(&mut clock, 1.0 / 120.0)).sum();
        assert!((299..=301).contains(&total), "{total} frames in 5 s");
        assert!((clock.speed() - 1.0).abs() < 0.05);
        // Drawing at 30 Hz with cheap steps: two frames per draw.
        clock.record_cost(1, 0.002);
        let total: u32 = (0..150).map(|_| draw(&mut clock, 1.0 / 30.0)).sum();
        assert!((299..=301).contains(&total), "{total} frames in 5 s at 30 Hz");
    }

    #[test]
    fn a_slow_machine_degrades_to_slow_motion() {
        let mut clock = SimClock::new(Pacing::RealTime {
            max_frames_per_draw: 2,
        });
        for _ in 0..100 {
            let frames = clock.frames_for(0.5);
            assert!(frames <= 2);
            clock.record(f64::from(frames) * f64::from(FRAME_DT), 0.5);
        }
        assert!(clock.speed() < 0.1, "speed {}", clock.speed());
        // Stepping costs a second per frame: one frame per draw, never a backlog.
        let mut clock = SimClock::new(Pacing::RealTime {
            max_frames_per_draw: 4,
        });
        for _ in 0..20 {
            let frames = clock.frames_for(1.0);
            assert_eq!(frames, 1);
            clock.record_cost(frames, 1.0);
        }
    }

    #[test]
    fn fixed_pacing_ignores_wall_time() {
        let mut clock = SimClock::new(Pacing::Fixed { frames_per_draw: 1 });
        assert_eq!(clock.frames_for(0.001), 1);
        assert_eq!(clock.frames_for(3.0), 1);
    }

    /// The exit line's figures are per draw and per frame: what the stepping thread took is reported
    /// beside the sections, not among them, and nothing is reported before it was measured.
    #[test]
    fn the_exit_line_averages_per_draw_and_per_frame() {
        let mut costs = DrawCosts::default();
        assert_eq!(costs.summary(), None);
        for _ in 0..4 {
            costs.begin();
            costs.stepped(
                std::time::Duration::from_millis(10),
                std::time::Duration::from_micros(50),
            );
        }
        let line = costs.summary().unwrap();
        assert!(line.starts_with("feed "), "{line}");
        assert!(line.contains(", step wait "), "{line}");
        assert!(
            line.ends_with("; stepping 10.00 (beside the draw), handover 0.05"),
            "{line}"
        );

        let mut steps = StepCosts::default();
        assert_eq!(steps.summary(), None);
        steps.add(30.0, 2);
        steps.add(6.0, 1);
        assert_eq!(steps.summary().unwrap(), "step total 12.00 per frame (3 frames)");
    }
}

/// Where the host's time in a draw goes, section by section (the viewer's exit line): what is neither
/// simulation nor rendering shows here as panel, present or feed time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DrawSection {
    /// The particles into the GL buffer (interop map, kernel, unmap; or the host copy).
    Feed,
    /// Building the panel (egui).
    Panel,
    /// The scene's GL commands.
    Draw,
    /// Painting the panel.
    Paint,
    /// Swapping buffers.
    Present,
    /// Waiting for the stepping thread once the frame is presented: the stepping that the panel, the
    /// drawing and the present did not hide.
    StepWait,
}

impl DrawSection {
    const ALL: [DrawSection; 6] = [
        DrawSection::Feed,
        DrawSection::Panel,
        DrawSection::Draw,
        DrawSection::Paint,
        DrawSection::Present,
        DrawSection::StepWait,
    ];

    fn name(self) -> &'static str {
        match self {
            DrawSection::Feed => "feed",
            DrawSection::Panel => "panel",
            DrawSection::Draw => "draw",
            DrawSection::Paint => "paint",
            DrawSection::Present => "present",
            DrawSection::StepWait => "step wait",
        }
    }
}

/// Host seconds per [`DrawSection`], summed over the draws measured.
#[derive(Debug, Clone, Default)]
pub struct DrawCosts {
    seconds: [f64; 6],
    /// The stepping thread's wall time, beside the sections.
    stepping: f64,
    /// Handing the simulation to the stepping thread and taking it back, beyond the stepping.
    handover: f64,
    draws: u64,
    lap: Option<std::time::Instant>,
}

impl DrawCosts {
    /// A draw begins now.
    pub fn begin(&mut self) {
        self.lap = Some(std::time::Instant::now());
        self.draws += 1;
    }

    /// The time since the last lap was `section`'s.
    pub fn lap(&mut self, section: DrawSection) {
        let now = std::time::Instant::now();
        if let Some(last) = self.lap.replace(now) {
            self.seconds[section as usize] += (now - last).as_secs_f64();
        }
    }

    /// The stepping thread took `took` in this draw (beside the panel, the drawing and the present),
    /// and its handover (from the simulation handed over to the thread's start, and from the thread's
    /// end to the simulation taken back) `handover` more.
    pub fn stepped(&mut self, took: std::time::Duration, handover: std::time::Duration) {
        self.stepping += took.as_secs_f64();
        self.handover += handover.as_secs_f64();
    }

    /// `feed 0.12, panel 0.50, ..., step wait 7.10; stepping 12.01 (beside the draw), handover 0.05`
    /// ms per draw; `None` before the first draw.
    pub fn summary(&self) -> Option<String> {
        (self.draws > 0).then(|| {
            let per_draw = |s: f64| s * 1e3 / self.draws as f64;
            let parts: Vec<String> = DrawSection::ALL
                .iter()
                .map(|&s| format!("{} {:.2}", s.name(), per_draw(self.seconds[s as usize])))
                .collect();
            format!(
                "{}; stepping {:.2} (beside the draw), handover {:.2}",
                parts.join(", "),
                per_draw(self.stepping),
                per_draw(self.handover)
            )
        })
    }
}

/// Milliseconds per 60 Hz frame stepped, as the panel's "step total" shows them (the backend's phase
/// timings: CUDA events on the GPU), averaged over the run for the viewer's exit line, where they
/// stand beside the render total and the draw interval.
#[derive(Debug, Clone, Default)]
pub struct StepCosts {
    ms: f64,
    frames: u64,
}

impl StepCosts {
    /// `frames` frames were stepped in `ms` milliseconds of phase timings, summed.
    pub fn add(&mut self, ms: f64, frames: u32) {
        self.ms += ms;
        self.frames += u64::from(frames);
    }

    /// `step total 9.85 per frame (299 frames)`; `None` before a frame was timed.
    pub fn summary(&self) -> Option<String> {
        (self.frames > 0).then(|| {
            format!(
                "step total {:.2} per frame ({} frames)",
                self.ms / self.frames as f64,
                self.frames
            )
        })
    }
}
