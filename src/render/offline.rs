//! `mpm render`: the scene stepped one 60 Hz frame per image, drawn by the same renderer as the
//! window into an EGL device framebuffer, written as numbered PNGs (and optionally an MP4 by ffmpeg).
//! Every output is checked before the first step, so a bad path fails at once.

use super::capture::FrameSequence;
use super::feed::{ParticleFeed, Transfer};
use super::headless::HeadlessGl;
use super::renderer::{Colouring, DrawMode, RenderSettings, Renderer, Viewport};
use crate::backend::{self, BackendKind};
use crate::sim::{Scene, Simulation};
use anyhow::{bail, Context, Result};
use std::io::Write;
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

pub struct RenderOptions {
    pub scene: Scene,
    pub backend: BackendKind,
    pub frames: u64,
    /// Where the PNGs go; `None` renders without writing (for timing).
    pub out: Option<PathBuf>,
    pub size: [u32; 2],
    pub mode: DrawMode,
    /// `None`: the scene's default ([`Colouring::default_for`]).
    pub colouring: Option<Colouring>,
    /// Replaces the particle radius derived from the scene (spheres and surface), m.
    pub particle_radius: Option<f32>,
    /// Smooth the surface's depth at full resolution (`SurfaceSettings::half_res_smoothing` off).
    pub full_res_smoothing: bool,
    pub transfer: Transfer,
    pub video: Option<PathBuf>,
    /// Show a progress bar (stdout is a terminal).
    pub progress: bool,
}

/// Mean wall milliseconds per frame, over the frames after the first few (warm-up).
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct RenderTimings {
    pub frames_measured: u64,
    /// Stepping one 60 Hz frame (all its substeps; the host waits for the step's counters).
    pub sim_ms: f64,
    /// Particle data into the GL buffer, drawing, and glFinish.
    pub render_ms: f64,
    /// sim + render (PNG encoding and writing excluded).
    pub frame_ms: f64,
    /// GPU milliseconds per render pass (OpenGL timer queries), means over the same frames; the
    /// passes the draw mode has, by name.
    pub gpu_passes_ms: std::collections::BTreeMap<&'static str, f64>,
    /// Their sum: the GPU time of drawing one frame (the particle data's transfer is not in it).
    pub gpu_render_ms: f64,
}

pub struct RenderReport {
    pub timings: RenderTimings,
    pub frames_written: u64,
    pub path: &'static str,
    pub gl: String,
}

const WARM_UP_FRAMES: u64 = 3;

pub fn render(options: RenderOptions, log: &mut dyn Write) -> Result<RenderReport> {
    let mut sequence = options
        .out
        .as_deref()
        .map(|dir| FrameSequence::create(dir, options.frames + 1))
        .transpose()?;
    if let Some(video) = &options.video {
        if sequence.is_none() {
            bail!("--video needs the PNG frames: give --out DIR");
        }
        if video.exists() {
            bail!("{} exists already; not overwriting it", video.display());
        }
        Command::new("ffmpeg")
            .arg("-version")
            .output()
            .context("--video needs ffmpeg on PATH (e.g. `apt-get install ffmpeg`); it was not found")?;
    }

    // GL first: CUDA then shares the GPU that GL renders on.
    let headless = HeadlessGl::new(options.size[0], options.size[1])?;
    writeln!(log, "OpenGL: {}", headless.description)?;
    let mut renderer = Renderer::new(headless.gl().clone())?;
    let scene = options.scene;
    let colouring = options
        .colouring
        .unwrap_or_else(|| Colouring::default_for(&scene));
    let mut settings = RenderSettings::for_scene(&scene, options.mode, colouring, options.particle_radius)?;
    settings.surface.half_res_smoothing = !options.full_res_smoothing;
    let solver = backend::create(options.backend, &scene)?;
    writeln!(
        log,
        "scene {}: {} particles, backend {}, {}x{} {:?}",
        scene.name,
        scene.num_particles,
        solver.name(),
        options.size[0],
        options.size[1],
        options.mode
    )?;
    let (lo, hi) = scene.fluid_region();
    let domain = (lo.as_vec3(), hi.as_vec3());
    let camera = settings.framing(domain.0, domain.1, Viewport::full(headless.size()));
    renderer.set_colliders(&scene.colliders)?;
    renderer.set_flow(&scene.flow, domain);
    let mut sim = Simulation::new(scene, solver);
    let mut feed = ParticleFeed::new(options.transfer);

    let mut sums = RenderTimings::default();
    let bar = options
        .progress
        .then(|| crate::runner::progress_bar(options.frames + 1));
    // From the initial frame drawn (GL's and the backend's start-up are behind it) to the second
    // stepped one: what a frame costs here, said when the whole will take a minute or more.
    let mut first_drawn = None;
    for frame in 0..=options.frames {
        let start = Instant::now();
        if frame > 0 {
            sim.step_frame()?;
        }
        let stepped = Instant::now();
        let fed = feed.update(&mut sim, &mut renderer, settings.colouring)?;
        renderer.set_collider_frame(sim.collider_frame());
        renderer.draw(
            Viewport::full(headless.size()),
            &camera,
            &settings,
            fed.slots,
            domain,
        )?;
        headless.finish();
        let drawn = Instant::now();
        // After glFinish this frame's timer queries are done: read them now, so that each frame's
        // GPU times count with the same frames as its wall times.
        renderer.timer_mut().collect();
        if frame == WARM_UP_FRAMES {
            renderer.timer_mut().reset_means();
        }
        if frame > WARM_UP_FRAMES {
            sums.frames_measured += 1;
            sums.sim_ms += (stepped - start).as_secs_f64() * 1e3;
            sums.render_ms += (drawn - stepped).as_secs_f64() * 1e3;
        }
        if let Some(sequence) = &mut sequence {
            sequence.write(&headless.read_image())?;
        }
        if let Some(bar) = &bar {
            bar.inc(1);
        }
        match (frame, first_drawn) {
            (0, _) => first_drawn = Some(Instant::now()),
            (2, Some(at)) if options.frames > 2 => {
                let note = crate::runner::long_run_note(
                    at.elapsed() / 2,
                    options.frames,
                    &format!("stepping ({}) and drawing a frame takes", sim.backend()),
                    &sim.scene().name,
                );
                match (note, &bar) {
                    (Some(note), Some(bar)) => bar.println(note),
                    (Some(note), None) => {
                        writeln!(log, "{note}")?;
                        log.flush()?;
                    }
                    (None, _) => {}
                }
            }
            _ => {}
        }
    }
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let n = sums.frames_measured.max(1) as f64;
    let (_, passes) = renderer.timer_mut().means();
    let timings = RenderTimings {
        frames_measured: sums.frames_measured,
        sim_ms: sums.sim_ms / n,
        render_ms: sums.render_ms / n,
        frame_ms: (sums.sim_ms + sums.render_ms) / n,
        gpu_passes_ms: passes.iter().map(|(pass, ms)| (pass.name(), ms)).collect(),
        gpu_render_ms: passes.total(),
    };
    if timings.frames_measured == 0 {
        // Zeros here would read like a measurement.
        writeln!(
            log,
            "{} via {}: too few to time (the first {} are warm-up; ask for more --frames)",
            crate::text::count(options.frames + 1, "frame", "frames"),
            feed.path(),
            WARM_UP_FRAMES + 1
        )?;
    } else {
        writeln!(
            log,
            "{} frames via {}: sim {:.3} ms, render {:.3} ms, frame {:.3} ms (mean of {} after {} warm-up)",
            options.frames + 1,
            feed.path(),
            timings.sim_ms,
            timings.render_ms,
            timings.frame_ms,
            timings.frames_measured,
            WARM_UP_FRAMES + 1
        )?;
        let passes: Vec<String> = passes
            .iter()
            .map(|(pass, ms)| format!("{} {ms:.3}", pass.name()))
            .collect();
        let thickness = match options.mode {
            DrawMode::Surface if renderer.thickness_by_cuda() => ", the thickness summed by CUDA",
            DrawMode::Surface => ", the thickness blended by GL",
            _ => "",
        };
        writeln!(
            log,
            "GPU ms per pass (timer queries, same frames{thickness}): {}; total {:.3}",
            passes.join(", "),
            timings.gpu_render_ms
        )?;
    }
    let frames_written = sequence.as_ref().map_or(0, |s| s.frames_written());
    if let Some(sequence) = &sequence {
        writeln!(
            log,
            "wrote {} to {}",
            crate::text::count(frames_written, "PNG", "PNGs"),
            sequence.dir().display()
        )?;
    }
    if let (Some(video), Some(sequence)) = (&options.video, &sequence) {
        let status = Command::new("ffmpeg")
            .args(["-loglevel", "error", "-n", "-framerate", "60", "-i"])
            .arg(sequence.dir().join("frame-%05d.png"))
            .args(["-c:v", "libx264", "-pix_fmt", "yuv420p"])
            .arg(video)
            .status()
            .context("running ffmpeg")?;
        if !status.success() {
            bail!(
                "ffmpeg failed ({status}); the PNG frames are kept in {}",
                sequence.dir().display()
            );
        }
        writeln!(log, "wrote {}", video.display())?;
    }
    let path = feed.path();
    feed.release();
    renderer.destroy();
    Ok(RenderReport {
        timings,
        frames_written,
        path,
        gl: headless.description.clone(),
    })
}
