//! The headless runner: steps a scene frame by frame, prints one line of statistics per frame,
//! and optionally writes them as JSON lines and exports PLY frames.

use crate::export::PlyExporter;
use crate::sim::scene::MAX_CFL;
use crate::sim::{FrameStats, Simulation};
use anyhow::{Context, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

pub struct RunOptions {
    pub frames: u64,
    /// Writes the initial state as frame 0, then every K-th frame.
    pub export: Option<PlyExporter>,
    pub stats: Option<StatsFile>,
    /// Show a progress bar (stdout is a terminal).
    pub progress: bool,
}

/// The JSON-lines stats file: one [`FrameStats`] object per line.
pub struct StatsFile {
    file: BufWriter<File>,
    path: PathBuf,
}

impl StatsFile {
    /// Refuses to replace an existing file unless `overwrite`.
    pub fn create(path: &Path, overwrite: bool) -> Result<StatsFile> {
        if !overwrite && path.exists() {
            anyhow::bail!(
                "{} already exists; choose another --stats file, or pass --overwrite to replace it",
                path.display()
            );
        }
        if path.is_dir() {
            anyhow::bail!("--stats {} is a directory; give a file name", path.display());
        }
        let file = File::create(path).map_err(|e| {
            anyhow::anyhow!(
                "cannot create the stats file {}: {}",
                path.display(),
                crate::text::io_reason(&e)
            )
        })?;
        Ok(StatsFile {
            file: BufWriter::new(file),
            path: path.to_path_buf(),
        })
    }

    fn append(&mut self, stats: &FrameStats) -> Result<()> {
        serde_json::to_writer(&mut self.file, stats)
            .map_err(anyhow::Error::from)
            .and_then(|_| writeln!(self.file).map_err(Into::into))
            .and_then(|_| self.file.flush().map_err(Into::into))
            .with_context(|| format!("cannot write the stats file {}", self.path.display()))
    }
}

/// The one-line summary the runner prints per frame.
pub fn format_frame(s: &FrameStats) -> String {
    let m = &s.summary;
    let c = m.centre_of_mass;
    let mut line = format!(
        "frame {:>5}  t={:.4} s  n={}  substeps={:>3}  |v|max={:.3} m/s  rho/rho0=[{:.3} {:.3} {:.3}]  \
         CFL={:.3}  KE={:.4e} J  com=({:.4}, {:.4}, {:.4}) m",
        s.frame,
        s.time,
        m.particles,
        s.substeps,
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

/// The closing line of a run whose particles the colliders' backstop had to put back on a collider's
/// surface, or `None`: the grid's boundary condition alone did not keep them out.
pub fn backstop_note(all: &[FrameStats]) -> Option<String> {
    let pushes: u64 = all.iter().map(|s| s.backstop_pushes).sum();
    if pushes == 0 {
        return None;
    }
    let frames = all.iter().filter(|s| s.backstop_pushes > 0).count();
    Some(format!(
        "note: the collider backstop put {} back on a collider's surface, in {} of {} (the grid's \
         boundary condition did not stop them: a fast or thin collider, or a large time step)",
        crate::text::count(pushes, "particle", "particles"),
        crate::text::count(frames, "frame", "frames"),
        all.len()
    ))
}

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

fn export_frame(sim: &mut Simulation, exporter: &PlyExporter) -> Result<()> {
    let scene = sim.scene();
    let comment = format!(
        "mpm frame {} t={:.6} s scene={} backend={}\ndx={} m grid={}x{}x{} rest_density={} kg/m^3",
        sim.frame(),
        sim.time(),
        scene.name,
        sim.backend(),
        scene.dx,
        scene.grid_res[0],
        scene.grid_res[1],
        scene.grid_res[2],
        scene.material.rest_density
    );
    let particles = sim.solver_mut().read_particles()?;
    exporter.write(sim.frame(), &comment, &particles)?;
    Ok(())
}

/// Runs `opts.frames` frames; every line goes to `out`. Stops at the first error (a diverged state,
/// a failed write) with that error.
pub fn run(sim: &mut Simulation, opts: RunOptions, out: &mut dyn Write) -> Result<Vec<FrameStats>> {
    let RunOptions {
        frames,
        export,
        mut stats,
        progress,
    } = opts;
    if let Some(exporter) = &export {
        export_frame(sim, exporter)?;
    }
    let bar = if progress {
        let bar = indicatif::ProgressBar::new(frames);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} frames  {elapsed} elapsed, eta {eta}",
            )
            .expect("the progress template is valid"),
        );
        Some(bar)
    } else {
        None
    };
    // Grows as frames finish: reserving `frames` up front aborted the program for a huge --frames.
    let mut all = Vec::new();
    for _ in 0..frames {
        let frame_stats = sim.advance_frame()?;
        let line = format_frame(&frame_stats);
        match &bar {
            Some(bar) => {
                bar.println(&line);
                bar.inc(1);
            }
            None => writeln!(out, "{line}")?,
        }
        if let Some(file) = &mut stats {
            file.append(&frame_stats)?;
        }
        if let Some(exporter) = &export {
            if exporter.wants(sim.frame()) {
                export_frame(sim, exporter)?;
            }
        }
        all.push(frame_stats);
    }
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    if let Some(warning) = cfl_warning(&all) {
        writeln!(out, "{warning}")?;
    }
    if let Some(note) = backstop_note(&all) {
        writeln!(out, "{note}")?;
    }
    Ok(all)
}
