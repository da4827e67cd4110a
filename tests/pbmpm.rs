//! The position-based solver (`solver.method = "pbmpm"`, src/sim/pbmpm.rs) on the CPU: stable at
//! one substep a frame where the explicit solver would need hundreds (a liquid fired at a wall at
//! 50 m/s, a jelly crushed on the floor), the volume of a liquid at rest, the dam break's surge
//! front against Martin & Moyce (1952) for 1, 2, 4 and 8 iterations, runs byte for byte
//! reproducible, and the scene keys' and backends' refusals. Each case is coarse and quasi-2D
//! (a slab a few cells thick) for CI's two cores; each prints what it measured (`cargo test
//! --release --test pbmpm -- --nocapture`, lines starting RESULT).

mod common;

use mpm::backend::{self, BackendKind};
use mpm::sim::{Particles, Scene, Simulation};
use std::time::Instant;

fn simulation(scene: &Scene) -> Simulation {
    Simulation::new(
        scene.clone(),
        backend::create(BackendKind::Cpu, scene).expect("the pbmpm solver"),
    )
}

fn particles(sim: &mut Simulation) -> Particles {
    sim.solver_mut().read_particles().unwrap()
}

/// Every particle finite and inside the fluid region, and as many as at the start.
fn assert_sound(scene: &Scene, p: &Particles, count: usize, when: &str) {
    let (lo, hi) = scene.fluid_region();
    let (lo, hi) = (lo.as_vec3(), hi.as_vec3());
    let eps = 1e-5;
    assert_eq!(p.num_live(), count, "{when}: particles lost");
    for i in 0..p.len() {
        let (x, v, c) = (p.x[i], p.v[i], p.c[i]);
        assert!(
            x.is_finite() && v.is_finite() && c.is_finite() && p.rho[i].is_finite(),
            "{when}: particle {i} is not finite: x {x:?} v {v:?}"
        );
        assert!(
            x.cmpge(lo - eps).all() && x.cmple(hi + eps).all(),
            "{when}: particle {i} at {x:?} left the fluid region {lo:?} to {hi:?}"
        );
        if let Some(d) = p.deformation.get(i) {
            assert!(
                d.f.is_finite() && d.plastic.is_finite(),
                "{when}: particle {i}'s F"
            );
        }
    }
}

/// Runs `frames` frames, checking the particles after each ([`assert_sound`]); returns the largest
/// speed seen.
fn run_sound(scene: &Scene, frames: u64) -> f32 {
    let mut sim = simulation(scene);
    let count = scene.num_particles;
    let mut fastest = 0.0f32;
    for frame in 1..=frames {
        let stats = sim.advance_frame().expect("a frame");
        fastest = fastest.max(stats.summary.max_speed);
        assert_sound(scene, &particles(&mut sim), count, &format!("frame {frame}"));
    }
    fastest
}

/// A 20 x 10 x 8 cm block of water fired at +50 m/s at the far wall of a 1.2 m tank, one substep a
/// 60 Hz frame (0.83 m a substep, 42 cells), four iterations: a second of it stays finite, inside
/// the tank, with every particle. (The explicit solver would need dt <= 0.5 dx / (c0 + 50 m/s).)
#[test]
fn a_liquid_fired_at_a_wall_at_50_m_s_stays_whole_at_one_substep_a_frame() {
    let start = Instant::now();
    let scene = common::scene(
        "[domain]\nsize = [1.2, 0.3, 0.16]\nresolution = [60, 15, 8]\n\
         [material]\nrest_density = 1000.0\nviscosity = 1.0e-3\n\
         [solver]\nmethod = \"pbmpm\"\niterations = 4\n\
         [time_step]\nsubsteps = 1\n\
         [[block]]\nmin = [0.3, 0.04, 0.02]\nmax = [0.5, 0.14, 0.12]\nvelocity = [50.0, 0.0, 0.0]\n",
    );
    let fastest = run_sound(&scene, 60);
    println!(
        "RESULT pbmpm liquid at 50 m/s into a wall: {} particles whole and inside over 60 frames at 1 substep, \
         largest speed {fastest:.1} m/s ({:.1} s)",
        scene.num_particles,
        start.elapsed().as_secs_f32()
    );
}

/// A 12 x 12 x 10 cm jelly block (E = 100 kPa, nu = 0.3) thrown down at 30 m/s onto the floor from 10 cm
/// above it, one substep a frame (0.5 m a substep, four times its fall), four iterations: crushed
/// flat in the first substep, it stays finite, inside the tank and whole for a second.
#[test]
fn a_jelly_crushed_on_the_floor_stays_whole_at_one_substep_a_frame() {
    let start = Instant::now();
    let scene = common::scene(
        "[domain]\nsize = [0.6, 0.4, 0.16]\nresolution = [30, 20, 8]\n\
         [material]\nlaw = \"fixed-corotated\"\nrest_density = 1000.0\nyoungs_modulus = 1.0e5\npoisson_ratio = 0.3\n\
         [solver]\nmethod = \"pbmpm\"\niterations = 4\n\
         [time_step]\nsubsteps = 1\n\
         [[block]]\nmin = [0.24, 0.12, 0.02]\nmax = [0.36, 0.24, 0.12]\nvelocity = [0.0, -30.0, 0.0]\n",
    );
    let fastest = run_sound(&scene, 60);
    println!(
        "RESULT pbmpm jelly thrown at the floor at 30 m/s: {} particles whole and inside over 60 frames at 1 \
         substep, largest speed {fastest:.1} m/s ({:.1} s)",
        scene.num_particles,
        start.elapsed().as_secs_f32()
    );
}

/// The pool's height above the floor's plane, m: the 98th percentile of its particles' heights (the
/// free surface, without the odd particle above it). Its walls hold it on every side, so its volume
/// is its height times their span.
fn pool_height(scene: &Scene, p: &Particles) -> f64 {
    let mut y: Vec<f32> = p.x.iter().map(|x| x.y).collect();
    y.sort_by(f32::total_cmp);
    let (floor, _) = scene.fluid_region();
    f64::from(y[(y.len() * 98) / 100]) - floor.y
}

/// The mean of the particles' own volume ratio J = rho0 / rho.
fn mean_j(scene: &Scene, p: &Particles) -> f64 {
    let rho0 = f64::from(scene.material().rest_density);
    p.rho.iter().map(|&r| rho0 / f64::from(r)).sum::<f64>() / p.len() as f64
}

/// The pool's volume by its height ([`pool_height`]) and by its particles' mean J, each relative
/// to the start.
#[derive(Clone, Copy, Debug)]
struct PoolVolume {
    height: f64,
    mean_j: f64,
}

/// A pool of water 34 x 10 x 10 cm (five cells deep at 2 cm) at rest for 10 s at two substeps a
/// frame and four iterations. The bound: its volume within 1 % of the start at 10 s, by its
/// height and by its mean J; and here also every second from 5 s on.
///
/// Under its own weight the pool first settles compressed (the iterations alone carry its load only
/// so compressed: about 12 % at this depth without the liquids' volume memory), about 3 % at 1 s;
/// then its particles' volume bias takes the load over and the pool recovers its volume within 1 %
/// by about 4 s (docs/physics.md, "Position-based MPM"). Prints every second's.
#[test]
fn a_pool_at_rest_keeps_its_volume_within_1_percent_over_10_s() {
    let seconds = pool_volumes(4);
    for (second, volume) in seconds.iter().enumerate().skip(4) {
        for (what, change) in [("height", volume.height), ("mean J", volume.mean_j)] {
            assert!(
                change.abs() <= 0.01,
                "the pool's volume by its {what} moved {:+.2} % by {} s",
                change * 100.0,
                second + 1
            );
        }
    }
}

/// The pool's [`PoolVolume`] after each of 10 s relative to the start (0: as it started), printing
/// each.
fn pool_volumes(iterations: u32) -> Vec<PoolVolume> {
    let clock = Instant::now();
    let scene = common::scene(&format!(
        "[domain]\nsize = [0.4, 0.2, 0.16]\nresolution = [20, 10, 8]\n\
         [material]\nrest_density = 1000.0\nviscosity = 1.0e-3\n\
         [solver]\nmethod = \"pbmpm\"\niterations = {iterations}\n\
         [time_step]\nsubsteps = 2\n\
         [[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.36, 0.12, 0.12]\n"
    ));
    let mut sim = simulation(&scene);
    let first = particles(&mut sim);
    let (height, j) = (pool_height(&scene, &first), mean_j(&scene, &first));
    let measure = |p: &Particles| PoolVolume {
        height: pool_height(&scene, p) / height - 1.0,
        mean_j: mean_j(&scene, p) / j - 1.0,
    };
    let mut seconds = Vec::new();
    for second in 1..=10 {
        for _ in 0..60 {
            sim.advance_frame().expect("a frame");
        }
        let now = measure(&particles(&mut sim));
        println!(
            "RESULT pbmpm pool at rest, {iterations} iterations, t = {second:2} s: height {:+.2} %, mean J {:+.2} % of the start",
            now.height * 100.0,
            now.mean_j * 100.0
        );
        seconds.push(now);
    }
    let (settled, end) = (seconds[0], seconds[9]);
    println!(
        "RESULT pbmpm pool at rest, {iterations} iterations: height {:+.2} % at 1 s, {:+.2} % at 10 s; mean J {:+.2} % at 1 s, \
         {:+.2} % at 10 s ({:.1} s)",
        settled.height * 100.0,
        end.height * 100.0,
        settled.mean_j * 100.0,
        end.mean_j * 100.0,
        clock.elapsed().as_secs_f32()
    );
    seconds
}

/// Martin & Moyce (1952), the collapse of a column of width a = 2.25 in and height 2a (n^2 = 2):
/// the surge front z / a against T = t sqrt(2 g / a), as tabulated from their measurements (their
/// Figure 3's a = 2.25 in series gives the same curve).
const MARTIN_MOYCE: [(f64, f64); 15] = [
    (0.41, 1.11),
    (0.84, 1.22),
    (1.19, 1.44),
    (1.43, 1.67),
    (1.63, 1.89),
    (1.83, 2.11),
    (1.98, 2.33),
    (2.20, 2.56),
    (2.32, 2.78),
    (2.51, 3.00),
    (2.65, 3.22),
    (2.83, 3.44),
    (2.98, 3.67),
    (3.11, 3.89),
    (3.33, 4.11),
];

/// A quasi-2D column a = 10 cm wide, 2a high and 5 cm thick (1 cm grid, 8,000 particles) released
/// against the low x wall at `substeps` a frame and `iterations`: the surge front (the largest x
/// of the particles within 3 cm of the floor, from the wall's plane) every frame, in Martin &
/// Moyce's terms; returns the relative RMS error against their points (the front interpolated
/// between frames) and prints both curves.
fn dam_break_front(iterations: u32, substeps: u32) -> f64 {
    let clock = Instant::now();
    let a = 0.1f64;
    let scene = common::scene(&format!(
        "[domain]\nsize = [0.6, 0.25, 0.08]\nresolution = [60, 25, 8]\n\
         [material]\nrest_density = 1000.0\nviscosity = 1.0e-3\n\
         [solver]\nmethod = \"pbmpm\"\niterations = {iterations}\n\
         [time_step]\nsubsteps = {substeps}\n\
         [[block]]\nmin = [0.01, 0.01, 0.01]\nmax = [0.11, 0.21, 0.06]\n"
    ));
    let (wall, _) = scene.fluid_region();
    let g = f64::from(scene.gravity.length());
    let t_scale = (2.0 * g / a).sqrt();
    let front = |p: &Particles| {
        let x =
            p.x.iter()
                .filter(|x| x.y < 0.04)
                .map(|x| x.x)
                .fold(0.0f32, f32::max);
        (f64::from(x) - wall.x) / a
    };
    let mut sim = simulation(&scene);
    let mut curve = vec![(0.0, front(&particles(&mut sim)))];
    let last = MARTIN_MOYCE[MARTIN_MOYCE.len() - 1].0;
    while curve.last().unwrap().0 < last {
        let stats = sim.advance_frame().expect("a frame");
        curve.push((stats.time * t_scale, front(&particles(&mut sim))));
    }
    let at = |t: f64| {
        let k = curve.iter().position(|&(s, _)| s >= t).unwrap();
        let ((t0, z0), (t1, z1)) = (curve[k - 1], curve[k]);
        z0 + (z1 - z0) * (t - t0) / (t1 - t0)
    };
    let mut sum = 0.0;
    let mut line = String::new();
    for &(t, z) in &MARTIN_MOYCE {
        let ours = at(t);
        sum += ((ours - z) / z).powi(2);
        line += &format!(" T={t:.2}: {ours:.2}/{z:.2}");
    }
    let rms = (sum / MARTIN_MOYCE.len() as f64).sqrt();
    println!(
        "RESULT pbmpm dam break vs Martin & Moyce, {iterations} iterations, {substeps} substeps a frame: \
         relative RMS error {:.1} % ({:.1} s); Z ours/theirs:{line}",
        rms * 100.0,
        clock.elapsed().as_secs_f32()
    );
    rms
}

/// The surge front of the dam break at 1, 2, 4 and 8 iterations and two substeps a frame against
/// Martin & Moyce: within 20 % RMS at the default four iterations and at eight.
#[test]
fn the_dam_break_front_follows_martin_and_moyce() {
    let errors: Vec<(u32, f64)> = [1, 2, 4, 8].map(|n| (n, dam_break_front(n, 2))).to_vec();
    for &(n, rms) in errors.iter().filter(|(n, _)| *n >= 4) {
        assert!(
            rms <= 0.20,
            "{n} iterations: the front's RMS error against Martin & Moyce is {:.1} %, over 20 %",
            rms * 100.0
        );
    }
}

/// Two runs of the same scene give the same bytes: positions, velocities, C, densities, volume
/// biases and deformations.
#[test]
fn two_runs_give_identical_bytes() {
    let scene = common::scene(
        "[domain]\nsize = [0.6, 0.25, 0.08]\nresolution = [60, 25, 8]\n\
         [[material]]\nname = \"water\"\nrest_density = 1000.0\nviscosity = 1.0e-3\n\
         [[material]]\nname = \"jelly\"\nlaw = \"fixed-corotated\"\nrest_density = 1000.0\nyoungs_modulus = 1.0e5\npoisson_ratio = 0.3\n\
         [solver]\nmethod = \"pbmpm\"\n\
         [[block]]\nmin = [0.01, 0.01, 0.01]\nmax = [0.11, 0.21, 0.06]\nmaterial = \"water\"\n\
         [[block]]\nmin = [0.3, 0.1, 0.01]\nmax = [0.36, 0.16, 0.06]\nmaterial = \"jelly\"\n",
    );
    let run = || {
        let mut sim = simulation(&scene);
        for _ in 0..20 {
            sim.advance_frame().unwrap();
        }
        let p = particles(&mut sim);
        let mut bytes: Vec<u8> = Vec::new();
        for i in 0..p.len() {
            for v in p.x[i]
                .to_array()
                .into_iter()
                .chain(p.v[i].to_array())
                .chain(p.c[i].to_cols_array())
            {
                bytes.extend(v.to_bits().to_le_bytes());
            }
            bytes.extend(p.rho[i].to_bits().to_le_bytes());
            bytes.extend(p.volume_bias[i].to_bits().to_le_bytes());
            for v in p.deformation[i].f.to_cols_array() {
                bytes.extend(v.to_bits().to_le_bytes());
            }
        }
        bytes
    };
    let (first, second) = (run(), run());
    assert!(first == second, "two runs of the same scene differ");
    println!(
        "RESULT pbmpm determinism: two 20-frame runs, {} bytes, identical",
        first.len()
    );
}

/// The scene keys: each wrong combination refused with the key and the fix.
#[test]
fn the_scene_keys_are_checked() {
    let base = "[domain]\nsize = [0.4, 0.2, 0.16]\nresolution = [20, 10, 8]\n\
                [material]\nrest_density = 1000.0\nsound_speed = 10.0\n\
                [[block]]\nmin = [0.06, 0.06, 0.06]\nmax = [0.2, 0.1, 0.08]\n";
    let refused = |extra: &str, key: &str, words: &str| {
        let text = format!("{base}{extra}");
        let error = Scene::from_toml(&text, "test").expect_err(extra);
        assert_eq!(error.key, key, "{extra}: {error}");
        let message = error.to_string();
        assert!(message.contains(words), "{extra}: {message}");
    };
    refused(
        "[solver]\nmethod = \"pbmpm\"\n[time_step]\ncfl = 0.4\n",
        "time_step.cfl",
        "substeps",
    );
    refused(
        "[solver]\nmethod = \"pbmpm\"\n[time_step]\ndt = 1e-3\n",
        "time_step.dt",
        "substeps",
    );
    refused(
        "[solver]\nmethod = \"pbmpm\"\n[time_step]\nmax_substeps = 9\n",
        "time_step.max_substeps",
        "substeps",
    );
    refused(
        "[solver]\nmethod = \"pbmpm\"\n[time_step]\nsubsteps = 0\n",
        "time_step.substeps",
        "1 to",
    );
    refused(
        "[solver]\nmethod = \"pbmpm\"\niterations = 65\n",
        "solver.iterations",
        "1 to 64",
    );
    refused(
        "[solver]\nmethod = \"pbmpm\"\niterations = 0\n",
        "solver.iterations",
        "1 to 64",
    );
    refused(
        "[solver]\nmethod = \"pbmpm\"\nwall_friction = -1.0\n",
        "solver.wall_friction",
        ">= 0",
    );
    refused(
        "[solver]\niterations = 4\n",
        "solver.iterations",
        "method = \"pbmpm\"",
    );
    refused(
        "[solver]\nwall_friction = 0.5\n",
        "solver.wall_friction",
        "method = \"pbmpm\"",
    );
    refused(
        "[time_step]\nsubsteps = 2\n",
        "time_step.substeps",
        "method = \"pbmpm\"",
    );
    refused(
        "[solver]\nmethod = \"pbmpm\"\nsoft_wall = true\n",
        "solver.soft_wall",
        "drop",
    );
    refused(
        "[solver]\nmethod = \"pbmpm\"\n[[collider]]\nshape = \"sphere\"\ncenter = [0.3, 0.1, 0.08]\nradius = 0.03\n",
        "collider",
        "explicit",
    );
    // A pbmpm liquid needs no sound speed; the defaults are 4 iterations and 2 substeps.
    let scene = common::scene(
        "[domain]\nsize = [0.4, 0.2, 0.16]\nresolution = [20, 10, 8]\n\
         [material]\nrest_density = 1000.0\n[solver]\nmethod = \"pbmpm\"\n\
         [[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.2, 0.1, 0.1]\n",
    );
    assert_eq!(scene.pbmpm.iterations, 4);
    let (n, _) = scene
        .time_step
        .substeps(mpm::sim::FRAME_DT, 1.0, scene.dx)
        .unwrap();
    assert_eq!(n, 2);
}

/// The CUDA and cpu-parallel backends refuse a pbmpm scene before any work, naming the fix; a
/// scene made pbmpm on the command line runs on `--backend cpu`.
#[test]
fn only_the_cpu_backend_runs_pbmpm() {
    let scene = Scene::load("pbmpm-dam-break").unwrap();
    for kind in [BackendKind::Cuda, BackendKind::CpuParallel] {
        let message = backend::create(kind, &scene).err().expect("refused").to_string();
        assert!(message.contains("use --backend cpu"), "{kind:?}: {message}");
    }
    let cuda = backend::create(BackendKind::Cuda, &scene)
        .err()
        .unwrap()
        .to_string();
    assert_eq!(cuda, mpm::sim::pbmpm::CPU_ONLY);
    let out = common::cpu_run(
        "dam-break-coarse",
        "2",
        &["--method", "pbmpm", "--iterations", "2"],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("substeps=  2 (fixed"), "{stdout}");
    let out = common::cpu_run("dam-break-coarse", "1", &["--iterations", "2"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--method pbmpm"));
}

/// Every law of the material table under pbmpm: a 10 cm column of each (sand, snow, Neo-Hookean
/// jelly, an elastic Bingham mud, a shear-thinning power-law liquid, honey) collapses for half a
/// second at two substeps a frame on the tank's free-slip floor, staying finite, inside and whole.
/// How far each runs out is printed, not checked (docs/physics.md, "Position-based MPM", says what
/// the numbers show).
#[test]
fn every_law_collapses_soundly() {
    let laws = [
        ("sand", "law = \"sand\"\nrest_density = 1600.0\nyoungs_modulus = 3.5e5\npoisson_ratio = 0.3\nfriction_angle = 30.0\n"),
        ("snow", "law = \"snow\"\nrest_density = 400.0\nyoungs_modulus = 1.4e5\npoisson_ratio = 0.2\n"),
        ("neo-hookean", "law = \"neo-hookean\"\nrest_density = 1000.0\nyoungs_modulus = 1.0e5\npoisson_ratio = 0.3\n"),
        ("mud", "law = \"herschel-bulkley\"\nrest_density = 1800.0\nconsistency = 20.0\nyield_stress = 600.0\nshear_modulus = 5.0e4\n"),
        ("power law", "law = \"power-law\"\nrest_density = 1000.0\nconsistency = 2.0\nflow_index = 0.5\nmax_viscosity = 50.0\nmin_viscosity = 0.01\n"),
        ("honey", "rest_density = 1400.0\nviscosity = 10.0\n"),
    ];
    for (name, law) in laws {
        let clock = Instant::now();
        let scene = common::scene(&format!(
            "[domain]\nsize = [0.6, 0.25, 0.08]\nresolution = [60, 25, 8]\n\
             [material]\n{law}\
             [solver]\nmethod = \"pbmpm\"\n\
             [[block]]\nmin = [0.01, 0.01, 0.01]\nmax = [0.11, 0.11, 0.06]\n"
        ));
        let mut sim = simulation(&scene);
        for frame in 1..=30 {
            sim.advance_frame().expect("a frame");
            assert_sound(
                &scene,
                &particles(&mut sim),
                scene.num_particles,
                &format!("{name}, frame {frame}"),
            );
        }
        let p = particles(&mut sim);
        let front = p.x.iter().map(|x| x.x).fold(0.0f32, f32::max);
        let top = p.x.iter().map(|x| x.y).fold(0.0f32, f32::max);
        println!(
            "RESULT pbmpm {name}: a 10 cm column after 0.5 s reaches x = {front:.3} m, y = {top:.3} m ({:.1} s)",
            clock.elapsed().as_secs_f32()
        );
    }
}
