//! What the position-based solver's checks share (`solver.method = "pbmpm"`): runs on any backend,
//! the violent scenes, the pool at rest, the dam break against Martin & Moyce and the bytes of a run;
//! on the CPU reference in CI (tests/pbmpm.rs), and on the GPU against it (tests/gpu_pbmpm.rs).
#![allow(dead_code)]

use mpm::backend::{self, BackendKind};
use mpm::checkpoint::Checkpoint;
use mpm::sim::scene::TimeStepPolicy;
use mpm::sim::{Particles, Scene, Simulation};
use std::time::Instant;

use super::common;

/// `scene` on `backend`.
pub fn simulation(scene: &Scene, backend: BackendKind) -> Simulation {
    Simulation::new(
        scene.clone(),
        backend::create(backend, scene).expect("the pbmpm solver"),
    )
}

pub fn particles(sim: &mut Simulation) -> Particles {
    sim.solver_mut().read_particles().unwrap()
}

/// Every particle finite and inside the fluid region, and as many as at the start.
pub fn assert_sound(scene: &Scene, p: &Particles, count: usize, when: &str) {
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
pub fn run_sound(scene: &Scene, frames: u64, backend: BackendKind) -> f32 {
    let mut sim = simulation(scene, backend);
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
/// 60 Hz frame (0.83 m a substep, 42 cells), four iterations. (The explicit solver would need
/// dt <= 0.5 dx / (c0 + 50 m/s).)
pub fn liquid_fired_at_a_wall() -> Scene {
    common::scene(
        "[domain]\nsize = [1.2, 0.3, 0.16]\nresolution = [60, 15, 8]\n\
         [material]\nrest_density = 1000.0\nviscosity = 1.0e-3\n\
         [solver]\nmethod = \"pbmpm\"\niterations = 4\n\
         [time_step]\nsubsteps = 1\n\
         [[block]]\nmin = [0.3, 0.04, 0.02]\nmax = [0.5, 0.14, 0.12]\nvelocity = [50.0, 0.0, 0.0]\n",
    )
}

/// A 12 x 12 x 10 cm jelly block (E = 100 kPa, nu = 0.3) thrown down at 30 m/s onto the floor from 10
/// cm above it, one substep a frame (0.5 m a substep, four times its fall), four iterations.
pub fn jelly_thrown_at_the_floor() -> Scene {
    common::scene(
        "[domain]\nsize = [0.6, 0.4, 0.16]\nresolution = [30, 20, 8]\n\
         [material]\nlaw = \"fixed-corotated\"\nrest_density = 1000.0\nyoungs_modulus = 1.0e5\npoisson_ratio = 0.3\n\
         [solver]\nmethod = \"pbmpm\"\niterations = 4\n\
         [time_step]\nsubsteps = 1\n\
         [[block]]\nmin = [0.24, 0.12, 0.02]\nmax = [0.36, 0.24, 0.12]\nvelocity = [0.0, -30.0, 0.0]\n",
    )
}

/// A column of water and a jelly block in one tank at the defaults (four iterations, two substeps).
pub fn water_and_jelly() -> Scene {
    common::scene(
        "[domain]\nsize = [0.6, 0.25, 0.08]\nresolution = [60, 25, 8]\n\
         [[material]]\nname = \"water\"\nrest_density = 1000.0\nviscosity = 1.0e-3\n\
         [[material]]\nname = \"jelly\"\nlaw = \"fixed-corotated\"\nrest_density = 1000.0\nyoungs_modulus = 1.0e5\npoisson_ratio = 0.3\n\
         [solver]\nmethod = \"pbmpm\"\n\
         [[block]]\nmin = [0.01, 0.01, 0.01]\nmax = [0.11, 0.21, 0.06]\nmaterial = \"water\"\n\
         [[block]]\nmin = [0.3, 0.1, 0.01]\nmax = [0.36, 0.16, 0.06]\nmaterial = \"jelly\"\n",
    )
}

/// The bytes of `scene` after `frames` frames on `backend`: positions, velocities, C, densities,
/// volume biases and deformations.
pub fn run_bytes(scene: &Scene, frames: u32, backend: BackendKind) -> Vec<u8> {
    let mut sim = simulation(scene, backend);
    for _ in 0..frames {
        sim.advance_frame().unwrap();
    }
    particle_bytes(&mut sim)
}

/// The bytes of `sim`'s particles as [`run_bytes`] gives them.
pub fn particle_bytes(sim: &mut Simulation) -> Vec<u8> {
    let p = particles(sim);
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
        for v in p
            .deformation
            .get(i)
            .map(|d| d.f.to_cols_array())
            .unwrap_or_default()
        {
            bytes.extend(v.to_bits().to_le_bytes());
        }
    }
    bytes
}

/// The viewer's live controls (`Simulation::set_iterations`, `set_substeps`) set before the first
/// frame run as the scene that starts with them: water beside a jelly at 2 iterations and 3
/// substeps a frame, set live on the defaults' scene, writes that scene's bytes 5 frames on; a
/// checkpoint of it (a viewer snapshot) keeps the live counts, and its run goes on as the live one
/// for 3 frames more, byte for byte; a scene under the explicit scheme refuses both, and counts
/// outside the keys' ranges are refused.
pub fn live_controls_run_as_the_scene_keys(backend: BackendKind) {
    let mut live = simulation(&water_and_jelly(), backend);
    live.set_iterations(2).unwrap();
    live.set_substeps(3).unwrap();
    let toml = water_and_jelly()
        .toml
        .replace("method = \"pbmpm\"\n", "method = \"pbmpm\"\niterations = 2\n")
        + "[time_step]\nsubsteps = 3\n";
    let keyed = common::scene(&toml);
    assert_eq!(
        (keyed.pbmpm.iterations, keyed.num_particles),
        (2, live.scene().num_particles)
    );
    let mut from_keys = simulation(&keyed, backend);
    for _ in 0..5 {
        live.advance_frame().unwrap();
        from_keys.advance_frame().unwrap();
    }
    assert!(
        common::same_particles(&particles(&mut live), &particles(&mut from_keys)),
        "{backend:?}: the live controls' run differs from the scene keys' run"
    );
    // A checkpoint (a viewer snapshot) keeps the live counts: its run goes on as the live one.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("live.mpmck");
    Checkpoint::capture(&mut live).unwrap().write_new(&file).unwrap();
    let saved = Checkpoint::read(&file).unwrap();
    let scene = saved.scene().unwrap();
    assert_eq!(
        (scene.pbmpm.iterations, scene.time_step),
        (2, TimeStepPolicy::pbmpm(3)),
        "{backend:?}: the checkpoint's scene lost the live counts"
    );
    let mut resumed = saved.resume(scene, backend).unwrap();
    for _ in 0..3 {
        live.advance_frame().unwrap();
        resumed.advance_frame().unwrap();
    }
    assert!(
        common::same_particles(&particles(&mut live), &particles(&mut resumed)),
        "{backend:?}: the run resumed from a checkpoint of the live controls differs from the live run"
    );
    for refused in [
        live.set_iterations(0),
        live.set_iterations(65),
        live.set_substeps(0),
    ] {
        assert!(refused.is_err(), "{backend:?}: a count out of range was taken");
    }
    let explicit_box = common::water_box(
        16,
        "[[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.08, 0.08, 0.08]\n",
    );
    let mut explicit = simulation(&common::scene(&explicit_box), backend);
    let message = explicit.set_iterations(2).unwrap_err().to_string();
    assert!(message.contains("explicit"), "{message}");
    assert!(explicit.set_substeps(2).is_err());
}

/// Every law of the material table, as `[material]` keys: sand, snow, a Neo-Hookean jelly, an
/// elastic Bingham mud, a shear-thinning power-law liquid, honey.
pub fn every_law() -> [(&'static str, &'static str); 6] {
    [
        ("sand", "law = \"sand\"\nrest_density = 1600.0\nyoungs_modulus = 3.5e5\npoisson_ratio = 0.3\nfriction_angle = 30.0\n"),
        ("snow", "law = \"snow\"\nrest_density = 400.0\nyoungs_modulus = 1.4e5\npoisson_ratio = 0.2\n"),
        ("neo-hookean", "law = \"neo-hookean\"\nrest_density = 1000.0\nyoungs_modulus = 1.0e5\npoisson_ratio = 0.3\n"),
        ("mud", "law = \"herschel-bulkley\"\nrest_density = 1800.0\nconsistency = 20.0\nyield_stress = 600.0\nshear_modulus = 5.0e4\n"),
        ("power law", "law = \"power-law\"\nrest_density = 1000.0\nconsistency = 2.0\nflow_index = 0.5\nmax_viscosity = 50.0\nmin_viscosity = 0.01\n"),
        ("honey", "rest_density = 1400.0\nviscosity = 10.0\n"),
    ]
}

/// A 10 cm column of `law` in a quasi-2D tank at the defaults.
pub fn column_of(law: &str) -> Scene {
    common::scene(&format!(
        "[domain]\nsize = [0.6, 0.25, 0.08]\nresolution = [60, 25, 8]\n\
         [material]\n{law}\
         [solver]\nmethod = \"pbmpm\"\n\
         [[block]]\nmin = [0.01, 0.01, 0.01]\nmax = [0.11, 0.11, 0.06]\n"
    ))
}

/// The pool's height above the floor's plane, m: the 98th percentile of its particles' heights (the
/// free surface, without the odd particle above it). Its walls hold it on every side, so its volume
/// is its height times their span.
pub fn pool_height(scene: &Scene, p: &Particles) -> f64 {
    let mut y: Vec<f32> = p.x.iter().map(|x| x.y).collect();
    y.sort_by(f32::total_cmp);
    let (floor, _) = scene.fluid_region();
    f64::from(y[(y.len() * 98) / 100]) - floor.y
}

/// The mean of the particles' own volume ratio J = rho0 / rho.
pub fn mean_j(scene: &Scene, p: &Particles) -> f64 {
    let rho0 = f64::from(scene.material().rest_density);
    p.rho.iter().map(|&r| rho0 / f64::from(r)).sum::<f64>() / p.len() as f64
}

/// The pool's volume by its height ([`pool_height`]) and by its particles' mean J, each relative
/// to the start.
#[derive(Clone, Copy, Debug)]
pub struct PoolVolume {
    pub height: f64,
    pub mean_j: f64,
}

/// The pool's [`PoolVolume`] after each of 10 s relative to the start (0: as it started), printing
/// each.
pub fn pool_volumes(iterations: u32, backend: BackendKind) -> Vec<PoolVolume> {
    let clock = Instant::now();
    let scene = common::scene(&format!(
        "[domain]\nsize = [0.4, 0.2, 0.16]\nresolution = [20, 10, 8]\n\
         [material]\nrest_density = 1000.0\nviscosity = 1.0e-3\n\
         [solver]\nmethod = \"pbmpm\"\niterations = {iterations}\n\
         [time_step]\nsubsteps = 2\n\
         [[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.36, 0.12, 0.12]\n"
    ));
    let mut sim = simulation(&scene, backend);
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
            "RESULT pbmpm pool at rest ({backend:?}), {iterations} iterations, t = {second:2} s: height {:+.2} %, mean J {:+.2} % of the start",
            now.height * 100.0,
            now.mean_j * 100.0
        );
        seconds.push(now);
    }
    let (settled, end) = (seconds[0], seconds[9]);
    println!(
        "RESULT pbmpm pool at rest ({backend:?}), {iterations} iterations: height {:+.2} % at 1 s, {:+.2} % at 10 s; mean J {:+.2} % at 1 s, \
         {:+.2} % at 10 s ({:.1} s)",
        settled.height * 100.0,
        end.height * 100.0,
        settled.mean_j * 100.0,
        end.mean_j * 100.0,
        clock.elapsed().as_secs_f32()
    );
    seconds
}

/// The bound on the pool at rest: its volume within 1 % of the start, by its height and by
/// its mean J, every second from 5 s to 10 s (`seconds`: [`pool_volumes`]).
pub fn assert_the_pool_holds_within_1_percent(seconds: &[PoolVolume]) {
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

/// Martin & Moyce (1952), the collapse of a column of width a = 2.25 in and height 2a (n^2 = 2):
/// the surge front z / a against T = t sqrt(2 g / a), as tabulated from their measurements (their
/// Figure 3's a = 2.25 in series gives the same curve).
pub const MARTIN_MOYCE: [(f64, f64); 15] = [
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
pub fn dam_break_front(iterations: u32, substeps: u32, backend: BackendKind) -> f64 {
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
    let mut sim = simulation(&scene, backend);
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
        "RESULT pbmpm dam break vs Martin & Moyce ({backend:?}), {iterations} iterations, {substeps} substeps a frame: \
         relative RMS error {:.1} % ({:.1} s); Z ours/theirs:{line}",
        rms * 100.0,
        clock.elapsed().as_secs_f32()
    );
    rms
}

/// The plate of [`jelly_crushed_by_a_plate`]: a box 40 x 8 x 20 cm (four cells thick: a collider
/// thinner than the stencil's reach lets nodes through) whose underside starts 2 cm above
/// the jelly and goes down 9 cm and back up as a piston of period 0.2 s, five times a second (1.4
/// m/s at its fastest, 2.4 cm a substep at one substep a frame): it squeezes the jelly to a quarter
/// of its height.
const PLATE_START: f32 = 0.16;
const PLATE_STROKE: f32 = 0.09;
const PLATE_PERIOD: f32 = 0.2;

/// The 12 x 12 x 10 cm jelly of [`jelly_thrown_at_the_floor`] resting on the floor of a 60 x 40 cm
/// tank, crushed again and again by a plate ([`PLATE_STROKE`]; a `slip` box collider), one substep a
/// frame and four iterations.
pub fn jelly_crushed_by_a_plate() -> Scene {
    let half = 0.5 * PLATE_STROKE;
    common::scene(&format!(
        "[domain]\nsize = [0.6, 0.4, 0.16]\nresolution = [30, 20, 8]\n\
         [material]\nlaw = \"fixed-corotated\"\nrest_density = 1000.0\nyoungs_modulus = 1.0e5\npoisson_ratio = 0.3\n\
         [solver]\nmethod = \"pbmpm\"\niterations = 4\n\
         [time_step]\nsubsteps = 1\n\
         [[block]]\nmin = [0.24, 0.02, 0.02]\nmax = [0.36, 0.14, 0.12]\n\
         [[collider]]\nshape = \"box\"\ncenter = [0.3, {}, 0.08]\nsize = [0.4, 0.08, 0.2]\n\
         [collider.motion]\npiston = {{ direction = [0.0, -1.0, 0.0], amplitude = {half}, period = {PLATE_PERIOD}, phase = -90.0 }}\n",
        PLATE_START + 0.04 - half,
    ))
}

/// The plate's underside at time t, m.
pub fn plate_underside(t: f32) -> f32 {
    let half = 0.5 * PLATE_STROKE;
    PLATE_START - half + half * (std::f32::consts::TAU * t / PLATE_PERIOD).cos()
}

/// What [`jelly_crushed_by_a_plate`] did: the jelly's top (its highest particle) after the first frame,
/// at the plate's first lowest and at its highest as the plate lifts again; the plate's underside at
/// its lowest; the backstop's pushes over the second.
pub struct Crush {
    pub top_at_start: f32,
    pub top_at_lowest: f32,
    pub top_back: f32,
    pub plate_at_lowest: f32,
    pub backstop_pushes: u64,
}

/// Runs [`jelly_crushed_by_a_plate`] for a second on `backend`, checking the particles after every
/// frame ([`assert_sound`]) and that none is inside the plate.
pub fn crush_the_jelly(backend: BackendKind) -> Crush {
    let scene = jelly_crushed_by_a_plate();
    let mut sim = simulation(&scene, backend);
    let lowest_frame = (0.5 * PLATE_PERIOD * 60.0).round() as u64;
    let mut crush = Crush {
        top_at_start: 0.0,
        top_at_lowest: 0.0,
        top_back: 0.0,
        plate_at_lowest: plate_underside(0.5 * PLATE_PERIOD),
        backstop_pushes: 0,
    };
    for frame in 1..=60u64 {
        let stats = sim.advance_frame().expect("a frame");
        crush.backstop_pushes += stats.backstop_pushes;
        let p = particles(&mut sim);
        assert_sound(&scene, &p, scene.num_particles, &format!("frame {frame}"));
        let plate = plate_underside(frame as f32 / 60.0);
        let top = p.x.iter().map(|x| x.y).fold(0.0f32, f32::max);
        assert!(
            top <= plate + 1e-4,
            "frame {frame}: a jelly particle at y = {top:.4} is inside the plate (its underside at {plate:.4})"
        );
        match frame {
            1 => crush.top_at_start = top,
            f if f == lowest_frame => crush.top_at_lowest = top,
            f if f > lowest_frame && f <= 2 * lowest_frame => crush.top_back = crush.top_back.max(top),
            _ => {}
        }
    }
    crush
}

/// A 10 x 4 x 5 cm jelly block sliding at 1.5 m/s along the top of a Coulomb box collider of
/// coefficient `mu` (a platform 4 cm high across the tank), 1 cm cells, at the defaults (two
/// substeps a frame, four iterations).
pub fn block_on_a_coulomb_platform(mu: f32) -> Scene {
    common::scene(&format!(
        "[domain]\nsize = [0.8, 0.15, 0.08]\nresolution = [80, 15, 8]\n\
         [material]\nlaw = \"fixed-corotated\"\nrest_density = 1000.0\nyoungs_modulus = 1.0e5\npoisson_ratio = 0.3\n\
         [solver]\nmethod = \"pbmpm\"\n\
         [[block]]\nmin = [0.05, 0.04, 0.01]\nmax = [0.15, 0.08, 0.06]\nvelocity = [1.5, 0.0, 0.0]\n\
         [[collider]]\nshape = \"box\"\ncenter = [0.4, 0.0, 0.04]\nsize = [1.0, 0.08, 0.3]\nfriction = {mu}\n",
    ))
}

/// The deceleration of [`block_on_a_coulomb_platform`] on `backend` while it slides: the slope of
/// its particles' mean x velocity, frame by frame, fitted from 1.3 down to 0.3 m/s.
pub fn platform_deceleration(mu: f32, backend: BackendKind) -> f32 {
    let scene = block_on_a_coulomb_platform(mu);
    let mut sim = simulation(&scene, backend);
    let mut samples = Vec::new();
    for frame in 1..=45u32 {
        sim.advance_frame().expect("a frame");
        let v = particles(&mut sim).v;
        let vx = v.iter().map(|v| f64::from(v.x)).sum::<f64>() / v.len() as f64;
        if vx < 1.3 && vx > 0.3 {
            samples.push((f64::from(frame) / 60.0, vx));
        }
    }
    assert!(samples.len() >= 10, "too few sliding frames: {samples:?}");
    -common::fitted_slope(&samples) as f32
}

/// A water column released towards a slip box turned 30 degrees, a Coulomb one (friction 0.3) on
/// the floor and a sticking sphere moving across the tank at 0.3 m/s, at the defaults: each kind of
/// collider, fixed and moving, under pbmpm.
pub fn water_among_colliders() -> Scene {
    common::scene(
        "[domain]\nsize = [0.6, 0.25, 0.08]\nresolution = [60, 25, 8]\n\
         [material]\nrest_density = 1000.0\nviscosity = 1.0e-3\n\
         [solver]\nmethod = \"pbmpm\"\n\
         [[block]]\nmin = [0.01, 0.01, 0.01]\nmax = [0.11, 0.21, 0.06]\n\
         [[collider]]\nshape = \"box\"\ncenter = [0.25, 0.05, 0.04]\nsize = [0.08, 0.04, 0.2]\nrotation = [0.0, 0.0, 30.0]\n\
         [[collider]]\nshape = \"box\"\ncenter = [0.45, 0.02, 0.04]\nsize = [0.12, 0.04, 0.2]\nfriction = 0.3\n\
         [[collider]]\nshape = \"sphere\"\ncenter = [0.5, 0.14, 0.04]\nradius = 0.04\nboundary = \"stick\"\n\
         [collider.motion]\nvelocity = [-0.3, 0.0, 0.0]\n",
    )
}

/// [`crush_the_jelly`] on `backend`, printed; the jelly must spring back to 90 % of its height or
/// more as the plate lifts.
pub fn assert_the_crushed_jelly_springs_back(backend: BackendKind) {
    let start = Instant::now();
    let crush = crush_the_jelly(backend);
    println!(
        "RESULT pbmpm ({backend:?}) jelly crushed by a plate: top {:.3} m, {:.3} m under the plate at its lowest \
         ({:.3} m), back to {:.3} m as it lifts; {} backstop pushes in 1 s ({:.1} s)",
        crush.top_at_start,
        crush.top_at_lowest,
        crush.plate_at_lowest,
        crush.top_back,
        crush.backstop_pushes,
        start.elapsed().as_secs_f32()
    );
    assert!(
        crush.top_back >= 0.9 * crush.top_at_start,
        "the jelly did not spring back"
    );
}

/// [`platform_deceleration`] on `backend` for mu = 0.2 and 0.4, printed: each within 5 % of mu g,
/// Coulomb's law.
pub fn assert_the_block_slows_at_mu_g(backend: BackendKind) {
    for mu in [0.2f32, 0.4] {
        let deceleration = platform_deceleration(mu, backend);
        let expected = mu * 9.81;
        println!(
            "RESULT pbmpm ({backend:?}) block on a Coulomb collider, mu = {mu}: slows at {deceleration:.3} m/s^2, \
             mu g = {expected:.3} ({:+.1} %)",
            100.0 * (deceleration / expected - 1.0)
        );
        assert!(
            (deceleration / expected - 1.0).abs() < 0.05,
            "mu = {mu}: {deceleration:.3} m/s^2 against mu g = {expected:.3}"
        );
    }
}
