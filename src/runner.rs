//! The headless runner: steps a scene frame by frame, prints one line of statistics per frame,
//! and optionally writes them as JSON lines, exports PLY frames, surface meshes, volumes, the rigid bodies
//! and a USD stage.

use crate::checkpoint::CheckpointSeries;
use crate::export::bodies::BodyExporter;
use crate::export::frames::{frame_comment, ExportProgress, FrameExportSet, FrameExports};
use crate::export::surface::SurfaceExporter;
use crate::export::usd::UsdCache;
use crate::export::volume::VolumeExporter;
use crate::export::PlyExporter;
use crate::sim::scene::MAX_CFL;
use crate::sim::{FrameStats, Simulation};
use anyhow::{Context, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

pub struct RunOptions {
    pub frames: u64,
    /// Writes the initial state as frame 0, then every K-th frame.
    pub export: Option<PlyExporter>,
    /// Reconstructs the surface of the initial state and of every K-th frame as a mesh file, on
    /// worker threads while the simulation steps on.
    pub surface: Option<SurfaceExporter>,
    /// Builds the volumes (level set, density, velocity) of the initial state and of every K-th
    /// frame as OpenVDB files, on worker threads while the simulation steps on.
    pub volume: Option<VolumeExporter>,
    /// Writes the rigid bodies' meshes and poses of the initial state and every K-th frame.
    pub bodies: Option<BodyExporter>,
    /// Writes the USD stage's layer of the initial state and of every K-th frame, on a thread of its
    /// own (the surface's layers come from `surface`'s workers).
    pub usd: Option<Arc<UsdCache>>,
    pub stats: Option<StatsFile>,
    /// Writes the state every K-th frame and at the last one.
    pub checkpoints: Option<CheckpointSeries>,
    /// Show a progress bar (stdout is a terminal).
    pub progress: bool,
    /// When the command started (before the scene was read and the backend made), for the closing
    /// line that says where the wall time went.
    pub started: Instant,
}

impl RunOptions {
    /// `frames` frames that write nothing and show no progress: what a test, or a rank other than
    /// rank 0 of a run of a process per GPU, steps. Outputs are added with struct update syntax.
    pub fn writing_nothing(frames: u64, started: Instant) -> RunOptions {
        RunOptions {
            frames,
            export: None,
            surface: None,
            volume: None,
            bodies: None,
            usd: None,
            stats: None,
            checkpoints: None,
            progress: false,
            started,
        }
    }
}

/// The JSON-lines stats file: one [`FrameStats`] object per line. Checked when made, created with
/// its first line: a run that stops before its first frame leaves no empty file behind.
pub struct StatsFile {
    file: Option<BufWriter<File>>,
    path: PathBuf,
    /// It existed, and `--overwrite` said to replace it.
    replaces: bool,
}

impl StatsFile {
    /// Refuses to replace an existing file unless `overwrite`, and a path that cannot be a file.
    pub fn create(path: &Path, overwrite: bool) -> Result<StatsFile> {
        if path.is_dir() {
            anyhow::bail!("--stats {} is a directory; give a file name", path.display());
        }
        let exists = path.exists();
        if !overwrite && exists {
            anyhow::bail!(
                "{} already exists; choose another --stats file, or pass --overwrite to replace it",
                path.display()
            );
        }
        let folder = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        if !folder.is_dir() {
            anyhow::bail!(
                "cannot create the stats file {}: its folder {} does not exist",
                path.display(),
                folder.display()
            );
        }
        Ok(StatsFile {
            file: None,
            path: path.to_path_buf(),
            replaces: exists,
        })
    }

    fn append(&mut self, stats: &FrameStats, out: &mut dyn Write) -> Result<()> {
        let file = match &mut self.file {
            Some(file) => file,
            None => {
                let created = File::create(&self.path).map_err(|e| {
                    anyhow::anyhow!(
                        "cannot create the stats file {}: {}",
                        self.path.display(),
                        crate::text::io_reason(&e)
                    )
                })?;
                if self.replaces {
                    writeln!(
                        out,
                        "--overwrite: replaced the stats file {}",
                        self.path.display()
                    )?;
                }
                self.file.insert(BufWriter::new(created))
            }
        };
        serde_json::to_writer(&mut *file, stats)
            .map_err(anyhow::Error::from)
            .and_then(|_| writeln!(file).map_err(Into::into))
            .and_then(|_| file.flush().map_err(Into::into))
            .with_context(|| format!("cannot write the stats file {}", self.path.display()))
    }
}

/// The one-line summary the runner prints per frame.
pub fn format_frame(s: &FrameStats) -> String {
    let m = &s.summary;
    let c = m.centre_of_mass;
    let mut line = format!(
        "frame {:>5}  t={:.4} s  n={}  substeps={:>3} ({} limit)  |v|max={:.3} m/s  rho/rho0=[{:.3} {:.3} {:.3}]  \
         CFL={:.3}  KE={:.4e} J  com=({:.4}, {:.4}, {:.4}) m",
        s.frame,
        s.time,
        m.particles,
        s.substeps,
        s.limit.name(),
        m.max_speed,
        m.density_ratio_min,
        m.density_ratio_mean,
        m.density_ratio_max,
        s.max_cfl,
        m.kinetic_energy,
        c[0],
        c[1],
        c[2],
    );
    if let Some(f) = &s.flow {
        line += &format!("  emitted={} drained={}", f.emitted, f.drained);
        if f.exhausted > 0 {
            line += &format!(
                "  capacity exhausted at {}",
                crate::text::count(f.exhausted, "nozzle point", "nozzle points")
            );
        }
    }
    for b in &s.bodies {
        let [x, y, z] = b.center;
        line += &format!("  collider[{}]=({x:.4}, {y:.4}, {z:.4}) m", b.collider);
        // A body turning shows how fast (a hinged wheel's centre never moves).
        let spin = glam::DVec3::from(b.angular_velocity).length();
        if spin >= 0.05 {
            line += &format!(" turning {spin:.2} rad/s");
        }
    }
    if let Some(t) = &s.timings {
        line += &format!("  step={:.3} ms", t.per_step());
    }
    if s.substeps_over_cfl > 0 {
        line += &format!(
            "  CFL>{MAX_CFL} in {}",
            crate::text::count(s.substeps_over_cfl, "substep", "substeps")
        );
    }
    if s.backstop_pushes > 0 {
        line += &format!("  backstop={}", s.backstop_pushes);
    }
    line
}

/// The closing warning of a run whose emitters ran out of particle slots or could not keep their rate,
/// or `None`.
pub fn flow_warning(last: &FrameStats) -> Option<String> {
    let exhausted = last.flow.map_or(0, |f| f.exhausted);
    let mut warnings = Vec::new();
    if exhausted > 0 {
        warnings.push(format!(
            "warning: the emitters found no free particle slot {} (the scene's [particles] capacity is \
             used up: live particles {}); raise capacity, or add a sink that drains as fast as they fill",
            crate::text::count(exhausted, "time", "times"),
            last.flow.map_or(0, |f| f.live)
        ));
    }
    if last.late_layers > 0 {
        warnings.push(format!(
            "warning: {} fell due more than once in a substep and were skipped (the jet is faster than a \
             particle spacing per substep); lower the emitter's speed or time_step.cfl",
            crate::text::count(last.late_layers, "emitter layer", "emitter layers")
        ));
    }
    (!warnings.is_empty()).then(|| warnings.join("\n"))
}

/// The closing line of a run whose particles the colliders' backstop had to put back on a collider's
/// surface, or `None`: the grid's boundary condition alone did not keep them out. The pushes a
/// substep tell the likely causes apart: a few at most is fluid settling into the half cell above a
/// surface (a heap on a plate, over thousands of substeps), more is a fast or thin collider or a
/// large time step.
pub fn backstop_note(all: &[FrameStats]) -> Option<String> {
    let pushes: u64 = all.iter().map(|s| s.backstop_pushes).sum();
    if pushes == 0 {
        return None;
    }
    let frames = all.iter().filter(|s| s.backstop_pushes > 0).count();
    let substeps: u64 = all.iter().map(|s| u64::from(s.substeps)).sum();
    let per_substep = pushes as f64 / substeps.max(1) as f64;
    Some(format!(
        "note: the collider backstop put {} back on a collider's surface, in {} of {}, {per_substep:.2} a \
         substep (the grid's boundary condition did not stop them: {})",
        crate::text::count(pushes, "particle", "particles"),
        crate::text::count(frames, "frame", "frames"),
        all.len(),
        backstop_cause(per_substep)
    ))
}

/// The likely cause of a run's backstop pushes, from how many a substep there were.
fn backstop_cause(per_substep: f64) -> &'static str {
    if per_substep <= BACKSTOP_SETTLING_PER_SUBSTEP {
        "most likely fluid creeping into the half cell above a collider's surface, which its stencil \
         reaches past the one-cell band, as a heap settling on a plate does"
    } else {
        "most likely a fast or thin collider, or a large time step"
    }
}

/// Pushes a substep up to which the backstop note names settling fluid: the honey preset's heap on
/// its plate makes 1.4, the dam break with obstacles at 2.5 cm and one particle a cell about 1
/// (docs/physics.md, "Colliders"); a collider that outruns its band meets a whole layer of fluid
/// each substep.
const BACKSTOP_SETTLING_PER_SUBSTEP: f64 = 4.0;

/// The closing warning of a run whose CFL number went above the stability bound, or `None`.
pub fn cfl_warning(all: &[FrameStats]) -> Option<String> {
    let substeps: u64 = all.iter().map(|s| u64::from(s.substeps_over_cfl)).sum();
    if substeps == 0 {
        return None;
    }
    let frames = all.iter().filter(|s| s.substeps_over_cfl > 0).count();
    let worst = all.iter().map(|s| s.max_cfl).fold(0.0f32, f32::max);
    Some(format!(
        "warning: the CFL number went above {MAX_CFL} (the stability bound) in {} of {}, up to {worst:.3}; \
         the fluid may be unstable there: lower time_step.cfl (or time_step.dt)",
        crate::text::count(substeps, "substep", "substeps"),
        crate::text::count(frames, "frame", "frames"),
    ))
}

/// What a long run on a CPU backend will roughly cost, from its first frames (`per_frame`), said once
/// so a user can stop it early; `None` on the GPU or where the whole run takes under a minute.
fn cost_note(sim: &Simulation, per_frame: Duration, frames: u64) -> Option<String> {
    if sim.backend() == "cuda" {
        return None;
    }
    long_run_note(
        per_frame,
        frames,
        &format!("on the CPU ({}) a frame takes", sim.backend()),
        &sim.scene().name,
    )
}

/// The cost note of a run of `frames` frames at `per_frame` each, where the whole takes a minute or
/// more: `what` says what takes the time ("on the CPU (cpu) a frame takes"), and a scene other
/// than the coarse dam break gets the lighter command. `mpm run` and `mpm render` both say it after
/// their second frame.
pub fn long_run_note(per_frame: Duration, frames: u64, what: &str, scene: &str) -> Option<String> {
    let total = per_frame.as_secs_f64() * frames as f64;
    if total < 60.0 {
        return None;
    }
    let light = if scene == "dam-break-coarse" {
        String::new()
    } else {
        " (`--scene dam-break-coarse` is the dam break at a size a CPU steps at about a fifth of real \
         time)"
            .to_string()
    };
    Some(format!(
        "note: {what} about {:.1} s, so these {frames} frames take about {}{light}",
        per_frame.as_secs_f64(),
        spoken_duration(total)
    ))
}

/// "40 seconds", "12 minutes", "3.5 hours": a long run's length as a user says it.
fn spoken_duration(seconds: f64) -> String {
    match seconds {
        s if s < 90.0 => format!("{s:.0} seconds"),
        s if s < 90.0 * 60.0 => format!("{:.0} minutes", s / 60.0),
        s if s < 48.0 * 3600.0 => format!("{:.1} hours", s / 3600.0),
        s => format!("{:.0} days", s / 86400.0),
    }
}

/// Time left after `done` of `len` frames, the `done` having taken `at_done` and `now` having passed
/// since the start: the mean frame so far for each frame left, less what the frame under way has
/// already run. It counts down through a slow frame instead of growing with it, and does not leap
/// with one frame's cost as a recent-rate estimate does (indicatif's `{eta}` jumped between 12 and
/// 24 minutes every frame of a 10-s-a-frame run). `None` before the first frame: nothing to go on.
pub fn eta(done: u64, len: u64, at_done: Duration, now: Duration) -> Option<Duration> {
    if done == 0 {
        return None;
    }
    let per_frame = at_done.as_secs_f64() / done as f64;
    let left = per_frame * len.saturating_sub(done) as f64 - now.saturating_sub(at_done).as_secs_f64();
    Some(Duration::from_secs_f64(left.max(0.0)))
}

/// The `{left}` key of the progress bars: [`eta`], from the moment the position last moved.
#[derive(Clone, Default)]
struct EtaKey {
    /// The position and the elapsed time when it was reached.
    moved: Option<(u64, Duration)>,
}

impl indicatif::style::ProgressTracker for EtaKey {
    fn clone_box(&self) -> Box<dyn indicatif::style::ProgressTracker> {
        Box::new(self.clone())
    }

    fn tick(&mut self, state: &indicatif::ProgressState, _: std::time::Instant) {
        if self.moved.is_none_or(|(pos, _)| pos != state.pos()) {
            self.moved = Some((state.pos(), state.elapsed()));
        }
    }

    fn reset(&mut self, _: &indicatif::ProgressState, _: std::time::Instant) {
        self.moved = None;
    }

    fn write(&self, state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write) {
        let now = state.elapsed();
        let at_done = match self.moved {
            Some((pos, at)) if pos == state.pos() => at,
            _ => now,
        };
        let _ = match eta(state.pos(), state.len().unwrap_or(0), at_done, now) {
            Some(left) => write!(w, "{:#}", indicatif::HumanDuration(left)),
            None => write!(w, "after the first frame"),
        };
    }
}

/// A progress bar of `frames` frames, with an ETA that holds steady ([`eta`]).
pub fn progress_bar(frames: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(frames);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} frames  {elapsed} elapsed, eta {left}  {msg}",
        )
        .expect("the progress template is valid")
        .with_key("left", EtaKey::default()),
    );
    bar
}

/// The frame's body meshes and poses, where the exporter wants this frame; whether it did.
pub fn export_bodies(sim: &Simulation, exporter: Option<&mut BodyExporter>) -> Result<bool> {
    let frame = sim.frame();
    match exporter.filter(|e| e.wants(frame)) {
        Some(exporter) => {
            exporter.write(frame, sim.time(), &frame_comment(sim), sim.bodies())?;
            Ok(true)
        }
        None => Ok(false),
    }
}

/// The closing line of the rigid bodies' export, which wrote `frames` frames.
pub fn bodies_closing_line(exporter: &BodyExporter, frames: u64) -> String {
    format!(
        "exported the rigid bodies of {} into {} ({} and bodies_NNNNNN.obj)",
        crate::text::count(frames, "frame", "frames"),
        exporter.dir().display(),
        crate::export::bodies::POSE_TABLE
    )
}

/// Runs `opts.frames` frames; every line goes to `out`. Stops at the first error (a diverged state,
/// a failed write) with that error.
pub fn run(sim: &mut Simulation, opts: RunOptions, out: &mut dyn Write) -> Result<Vec<FrameStats>> {
    let RunOptions {
        frames,
        export,
        surface,
        volume,
        mut bodies,
        usd,
        mut stats,
        checkpoints,
        progress,
        started: command_started,
    } = opts;
    let bar = progress.then(|| progress_bar(frames));
    let mut exports = FrameExports::start(
        FrameExportSet {
            ply: export,
            surface,
            volume,
            usd,
        },
        sim.scene(),
        match &bar {
            Some(bar) => ExportProgress::Bar(bar.clone()),
            None => ExportProgress::Lines,
        },
    )?;
    let mut export_frame = |sim: &mut Simulation| match exports.as_mut() {
        Some(exports) => exports.submit(sim).map(|_| ()),
        None => Ok(()),
    };
    export_frame(sim)?;
    let mut bodies_exported = u64::from(export_bodies(sim, bodies.as_mut())?);
    // Grows as frames finish: reserving `frames` up front aborted the program for a huge --frames.
    let mut all = Vec::new();
    let say = |out: &mut dyn Write, line: &str| -> Result<()> {
        match &bar {
            Some(bar) => bar.println(line),
            None => writeln!(out, "{line}")?,
        }
        Ok(())
    };
    let started = Instant::now();
    let start_up = started.duration_since(command_started);
    for done in 1..=frames {
        let frame_stats = sim.advance_frame()?;
        say(out, &format_frame(&frame_stats))?;
        if done == 2 && frames > 2 {
            if let Some(note) = cost_note(sim, started.elapsed() / 2, frames) {
                say(out, &note)?;
            }
        }
        if let Some(bar) = &bar {
            bar.inc(1);
        }
        if let Some(file) = &mut stats {
            file.append(&frame_stats, out)?;
        }
        export_frame(sim)?;
        bodies_exported += u64::from(export_bodies(sim, bodies.as_mut())?);
        if let Some(series) = &checkpoints {
            if series.wants(sim.frame(), done == frames) {
                let path = series.write(sim)?;
                say(out, &format!("checkpoint {}", path.display()))?;
            }
        }
        all.push(frame_stats);
    }
    // No frame to step: the state as it is, as the checkpoint after the last frame it then is.
    if frames == 0 {
        if let Some(series) = &checkpoints {
            let path = series.write(sim)?;
            say(out, &format!("checkpoint {}", path.display()))?;
        }
    }
    let stepping = started.elapsed();
    let export_lines = exports.map(FrameExports::finish).transpose()?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    for line in export_lines.iter().flatten() {
        writeln!(out, "{line}")?;
    }
    if let Some(exporter) = &bodies {
        writeln!(out, "{}", bodies_closing_line(exporter, bodies_exported))?;
    }
    if let Some(warning) = cfl_warning(&all) {
        writeln!(out, "{warning}")?;
    }
    if let Some(warning) = all.last().and_then(flow_warning) {
        writeln!(out, "{warning}")?;
    }
    if let Some(note) = backstop_note(&all) {
        writeln!(out, "{note}")?;
    }
    let wall = command_started.elapsed();
    writeln!(out, "{}", time_line(wall, start_up, stepping, &all))?;
    Ok(all)
}

/// Where a run's wall time went: start-up (reading the scene, opening the device, making the
/// particles, writing frame 0 where the run exports), stepping the frames (with the backend's own timing of its substeps beside it, where
/// it times them), and finishing (the surface meshes still queued, the closing lines). What the
/// process spends after it (the device's teardown at exit) is not in it.
pub fn time_line(wall: Duration, start_up: Duration, stepping: Duration, frames: &[FrameStats]) -> String {
    let mut line = format!(
        "time: {:.3} s = start-up {:.3} s + {} {:.3} s + finishing {:.3} s",
        wall.as_secs_f64(),
        start_up.as_secs_f64(),
        crate::text::count(frames.len() as u64, "frame", "frames"),
        stepping.as_secs_f64(),
        wall.saturating_sub(start_up + stepping).as_secs_f64(),
    );
    let timed: f64 = frames
        .iter()
        .filter_map(|f| f.timings.as_ref())
        .map(|t| t.total())
        .sum();
    if timed > 0.0 {
        let timed = timed / 1e3;
        line += &format!(
            "; the substeps' own timing {timed:.3} s (wall / substeps {:.2})",
            wall.as_secs_f64() / timed
        );
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_backstop_note_names_the_cause_its_rate_points_to() {
        assert!(backstop_cause(1.4).contains("settling"));
        assert!(backstop_cause(BACKSTOP_SETTLING_PER_SUBSTEP).contains("settling"));
        assert!(backstop_cause(250.0).contains("fast or thin collider"));
    }
}
