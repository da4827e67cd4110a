//! The viewer window: winit's `ApplicationHandler` drives one redraw after another; each feeds the
//! particles to the renderer (interop or host copy), then draws the egui panel and the scene,
//! captures images if asked and presents the frame, while a worker thread steps the simulation on to
//! the next draw's state, as many 60 Hz frames as the clock says.
//!
//! Why a worker: the swap blocks the host for milliseconds (under Xvfb it copies the frame through
//! the host; everywhere it waits for the GPU to finish drawing), building the panel and the scene's
//! GL commands takes more, and the simulation's steps each wait for the GPU's extremes before choosing
//! the next, so stepping in line with them left the GPU idle through them (BENCHMARKS.md 0f, 0o). The
//! next draw shows what was stepped, so the picture is one draw behind the stepping, never torn: the
//! feed has read the particles before the worker starts, and the worker joins before the next feed.
//! The panel's actions (pause, reset, sliders) apply once it has joined, to the next draw's steps.
//! Where the simulation runs on CUDA, the draw closes a gate over its GL work (`GpuGate`): the
//! worker enqueues no new stretch of substeps until that work is done, so the GPU, which runs the
//! two contexts' work in turns, runs the draw as one block between stretches (BENCHMARKS.md M19).

use super::camera::OrbitCamera;
use super::capture::{next_free_screenshot, FrameSequence, Image};
use super::clock::{DrawCosts, DrawSection, Pacing, SimClock, StepCosts};
use super::colliders::ColliderDrag;
use super::feed::{Fed, ParticleFeed, Transfer};
use super::hud::{self, Action, Controls, HudInfo, PbmpmControls};
use super::renderer::{Colouring, DrawMode, RenderSettings, Renderer, Viewport};
use super::surface::SurfaceSettings;
use crate::backend::{self, BackendKind};
use crate::checkpoint::Checkpoint;
use crate::export::frames::Exports;
use crate::sim::colliders::Motion;
use crate::sim::dropped::{DropShape, DroppedBody};
use crate::sim::gpu_gate::GpuGate;
use crate::sim::{PhaseTimings, Scene, Simulation};
use anyhow::{anyhow, Context, Result};
use glam::{Vec2, Vec3};
use glow::HasContext;
use glutin::config::ConfigTemplateBuilder;
use glutin::context::{ContextApi, ContextAttributesBuilder, GlProfile, PossiblyCurrentContext, Version};
use glutin::display::GetGlDisplay;
use glutin::prelude::*;
use glutin::surface::{Surface, SwapInterval, WindowSurface};
use glutin_winit::GlWindow;
use std::num::NonZeroU32;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, StartCause, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, ModifiersState, NamedKey};
use winit::raw_window_handle::HasWindowHandle;
use winit::window::{Window, WindowId};

mod export;
mod snapshot;
mod stepping;

use export::{ColliderChange, ExportEnd, ExportSession, FinishingExport};
use stepping::{SimGlance, Stepped, Stepper};

pub struct ViewerOptions {
    pub scene: Scene,
    pub backend: BackendKind,
    pub vsync: bool,
    /// Draws a second at most: the next draw waits for its turn (`ControlFlow::WaitUntil`).
    pub max_fps: Option<u32>,
    pub size: [u32; 2],
    pub mode: DrawMode,
    /// `None`: each scene's own default ([`Colouring::default_for`]: by material where it has
    /// several, else by speed).
    pub colouring: Option<Colouring>,
    /// Replaces the particle radius derived from the scene (spheres and surface), m.
    pub particle_radius: Option<f32>,
    /// Smooth the surface's depth at full resolution (`SurfaceSettings::half_res_smoothing` off).
    pub full_res_smoothing: bool,
    pub transfer: Transfer,
    /// Step this many 60 Hz frames per drawn frame instead of following wall time.
    pub fixed_frames: Option<u32>,
    /// Where screenshots and recordings go.
    pub capture_dir: PathBuf,
    /// Quit after this many drawn frames (scripted runs and tests).
    pub quit_after: Option<u64>,
    /// Write the last drawn frame here on quitting (scripted runs and tests); must not exist.
    pub final_screenshot: Option<PathBuf>,
}

/// Opens the window and runs until it is closed. `exports` makes the exports the run is to write
/// (`mpm view --export DIR ...`; none: `Exports::default()`) for its scene: after the viewer's own
/// paths are checked and before the window opens, so that every refusal comes before anything
/// starts.
pub fn run(options: ViewerOptions, exports: impl FnOnce(&Scene) -> Result<Exports>) -> Result<()> {
    check_paths(&options)?;
    let exports = exports(&options.scene)?;
    let render_instead = render_command(&options.scene);
    let mut app = ViewerApp::new(options, exports)?;
    let event_loop = EventLoop::new().map_err(|e| {
        // winit's message starts with the path of its own source file; the user needs the rest.
        let text = e.to_string();
        let reason = text
            .split_once(".rs:")
            .and_then(|(_, rest)| rest.split_once(": "))
            .map_or(text.as_str(), |(_, reason)| reason)
            .trim_end_matches('.');
        // Where a display is named, the reason is that it did not answer; where none is, winit's
        // reason says so already, and asking whether one is set would be asking twice.
        let named: Vec<String> = ["DISPLAY", "WAYLAND_DISPLAY"]
            .iter()
            .filter_map(|v| std::env::var(v).ok().map(|value| format!("{v}={value}")))
            .collect();
        let display = if named.is_empty() {
            String::new()
        } else {
            format!(" ({} is set, but no display answered there)", named.join(", "))
        };
        anyhow!(
            "cannot open a window: {reason}. The viewer needs a display (X11 or Wayland){display}; \
             without one, {render_instead}"
        )
    })?;
    event_loop
        .run_app(&mut app)
        .context("the window's event loop failed")?;
    match app.fatal.take() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// The headless command that draws `scene` instead of the viewer, whole: with `--out`, and on a
/// machine without a CUDA device the coarse dam break in place of a scene a CPU steps for seconds a
/// frame.
fn render_command(scene: &Scene) -> String {
    let arg = scene.source.strip_prefix("preset ").unwrap_or(&scene.source);
    let quoted = if arg.contains(char::is_whitespace) {
        format!("'{arg}'")
    } else {
        arg.to_string()
    };
    // About where a 2-core CPU takes a second or more per frame (the full dam break, 451,200
    // particles, took about 10 s a frame drawn there; the fountain, 20,128, well under one).
    const HEAVY_ON_A_CPU: usize = 100_000;
    let on_cpu = crate::cuda::library::device_available().is_err();
    if on_cpu && scene.num_particles > HEAVY_ON_A_CPU {
        format!(
            "`mpm render --scene dam-break-coarse --frames 120 --out frames` draws frames to PNG files \
             headless (no CUDA device here: a CPU takes seconds a frame over the {} particles of {}, \
             which `--scene {quoted}` renders)",
            scene.num_particles, scene.name
        )
    } else {
        format!("`mpm render --scene {quoted} --frames 120 --out frames` draws frames to PNG files headless")
    }
}

/// Every path the viewer may write, checked before the window opens and the first step runs: a
/// mistyped folder must not surface only when the user quits or presses P.
pub fn check_paths(options: &ViewerOptions) -> Result<()> {
    let dir = &options.capture_dir;
    anyhow::ensure!(
        dir.is_dir(),
        "--capture-dir {}: {}",
        dir.display(),
        if dir.exists() {
            "is a file, not a directory"
        } else {
            "no such directory; create it first"
        }
    );
    let probe = dir.join(".mpm-write-test");
    if let Err(e) = std::fs::File::create(&probe).and_then(|_| std::fs::remove_file(&probe)) {
        let why = format!(
            "--capture-dir {} is not writable: {}",
            dir.display(),
            crate::text::io_reason(&e)
        );
        // The default (the working directory) only matters once P or V is pressed: say so and go on.
        if dir.as_os_str() == "." {
            eprintln!(
                "note: {why}; screenshots (P) and recordings (V) will fail until you give --capture-dir"
            );
        } else {
            anyhow::bail!(why);
        }
    }
    if let Some(path) = &options.final_screenshot {
        anyhow::ensure!(
            !path.exists(),
            "{} exists already; not overwriting it",
            path.display()
        );
        let parent = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => std::path::Path::new("."),
        };
        anyhow::ensure!(
            parent.is_dir(),
            "--final-screenshot {}: the folder {} does not exist; create it first",
            path.display(),
            parent.display()
        );
        // Create and remove the file itself: a folder that refuses it fails now, not after the run.
        std::fs::File::create_new(path)
            .and_then(|_| std::fs::remove_file(path))
            .map_err(|e| {
                anyhow!(
                    "--final-screenshot {}: cannot write it: {}",
                    path.display(),
                    crate::text::io_reason(&e)
                )
            })?;
    }
    Ok(())
}

/// The window and everything tied to its GL context.
struct Gpu {
    // Field order is drop order: GL users first, then the surface and context, then the window.
    egui: egui_glow::EguiGlow,
    renderer: Renderer,
    /// Whether the renderer holds the current scene's colliders' meshes.
    colliders_built: bool,
    gl: Arc<glow::Context>,
    surface: Surface<WindowSurface>,
    context: PossiblyCurrentContext,
    window: Window,
}

#[derive(Default)]
struct Mouse {
    position: Vec2,
    left: bool,
    right: bool,
    /// Drag movement since the last frame, for the push.
    push_drag: Vec2,
    /// A collider held with Ctrl + left button.
    collider_drag: Option<ColliderDrag>,
}

struct Recording {
    sequence: FrameSequence,
}

struct ViewerApp {
    options: ViewerOptions,
    gpu: Option<Gpu>,
    sim: Option<Simulation>,
    scene: Scene,
    feed: ParticleFeed,
    camera: OrbitCamera,
    controls: Controls,
    clock: SimClock,
    mouse: Mouse,
    modifiers: ModifiersState,
    show_panel: bool,
    step_requested: bool,
    screenshot_requested: bool,
    recording: Option<Recording>,
    /// Where the scene is drawn: the window right of the panel (GL convention, bottom-left origin).
    scene_viewport: Viewport,
    /// The camera frames the domain anew at each draw (so a resized window, the panel shown or hidden
    /// and the colour bar are allowed for) until the user turns, slides or zooms it.
    camera_follows_view: bool,
    /// The last error or notice, shown in the panel (a bad scene file, a refused value...).
    message: Option<String>,
    /// An error that ends the viewer (no GL context, no backend).
    fatal: Option<anyhow::Error>,
    started: Instant,
    last_frame: Instant,
    /// When the first frame was drawn, and the simulated time then: the run's mean frame rate and its
    /// pace against real time, said on exit.
    first_draw: Option<(Instant, f64)>,
    frames_drawn: u64,
    fps: f64,
    frame_ms: f64,
    /// The last completed 60 Hz frame's phase timings.
    last_timings: Option<PhaseTimings>,
    last_steps: (u32, f32, f32),
    /// Substeps since the scene (re)started whose CFL number went above the bound.
    over_cfl: u64,
    /// N was pressed while paused and that frame is not complete yet (it may take several draws).
    step_owed: bool,
    /// Frames of the current fixed-pacing batch not complete yet.
    fixed_owed: u32,
    /// The longest wall time one draw spent stepping (reported on exit).
    longest_step: Duration,
    /// The last error that stopped the stepping, with the simulated time it stopped at: reported on
    /// exit, since the run's frame rate and speed then cover a paused simulation.
    step_error: Option<(f64, String)>,
    /// Host time per section of a draw, for the exit line.
    draw_costs: DrawCosts,
    /// The phase timings' milliseconds per frame stepped, for the exit line.
    step_costs: StepCosts,
    /// What was stepped while the last frame was drawn, for the next draw to show and account.
    stepped: Option<Stepped>,
    /// The thread that steps the simulation beside each draw.
    stepper: Stepper,
    /// Closed over each draw while the simulation steps on the GPU that draws (`GpuGate`); `None`
    /// for a CPU simulation, which the draw does not wait for.
    gpu_gate: Option<Arc<GpuGate>>,
    /// The exports asked for, until the first scene starts them.
    pending_export: Option<Exports>,
    /// The export under way (with the simulation on the stepping thread while it steps).
    export: Option<ExportSession>,
    /// An ended export whose last frames are being written.
    finishing_export: Option<FinishingExport>,
}

impl ViewerApp {
    fn new(options: ViewerOptions, exports: Exports) -> Result<ViewerApp> {
        let scene = options.scene.clone();
        let (camera, controls) = Self::scene_defaults(&scene, &options)?;
        let pacing = match options.fixed_frames {
            Some(n) => Pacing::Fixed {
                frames_per_draw: n.max(1),
            },
            None => Pacing::RealTime {
                max_frames_per_draw: 4,
            },
        };
        Ok(ViewerApp {
            feed: ParticleFeed::new(options.transfer),
            gpu: None,
            sim: None,
            scene,
            camera,
            controls,
            clock: SimClock::new(pacing),
            mouse: Mouse::default(),
            modifiers: ModifiersState::empty(),
            show_panel: true,
            step_requested: false,
            screenshot_requested: false,
            recording: None,
            scene_viewport: Viewport::full(options.size),
            camera_follows_view: true,
            message: None,
            fatal: None,
            started: Instant::now(),
            last_frame: Instant::now(),
            first_draw: None,
            frames_drawn: 0,
            fps: 0.0,
            frame_ms: 0.0,
            last_timings: None,
            last_steps: (0, 0.0, 0.0),
            over_cfl: 0,
            step_owed: false,
            fixed_owed: 0,
            longest_step: Duration::ZERO,
            step_error: None,
            draw_costs: DrawCosts::default(),
            step_costs: StepCosts::default(),
            stepped: None,
            stepper: Stepper::new()?,
            gpu_gate: None,
            pending_export: Some(exports),
            export: None,
            finishing_export: None,
            options,
        })
    }

    fn scene_defaults(scene: &Scene, options: &ViewerOptions) -> Result<(OrbitCamera, Controls)> {
        let (lo, hi) = scene.fluid_region();
        let colouring = options.colouring.unwrap_or_else(|| Colouring::default_for(scene));
        let mut render = RenderSettings::for_scene(scene, options.mode, colouring, options.particle_radius)?;
        render.surface.half_res_smoothing = !options.full_res_smoothing;
        // The window's whole size until the panel's width is known; the first draw frames it anew.
        let camera = render.framing(lo.as_vec3(), hi.as_vec3(), Viewport::full(options.size));
        let params = scene.params();
        let controls = Controls {
            paused: false,
            render,
            liquid: 0,
            viscosity: params.materials.map(|m| m.viscosity),
            sound_speed: params.materials.map(|m| m.sound_speed()),
            gravity: scene.gravity,
            fixed_pacing: options.fixed_frames.is_some(),
            frames_per_draw: options.fixed_frames.unwrap_or(1).max(1),
            // A preset's source reads "preset NAME"; a scene file does not pre-select one.
            preset: crate::sim::presets::NAMES
                .iter()
                .position(|&n| scene.source == format!("preset {n}")),
            scene_path: String::new(),
            push_strength: 0.02,
            push_radius: 0.1,
            box_density: DropShape::default_density(false, scene),
            ball_density: DropShape::default_density(true, scene),
            pbmpm: PbmpmControls::of(scene),
        };
        Ok((camera, controls))
    }

    /// Starts `scene` afresh on the chosen backend; on failure the old simulation keeps running.
    fn start_scene(&mut self, scene: Scene, reframe: bool) -> Result<()> {
        self.start_scene_from(scene, reframe, None)
    }

    /// [`Self::start_scene`], or with `checkpoint` (of `scene`): going on from its state.
    fn start_scene_from(
        &mut self,
        scene: Scene,
        reframe: bool,
        checkpoint: Option<&Checkpoint>,
    ) -> Result<()> {
        // The new scene's view first: a --particle-radius too large for it is refused before the
        // running scene is touched.
        let defaults = if reframe {
            Some(Self::scene_defaults(&scene, &self.options)?)
        } else {
            None
        };
        // The colouring carries over where the user chose one; one left at the old scene's default
        // becomes the new scene's (by material where it has several).
        let colouring_chosen = self.options.colouring.is_none()
            && self.controls.render.colouring != Colouring::default_for(&self.scene);
        // The running simulation goes: its export ends with it, so that no file of the new run
        // replaces or mixes with the old run's (the frame numbers start again). What replaces it:
        // a snapshot (F9), another scene (a preset or a file, framed anew) or the same scene (R).
        self.end_export(match (checkpoint, reframe) {
            (Some(_), _) => ExportEnd::Snapshot,
            (None, true) => ExportEnd::NewScene,
            (None, false) => ExportEnd::Restart,
        });
        // The registration refers to the old solver's context and buffer size: release it first.
        self.feed.release();
        self.sim = None;
        let mut sim = match checkpoint {
            Some(checkpoint) => checkpoint.resume(scene.clone(), self.options.backend)?,
            None => Simulation::new(scene.clone(), backend::create(self.options.backend, &scene)?),
        };
        // The window draws a frame while the GPU finishes simulating it (Simulation::overlap_frames).
        sim.overlap_frames(true)?;
        // A CUDA simulation shares the GPU with the drawing; a CPU one steps through the draw.
        self.gpu_gate = (sim.backend() == "cuda").then(Arc::default);
        sim.share_gpu(self.gpu_gate.clone());
        if let Some((camera, mut controls)) = defaults {
            // The look carries over; the radius follows the new scene's particle spacing.
            controls.render.surface = SurfaceSettings {
                radius: controls.render.surface.radius,
                ..self.controls.render.surface
            };
            controls.render.mode = self.controls.render.mode;
            if self.options.colouring.is_some() || colouring_chosen {
                controls.render.colouring = self.controls.render.colouring;
                controls.render.scale_range = self.controls.render.scale_range;
            }
            controls.paused = self.controls.paused;
            self.camera = camera;
            self.camera_follows_view = true;
            self.controls = controls;
        }
        // The live sliders follow the simulation's parameters (a checkpoint's may differ from its scene).
        let params = sim.params();
        let rows = params.material_count as usize;
        for (row, m) in params.materials.iter().enumerate().take(rows) {
            self.controls.viscosity[row] = m.viscosity;
            self.controls.sound_speed[row] = m.sound_speed();
        }
        self.controls.liquid = self.controls.liquid.min(rows.saturating_sub(1));
        self.controls.gravity = Vec3::from(params.gravity);
        self.controls.pbmpm = PbmpmControls::of(sim.scene());
        self.sim = Some(sim);
        self.scene = scene;
        self.mouse.collider_drag = None;
        if let Some(gpu) = self.gpu.as_mut() {
            // Rebuilt for the new scene's colliders and flow outlines at the next draw (a restart
            // drops the bodies dropped into the run: `self.scene` never holds them).
            gpu.colliders_built = false;
        }
        self.clock.reset();
        self.over_cfl = 0;
        self.step_owed = false;
        self.fixed_owed = 0;
        // The old simulation's steps, not yet accounted, are no part of the new one.
        self.stepped = None;
        Ok(())
    }

    fn create_gpu(&mut self, event_loop: &ActiveEventLoop) -> Result<Gpu> {
        let attributes = Window::default_attributes()
            .with_title(format!("mpm — {}", self.scene.name))
            .with_inner_size(winit::dpi::PhysicalSize::new(
                self.options.size[0],
                self.options.size[1],
            ))
            .with_resizable(true);
        let template = ConfigTemplateBuilder::new()
            .with_depth_size(24)
            .with_alpha_size(8);
        let (window, config) = glutin_winit::DisplayBuilder::new()
            .with_window_attributes(Some(attributes.clone()))
            .build(event_loop, template, |configs| {
                // A depth buffer (the impostors write depth) and the fewest samples. glutin-winit
                // reports an error before calling this when there is no config at all.
                configs
                    .max_by_key(|c| (c.depth_size() >= 24, std::cmp::Reverse(c.num_samples())))
                    .expect("glutin-winit passes a non-empty config list")
            })
            .map_err(|e| anyhow!("no OpenGL config for a window: {e}"))?;
        let display = config.display();
        let window = match window {
            Some(window) => window,
            None => glutin_winit::finalize_window(event_loop, attributes, &config)
                .context("creating the window")?,
        };
        let handle = window
            .window_handle()
            .context("the window has no handle")?
            .as_raw();
        let mut context = None;
        let mut failures = Vec::new();
        // OpenGL 4.5 core first, then 3.3 core (every shader here is GLSL 3.30).
        for version in [Version::new(4, 5), Version::new(3, 3)] {
            let attributes = ContextAttributesBuilder::new()
                .with_context_api(ContextApi::OpenGl(Some(version)))
                .with_profile(GlProfile::Core)
                .build(Some(handle));
            // SAFETY: config and handle come from this display and window.
            match unsafe { display.create_context(&config, &attributes) } {
                Ok(c) => {
                    context = Some(c);
                    break;
                }
                Err(e) => failures.push(format!("{version:?}: {e}")),
            }
        }
        let context = context.ok_or_else(|| {
            anyhow!(
                "the driver gives no OpenGL 3.3+ core context ({})",
                failures.join("; ")
            )
        })?;
        let surface_attributes = window
            .build_surface_attributes(Default::default())
            .context("the window has no usable size or handle")?;
        // SAFETY: as above.
        let surface = unsafe { display.create_window_surface(&config, &surface_attributes) }
            .context("creating the window surface")?;
        let context = context
            .make_current(&surface)
            .context("making the GL context current")?;
        let interval = if self.options.vsync {
            SwapInterval::Wait(NonZeroU32::MIN)
        } else {
            SwapInterval::DontWait
        };
        if let Err(e) = surface.set_swap_interval(&context, interval) {
            eprintln!(
                "note: cannot set vsync {}: {e}",
                if self.options.vsync { "on" } else { "off" }
            );
        }
        // SAFETY: the context is current; the loader is its display's.
        let gl =
            Arc::new(unsafe { glow::Context::from_loader_function_cstr(|s| display.get_proc_address(s)) });
        // SAFETY: the context is current.
        let description = unsafe {
            format!(
                "{} / OpenGL {} ({})",
                gl.get_parameter_string(glow::RENDERER),
                gl.get_parameter_string(glow::VERSION),
                display.version_string()
            )
        };
        eprintln!("OpenGL: {description}");
        let renderer = Renderer::new(gl.clone())?;
        let egui = egui_glow::EguiGlow::new(
            event_loop,
            gl.clone(),
            None,
            Some(window.scale_factor() as f32),
            true,
        );
        Ok(Gpu {
            egui,
            renderer,
            colliders_built: false,
            gl,
            surface,
            context,
            window,
        })
    }

    fn handle_key(&mut self, key: &Key, event_loop: &ActiveEventLoop) {
        match key {
            Key::Named(NamedKey::Space) => self.controls.paused = !self.controls.paused,
            Key::Named(NamedKey::Escape) => event_loop.exit(),
            Key::Named(NamedKey::F5) => self.act(Action::SaveSnapshot, event_loop),
            Key::Named(NamedKey::F9) => self.act(Action::LoadSnapshot, event_loop),
            Key::Character(c) => match c.to_lowercase().as_str() {
                "n" => self.step_requested = true,
                "r" => self.act(Action::Reset, event_loop),
                "m" => self.controls.render.mode = self.controls.render.mode.next(),
                "c" => {
                    let r = &mut self.controls.render;
                    r.colouring = r.colouring.next();
                    r.scale_range = RenderSettings::default_range(r.colouring);
                }
                "f" => self.act(Action::FrameCamera, event_loop),
                "b" => self.act(Action::DropBody { ball: false }, event_loop),
                "o" => self.act(Action::DropBody { ball: true }, event_loop),
                "p" => self.screenshot_requested = true,
                "v" => self.act(Action::ToggleRecording, event_loop),
                "e" => self.act(Action::StopExport, event_loop),
                "h" => self.show_panel = !self.show_panel,
                _ => {}
            },
            _ => {}
        }
    }

    fn act(&mut self, action: Action, event_loop: &ActiveEventLoop) {
        let result = match action {
            Action::Step => {
                self.step_requested = true;
                Ok(())
            }
            Action::Reset => self.start_scene(self.scene.clone(), false),
            Action::LoadPreset(name) => Scene::load(name)
                .map_err(anyhow::Error::from)
                .and_then(|scene| self.start_scene(scene, true)),
            Action::LoadFile(path) => Scene::load(path.trim())
                .map_err(anyhow::Error::from)
                .and_then(|scene| self.start_scene(scene, true)),
            Action::Screenshot => {
                self.screenshot_requested = true;
                Ok(())
            }
            Action::ToggleRecording => self.toggle_recording(),
            Action::StopExport => match self.export {
                Some(_) => {
                    self.end_export(ExportEnd::Stopped);
                    Ok(())
                }
                None => Err(anyhow!(
                    "no export is running: an export starts with the viewer (`mpm view --export DIR` \
                     or another export option) and ends for good at R, a new scene, F9 or E"
                )),
            },
            Action::SaveSnapshot => self.save_snapshot(),
            Action::LoadSnapshot => self.load_snapshot(),
            Action::FrameCamera => {
                self.camera_follows_view = true;
                Ok(())
            }
            Action::SetViscosity(row, mu) => self.with_sim(|sim| sim.set_viscosity(row, mu)),
            Action::SetSoundSpeed(row, c) => self.with_sim(|sim| sim.set_sound_speed(row, c)),
            Action::SetIterations(n) => self.with_sim(|sim| sim.set_iterations(n)),
            Action::SetSubsteps(n) => self.with_sim(|sim| sim.set_substeps(n)),
            Action::SetGravity(g) => self.with_sim(|sim| sim.set_gravity(g)),
            Action::DropBody { ball } => self.drop_body(ball),
            Action::Quit => {
                event_loop.exit();
                Ok(())
            }
        };
        if let Err(e) = result {
            self.message = Some(format!("{e:#}"));
        }
    }

    /// Drops a box or a ball (`ball`) into the running scene, at the panel's density, about a tenth
    /// of the tank's smallest side across, over the camera's target (the domain's middle until the
    /// camera is slid) above the liquid there; the renderer then builds the colliders' meshes anew.
    /// A refusal (a full run, a backend that moves no bodies) is the panel's message.
    fn drop_body(&mut self, ball: bool) -> Result<()> {
        let Some(sim) = self.sim.as_mut() else {
            return Ok(());
        };
        if let Some(export) = &self.export {
            export.check_collider_change(ColliderChange::Drop)?;
        }
        let shape = DropShape::sized_for(ball, sim.scene());
        let density = if ball {
            self.controls.ball_density
        } else {
            self.controls.box_density
        };
        let target = self.camera.target.as_dvec3();
        let center = sim.drop_center(&shape, (target.x, target.z))?;
        sim.drop_body(DroppedBody {
            shape,
            density,
            center,
        })?;
        if let Some(gpu) = self.gpu.as_mut() {
            gpu.colliders_built = false;
        }
        let size = match shape {
            DropShape::Box { size } => format!(
                "{:.1} x {:.1} x {:.1} cm",
                1e2 * size.x,
                1e2 * size.y,
                1e2 * size.z
            ),
            DropShape::Ball { radius } => format!("{:.1} cm across", 2e2 * radius),
        };
        self.message = Some(format!(
            "dropped a {} of {density:.0} kg/m³, {size}, at ({:.3}, {:.3}, {:.3}) m (R restarts without it)",
            shape.name(),
            center.x,
            center.y,
            center.z
        ));
        Ok(())
    }

    fn with_sim(&mut self, f: impl FnOnce(&mut Simulation) -> Result<()>) -> Result<()> {
        match &mut self.sim {
            Some(sim) => f(sim),
            None => Ok(()),
        }
    }

    fn toggle_recording(&mut self) -> Result<()> {
        if let Some(recording) = self.recording.take() {
            self.message = Some(format!(
                "recorded {} to {}",
                crate::text::count(recording.sequence.frames_written(), "frame", "frames"),
                recording.sequence.dir().display()
            ));
            return Ok(());
        }
        // A new numbered folder each time, so no earlier recording is touched.
        let dir = (0..)
            .map(|i| self.options.capture_dir.join(format!("recording-{i:03}")))
            .find(|d| !d.exists())
            .unwrap_or_else(|| self.options.capture_dir.join("recording"));
        let sequence = FrameSequence::create(&dir, 1)?;
        self.recording = Some(Recording { sequence });
        Ok(())
    }

    /// One frame: account what was stepped during the last draw, feed the particles, then draw the
    /// panel and the scene, take the images asked for and present, while a worker thread steps the
    /// next frames.
    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let now = Instant::now();
        let wall_dt = (now - self.last_frame).as_secs_f64();
        self.last_frame = now;
        if self.first_draw.is_none() {
            self.first_draw = self.sim.as_ref().map(|sim| (now, sim.time()));
        }
        if self.frames_drawn > 0 {
            // The first interval seeds the average (from zero it would read low for dozens of draws).
            self.frame_ms = if self.frame_ms == 0.0 {
                wall_dt * 1e3
            } else {
                0.9 * self.frame_ms + 0.1 * wall_dt * 1e3
            };
            self.fps = 1e3 / self.frame_ms.max(1e-3);
        }

        self.draw_costs.begin();
        // The frames stepped during the last draw, under the pacing they were asked with.
        let fixed = matches!(self.clock.pacing, Pacing::Fixed { .. });
        let completed = match self.stepped.take() {
            Some(stepped) => self.account_step(stepped, wall_dt),
            None => 0,
        };
        self.poll_export();
        // With fixed pacing (and recording) an image is taken only when the batch is complete, so the
        // images stay exactly frames_per_draw 60 Hz frames apart.
        let batch_complete = if fixed && !self.controls.paused {
            self.fixed_owed = self.fixed_owed.saturating_sub(completed);
            self.fixed_owed == 0
        } else {
            true
        };

        // The fluid's region, as the camera frames it and the renderer bounds it.
        let domain = {
            let (lo, hi) = self.scene.fluid_region();
            (lo.as_vec3(), hi.as_vec3())
        };
        let Some(gpu) = self.gpu.as_mut() else {
            return Ok(());
        };
        let fed = match &mut self.sim {
            Some(sim) => self
                .feed
                .update(sim, &mut gpu.renderer, self.controls.render.colouring)?,
            None => Fed::default(),
        };
        self.draw_costs.lap(DrawSection::Feed);
        // What the drawing needs of the simulation, taken before the stepping thread has it.
        let glance = match &self.sim {
            Some(sim) => {
                if !gpu.colliders_built {
                    gpu.renderer.set_colliders(sim.colliders())?;
                    gpu.renderer.set_flow(&sim.scene().flow, domain);
                    gpu.colliders_built = true;
                }
                gpu.renderer.set_collider_frame(sim.collider_frame());
                Some(SimGlance::of(sim))
            }
            None => None,
        };
        let last_frame = self
            .options
            .quit_after
            .is_some_and(|n| self.frames_drawn + 1 >= n);
        let record = self.recording.is_some() && batch_complete && completed > 0;
        let frames = if last_frame {
            0
        } else {
            self.frames_to_step(wall_dt)
        };
        if frames > 0 {
            self.prepare_step(frames);
        }
        // The particles are in the GL buffer: the next frames are stepped from here on, beside the
        // panel, the drawing and the present, on the simulation's own CUDA stream after the feed.
        let handed = Instant::now();
        // The export's line for the panel, read before the export goes along with the simulation.
        let export = self.export_status();
        let stepping = match self.sim.take_if(|_| frames > 0) {
            Some(sim) => {
                self.stepper.start(sim, self.export.take(), frames);
                true
            }
            None => false,
        };
        let drawn = self.draw_frame(fed, domain, glance, export, record, last_frame);
        let stepped = stepping.then(|| self.stepper.finish());
        self.draw_costs.lap(DrawSection::StepWait);
        if let Some((sim, export, stepped)) = stepped {
            let handover = (stepped.began - handed) + stepped.ended.elapsed();
            self.draw_costs.stepped(stepped.took, handover);
            self.sim = Some(sim);
            self.export = export;
            self.stepped = Some(stepped);
        }
        // The panel's actions once the simulation is back: they may pause, step or restart it.
        for action in drawn? {
            self.act(action, event_loop);
        }
        self.frames_drawn += 1;
        if last_frame {
            event_loop.exit();
        }
        self.schedule_draw(event_loop, now);
        Ok(())
    }

    /// Asks for the next draw: at once, or under `--max-fps` at its turn after the draw that began
    /// at `began` (the event loop sleeps until then, answering input meanwhile; [`Self::new_events`]).
    fn schedule_draw(&self, event_loop: &ActiveEventLoop, began: Instant) {
        let Some(gpu) = &self.gpu else { return };
        let turn = self
            .options
            .max_fps
            .map(|fps| began + Duration::from_secs_f64(1.0 / f64::from(fps)));
        match turn {
            Some(turn) if turn > Instant::now() => event_loop.set_control_flow(ControlFlow::WaitUntil(turn)),
            _ => gpu.window.request_redraw(),
        }
    }

    /// The panel, the scene, the images asked for and the present: everything of a draw that does
    /// not touch the simulation (which the stepping thread has meanwhile). Returns the panel's
    /// actions.
    fn draw_frame(
        &mut self,
        fed: Fed,
        domain: (Vec3, Vec3),
        glance: Option<SimGlance>,
        export: Option<String>,
        record: bool,
        last_frame: bool,
    ) -> Result<Vec<Action>> {
        let Some(gpu) = self.gpu.as_mut() else {
            return Ok(Vec::new());
        };
        let size = gpu.window.inner_size();
        let size = [size.width.max(1), size.height.max(1)];
        // The panel first: it decides how much of the window the scene gets.
        let mut actions = Vec::new();
        let mut scene_rect = None;
        if self.show_panel {
            let info = HudInfo {
                scene: &self.scene.name,
                materials: &self.scene.materials,
                backend: glance.map_or("none", |g| g.backend),
                particles: fed.live,
                fps: self.fps,
                frame_ms: self.frame_ms,
                timings: self.last_timings,
                substeps: self.last_steps.0,
                dt: self.last_steps.1,
                max_cfl: self.last_steps.2,
                substeps_over_cfl: self.over_cfl,
                backstop_pushes: glance.and_then(|g| g.backstop_pushes),
                frame_in_progress: glance.is_some_and(|g| g.frame_in_progress),
                sim_time: glance.map_or(0.0, |g| g.time),
                wall_time: self.started.elapsed().as_secs_f64(),
                speed: self.clock.speed(),
                transfer: self.feed.path(),
                render_passes: gpu.renderer.pass_times(),
                thickness_by_cuda: gpu.renderer.thickness_by_cuda(),
                recording: self.recording.as_ref().map(|r| {
                    (
                        r.sequence.dir().display().to_string(),
                        r.sequence.frames_written(),
                    )
                }),
                export: export.as_deref(),
                message: self.message.as_deref(),
            };
            let controls = &mut self.controls;
            gpu.egui.run(&gpu.window, |ctx| {
                actions = hud::panel(ctx, controls, &info);
                scene_rect = Some((ctx.available_rect(), ctx.pixels_per_point()));
            });
        }
        self.draw_costs.lap(DrawSection::Panel);
        self.scene_viewport = match scene_rect {
            Some((rect, ppp)) => {
                let left = (rect.min.x * ppp).round().clamp(0.0, size[0] as f32 - 1.0) as u32;
                let top = (rect.min.y * ppp).round().clamp(0.0, size[1] as f32 - 1.0) as u32;
                let right = ((rect.max.x * ppp).round() as u32).clamp(left + 1, size[0]);
                let bottom = ((rect.max.y * ppp).round() as u32).clamp(top + 1, size[1]);
                Viewport {
                    x: left as i32,
                    y: (size[1] - bottom) as i32,
                    width: right - left,
                    height: bottom - top,
                }
            }
            None => Viewport::full(size),
        };
        if self.camera_follows_view {
            self.camera = self
                .controls
                .render
                .framing(domain.0, domain.1, self.scene_viewport);
        }
        // The stepping enqueues no more substeps until the GPU has done this draw's work (GpuGate).
        let gpu_gate = self.gpu_gate.clone();
        let gate = gpu_gate.as_deref().map(GpuGate::close);
        if let Err(e) = gpu.renderer.draw(
            self.scene_viewport,
            &self.camera,
            &self.controls.render,
            fed.slots,
            domain,
        ) {
            // The surface needs float render targets; without them the spheres still draw.
            self.message = Some(format!("{e:#}"));
            self.controls.render.mode = DrawMode::Spheres;
        }

        let want_image =
            self.screenshot_requested || record || (last_frame && self.options.final_screenshot.is_some());
        if want_image {
            // The scene alone, before the panel is painted over the frame.
            let image = read_back_buffer(&gpu.gl, self.scene_viewport);
            if std::mem::take(&mut self.screenshot_requested) {
                let path = next_free_screenshot(&self.options.capture_dir);
                match image.write_png_new(&path) {
                    Ok(()) => self.message = Some(format!("saved {}", path.display())),
                    Err(e) => self.message = Some(format!("{e:#}")),
                }
            }
            if let Some(recording) = self.recording.as_mut().filter(|_| record) {
                if let Err(e) = recording.sequence.write(&image) {
                    self.message = Some(format!("recording stopped: {e:#}"));
                    self.recording = None;
                }
            }
            if last_frame {
                if let Some(path) = &self.options.final_screenshot {
                    image.write_png_new(path)?;
                }
            }
        }

        self.draw_costs.lap(DrawSection::Draw);
        if self.show_panel {
            gpu.egui.paint(&gpu.window);
        }
        if let Some(gate) = gate {
            // SAFETY: the window's context is current on this thread.
            unsafe { gpu.gl.finish() };
            drop(gate);
        }
        self.draw_costs.lap(DrawSection::Paint);
        gpu.surface
            .swap_buffers(&gpu.context)
            .context("presenting the frame (swap buffers)")?;
        self.draw_costs.lap(DrawSection::Present);
        Ok(actions)
    }

    /// The cursor relative to the scene's viewport (window y runs down, GL's up), and the viewport's
    /// size; `None` without a window.
    fn scene_cursor(&self) -> Option<(Vec2, Vec2)> {
        let gpu = self.gpu.as_ref()?;
        let window_height = gpu.window.inner_size().height as f32;
        let vp = self.scene_viewport;
        let size = Vec2::new(vp.width as f32, vp.height as f32);
        let top = window_height - (vp.y as f32 + vp.height as f32);
        Some((self.mouse.position - Vec2::new(vp.x as f32, top), size))
    }

    /// Ctrl + left button: takes hold of the collider under the cursor, if any; on release lets it
    /// go (it stays where it is, at rest).
    fn collider_button(&mut self, pressed: bool) {
        let cursor = self.scene_cursor();
        let Some(sim) = self.sim.as_mut() else { return };
        if pressed {
            if let Some((cursor, size)) = cursor {
                let grabbed = ColliderDrag::grab(sim, &self.camera, cursor, size);
                // A static collider moves from the moment it is taken, which an export holding it as
                // static cannot follow.
                let refused = match (&grabbed, &self.export) {
                    (Some(held), Some(export)) => {
                        let collider = &sim.colliders().list[held.index];
                        let moves_now = collider.body.is_none() && matches!(collider.motion, Motion::Static);
                        moves_now
                            .then(|| export.check_collider_change(ColliderChange::MoveStatic).err())
                            .flatten()
                    }
                    _ => None,
                };
                match refused {
                    Some(e) => self.message = Some(format!("{e:#}")),
                    None => self.mouse.collider_drag = grabbed,
                }
            }
        } else if let Some(held) = self.mouse.collider_drag.take() {
            if let Err(e) = held.release(sim) {
                self.message = Some(format!("drag failed: {e:#}"));
            }
        }
    }
}

/// A region of the back buffer as an image.
fn read_back_buffer(gl: &glow::Context, viewport: Viewport) -> Image {
    let (w, h) = (viewport.width, viewport.height);
    let mut pixels = vec![0u8; 4 * w as usize * h as usize];
    // SAFETY: the context is current; the buffer has room for w x h RGBA8.
    unsafe {
        gl.pixel_store_i32(glow::PACK_ALIGNMENT, 1);
        gl.read_pixels(
            viewport.x,
            viewport.y,
            w as i32,
            h as i32,
            glow::RGBA,
            glow::UNSIGNED_BYTE,
            glow::PixelPackData::Slice(Some(&mut pixels)),
        );
    }
    let mut image = Image::from_gl_rows(w, h, pixels);
    for px in image.rgba.chunks_exact_mut(4) {
        px[3] = 255;
    }
    image
}

impl ApplicationHandler for ViewerApp {
    /// A `--max-fps` draw's turn has come (`schedule_draw`).
    fn new_events(&mut self, event_loop: &ActiveEventLoop, cause: StartCause) {
        if let (StartCause::ResumeTimeReached { .. }, Some(gpu)) = (cause, &self.gpu) {
            event_loop.set_control_flow(ControlFlow::Wait);
            gpu.window.request_redraw();
        }
    }

    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gpu.is_some() {
            return;
        }
        let started = self.create_gpu(event_loop).and_then(|gpu| {
            self.gpu = Some(gpu);
            self.start_scene(self.scene.clone(), false)?;
            self.start_export()
        });
        if let Err(e) = started {
            self.fatal = Some(e);
            event_loop.exit();
            return;
        }
        if let Some(gpu) = &self.gpu {
            gpu.window.request_redraw();
        }
        self.last_frame = Instant::now();
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(gpu) = self.gpu.as_mut() else { return };
        let consumed = self.show_panel && gpu.egui.on_window_event(&gpu.window, &event).consumed;
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let (Some(w), Some(h)) = (NonZeroU32::new(size.width), NonZeroU32::new(size.height)) {
                    gpu.surface.resize(&gpu.context, w, h);
                    // Re-register after a surface change: cheap, and some drivers move GL objects then.
                    self.feed.release();
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw(event_loop) {
                    self.fatal = Some(e);
                    event_loop.exit();
                }
            }
            WindowEvent::ModifiersChanged(m) => self.modifiers = m.state(),
            WindowEvent::KeyboardInput { event, .. }
                if !consumed && event.state == ElementState::Pressed && !event.repeat =>
            {
                self.handle_key(&event.logical_key, event_loop);
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let pressed = state == ElementState::Pressed;
                if pressed && consumed {
                    return;
                }
                match button {
                    MouseButton::Left => {
                        self.mouse.left = pressed;
                        if (pressed && self.modifiers.control_key())
                            || (!pressed && self.mouse.collider_drag.is_some())
                        {
                            self.collider_button(pressed);
                        }
                    }
                    MouseButton::Right | MouseButton::Middle => self.mouse.right = pressed,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let position = Vec2::new(position.x as f32, position.y as f32);
                let delta = position - self.mouse.position;
                self.mouse.position = position;
                if consumed {
                    return;
                }
                let height = self.scene_viewport.height as f32;
                if self.mouse.collider_drag.is_some() {
                    // The held collider follows the cursor at the next step.
                } else if self.mouse.left && self.modifiers.shift_key() {
                    self.mouse.push_drag += delta;
                } else if self.mouse.left {
                    self.camera.orbit(delta);
                    self.camera_follows_view = false;
                } else if self.mouse.right {
                    self.camera.pan(delta, height);
                    self.camera_follows_view = false;
                }
            }
            WindowEvent::MouseWheel { delta, .. } if !consumed => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                self.camera.zoom(steps);
                self.camera_follows_view = false;
            }
            _ => {}
        }
    }

    fn exiting(&mut self, _event_loop: &ActiveEventLoop) {
        // The particles' path is said here as well as in the panel: scripted runs (a GPU server's
        // Xvfb, tests) read it from the log to tell interop from its host-copy fallback.
        eprintln!(
            "viewer: {} drawn, particles by {}; the longest stepping in one draw took {:.0} ms",
            crate::text::count(self.frames_drawn, "frame", "frames"),
            self.feed.path(),
            self.longest_step.as_secs_f64() * 1e3
        );
        if let Some(costs) = self.draw_costs.summary() {
            // Where the host's time goes: what is neither stepping nor drawing is waiting or overhead.
            eprintln!("viewer: host ms per draw: {costs}");
        }
        // Against the draw interval below: what the window adds to stepping and rendering.
        let render = self.gpu.as_mut().map(|gpu| gpu.renderer.timer_mut().means());
        let timed = [
            self.step_costs.summary(),
            render.filter(|(frames, _)| *frames > 0).map(|(frames, passes)| {
                format!(
                    "render total {:.2} per drawn frame ({frames} frames)",
                    passes.total()
                )
            }),
        ];
        let timed: Vec<String> = timed.into_iter().flatten().collect();
        if !timed.is_empty() {
            eprintln!("viewer: timed ms, as the panel shows them: {}", timed.join(", "));
        }
        if let Some((time, error)) = &self.step_error {
            eprintln!(
                "viewer: the stepping stopped on an error at t = {time:.3} s (the speed below counts the \
                 paused time after it): {error}"
            );
        }
        if let (Some((start, sim_start)), Some(sim)) = (self.first_draw, &self.sim) {
            let wall = (self.last_frame - start).as_secs_f64();
            if self.frames_drawn > 1 && wall > 0.0 {
                let interval = wall / (self.frames_drawn - 1) as f64;
                eprintln!(
                    "viewer: mean draw interval {:.2} ms ({:.1} FPS); simulated {:.3} s in {:.3} s of wall time \
                     ({:.2}x real time)",
                    interval * 1e3,
                    1.0 / interval,
                    sim.time() - sim_start,
                    wall,
                    (sim.time() - sim_start) / wall
                );
            }
        }
        // The export's queued frames are written before the simulation (whose GPU copies they may
        // still wait for) goes.
        self.end_export(ExportEnd::Closed);
        self.join_finishing_export();
        // Release in dependency order: the CUDA registration, the solver, then GL objects.
        self.feed.release();
        self.sim = None;
        if let Some(mut gpu) = self.gpu.take() {
            gpu.renderer.destroy();
            gpu.egui.destroy();
        }
        if let Some(recording) = self.recording.take() {
            eprintln!(
                "recorded {} to {}",
                crate::text::count(recording.sequence.frames_written(), "frame", "frames"),
                recording.sequence.dir().display()
            );
        }
    }
}
