//! The `mpm` command line: nothing but argument parsing and dispatch.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use mpm::backend::{self, BackendKind};
use mpm::bench;
use mpm::checkpoint::{Checkpoint, CheckpointSeries};
use mpm::dist::launch::Process;
use mpm::dist::Start;
use mpm::export::bodies::BodyExporter;
use mpm::export::frames::{Exports, FrameExportSet};
use mpm::export::mesh_files::SurfaceFormat;
use mpm::export::surface::{SurfaceExporter, SurfaceOverrides, SurfaceSettings};
use mpm::export::usd::UsdCache;
use mpm::export::volume::{VolumeExporter, VolumeFormat, VolumeOverrides, VolumeSettings};
use mpm::export::{check_output_file, PlyExporter};
use mpm::render::{self, app::ViewerOptions, offline::RenderOptions, Colouring, DrawMode, Transfer};
use mpm::runner::{self, RunOptions, StatsFile};
use mpm::sim::{presets, Method, Pipeline, ScatterMode, Scene, Simulation};
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "mpm",
    version,
    about = "Real-time MLS-MPM fluid: CUDA kernels, a CPU reference, headless runs"
)]
#[command(
    after_help = "Without a command, `mpm [OPTIONS]` is `mpm view [OPTIONS]`: the viewer \
    (`mpm view --help` lists its options). A command's options follow the command: `mpm run --scene drop`."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// The command names, for reading `mpm [OPTIONS]` as `mpm view [OPTIONS]`.
const COMMANDS: [&str; 7] = ["view", "render", "run", "bench", "scenes", "devices", "help"];

/// The arguments with `view` put in where the user gave options but no command (`mpm --scene drop`
/// opens the viewer). Options before a command (`mpm --scene x run`) are an error that says where
/// they go.
fn arguments() -> Result<Vec<std::ffi::OsString>, String> {
    let mut args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let first = args.get(1).and_then(|a| a.to_str()).unwrap_or("");
    let top_level_flag = matches!(first, "-h" | "--help" | "-V" | "--version");
    if COMMANDS.contains(&first) || top_level_flag {
        return Ok(args);
    }
    // A command name counts as a misplaced command unless it is an option's value (`--scene bench`).
    let words: Vec<&str> = args[1..].iter().map(|a| a.to_str().unwrap_or("")).collect();
    // The viewer's switches, which take no value.
    let switches = [
        "--no-vsync",
        "--full-res-smoothing",
        "--overwrite",
        "--usd-surface",
        "--volume-velocity",
        "--volume-half",
    ];
    let takes_value =
        |option: &str| option.starts_with('-') && !option.contains('=') && !switches.contains(&option);
    let misplaced = (0..words.len()).find(|&i| {
        COMMANDS.contains(&words[i]) && words[i] != "help" && (i == 0 || !takes_value(words[i - 1]))
    });
    if let Some(command) = misplaced.map(|i| words[i]) {
        let options: Vec<String> = args[1..]
            .iter()
            .map(|a| a.to_string_lossy().into_owned())
            .take_while(|a| a != command)
            .collect();
        return Err(format!(
            "options go after the command: write `mpm {command} {}` (options before a command are \
             the viewer's)",
            options.join(" ")
        ));
    }
    // An option of `mpm run` alone, given to the viewer: say where it goes (the exports' options are
    // the viewer's too).
    let run_only = ["--frames", "--stats", "--checkpoint", "--resume"];
    if let Some(option) = words
        .iter()
        .find(|w| run_only.contains(&w.split('=').next().unwrap_or(w)))
    {
        let given: Vec<String> = args[1..]
            .iter()
            .map(|a| a.to_string_lossy().into_owned())
            .collect();
        return Err(format!(
            "{} is an option of `mpm run` (a headless run), not of the viewer: write `mpm run {}`",
            option.split('=').next().unwrap_or(option),
            given.join(" ")
        ));
    }
    args.insert(1.min(args.len()), "view".into());
    Ok(args)
}

#[derive(Subcommand)]
enum Command {
    /// Open the viewer window (the default: `mpm` alone): the fluid live, with a control panel.
    View(ViewArgs),
    /// Draw frames headless (EGL device, no X server) into PNG files, optionally an MP4.
    Render(RenderArgs),
    /// Step a scene headless, printing one line of statistics per 60 Hz frame.
    Run(RunArgs),
    /// Time the step per phase (CUDA events), the CPU baseline and the scaling sweep; markdown tables
    /// on stdout, everything as JSON with --json.
    Bench(BenchArgs),
    /// List the built-in scenes, or print one as a TOML file to start your own from. A scene file
    /// holds the domain, one `[material]` (or up to 8 named `[[material]]` liquids, which its
    /// bodies and emitters name), the fluid bodies, and optionally colliders, emitters and sinks:
    /// docs/scenes.md.
    Scenes {
        /// Print this preset's scene file, exactly as it is built in (without a name: list the presets).
        #[arg(long, value_name = "PRESET", num_args = 0..=1)]
        show: Option<Option<String>>,
        /// Print a mesh file a preset uses (`glass.obj`, the tap's glass; `water-wheel.obj`, the
        /// water wheel's), to save beside a scene file saved with --show.
        #[arg(long, value_name = "FILE", conflicts_with = "show")]
        mesh: Option<String>,
    },
    /// List the CUDA devices (memory, peer access between them) and whether NCCL, which runs on
    /// several GPUs will need, is found, with its version.
    Devices,
}

#[derive(clap::Args)]
struct RunArgs {
    /// A preset name (`mpm scenes` lists them) or the path of a scene .toml file.
    #[arg(long, default_value = presets::DEFAULT, value_parser = scene_arg())]
    scene: String,
    /// Number of 60 Hz frames to simulate (with --resume: frames after the checkpoint's).
    #[arg(long, default_value_t = 60, allow_negative_numbers = true, value_parser = count::<0>)]
    frames: u64,
    /// The backend [default: auto; with --resume, the checkpoint's].
    #[arg(long, value_enum)]
    backend: Option<BackendKind>,
    #[command(flatten)]
    solver: SolverArgs,
    #[command(flatten)]
    method: MethodArgs,
    #[command(flatten)]
    exports: ExportArgs,
    /// Also write the per-frame statistics as JSON lines to this file.
    #[arg(long, value_name = "FILE")]
    stats: Option<PathBuf>,
    /// Write the whole state into this directory every --checkpoint-every frames and after the
    /// last frame (checkpoint_NNNNNN.mpmck), for `mpm run --resume FILE`.
    #[arg(long, value_name = "DIR")]
    checkpoint: Option<PathBuf>,
    /// Frames between checkpoints.
    #[arg(long, value_name = "K", default_value_t = 60, requires = "checkpoint",
          allow_negative_numbers = true, value_parser = count::<1>)]
    checkpoint_every: u64,
    /// Go on from a checkpoint file: its scene, backend and solver options (--backend, --scatter and
    /// --pipeline override them), frame numbers and time continuing from it.
    #[arg(long, value_name = "FILE", conflicts_with = "scene")]
    resume: Option<PathBuf>,
    /// Replace existing exported frames, stats file or checkpoints instead of refusing.
    #[arg(long)]
    overwrite: bool,
}

/// The flags of the frame exports, one definition for `mpm run` and `mpm view` (both flatten it),
/// built into exporters by [`ExportArgs::build`].
#[derive(clap::Args)]
#[command(group = clap::ArgGroup::new("frame_export").args(["export", "export_surface", "export_volume", "export_bodies", "export_usd"]).multiple(true))]
#[command(group = clap::ArgGroup::new("surface_on").args(["export_surface", "usd_surface"]).multiple(true))]
#[command(group = clap::ArgGroup::new("field_on").args(["export_surface", "usd_surface", "export_volume"]).multiple(true))]
struct ExportArgs {
    /// Write one binary PLY per exported frame (frame 0 is the initial state) into this directory.
    #[arg(long, value_name = "DIR")]
    export: Option<PathBuf>,
    /// Reconstruct the water surface of frame 0 and every K-th frame as a triangle mesh,
    /// surface_NNNNNN.obj|ply|vtk, into this directory (on worker threads while the run goes on).
    #[arg(long, value_name = "DIR")]
    export_surface: Option<PathBuf>,
    /// The surface meshes' file format.
    #[arg(long, value_enum, value_name = "FORMAT", default_value_t = SurfaceFormat::Obj,
          requires = "export_surface")]
    surface_format: SurfaceFormat,
    #[command(flatten)]
    surface: SurfaceArgs,
    /// Sample the liquid of frame 0 and every K-th frame on voxels and write it as an OpenVDB file,
    /// volume_NNNNNN.vdb, into this directory (on worker threads while the run goes on): a
    /// narrow-band level set `surface` from the surface meshes' field, a fog volume `density`, and
    /// with --volume-velocity a vector grid `velocity`.
    #[arg(long, value_name = "DIR")]
    export_volume: Option<PathBuf>,
    /// The volumes' file format.
    #[arg(long, value_enum, value_name = "FORMAT", default_value_t = VolumeFormat::Vdb,
          requires = "export_volume")]
    volume_format: VolumeFormat,
    #[command(flatten)]
    volume: VolumeArgs,
    /// Write the rigid bodies of frame 0 and every K-th frame into this directory: bodies_NNNNNN.obj,
    /// each body's mesh posed in world coordinates (an object a body, collider_K), and the pose
    /// table bodies.csv (a row a body a frame). The scene must have rigid bodies.
    #[arg(long, value_name = "DIR")]
    export_bodies: Option<PathBuf>,
    /// Write the run as a USD stage: this .usda file (the root layer: stage metadata, the prims, the
    /// colliders' meshes) and a layer a frame in FILE_clips/ (value clips): the particles as a Points
    /// prim, the moving colliders' transforms, and with --usd-surface or --export-surface the surface
    /// mesh; at 60 time codes a second, frame 0 and every K-th frame.
    #[arg(long, value_name = "FILE")]
    export_usd: Option<PathBuf>,
    /// Reconstruct the water surface into the --export-usd stage (the --surface-* options apply),
    /// without mesh files of its own; --export-surface puts its meshes in the stage too.
    #[arg(long, requires = "export_usd")]
    usd_surface: bool,
    /// Export every K-th frame (--export, --export-surface, --export-volume, --export-bodies and
    /// --export-usd).
    #[arg(long, value_name = "K", default_value_t = 1, requires = "frame_export", allow_negative_numbers = true,
          value_parser = count::<1>)]
    every: u64,
}

impl ExportArgs {
    /// The exporters these flags ask for, for a run of `scene`, every one checked before anything
    /// starts (the same for `mpm run` and `mpm view`): unwritable folders, settings that cannot work
    /// (a voxel too small for this machine's memory), an earlier run's files without `overwrite`
    /// (with it they are removed: [`Exports::removed_notes`] says which), a scene without the rigid
    /// bodies `--export-bodies` asks for.
    fn build(&self, scene: &Scene, overwrite: bool) -> Result<Exports> {
        let every = self.every;
        let ply = self
            .export
            .as_deref()
            .map(|dir| PlyExporter::new(dir, every, overwrite))
            .transpose()?;
        let surface = self
            .export_surface
            .as_deref()
            .map(|dir| -> Result<SurfaceExporter> {
                let settings = SurfaceSettings::for_scene(scene, self.surface.overrides())?;
                SurfaceExporter::new(dir, every, self.surface_format, settings, overwrite)
            })
            .transpose()?;
        let volume = self
            .export_volume
            .as_deref()
            .map(|dir| -> Result<VolumeExporter> {
                let settings = VolumeSettings::for_scene(
                    scene,
                    self.surface.overrides(),
                    self.volume.overrides(),
                    mpm::export::frames::VOLUME_WORKERS,
                )?;
                VolumeExporter::new(dir, every, self.volume_format, settings, overwrite)
            })
            .transpose()?;
        let bodies = self
            .export_bodies
            .as_deref()
            .map(|dir| BodyExporter::new(dir, every, scene, overwrite))
            .transpose()?;
        // The stage holds the surface wherever it is reconstructed (--export-surface, --usd-surface).
        let usd = self
            .export_usd
            .as_deref()
            .map(|path| {
                let surface = self.usd_surface || surface.is_some();
                UsdCache::create(path, scene, every, surface, overwrite).map(std::sync::Arc::new)
            })
            .transpose()?;
        let surface = match (surface, &usd) {
            (Some(exporter), Some(usd)) => Some(exporter.with_usd(usd.clone())),
            (None, Some(usd)) if self.usd_surface => Some(SurfaceExporter::for_usd(
                usd.clone(),
                every,
                SurfaceSettings::for_scene(scene, self.surface.overrides())?,
            )?),
            (surface, _) => surface,
        };
        Ok(Exports {
            frames: FrameExportSet {
                ply,
                surface,
                volume,
                usd,
            },
            bodies,
        })
    }
}

/// The surface reconstruction's parameters, overriding the defaults derived from the scene (the
/// field's also the volumes').
#[derive(clap::Args)]
struct SurfaceArgs {
    /// Particle radius, m, of the surface meshes and volumes [default: dx / (2 n) for n^3 particles
    /// per cell: the particle's share of the spawn lattice, as a cube of edge 2 r].
    #[arg(long, value_name = "M", requires = "field_on", allow_negative_numbers = true,
          value_parser = positive)]
    surface_particle_radius: Option<f32>,
    /// Kernel smoothing length, in particle radii (the kernel reaches twice as far) [default: 2].
    #[arg(long, value_name = "RADII", requires = "field_on", allow_negative_numbers = true,
          value_parser = positive)]
    surface_smoothing_length: Option<f32>,
    /// Iso-surface threshold, a fraction of rest density [default: 0.6].
    #[arg(long, value_name = "FRACTION", requires = "field_on", allow_negative_numbers = true,
          value_parser = positive)]
    surface_threshold: Option<f32>,
    /// Marching-cubes cell edge, in particle radii (smaller: finer and slower) [default: 1].
    #[arg(long, value_name = "RADII", requires = "surface_on", allow_negative_numbers = true,
          value_parser = positive)]
    surface_cube_size: Option<f32>,
}

impl SurfaceArgs {
    fn overrides(&self) -> SurfaceOverrides {
        SurfaceOverrides {
            particle_radius: self.surface_particle_radius,
            smoothing_length: self.surface_smoothing_length,
            threshold: self.surface_threshold,
            cube_size: self.surface_cube_size,
        }
    }
}

/// The volumes' voxels, band and grids.
#[derive(clap::Args)]
struct VolumeArgs {
    /// Voxel edge, m [default: the particle radius, the surface meshes' cell: dx / (2 n)].
    #[arg(long, value_name = "M", requires = "export_volume", allow_negative_numbers = true,
          value_parser = positive)]
    volume_voxel_size: Option<f32>,
    /// The level set's narrow band on each side of the surface, in voxels, 1 or more [default: 3].
    #[arg(long, value_name = "VOXELS", requires = "export_volume", allow_negative_numbers = true,
          value_parser = positive)]
    volume_band: Option<f32>,
    /// Also write the particles' velocity (m/s) as the vector grid `velocity`.
    #[arg(long, requires = "export_volume")]
    volume_velocity: bool,
    /// Store the grids' values as 16-bit halves (about half the file).
    #[arg(long, requires = "export_volume")]
    volume_half: bool,
}

impl VolumeArgs {
    fn overrides(&self) -> VolumeOverrides {
        VolumeOverrides {
            voxel_size: self.volume_voxel_size,
            band: self.volume_band,
            velocity: self.volume_velocity,
            half: self.volume_half,
        }
    }
}

/// Which scheme runs the scene: overrides of its `solver.method` and `solver.iterations` (`mpm
/// run`, `view` and `render`; `mpm bench` times each scene under its own).
#[derive(clap::Args)]
struct MethodArgs {
    /// The scheme, overriding the scene's `solver.method`: explicit (MLS-MPM under the CFL policy)
    /// or pbmpm (position-based MPM, on CUDA or --backend cpu). A CFL scene made pbmpm runs
    /// time_step.substeps' default, 2 a frame; a pbmpm scene made explicit, the CFL policy's default.
    #[arg(long, value_enum)]
    method: Option<Method>,
    /// pbmpm's constraint iterations a substep (1 to 64), overriding the scene's `solver.iterations`.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=64))]
    iterations: Option<u32>,
}

impl MethodArgs {
    /// The overrides, after the solver options' ([`SolverArgs::apply`]: `--ranks` is checked
    /// against the method here), and what pbmpm does not run refused ([`Scene::check_method`]).
    fn apply(&self, scene: &mut Scene) -> Result<()> {
        if let Some(method) = self.method {
            scene.set_method(method);
        }
        if let Some(iterations) = self.iterations {
            anyhow::ensure!(
                scene.method == Method::Pbmpm,
                "--iterations sets the position-based solver's constraint iterations, and scene {} runs \
                 the explicit one: add --method pbmpm, or drop --iterations",
                scene.source
            );
            scene.pbmpm.iterations = iterations;
        }
        scene.check_method()?;
        Ok(())
    }
}

/// How the GPU steps: overrides of the scene's `solver.scatter` and `solver.pipeline`.
#[derive(clap::Args)]
struct SolverArgs {
    /// GPU scatter mode, overriding the scene's `solver.scatter`.
    #[arg(long, value_enum)]
    scatter: Option<ScatterMode>,
    /// Kernel sequence and density rule, overriding the scene's `solver.pipeline`: fused (default: one
    /// particle pass, the density advected), binned (two passes, the report's density) or report.
    #[arg(long, value_enum)]
    pipeline: Option<Pipeline>,
    /// Split the run into N ranks, each over a slab of the grid with ghost exchanges between them
    /// (backends cuda and cpu; docs/several-gpus.md). Every CUDA rank runs on the one device
    /// MPM_CUDA_DEVICE names: a check of the decomposition, slower than one rank.
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = count::<1>)]
    ranks: Option<u64>,
    /// Run on the first N GPUs of this host, one rank each over a slab of the grid, the ghost
    /// exchanges over NCCL (backend cuda; docs/several-gpus.md).
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = count::<1>, conflicts_with = "ranks")]
    gpus: Option<u64>,
    /// Run one rank per process, as mpirun, srun or torchrun start them: the rank and the number of
    /// processes from the launcher's environment, each process on one GPU (backend cuda), or with
    /// --backend cpu the CPU reference's ranks on one host (`mpm run` and `mpm bench`;
    /// docs/several-gpus.md).
    #[arg(long, conflicts_with_all = ["ranks", "gpus"])]
    processes: bool,
}

impl SolverArgs {
    /// The overrides, and this process's place among the ranks where they run a process each
    /// (`process`, from [`SolverArgs::process`]).
    fn apply(&self, scene: &mut Scene, process: Option<Process>) {
        if let Some(scatter) = self.scatter {
            scene.scatter = scatter;
        }
        if let Some(pipeline) = self.pipeline {
            scene.pipeline = pipeline;
        }
        if let Some(ranks) = self.ranks(process) {
            scene.ranks = ranks;
        }
        if let Some(gpus) = self.gpus() {
            scene.gpus = gpus;
        }
        scene.process = process;
    }

    /// With `--processes`, this process's place, from its launcher's environment; `None` where the
    /// run is one process (a launch of one runs as without the flag).
    fn process(&self) -> Result<Option<Process>> {
        if !self.processes {
            return Ok(None);
        }
        let var = |name: &str| std::env::var(name).ok();
        let process = Process::from_env(&var)?;
        if process.size == 1 {
            return Ok(None);
        }
        process.check_settings(&var)?;
        mpm::dist::launch::prefer_nccl_without_cumem();
        Ok(Some(process))
    }

    /// `--ranks`, or `--gpus` (a rank per GPU), or the processes of `process`'s run, where given (a
    /// count past the address space reads as the largest, which the slab check then refuses with
    /// the limit).
    fn ranks(&self, process: Option<Process>) -> Option<usize> {
        let asked = self
            .ranks
            .or(self.gpus)
            .map(|n| n.try_into().unwrap_or(usize::MAX));
        asked.or(process.map(|p| p.size))
    }

    /// `--gpus`, where given (a process per rank finds its GPU from its place, `Scene::process`).
    fn gpus(&self) -> Option<usize> {
        self.gpus.map(|n| n.try_into().unwrap_or(usize::MAX))
    }

    /// The window draws what one process steps.
    fn refuse_processes(&self, command: &str) -> Result<()> {
        anyhow::ensure!(
            !self.processes,
            "--processes: `mpm {command}` runs in one process; use --gpus N to step on the GPUs of \
             this host, or `mpm run --processes` for a run without a window"
        );
        Ok(())
    }
}

/// How the particles are drawn, and how their data reaches OpenGL: the same for `view` and `render`.
#[derive(clap::Args)]
struct LookArgs {
    #[arg(long, value_enum, default_value_t = DrawMode::Surface)]
    draw: DrawMode,
    /// Radius of the spheres (spheres) or of the splats the surface is built from (surface), in
    /// metres; default from the scene: 0.6 (spheres) or 0.75 (surface) particle spacings.
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    particle_radius: Option<f32>,
    /// What the particles' colour shows [default: material in a scene of several materials, else
    /// speed].
    #[arg(long, value_enum)]
    colour: Option<Colouring>,
    /// Smooth the water surface's depth at full resolution (slower; by default it is smoothed at half
    /// resolution and brought back with a depth-aware upsample, silhouettes kept sharp).
    #[arg(long)]
    full_res_smoothing: bool,
    /// How particle data reaches OpenGL with the CUDA backend (host-copy: for comparison).
    #[arg(long, value_enum, default_value_t = Transfer::Interop)]
    transfer: Transfer,
}

#[derive(clap::Args)]
struct ViewArgs {
    /// A preset name (`mpm scenes` lists them) or the path of a scene .toml file.
    #[arg(long, default_value = presets::DEFAULT, value_parser = scene_arg())]
    scene: String,
    #[arg(long, value_enum, default_value_t = BackendKind::Auto)]
    backend: BackendKind,
    #[command(flatten)]
    solver: SolverArgs,
    #[command(flatten)]
    method: MethodArgs,
    /// Turn vsync off (draw as fast as possible, or as --max-fps allows).
    #[arg(long)]
    no_vsync: bool,
    /// Draw at most this many frames a second (1 to 1000): without vsync, or on a display faster than
    /// the simulation needs, the draws leave the GPU to the stepping (a 60 Hz display's pace: 60).
    #[arg(long, value_name = "FPS", allow_negative_numbers = true, value_parser = max_fps)]
    max_fps: Option<u32>,
    /// Window size in physical pixels, WxH.
    #[arg(long, value_name = "WxH", default_value = "1600x900", value_parser = parse_size)]
    size: [u32; 2],
    #[command(flatten)]
    look: LookArgs,
    /// Step this many 60 Hz frames per drawn frame (1 to 60; for recording) instead of following wall
    /// time.
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = fixed_frames)]
    fixed_frames: Option<u32>,
    /// Directory for screenshots (P) and recordings (V).
    #[arg(long, value_name = "DIR", default_value = ".")]
    capture_dir: PathBuf,
    /// Quit after this many drawn frames (scripted runs, tests).
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = count::<1>)]
    quit_after: Option<u64>,
    /// On quitting, write the last frame to this PNG (must not exist).
    #[arg(long, value_name = "FILE")]
    final_screenshot: Option<PathBuf>,
    // Under a heading of their own, which says what ends the viewer's export.
    #[command(
        flatten,
        next_help_heading = "Export, as `mpm run` does (from the start; R, another scene, F9, E or \
                             closing the window ends it)"
    )]
    exports: ExportArgs,
    /// Replace existing exported frames instead of refusing.
    #[arg(long)]
    overwrite: bool,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// A preset name (`mpm scenes` lists them) or the path of a scene .toml file.
    #[arg(long, default_value = presets::DEFAULT, value_parser = scene_arg())]
    scene: String,
    /// Number of 60 Hz frames after the initial state (frame-00000.png is the initial state; at most
    /// 99999, the five digits of the names).
    #[arg(long, default_value_t = 120, allow_negative_numbers = true, value_parser = render_frames_count)]
    frames: u64,
    /// Directory for frame-NNNNN.png (created; existing frames are never overwritten).
    #[arg(long, value_name = "DIR", required_unless_present = "no_images")]
    out: Option<PathBuf>,
    /// Render and time the frames without writing images.
    #[arg(long, conflicts_with_all = ["out", "video"])]
    no_images: bool,
    /// Image size, WxH.
    #[arg(long, value_name = "WxH", default_value = "1280x720", value_parser = parse_size)]
    size: [u32; 2],
    #[arg(long, value_enum, default_value_t = BackendKind::Auto)]
    backend: BackendKind,
    #[command(flatten)]
    solver: SolverArgs,
    #[command(flatten)]
    method: MethodArgs,
    #[command(flatten)]
    look: LookArgs,
    /// Also encode the frames into this MP4 (needs ffmpeg on PATH).
    #[arg(long, value_name = "FILE")]
    video: Option<PathBuf>,
    /// Write the timings as JSON to this file as well.
    #[arg(long, value_name = "FILE")]
    timings: Option<PathBuf>,
}

/// A whole number of at least `MIN` (frames, steps), with a message that names the number: without
/// this, clap reads `--frames -1` as an unknown option `-1`.
fn count<const MIN: u64>(text: &str) -> Result<u64, String> {
    match text.trim().parse::<i128>() {
        Ok(n) if n >= i128::from(MIN) && n <= i128::from(u64::MAX) => Ok(n as u64),
        Ok(n) if n < i128::from(MIN) => Err(format!("{n} is too small: give a whole number from {MIN} up")),
        Ok(_) => Err(too_large(text, MIN)),
        // Digits alone, past what i128 holds, are a number too: too large, not "not a number".
        Err(_) if !text.trim().is_empty() && text.trim().bytes().all(|b| b.is_ascii_digit()) => {
            Err(too_large(text, MIN))
        }
        _ => Err(format!("`{text}` is not a whole number from {MIN} up")),
    }
}

fn too_large(text: &str, min: u64) -> String {
    format!(
        "{} is too large: give a whole number from {min} to {}",
        text.trim(),
        u64::MAX
    )
}

/// `--scene`: a preset name or a path. A scene's path is kept as text (in checkpoints, exports and
/// messages), so a path that is not UTF-8 is refused here, saying so, not with clap's generic
/// "invalid UTF-8" that names no option.
fn scene_arg() -> impl clap::builder::TypedValueParser<Value = String> {
    use clap::builder::TypedValueParser;
    clap::builder::OsStringValueParser::new().try_map(|path| {
        // clap's message shows the path, with � where its bytes are not UTF-8.
        path.into_string().map_err(|_| {
            "the path is not valid UTF-8 (the � marks where), and mpm keeps a scene's path as \
             text: rename the file or folder, or give a link to it with a UTF-8 name (`ln -s`)"
        })
    })
}

/// A positive, finite number (a length, a fraction).
fn positive(text: &str) -> Result<f32, String> {
    match text.trim().parse::<f32>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        Ok(x) => Err(format!("{x} is not a positive number: give a number above 0")),
        Err(_) => Err(format!("`{text}` is not a number: give a number above 0")),
    }
}

/// `bench --block-size`: what the CUDA kernels accept (they reduce per warp).
fn block_size(text: &str) -> Result<u32, String> {
    let n = count::<32>(text)?;
    if n > 1024 || n % 32 != 0 {
        return Err(format!(
            "{n} is not a multiple of 32 from 32 to 1024 (128 is the default)"
        ));
    }
    Ok(n as u32)
}

/// `render --frames`: the PNG names have five digits.
fn render_frames_count(text: &str) -> Result<u64, String> {
    let n = count::<0>(text)?;
    if n > 99_999 {
        return Err(format!(
            "{n} frames: `mpm render` writes at most 99999 after the initial state (frame-NNNNN.png)"
        ));
    }
    Ok(n)
}

/// `view --fixed-frames`: 60 Hz frames per drawn frame, 1 to 60 (a second of simulation per redraw).
fn fixed_frames(text: &str) -> Result<u32, String> {
    let n = count::<1>(text)?;
    if n > 60 {
        return Err(format!("{n} is too many: give 1 to 60 frames per drawn frame"));
    }
    Ok(n as u32)
}

/// `view --max-fps`: draws a second, 1 to 1000.
fn max_fps(text: &str) -> Result<u32, String> {
    let n = count::<1>(text)?;
    if n > 1000 {
        return Err(format!("{n} is too many: give 1 to 1000 draws a second"));
    }
    Ok(n as u32)
}

/// Bench step counts arrive as u64 (so that any number typed parses) and are used as usize.
fn steps(n: u64, flag: &str) -> Result<usize> {
    usize::try_from(n).map_err(|_| anyhow::anyhow!("--{flag} {n} is more than this machine can count"))
}

fn parse_size(text: &str) -> Result<[u32; 2], String> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{text}` is not a size; write WIDTHxHEIGHT, e.g. 1280x720"))?;
    let parse = |s: &str| s.trim().parse::<u32>().ok().filter(|&v| (1..=16384).contains(&v));
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok([w, h]),
        _ => Err(format!(
            "`{text}`: width and height must be whole numbers from 1 to 16384"
        )),
    }
}

fn view(args: ViewArgs) -> Result<()> {
    args.solver.refuse_processes("view")?;
    let mut scene = Scene::load(&args.scene)?;
    args.solver.apply(&mut scene, None);
    args.method.apply(&mut scene)?;
    // The exports are made after the viewer's own paths are checked and before the window opens:
    // every refusal comes first, as in `mpm run`. Their notes go to stderr, the viewer's log.
    let exports = |scene: &Scene| -> Result<Exports> {
        let exports = args.exports.build(scene, args.overwrite)?;
        for line in exports
            .removed_notes()
            .into_iter()
            .chain(exports.settings_lines())
        {
            eprintln!("{line}");
        }
        if !exports.is_empty() {
            mpm::export::remove_unfinished_on_interrupt()?;
        }
        Ok(exports)
    };
    let options = ViewerOptions {
        scene,
        backend: args.backend,
        vsync: !args.no_vsync,
        max_fps: args.max_fps,
        size: args.size,
        mode: args.look.draw,
        colouring: args.look.colour,
        particle_radius: args.look.particle_radius,
        full_res_smoothing: args.look.full_res_smoothing,
        transfer: args.look.transfer,
        fixed_frames: args.fixed_frames,
        capture_dir: args.capture_dir,
        quit_after: args.quit_after,
        final_screenshot: args.final_screenshot,
    };
    render::app::run(options, exports)
}

fn render_frames(args: RenderArgs) -> Result<()> {
    args.solver.refuse_processes("render")?;
    let mut scene = Scene::load(&args.scene)?;
    args.solver.apply(&mut scene, None);
    args.method.apply(&mut scene)?;
    if let Some(path) = &args.timings {
        anyhow::ensure!(
            !path.exists(),
            "{} exists already; not overwriting it",
            path.display()
        );
    }
    let report = render::offline::render(
        RenderOptions {
            scene,
            backend: args.backend,
            frames: args.frames,
            out: args.out,
            size: args.size,
            mode: args.look.draw,
            colouring: args.look.colour,
            particle_radius: args.look.particle_radius,
            full_res_smoothing: args.look.full_res_smoothing,
            transfer: args.look.transfer,
            video: args.video,
            progress: std::io::stdout().is_terminal(),
        },
        &mut std::io::stdout().lock(),
    )?;
    if let Some(path) = &args.timings {
        let json = serde_json::json!({
            "timings": report.timings,
            "transfer": report.path,
            "opengl": report.gl,
            "size": args.size,
            "draw": format!("{:?}", args.look.draw),
        });
        std::fs::write(path, format!("{json}\n")).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

#[derive(clap::Args)]
struct BenchArgs {
    /// Presets or scene files to time (repeatable); default: the report's bench-65k and bench-655k.
    #[arg(long = "scene", value_name = "PRESET|FILE")]
    scenes: Vec<String>,
    /// Instead of scenes: a column of this many particles (repeatable) in a --grid^3 grid, rounded
    /// to whole cells of 8.
    #[arg(long, value_name = "N", conflicts_with = "scenes", allow_negative_numbers = true,
          value_parser = count::<8>)]
    particles: Vec<u64>,
    /// Nodes per axis of the --particles columns' grid.
    #[arg(long, value_name = "NODES", default_value_t = 100, requires = "particles")]
    grid: u32,
    /// Substeps measured per scene (the report averaged 5000 frames: --steps 5000).
    #[arg(long, default_value_t = 1000, allow_negative_numbers = true, value_parser = count::<1>)]
    steps: u64,
    /// Substeps run and dropped before measuring.
    #[arg(long, default_value_t = 200, allow_negative_numbers = true, value_parser = count::<0>)]
    warmup: u64,
    /// The backend [default: auto: CUDA where a device works, else cpu-parallel].
    #[arg(long, value_enum, default_value_t = BackendKind::Auto, hide_default_value = true)]
    backend: BackendKind,
    /// CUDA threads per block (a multiple of 32, 32 to 1024); default MPM_CUDA_BLOCK_SIZE or 128.
    #[arg(long, value_name = "THREADS", allow_negative_numbers = true, value_parser = block_size)]
    block_size: Option<u32>,
    #[command(flatten)]
    solver: SolverArgs,
    /// Also time the single-thread CPU reference at bench-65k and print the GPU/CPU speed-up.
    #[arg(long)]
    cpu_baseline: bool,
    /// Substeps measured for the CPU baseline.
    #[arg(long, value_name = "N", default_value_t = 1000, allow_negative_numbers = true,
          value_parser = count::<1>)]
    cpu_steps: u64,
    /// Also run the scaling sweep: 65,536 particles up to --sweep-max, grid grown to keep the fill.
    #[arg(long)]
    sweep: bool,
    /// The sweep's largest particle count.
    #[arg(long, value_name = "N", default_value_t = 1 << 26)]
    sweep_max: u64,
    /// Substeps measured per sweep size.
    #[arg(long, value_name = "N", default_value_t = 100, allow_negative_numbers = true,
          value_parser = count::<1>)]
    sweep_steps: u64,
    /// Device memory bandwidth for the traffic floor, GB/s (default: the H200's HBM3e).
    #[arg(long, value_name = "GBS", default_value_t = bench::H200_PEAK_GBS)]
    peak_gbs: f64,
    /// Write every measurement as JSON to this file.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Replace an existing --json file instead of refusing.
    #[arg(long)]
    overwrite: bool,
}

fn bench(args: BenchArgs) -> Result<()> {
    let process = args.solver.process()?;
    if let Some(process) = process {
        backend::check_processes(args.backend, process.size)?;
    }
    // One table, one JSON: rank 0's; the others run the same benchmark silently beside it.
    let root = process.is_none_or(|p| p.rank == 0);
    anyhow::ensure!(
        !(args.sweep && args.solver.ranks(process).is_some_and(|n| n > 1)),
        "--sweep times one rank; run it without --ranks"
    );
    anyhow::ensure!(
        args.peak_gbs.is_finite() && args.peak_gbs > 0.0,
        "--peak-gbs {} must be a positive bandwidth in GB/s (4800 for an H200)",
        args.peak_gbs
    );
    if let (Some(path), true) = (&args.json, root) {
        check_output_file(path, "--json", args.overwrite)?;
    }
    // Before the backend is resolved: `auto` would announce timing the CPU, then refuse the ranks.
    backend::check_ranks(
        args.backend,
        args.solver.ranks(process).unwrap_or(1),
        args.solver.gpus().unwrap_or(1),
    )?;
    let scenes = if !args.particles.is_empty() {
        let scenes = args
            .particles
            .iter()
            .map(|&n| bench::column_scene(n, args.grid))
            .collect::<Result<Vec<_>>>()?;
        for (&asked, scene) in args.particles.iter().zip(&scenes) {
            if scene.num_particles as u64 != asked {
                eprintln!(
                    "note: --particles {asked}: the column is whole cells at 8 particles per cell, so \
                     it holds {} particles; timing those",
                    scene.num_particles
                );
            }
        }
        scenes
    } else if args.scenes.is_empty() {
        bench::REPORT_SCENES
            .iter()
            .map(|name| Scene::load(name).map_err(Into::into))
            .collect::<Result<Vec<_>>>()?
    } else {
        args.scenes
            .iter()
            .map(|name| Scene::load(name).map_err(Into::into))
            .collect::<Result<Vec<_>>>()?
    };
    let sweep = args.sweep.then(|| {
        let sizes: Vec<u64> = bench::SWEEP_PARTICLES
            .iter()
            .copied()
            .filter(|&n| n <= args.sweep_max)
            .collect();
        (sizes, args.sweep_steps)
    });
    let sweep = sweep
        .map(|(sizes, n)| steps(n, "sweep-steps").map(|n| (sizes, n)))
        .transpose()?;
    let backend = args.backend.resolve();
    if let (Some(block), false) = (args.block_size, backend == BackendKind::Cuda) {
        anyhow::bail!(
            "--block-size {block} sets the CUDA kernels' threads per block, and this benchmark times the \
             CPU ({}): drop --block-size",
            if backend == BackendKind::Cpu {
                "cpu"
            } else {
                "cpu-parallel"
            }
        );
    }
    let plan = bench::BenchPlan {
        command: std::env::args().collect::<Vec<_>>().join(" "),
        scenes,
        options: bench::PhaseBenchOptions {
            backend,
            warmup_steps: steps(args.warmup, "warmup")?,
            steps: steps(args.steps, "steps")?,
            block_size: args.block_size,
            phase_sample: None,
            scatter: args.solver.scatter,
            pipeline: args.solver.pipeline,
            ranks: args.solver.ranks(process),
            gpus: args.solver.gpus(),
            process,
            peak_gbs: args.peak_gbs,
        },
        cpu_baseline_steps: args.cpu_baseline.then_some(steps(args.cpu_steps, "cpu-steps")?),
        sweep,
    };
    let report = match root {
        true => bench::run(&plan, &mut std::io::stdout().lock())?,
        false => bench::run(&plan, &mut std::io::sink())?,
    };
    if let (Some(path), true) = (&args.json, root) {
        let text = serde_json::to_string_pretty(&report)?;
        std::fs::write(path, text + "\n")
            .map_err(|e| anyhow::anyhow!("cannot write {}: {}", path.display(), mpm::text::io_reason(&e)))?;
        writeln!(std::io::stdout(), "wrote {}", path.display())?;
    }
    Ok(())
}

/// `mpm devices`: what this machine offers a run on several GPUs. Missing pieces are reported, not
/// errors: the command answers the question "what is here".
fn devices() -> Result<()> {
    let mut out = std::io::stdout().lock();
    match mpm::cuda::library::devices() {
        Ok(devices) if devices.is_empty() => writeln!(out, "CUDA: the driver shows no device")?,
        Ok(devices) => {
            writeln!(
                out,
                "CUDA: {}",
                mpm::text::count(devices.len(), "device", "devices")
            )?;
            for d in &devices {
                let peers: Vec<String> = (0..devices.len())
                    .filter(|&j| j != d.ordinal)
                    .map(|j| format!("{j}: {}", if d.peer_access[j] { "yes" } else { "no" }))
                    .collect();
                writeln!(
                    out,
                    "  device {}: {}, {:.1} GiB{}",
                    d.ordinal,
                    d.name,
                    d.memory_bytes as f64 / f64::from(1u32 << 30),
                    if peers.is_empty() {
                        String::new()
                    } else {
                        format!(", peer access to {}", peers.join(", "))
                    }
                )?;
            }
        }
        Err(why) => writeln!(out, "CUDA: no usable device: {why:#}")?,
    }
    match mpm::dist::nccl::Nccl::get() {
        Ok(nccl) => writeln!(out, "NCCL: {} ({})", nccl.version_text(), nccl.path)?,
        Err(why) => writeln!(out, "NCCL: unavailable ({why:#})")?,
    }
    Ok(())
}

fn run(args: RunArgs) -> Result<()> {
    let started = std::time::Instant::now();
    // With a process per rank, rank 0 writes every output and every line; the others step their
    // ranks beside it.
    let process = args.solver.process()?;
    let root = process.is_none_or(|p| p.rank == 0);
    // A folder of checkpoints stands for its latest one: what a user resuming a run means.
    let resume = match args.resume.as_deref() {
        Some(dir) if dir.is_dir() => {
            let newest = mpm::checkpoint::newest_in(dir)?;
            if root {
                writeln!(
                    std::io::stdout(),
                    "--resume {}: a folder; resuming from its latest checkpoint, {}",
                    dir.display(),
                    newest.display()
                )?;
            }
            Some(newest)
        }
        path => path.map(PathBuf::from),
    };
    // The checkpoint is read and checked first: a bad file fails before anything is created. Its
    // particles stay in the file until it is known whether this process needs them all.
    let (resumed, in_file) = resume.as_deref().map(Checkpoint::open).transpose()?.unzip();
    let (mut scene, backend_kind) = match &resumed {
        Some(checkpoint) => (
            checkpoint.scene()?,
            args.backend.map_or_else(|| checkpoint.backend_kind(), Ok)?,
        ),
        None => (
            Scene::load(&args.scene)?,
            args.backend.unwrap_or(BackendKind::Auto),
        ),
    };
    args.solver.apply(&mut scene, process);
    args.method.apply(&mut scene)?;
    if let Some(process) = scene.process {
        backend::check_processes(backend_kind, process.size)?;
    }
    // A checkpoint's bodies dropped into its run are bodies too, which its scene file does not name
    // (the exporter checks the run's scene, which has them, again).
    let dropped = resumed.as_ref().map_or(0, |checkpoint| checkpoint.dropped.len());
    if args.exports.export_bodies.is_some() && dropped == 0 {
        mpm::export::bodies::check_scene(&scene)?;
    }
    // The simulation first: a backend that cannot run the scene (no GPU, a pipeline that refuses
    // it) fails before any output exists, so nothing is left behind to block the retry.
    let mut sim = match (&resumed, &in_file) {
        (Some(checkpoint), Some(particles)) => checkpoint.resume_from_file(scene, backend_kind, particles)?,
        _ => {
            let solver = backend::create(backend_kind, &scene)?;
            Simulation::new(scene, solver)
        }
    };
    if !root {
        let quiet = RunOptions::writing_nothing(args.frames, started);
        runner::run(&mut sim, quiet, &mut std::io::sink())?;
        return sim.solver_mut().finish();
    }
    // Then every output, before the first step, so a bad path fails at once, not after a long run.
    let scene = sim.scene();
    let exports = args.exports.build(scene, args.overwrite)?;
    let stats = args
        .stats
        .as_deref()
        .map(|path| StatsFile::create(path, args.overwrite))
        .transpose()?;
    let checkpoints = args
        .checkpoint
        .as_deref()
        .map(|dir| CheckpointSeries::new(dir, args.checkpoint_every, resumed.as_ref(), args.overwrite))
        .transpose()?;
    let checkpoints_note = checkpoints.as_ref().and_then(CheckpointSeries::removed_note);
    for note in exports.removed_notes().into_iter().chain(checkpoints_note) {
        writeln!(std::io::stdout(), "{note}")?;
    }
    mpm::export::remove_unfinished_on_interrupt()?;
    writeln!(
        std::io::stdout(),
        "scene {} ({}): {} particles{}, grid {}x{}x{}, dx = {} m, c0 = {:.2} m/s, backend {}{}",
        scene.name,
        scene.source,
        in_file
            .as_ref()
            .map_or(scene.num_particles as u64, |particles| particles.live()),
        if scene.flow.is_active() {
            format!(" (capacity {})", scene.slots())
        } else {
            String::new()
        },
        scene.grid_res[0],
        scene.grid_res[1],
        scene.grid_res[2],
        scene.dx,
        sim.params().materials[0].sound_speed(),
        sim.backend(),
        if let Some(process) = scene.process {
            let units = if sim.backend() == "cpu" { "ranks" } else { "GPUs" };
            format!(
                " on {} {units}, a process each ({})",
                process.size, process.launcher
            )
        } else if scene.gpus > 1 {
            format!(" on {} GPUs", scene.gpus)
        } else if scene.ranks > 1 {
            format!(" on {} ranks", scene.ranks)
        } else {
            String::new()
        }
    )?;
    for line in exports.settings_lines() {
        writeln!(std::io::stdout(), "{line}")?;
    }
    if let (Some(path), Some(checkpoint)) = (&resume, &resumed) {
        writeln!(
            std::io::stdout(),
            "resumed from {} at frame {}, t = {:.4} s",
            path.display(),
            checkpoint.clock.frame,
            checkpoint.clock.time
        )?;
    }
    let Exports {
        frames:
            FrameExportSet {
                ply,
                surface,
                volume,
                usd,
            },
        bodies,
    } = exports;
    let opts = RunOptions {
        frames: args.frames,
        export: ply,
        surface,
        volume,
        bodies,
        usd,
        stats,
        checkpoints,
        progress: std::io::stdout().is_terminal(),
        started,
    };
    runner::run(&mut sim, opts, &mut std::io::stdout().lock())?;
    sim.solver_mut().finish()
}

fn scenes(show: Option<Option<String>>, mesh: Option<String>) -> Result<()> {
    if let Some(file) = mesh {
        let text = presets::mesh(&file).with_context(|| {
            format!(
                "no preset uses a mesh named `{file}`; the presets' meshes are {}",
                presets::MESH_NAMES.join(", ")
            )
        })?;
        write!(std::io::stdout(), "{text}")?;
        return Ok(());
    }
    match show.flatten() {
        Some(name) => match presets::get(&name) {
            Some(text) => {
                write!(std::io::stdout(), "{text}")?;
                // A mesh the preset names is read beside the scene file: say how to save it there.
                for file in presets::MESH_NAMES.iter().filter(|f| text.contains(*f)) {
                    eprintln!(
                        "note: this scene reads the mesh {file} from the folder it is saved in: \
                         `mpm scenes --mesh {file} > {file}` writes it there"
                    );
                }
            }
            None => anyhow::bail!(
                "no preset named `{name}`; the presets are {}",
                presets::NAMES.join(", ")
            ),
        },
        None => {
            for name in presets::NAMES {
                let scene = Scene::load(name)?;
                writeln!(std::io::stdout(), "{}", presets::listing(name, &scene))?;
            }
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = match arguments() {
        Ok(args) => Cli::parse_from(args),
        Err(message) => {
            eprintln!("error: {message}");
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::View(args) => view(args),
        Command::Render(args) => render_frames(args),
        Command::Run(args) => run(args),
        Command::Bench(args) => bench(args),
        Command::Scenes { show, mesh } => scenes(show, mesh),
        Command::Devices => devices(),
    };
    mpm::text::exit_code(result)
}
