//! The `mpm` command line: nothing but argument parsing and dispatch.

use anyhow::Result;
use clap::{Parser, Subcommand};
use mpm::backend::{self, BackendKind};
use mpm::export::PlyExporter;
use mpm::runner::{self, RunOptions, StatsFile};
use mpm::sim::{presets, ScatterMode, Scene, Simulation};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "mpm",
    version,
    about = "Real-time MLS-MPM fluid: CUDA kernels, a CPU reference, headless runs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Step a scene headless, printing one line of statistics per 60 Hz frame.
    Run(RunArgs),
    /// List the built-in scenes, or print one as a TOML file to start your own from.
    Scenes {
        /// Print this preset's scene file.
        #[arg(long, value_name = "PRESET")]
        show: Option<String>,
    },
}

#[derive(clap::Args)]
struct RunArgs {
    /// A preset name (`mpm scenes` lists them) or the path of a scene .toml file.
    #[arg(long, default_value = presets::DEFAULT)]
    scene: String,
    /// Number of 60 Hz frames to simulate.
    #[arg(long, default_value_t = 60)]
    frames: u64,
    #[arg(long, value_enum, default_value_t = BackendKind::Auto)]
    backend: BackendKind,
    /// GPU scatter mode, overriding the scene's `solver.scatter`.
    #[arg(long, value_enum)]
    scatter: Option<ScatterMode>,
    /// Write one binary PLY per exported frame (frame 0 is the initial state) into this directory.
    #[arg(long, value_name = "DIR")]
    export: Option<PathBuf>,
    /// Export every K-th frame.
    #[arg(long, value_name = "K", default_value_t = 1, requires = "export")]
    every: u64,
    /// Also write the per-frame statistics as JSON lines to this file.
    #[arg(long, value_name = "FILE")]
    stats: Option<PathBuf>,
    /// Replace existing exported frames or stats file instead of refusing.
    #[arg(long)]
    overwrite: bool,
}

fn run(args: RunArgs) -> Result<()> {
    let mut scene = Scene::load(&args.scene)?;
    if let Some(scatter) = args.scatter {
        scene.scatter = scatter;
    }
    // Open every output before the first step, so a bad path fails at once, not after a long run.
    let export = args
        .export
        .as_deref()
        .map(|dir| PlyExporter::new(dir, args.every, args.overwrite))
        .transpose()?;
    let stats = args
        .stats
        .as_deref()
        .map(|path| StatsFile::create(path, args.overwrite))
        .transpose()?;
    let solver = backend::create(args.backend, &scene)?;
    println!(
        "scene {} ({}): {} particles, grid {}x{}x{}, dx = {} m, c0 = {:.2} m/s, backend {}",
        scene.name,
        scene.source,
        scene.num_particles,
        scene.grid_res[0],
        scene.grid_res[1],
        scene.grid_res[2],
        scene.dx,
        scene.material.sound_speed(),
        solver.name()
    );
    let mut sim = Simulation::new(scene, solver);
    let opts = RunOptions {
        frames: args.frames,
        export,
        stats,
        progress: std::io::stdout().is_terminal(),
    };
    runner::run(&mut sim, opts, &mut std::io::stdout().lock())?;
    Ok(())
}

fn scenes(show: Option<String>) -> Result<()> {
    match show {
        Some(name) => match presets::get(&name) {
            Some(text) => print!("{text}"),
            None => anyhow::bail!(
                "no preset named `{name}`; the presets are {}",
                presets::NAMES.join(", ")
            ),
        },
        None => {
            for name in presets::NAMES {
                let scene = Scene::load(name)?;
                println!(
                    "{name:<18} {:>9} particles  {}",
                    scene.num_particles, scene.description
                );
            }
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(args) => run(args),
        Command::Scenes { show } => scenes(show),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
