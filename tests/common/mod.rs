//! Helpers shared by the test files.
#![allow(dead_code)]

use mpm::sim::cpu::CpuSolver;
use mpm::sim::{Params, Particles, Scene};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

/// The `mpm` binary cargo built beside the tests; where they run elsewhere (the executables copied
/// to a GPU machine), `MPM_BIN` names it.
pub fn mpm_binary() -> std::path::PathBuf {
    std::env::var_os("MPM_BIN").map_or_else(|| env!("CARGO_BIN_EXE_mpm").into(), Into::into)
}

/// The `mpm` binary run with `args` to its end, without a display (no case may open a window).
pub fn mpm(args: &[&str]) -> std::process::Output {
    std::process::Command::new(mpm_binary())
        .args(args)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("running mpm")
}

/// `mpm run --backend cpu --scene SCENE --frames FRAMES` and then `extra`.
pub fn cpu_run(scene: &str, frames: &str, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["run", "--backend", "cpu", "--scene", scene, "--frames", frames];
    args.extend_from_slice(extra);
    mpm(&args)
}

/// A scene from inline TOML; panics with the validation message if the test wrote a bad one.
pub fn scene(toml: &str) -> Scene {
    Scene::from_toml(toml, "test scene").unwrap_or_else(|e| panic!("{e}"))
}

/// The CPU solver of a scene and its parameters with `dt` set.
pub fn cpu(scene: &Scene, dt: f32) -> (CpuSolver, Params) {
    let mut params = scene.params();
    params.dt = dt;
    (CpuSolver::new(scene.spawn(), scene.grid_res), params)
}

/// The scene's parameters with the substep its time-step policy takes at a signal speed of c0 + 2 m/s.
pub fn cfl_params(scene: &Scene) -> Params {
    let mut params = scene.params();
    let (_, dt) = scene
        .time_step
        .substeps(mpm::sim::FRAME_DT, scene.material().sound_speed() + 2.0, scene.dx)
        .unwrap();
    params.dt = dt;
    params
}

/// How far apart two runs' particles are, in dx: the largest distance and the root mean square.
pub fn position_gap(a: &[glam::Vec3], b: &[glam::Vec3], dx: f32) -> (f32, f64) {
    let errors: Vec<f32> = a.iter().zip(b).map(|(a, b)| (*a - *b).length() / dx).collect();
    let max = errors.iter().copied().fold(0.0, f32::max);
    let rms = (errors.iter().map(|e| f64::from(e * e)).sum::<f64>() / errors.len() as f64).sqrt();
    (max, rms)
}

/// The largest magnitude among `values` (0 for none).
pub fn max_abs(values: impl Iterator<Item = f32>) -> f32 {
    values.fold(0.0, |m, v| m.max(v.abs()))
}

/// The largest difference of any component between two sets of vectors.
pub fn max_diff_vec3(a: &[glam::Vec3], b: &[glam::Vec3]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0, f32::max)
}

/// The largest difference of any entry between two sets of matrices.
pub fn max_diff_mat3(a: &[glam::Mat3], b: &[glam::Mat3]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| max_abs((*x - *y).to_cols_array().into_iter()))
        .fold(0.0, f32::max)
}

/// The fraction of `image`'s pixels (RGBA) that `keep` picks.
pub fn pixel_fraction(image: &mpm::render::capture::Image, keep: impl Fn(&[u8]) -> bool) -> f64 {
    let picked = image.rgba.chunks_exact(4).filter(|p| keep(p)).count();
    picked as f64 / f64::from(image.width * image.height)
}

/// Water pixels: clearly blue (the surface's water colour, or the floor seen through it).
pub fn water_fraction(image: &mpm::render::capture::Image) -> f64 {
    pixel_fraction(image, |p| p[2] > 50 && i32::from(p[2]) > i32::from(p[0]) + 25)
}

/// The render tests' run: `frames` frames of the preset `scene` on `backend`, PNGs into `out`,
/// at 320 x 180 as spheres coloured by speed through interop, the rest at `mpm render`'s defaults.
/// A test sets what it is about with `RenderOptions { .., ..render_options(..) }`.
pub fn render_options(
    scene: &str,
    backend: mpm::backend::BackendKind,
    frames: u64,
    out: &std::path::Path,
) -> mpm::render::offline::RenderOptions {
    mpm::render::offline::RenderOptions {
        scene: Scene::load(scene).expect("preset"),
        backend,
        frames,
        out: Some(out.to_path_buf()),
        size: [320, 180],
        mode: mpm::render::DrawMode::Spheres,
        colouring: Some(mpm::render::Colouring::Speed),
        particle_radius: None,
        full_res_smoothing: false,
        transfer: mpm::render::Transfer::Interop,
        video: None,
        progress: false,
    }
}

/// `mpm render` with `options`; prints its log.
pub fn render_logged(options: mpm::render::offline::RenderOptions) -> mpm::render::offline::RenderReport {
    let mut log = Vec::new();
    let report = mpm::render::offline::render(options, &mut log).expect("render");
    println!("{}", String::from_utf8_lossy(&log));
    report
}

/// The surface's passes each took GPU time (timer queries), by name.
pub fn assert_surface_passes_timed(passes: &std::collections::BTreeMap<&'static str, f64>) {
    for pass in ["scene", "depth", "thickness", "smoothing", "shading", "legend"] {
        let ms = passes.get(pass).copied();
        assert!(
            ms.is_some_and(|ms| ms > 0.0),
            "no GPU time for the {pass} pass: {passes:?}"
        );
    }
}

/// `n` particles with random positions in `[lo, hi)` (m), velocities up to `speed` per component and
/// C entries up to `shear` (1/s).
pub fn random_particles(n: usize, lo: f32, hi: f32, speed: f32, shear: f32, seed: u64) -> Particles {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut r = |a: f32, b: f32| if a < b { rng.random_range(a..b) } else { a };
    let mut p = Particles::default();
    for _ in 0..n {
        p.x.push(glam::Vec3::new(r(lo, hi), r(lo, hi), r(lo, hi)));
        p.v.push(glam::Vec3::new(
            r(-speed, speed),
            r(-speed, speed),
            r(-speed, speed),
        ));
        let cols: [f32; 9] = std::array::from_fn(|_| r(-shear, shear));
        p.c.push(glam::Mat3::from_cols_array(&cols));
        p.rho.push(0.0);
        p.material.push(0);
        p.live.push(true);
    }
    p
}

/// The TOML of a tank of the tests' water (rest density 1000 kg/m^3, c0 = 10 m/s; the rest of the
/// material at its defaults), as a `&'static str`: `tank!([size], [resolution], body)` with the
/// domain's size in m and its resolution in nodes, the body (solver, time step, bodies) as TOML
/// after the material; `tank!("name", ...)` names the scene. One header for the scenes of every test
/// file, so they differ only where the scenes do.
macro_rules! tank {
    ($name:literal, $size:tt, $resolution:tt, $body:literal) => {
        concat!(
            "name = \"",
            $name,
            "\"\n",
            $crate::common::tank!($size, $resolution, $body)
        )
    };
    ($size:tt, $resolution:tt, $body:literal) => {
        concat!(
            "[domain]\nsize = ",
            stringify!($size),
            "\nresolution = ",
            stringify!($resolution),
            "\n[material]\nrest_density = 1000.0\nsound_speed = 10.0\n",
            $body
        )
    };
}
#[allow(unused_imports)]
pub(crate) use tank;

/// A water scene in a cube of `res` nodes at dx = 1 cm, with the given bodies and solver tables
/// appended (TOML).
pub fn water_box(res: u32, extra: &str) -> String {
    format!(
        r#"
[domain]
size = [{size}, {size}, {size}]
resolution = [{res}, {res}, {res}]

[material]
rest_density = 1000.0
sound_speed = 20.0
eos_power = 7.0
viscosity = 1.0e-3
pressure_floor = 0.0
{extra}
"#,
        size = f64::from(res) * 0.01
    )
}

/// A 40 x 30 x 20 cm tank at dx = 2 cm with a pool and a jet from the left wall, `capacity` particle
/// slots and `extra` TOML after the emitter (its `rate`, a sink: [`JET_TANK_DRAIN`]).
pub fn jet_tank(capacity: u64, extra: &str) -> String {
    format!(
        tank!(
            "jet-tank",
            [0.4, 0.3, 0.2],
            [20, 15, 10],
            r#"
[time_step]
cfl = 0.35
[particles]
capacity = {capacity}
[[block]]
min = [0.02, 0.02, 0.02]
max = [0.36, 0.08, 0.16]
[[emitter]]
shape = "disc"
center = [0.05, 0.2, 0.1]
normal = [1.0, 0.5, 0.0]
radius = 0.02
speed = 1.5
{extra}
"#
        ),
        capacity = capacity,
        extra = extra
    )
}

/// [`jet_tank`] of a yield-stress liquid regularised elastically, whose particles carry a
/// deformation: the emitters' checks of a deformation.
pub fn elastic_mud_jet() -> String {
    jet_tank(40_000, "").replace(
        "sound_speed = 10.0\n",
        "sound_speed = 10.0\nlaw = \"herschel-bulkley\"\nconsistency = 1.0\nyield_stress = 20.0\nshear_modulus = 2000.0\n",
    )
}

/// The nozzle speed, the nozzle's height and the pipe's length of [`piped_rope`], m/s and m.
pub const ROPE_SPEED: f32 = 0.05;
pub const ROPE_NOZZLE_Y: f32 = 0.27;
pub const ROPE_PIPE: f32 = 0.02;

/// A rope of 150 Pa s poured at [`ROPE_SPEED`] from a 3 cm nozzle at [`ROPE_NOZZLE_Y`] with a pipe of
/// `pipe_length` (0: none), in a tank of 30 x 60 x 30 cells of 5 mm.
pub fn piped_rope(pipe_length: f32) -> String {
    format!(
        "[domain]\nsize = [0.15, 0.3, 0.15]\nresolution = [30, 60, 30]\n\
         [material]\nrest_density = 1400.0\nsound_speed = 8.0\nviscosity = 150.0\n\
         [particles]\ncapacity = 20000\n\
         [[emitter]]\nshape = \"disc\"\ncenter = [0.075, {ROPE_NOZZLE_Y}, 0.075]\nnormal = [0.0, -1.0, 0.0]\n\
         radius = 0.015\nspeed = {ROPE_SPEED}\npipe_length = {pipe_length}\n"
    )
}

/// What [`piped_rope`] did: the particles well inside the pipe (every node of their stencils
/// driven), the worst of their velocities' differences from the nozzle's,
/// the fastest live particle's speed and the lowest one's height.
#[derive(Debug)]
pub struct Rope {
    pub inside: usize,
    pub worst_inside: f32,
    pub fastest: f32,
    pub lowest: f32,
}

pub fn rope(p: &Particles) -> Rope {
    // The cell (5 mm), the nozzle's axis and radius, and the stencil's reach (1.5 cells).
    let (dx, axis_xz, radius) = (0.005f32, 0.075f32, 0.015f32);
    let reach = 1.5 * dx;
    let live = || (0..p.len()).filter(|&i| p.live[i]);
    let axis = |i: usize| (p.x[i].x - axis_xz).hypot(p.x[i].z - axis_xz);
    let nozzle = glam::Vec3::new(0.0, -ROPE_SPEED, 0.0);
    // Off the pipe's far end and rim by a stencil's reach; below the nozzle's plane by half a cell
    // (the pipe begins a cell behind it).
    let inside: Vec<usize> = live()
        .filter(|&i| {
            let y = p.x[i].y;
            y > ROPE_NOZZLE_Y - ROPE_PIPE + reach
                && y < ROPE_NOZZLE_Y - 0.5 * dx
                && axis(i) < radius - reach - 0.5 * dx
        })
        .collect();
    Rope {
        inside: inside.len(),
        worst_inside: inside
            .iter()
            .map(|&i| (p.v[i] - nozzle).length())
            .fold(0.0, f32::max),
        fastest: live().map(|i| p.v[i].length()).fold(0.0, f32::max),
        lowest: live().map(|i| p.x[i].y).fold(f32::MAX, f32::min),
    }
}

/// A drain in the jet tank's floor, where the jet lands.
pub const JET_TANK_DRAIN: &str = r#"
[[sink]]
min = [0.28, 0.0, 0.06]
max = [0.34, 0.04, 0.14]
"#;

/// A steel log (a box 6 x 4 cm, 7800 kg/m^3, turned 10 degrees) thrown down at 4 m/s into a pool
/// 9 cm deep, in a quasi-2D tank 24 cm square and 5 cells thick at dx = 1 cm, fixed-point scatter:
/// it lands on the floor through the water in its third frame, and the particle backstop pushes
/// water out of it from then on, so its pending impulse sums are not zero between frames. 7560
/// particles, about 0.4 s a frame on the CPU reference. Its checkpoint tests (tests/checkpoint.rs,
/// tests/gpu_lifecycle.rs) and `--export-bodies` (tests/export.rs) run it.
pub fn log_thrown_into_a_pool() -> String {
    r#"name = "log-into-a-pool"
[domain]
size = [0.24, 0.24, 0.08]
resolution = [24, 24, 8]

[material]
rest_density = 1000.0
sound_speed = 10.0
viscosity = 1.0e-3

[solver]
scatter = "fixed-point"

[time_step]
cfl = 0.4

[[block]]
min = [0.01, 0.01, 0.01]
max = [0.22, 0.1, 0.06]

[[collider]]
shape = "box"
center = [0.12, 0.15, 0.035]
size = [0.06, 0.04, 0.048]
rotation = [0.0, 0.0, 10.0]
density = 7800.0
contact_friction = 0.0
motion.velocity = [0.0, -4.0, 0.0]
"#
    .to_string()
}

/// A block 10 x 8 x 8 cells (0.02 to 0.12 m along x) against the low x wall of a 0.4 m box at
/// dx = 2 cm, 8 particles per cell, no gravity, moving away from the wall at `speed` m/s.
pub fn block_leaving_the_low_x_wall(speed: f32) -> Scene {
    scene(&format!(
        tank!(
            [0.4, 0.4, 0.4],
            [20, 20, 20],
            r#"
[solver]
gravity = [0.0, 0.0, 0.0]
[time_step]
cfl = 0.35
[[block]]
min = [0.02, 0.12, 0.12]
max = [0.12, 0.28, 0.28]
velocity = [{speed}, 0.0, 0.0]
"#
        ),
        speed = speed
    ))
}

/// A block leaving the low x wall at 1 m/s ([`block_leaving_the_low_x_wall`], in `scene`'s pipeline
/// and scatter) keeps its speed over three 60 Hz frames (0.05 s) on `backend`, to 5 %: the mean x
/// velocity of the whole block and of its wall layer (the particles that started within one cell of
/// the wall). `what` names the case.
pub fn assert_block_keeps_its_speed(scene: &Scene, backend: mpm::backend::BackendKind, what: &str) {
    let scene = scene.clone();
    let start = scene.spawn();
    let solver = mpm::backend::create(backend, &scene).expect("backend");
    let mut sim = mpm::sim::Simulation::new(scene, solver);
    for _ in 0..3 {
        sim.advance_frame().expect("frame");
    }
    let p = sim.solver_mut().read_particles().expect("particles");
    let mean = |keep: &dyn Fn(usize) -> bool| {
        let v: Vec<f32> = (0..p.len()).filter(|&i| keep(i)).map(|i| p.v[i].x).collect();
        v.iter().sum::<f32>() / v.len() as f32
    };
    let (mean, wall_layer) = (mean(&|_| true), mean(&|i| start.x[i].x < 0.04));
    println!("{what}: mean vx {mean:.4} m/s, wall layer {wall_layer:.4} m/s (1 m/s at the start)");
    assert!(
        (mean - 1.0).abs() < 0.05,
        "{what}: the block slowed to {mean} m/s"
    );
    assert!(
        (wall_layer - 1.0).abs() < 0.05,
        "{what}: the wall layer slowed to {wall_layer} m/s"
    );
}

/// A 48 x 24 x 24 tank, the water in its low x third: slabs cut across x, the surge crosses their
/// bounds and the counts start far out of balance (the ranks' tests).
pub const STIRRED_TANK: &str = tank!(
    [1.5, 0.75, 0.75],
    [48, 24, 24],
    r#"
[[block]]
min = [0.03125, 0.03125, 0.03125]
max = [0.5, 0.5, 0.6]
"#
);

/// [`STIRRED_TANK`]'s block as water (x below 0.25 m) and oil (800 kg/m^3) side by side.
pub const STIRRED_LIQUIDS: &str = r#"
[domain]
size = [1.5, 0.75, 0.75]
resolution = [48, 24, 24]
[[material]]
name = "water"
rest_density = 1000.0
sound_speed = 10.0
[[material]]
name = "oil"
rest_density = 800.0
sound_speed = 10.0
[[block]]
material = "water"
min = [0.03125, 0.03125, 0.03125]
max = [0.25, 0.5, 0.6]
[[block]]
material = "oil"
min = [0.25, 0.03125, 0.03125]
max = [0.5, 0.5, 0.6]
"#;

/// [`STIRRED_TANK`]'s block as four materials side by side along x, the axis the ranks cut: water,
/// a jelly (fixed-corotated), snow and sand, in fixed point. Each solid's deformation crosses the
/// cuts with its particles; the rest densities differ, so the grid's volume crosses them too.
pub const STIRRED_SOLIDS: &str = r#"
[domain]
size = [1.5, 0.75, 0.75]
resolution = [48, 24, 24]
[solver]
scatter = "fixed-point"
[[material]]
name = "water"
rest_density = 1000.0
sound_speed = 10.0
[[material]]
name = "jelly"
law = "fixed-corotated"
rest_density = 1000.0
youngs_modulus = 1.0e5
poisson_ratio = 0.3
[[material]]
name = "snow"
law = "snow"
rest_density = 400.0
youngs_modulus = 1.4e5
poisson_ratio = 0.2
[[material]]
name = "sand"
law = "sand"
rest_density = 1600.0
youngs_modulus = 3.5e5
poisson_ratio = 0.3
friction_angle = 30.0
[[block]]
material = "water"
min = [0.03125, 0.03125, 0.03125]
max = [0.15, 0.5, 0.6]
[[block]]
material = "jelly"
min = [0.15, 0.03125, 0.03125]
max = [0.28, 0.5, 0.6]
[[block]]
material = "snow"
min = [0.28, 0.03125, 0.03125]
max = [0.4, 0.5, 0.6]
[[block]]
material = "sand"
min = [0.4, 0.03125, 0.03125]
max = [0.5, 0.5, 0.6]
"#;

/// [`cfl_params`] at the step of `scene`'s fastest material (a solid's P wave): the step a scene of
/// several materials needs.
pub fn cfl_params_of_fastest(scene: &Scene) -> Params {
    let mut params = scene.params();
    let fastest = scene
        .materials
        .iter()
        .map(|m| m.law.sound_speed())
        .fold(0.0, f32::max);
    let (_, dt) = scene
        .time_step
        .substeps(mpm::sim::FRAME_DT, fastest + 2.0, scene.dx)
        .unwrap();
    params.dt = dt;
    params
}

/// [`STIRRED_TANK`] in fixed point with a box moving across it at x 0.2 to 0.3 m, where the first
/// rebin of two ranks puts the cut.
pub fn stirred_tank_with_moving_box() -> String {
    format!(
        r#"{STIRRED_TANK}
[solver]
scatter = "fixed-point"
[[collider]]
shape = "box"
center = [0.25, 0.12, 0.375]
size = [0.1, 0.24, 0.2]
[collider.motion]
velocity = [0.0, 0.0, 0.3]
"#
    )
}

/// The spawn with random velocities (up to 2 m/s), so particles cross slab bounds both ways from
/// the first substeps.
pub fn stirred(scene: &Scene) -> Particles {
    let mut p = scene.spawn();
    let noise = random_particles(p.len(), 0.0, 1.0, 2.0, 5.0, 11);
    p.v.copy_from_slice(&noise.v);
    p
}

/// Every slot's x, v, C, density and material row, and its deformation where the particles carry
/// one, as bits, slot by slot.
pub fn particle_bits(p: &Particles) -> Vec<u32> {
    let mut bits = Vec::new();
    for i in 0..p.len() {
        bits.extend(p.x[i].to_array().map(f32::to_bits));
        bits.extend(p.v[i].to_array().map(f32::to_bits));
        if let Some(c) = p.c.get(i) {
            bits.extend(c.to_cols_array().map(f32::to_bits));
        }
        bits.push(p.rho[i].to_bits());
        bits.push(u32::from(p.material[i]));
        if let Some(d) = p.deformation.get(i) {
            bits.extend(d.f.to_cols_array().map(f32::to_bits));
            bits.push(d.plastic.to_bits());
        }
    }
    bits
}

/// Two particle sets are the same state: every slot's x, v, C, density, liveness and deformation, bit for bit.
pub fn same_particles(a: &Particles, b: &Particles) -> bool {
    particle_bits(a) == particle_bits(b) && a.live == b.live
}

/// Through the command line on `backend`: the fixed-point coarse dam break for 10 frames on one
/// rank, against 5 frames split by `split` (`--ranks 2`, `--gpus 2`) checkpointed and resumed on 3
/// ranks of one device for 5 more; the PLY files of frames 5 and 10 must be the same bytes (a
/// checkpoint resumes on any rank count).
pub fn ranks_checkpoint_resumes_on_another_rank_count(backend: &str, split: &[&str]) {
    split_checkpoint_resumes_on_three_ranks(backend, split, 1);
}

/// As [`ranks_checkpoint_resumes_on_another_rank_count`], the split run launched as `processes`
/// processes (`launch_processes`) with `split` (`--processes`); each process's output is returned,
/// in rank order.
pub fn split_checkpoint_resumes_on_three_ranks(
    backend: &str,
    split: &[&str],
    processes: usize,
) -> Vec<String> {
    scene_split_resumes_on_three_ranks("dam-break-coarse", backend, split, processes)
}

/// As [`split_checkpoint_resumes_on_three_ranks`], of `scene` (a preset or a file).
pub fn scene_split_resumes_on_three_ranks(
    scene: &str,
    backend: &str,
    split: &[&str],
    processes: usize,
) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    let command = |args: &[&str]| {
        let mut command = std::process::Command::new(mpm_binary());
        command
            .current_dir(dir.path())
            .args(["run", "--backend", backend, "--scatter", "fixed-point"])
            .args(args);
        command
    };
    let run = |args: &[&str]| {
        let out = command(args).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "mpm run {args:?}: {text}");
        text
    };
    run(&["--scene", scene, "--frames", "10", "--export", "whole"]);
    let first: Vec<&str> = [
        "--scene",
        scene,
        "--frames",
        "5",
        "--checkpoint",
        "ck",
        "--checkpoint-every",
        "5",
        "--export",
        "split",
    ]
    .into_iter()
    .chain(split.iter().copied())
    .collect();
    let split_output = match processes {
        1 => vec![run(&first)],
        n => {
            let outputs = wait_for_processes(launch_processes(dir.path(), n, &mut || command(&first)));
            for (rank, (ok, text)) in outputs.iter().enumerate() {
                assert!(ok, "rank {rank} of mpm run {first:?}: {text}");
            }
            outputs.into_iter().map(|(_, text)| text).collect()
        }
    };
    let resumed = run(&[
        "--resume",
        "ck/checkpoint_000005.mpmck",
        "--ranks",
        "3",
        "--frames",
        "5",
        "--export",
        "resumed",
    ]);
    assert!(resumed.contains("on 3 ranks"), "{resumed}");
    let read = |path: &str| std::fs::read(dir.path().join(path)).unwrap();
    assert!(
        read("whole/frame_000005.ply") == read("split/frame_000005.ply"),
        "frame 5 on {split:?} differs from one rank's"
    );
    assert!(
        read("whole/frame_000010.ply") == read("resumed/frame_000010.ply"),
        "frame 10 resumed on 3 ranks from {split:?} differs from one rank's"
    );
    split_output
}

/// `fountain` (a jet into a basin with a floor drain) split as `split` says, in `processes`
/// processes: the sinks drain on the ranks, each nozzle point looks at its last particle wherever it
/// is, and each emitted particle goes to the rank whose slab holds it, so frame 5 is one rank's bytes,
/// with particles both emitted and drained by then; the checkpoint (its free slots and nozzle points
/// included) resumes on 3 ranks to one rank's bytes at frame 10. Each process's output.
pub fn fountain_on_ranks_gives_one_rank_s_bytes(
    backend: &str,
    split: &[&str],
    processes: usize,
) -> Vec<String> {
    let out = scene_split_resumes_on_three_ranks("fountain", backend, split, processes);
    let last = out[0]
        .lines()
        .rfind(|line| line.contains("emitted="))
        .unwrap_or_else(|| panic!("no frame line with the flow's counts: {}", out[0]));
    let count = |key: &str| -> u64 {
        let at = last.find(key).unwrap() + key.len();
        last[at..].split_whitespace().next().unwrap().parse().unwrap()
    };
    assert!(
        count("emitted=") > 0 && count("drained=") > 0,
        "nothing emitted or drained by frame 5: {last}"
    );
    out
}

/// One rank's checkpoint of the fixed-point coarse dam break resumed by `processes` processes (each
/// reads the file and keeps its share; the CUDA processes read only theirs from it): frame 8 is one
/// rank's bytes, and only rank 0 prints (which checkpoint it resumed).
pub fn processes_resume_one_rank_s_checkpoint_to_its_bytes(backend: &str, processes: usize) {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let out = std::process::Command::new(mpm_binary())
            .current_dir(dir.path())
            .args([
                "run",
                "--backend",
                backend,
                "--scatter",
                "fixed-point",
                "--scene",
                "dam-break-coarse",
            ])
            .args(args)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    };
    run(&["--frames", "8", "--export", "whole"]);
    run(&["--frames", "4", "--checkpoint", "ck", "--checkpoint-every", "4"]);
    let mut resume = || {
        let mut command = std::process::Command::new(mpm_binary());
        command.current_dir(dir.path()).args([
            "run",
            "--backend",
            backend,
            "--resume",
            "ck",
            "--frames",
            "4",
            "--export",
            "resumed",
            "--processes",
        ]);
        command
    };
    let outputs = wait_for_processes(launch_processes(dir.path(), processes, &mut resume));
    for (rank, (ok, text)) in outputs.iter().enumerate() {
        assert!(ok, "rank {rank}: {text}");
    }
    assert!(
        outputs[0].1.contains("resuming from its latest checkpoint"),
        "{}",
        outputs[0].1
    );
    for (rank, (_, text)) in outputs.iter().enumerate().skip(1) {
        assert!(text.is_empty(), "rank {rank} wrote lines of its own: {text}");
    }
    let read = |path: &str| std::fs::read(dir.path().join(path)).unwrap();
    assert!(
        read("whole/frame_000008.ply") == read("resumed/frame_000008.ply"),
        "frame 8 resumed by {processes} processes differs from one rank's"
    );
}

/// `n` processes of `command`, started as torch's launcher starts them (`RANK`, `WORLD_SIZE`,
/// `LOCAL_RANK`), meeting in `dir` under a name of their own (`MPM_RENDEZVOUS`, `MPM_RUN_ID`).
pub fn launch_processes(
    dir: &std::path::Path,
    n: usize,
    command: &mut dyn FnMut() -> std::process::Command,
) -> Vec<Launched> {
    static LAUNCHES: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let launch = LAUNCHES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let run_id = format!("test-{}-{launch}", std::process::id());
    (0..n)
        .map(|rank| {
            command()
                .env("RANK", rank.to_string())
                .env("WORLD_SIZE", n.to_string())
                .env("LOCAL_RANK", rank.to_string())
                .env("MPM_RENDEZVOUS", dir)
                .env("MPM_RUN_ID", &run_id)
                .stdout(std::fs::File::create(dir.join(format!("{run_id}.rank{rank}.out"))).unwrap())
                .stderr(std::fs::File::create(dir.join(format!("{run_id}.rank{rank}.err"))).unwrap())
                .spawn()
                .map(|child| Launched {
                    child,
                    dir: dir.to_path_buf(),
                    name: format!("{run_id}.rank{rank}"),
                })
                .unwrap()
        })
        .collect()
}

/// A process `launch_processes` started, its output going to files beside the run (a pipe nobody
/// drains would stop it once full).
pub struct Launched {
    pub child: std::process::Child,
    dir: std::path::PathBuf,
    name: String,
}

impl Launched {
    /// What it wrote so far, stdout then stderr.
    pub fn output(&self) -> String {
        let read = |ext: &str| {
            std::fs::read_to_string(self.dir.join(format!("{}.{ext}", self.name))).unwrap_or_default()
        };
        read("out") + &read("err")
    }
}

/// Each process's success and output (stdout, then stderr), in rank order.
pub fn wait_for_processes(launched: Vec<Launched>) -> Vec<(bool, String)> {
    launched
        .into_iter()
        .map(|mut launched| {
            let status = launched.child.wait().unwrap();
            (status.success(), launched.output())
        })
        .collect()
}

/// `steps` substeps of `scene` at `params` on the CPU reference and the GPU (its fused pipeline
/// unless the scene names another), held together every 100: positions within 0.1 dx, 0.01 dx rms
/// (the bound of tests/gpu_kernels.rs: rounding differences grow along the trajectory; a wrong term
/// moves particles by whole cells), every particle keeping its material, densities within 1e-3, and
/// a deformation where the particles carry one within 1e-3 of the CPU's (a strain of 1e-3; a wrong
/// term is a strain of the order of the motion's). Some particle must have moved `moved_dx` cells.
/// Returns the GPU's particles.
pub fn follow_cpu(scene: &Scene, params: &Params, steps: usize, moved_dx: f32, what: &str) -> Particles {
    use mpm::cuda::{CudaOptions, CudaSolver};
    use mpm::sim::Solver;
    let mut cpu = CpuSolver::new(scene.spawn(), scene.grid_res);
    let mut gpu = CudaSolver::new(scene, CudaOptions::default()).unwrap();
    for step in 1..=steps {
        cpu.step(params).unwrap();
        gpu.step(params).unwrap();
        if step % 100 == 0 {
            let p = gpu.read_particles().unwrap();
            let (max, rms) = position_gap(&p.x, &cpu.particles.x, scene.dx);
            assert!(
                max <= 0.1 && rms <= 0.01,
                "{what} step {step}: max {max} dx, rms {rms} dx"
            );
            assert_eq!(p.material, cpu.particles.material, "{what}: materials differ");
            assert_eq!(
                p.deformation.len(),
                cpu.particles.deformation.len(),
                "{what}: deformations"
            );
            let strain = p
                .deformation
                .iter()
                .zip(&cpu.particles.deformation)
                .map(|(a, b)| {
                    (a.f - b.f)
                        .abs()
                        .to_cols_array()
                        .into_iter()
                        .fold(0.0f32, f32::max)
                })
                .fold(0.0f32, f32::max);
            println!(
                "{what} step {step}: position error max {max:.3e} dx, rms {rms:.3e} dx; F {strain:.2e} apart"
            );
            assert!(
                strain <= 1e-3,
                "{what} step {step}: deformation gradients {strain} apart"
            );
            let (worst, worst_rho) = p
                .rho
                .iter()
                .zip(&cpu.particles.rho)
                .map(|(a, b)| (a - b).abs() / b)
                .enumerate()
                .fold((0, 0.0f32), |w, (n, e)| if e > w.1 { (n, e) } else { w });
            assert!(
                worst_rho <= 1e-3,
                "{what} step {step}: densities {worst_rho} apart, particle {worst} of row {}: GPU {} against \
                 CPU {} kg/m^3, at {} (CPU {}) m moving at {} m/s",
                p.material[worst],
                p.rho[worst],
                cpu.particles.rho[worst],
                p.x[worst],
                cpu.particles.x[worst],
                cpu.particles.v[worst].length()
            );
        }
    }
    let moved = max_diff_vec3(&cpu.particles.x, &scene.spawn().x) / scene.dx;
    assert!(
        moved > moved_dx,
        "{what}: nothing moved {moved_dx} dx ({moved} dx at most)"
    );
    gpu.read_particles().unwrap()
}

/// python3 with `.ci-cache/python` (where `.ci/run` pip-installs meshio and usd-core) ahead on its
/// path.
pub fn ci_python() -> std::process::Command {
    let ci_packages = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(".ci-cache/python");
    let mut path =
        std::env::split_paths(&std::env::var_os("PYTHONPATH").unwrap_or_default()).collect::<Vec<_>>();
    path.insert(0, ci_packages);
    let mut python = std::process::Command::new("python3");
    python.env("PYTHONPATH", std::env::join_paths(path).expect("a PYTHONPATH"));
    python
}

/// Whether [`ci_python`] runs `import` (a Python import statement); if not, why, naming
/// `pip_package` as the fix.
pub fn ci_python_imports(import: &str, pip_package: &str) -> Result<(), String> {
    match ci_python().args(["-c", import]).output() {
        Ok(out) if out.status.success() => Ok(()),
        Ok(out) => Err(format!(
            "python3 cannot run `{import}` (pip install {pip_package}): {}",
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or_default()
        )),
        Err(e) => Err(format!("no python3: {e}")),
    }
}

/// The stderr of an `mpm` run with `args` that must have been refused before its first step: it
/// failed, printed no frame line and did not panic.
pub fn refused_before_stepping(out: std::process::Output, args: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(!out.status.success(), "{args:?} accepted:\n{stdout}\n{stderr}");
    assert!(
        !stdout.contains("frame "),
        "{args:?}: refused only after stepping:\n{stdout}"
    );
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    stderr
}

/// The slope of the least-squares line through `points` (x, y).
pub fn fitted_slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (sx, sy) = points.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
    let (sxx, sxy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), p| (a + p.0 * p.0, b + p.0 * p.1));
    (n * sxy - sx * sy) / (n * sxx - sx * sx)
}

/// A run on `backend` of two processes (the coarse dam break, a checkpoint every 2 frames) whose
/// rank 1 gets signal `signal` (`KILL`: it dies; `STOP`: it hangs) after rank 0's second
/// checkpoint: rank 0 must stop within 30 s, failing, its error naming rank 1, and its latest
/// checkpoint must resume. Returns how long rank 0 took to stop, in seconds.
pub fn a_failed_process_stops_the_run(backend: &str, signal: &str) -> f64 {
    use std::time::{Duration, Instant};
    let dir = tempfile::tempdir().unwrap();
    let mut command = || {
        let mut command = std::process::Command::new(mpm_binary());
        command.current_dir(dir.path()).args([
            "run",
            "--backend",
            backend,
            "--scene",
            "dam-break-coarse",
            "--frames",
            "100000",
            "--processes",
            "--checkpoint",
            "ck",
            "--checkpoint-every",
            "2",
        ]);
        command
    };
    let mut launched = launch_processes(dir.path(), 2, &mut command);
    let started = Instant::now();
    let checkpoints = || std::fs::read_dir(dir.path().join("ck")).map_or(0, |d| d.count());
    while checkpoints() < 2 {
        assert!(
            started.elapsed() < Duration::from_secs(180),
            "no second checkpoint after 180 s: {}",
            launched[0].output()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let signalled = std::process::Command::new("kill")
        .args(["-s", signal, &launched[1].child.id().to_string()])
        .status()
        .unwrap();
    assert!(signalled.success(), "kill -s {signal} failed");
    let hit = Instant::now();
    let status = loop {
        if let Some(status) = launched[0].child.try_wait().unwrap() {
            break status;
        }
        if hit.elapsed() > Duration::from_secs(30) {
            let _ = launched[0].child.kill();
            let _ = launched[1].child.kill();
            panic!(
                "rank 0 still ran 30 s after rank 1 got SIG{signal}: {}",
                launched[0].output()
            );
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let took = hit.elapsed().as_secs_f64();
    // A stopped process is still there: end it.
    launched[1].child.kill().unwrap();
    launched[1].child.wait().unwrap();
    let text = launched[0].output();
    assert!(
        !status.success(),
        "rank 0 ended well after rank 1 got SIG{signal}: {text}"
    );
    assert!(
        text.contains("rank 1"),
        "rank 0's error does not name rank 1: {text}"
    );
    let resumed = std::process::Command::new(mpm_binary())
        .current_dir(dir.path())
        .args(["run", "--backend", backend, "--resume", "ck", "--frames", "1"])
        .output()
        .unwrap();
    let resumed_text =
        String::from_utf8_lossy(&resumed.stdout).to_string() + &String::from_utf8_lossy(&resumed.stderr);
    assert!(
        resumed.status.success(),
        "the latest checkpoint does not resume: {resumed_text}"
    );
    took
}
