//! Whole-step checks on the CPU reference: the closed-form cases of docs/physics.md and every preset.

mod common;

use glam::Vec3;
use mpm::backend::{self, BackendKind};
use mpm::sim::{presets, Pipeline, Scene, Simulation, Solver};

/// An 8^3-cell block at rest in the middle of a 24^3 grid, no gravity, on the 2-per-axis lattice.
fn rest_block() -> Scene {
    common::scene(&common::water_box(
        24,
        "[solver]\ngravity = [0.0, 0.0, 0.0]\n[time_step]\ndt = 1.6666667e-4\n\
         [[block]]\nmin = [0.08, 0.08, 0.08]\nmax = [0.16, 0.16, 0.16]",
    ))
}

#[test]
fn block_at_rest_has_exact_interior_density_and_stays_at_rest() {
    // Both density rules: the fused pipeline's (advected) and the report's (gathered).
    for pipeline in [Pipeline::Fused, Pipeline::Binned] {
        let mut scene = rest_block();
        scene.pipeline = pipeline;
        let (mut s, params) = common::cpu(&scene, 1.6666667e-4);
        let m_p = params.materials[0].particle_mass;
        s.clear_grid();
        s.p2g_init(&params);
        // Interior nodes (2 or more cells inside the block) carry exactly 8 particles' mass.
        let interior: Vec<f32> = (0..s.grid.mass.len())
            .filter(|&i| s.grid.shape.node(i).cmpge(glam::UVec3::splat(10)).all())
            .filter(|&i| s.grid.shape.node(i).cmple(glam::UVec3::splat(14)).all())
            .map(|i| s.grid.mass[i])
            .collect();
        assert_eq!(interior.len(), 125);
        for m in interior {
            assert!(
                (m / (8.0 * m_p) - 1.0).abs() < 1e-5,
                "interior node mass {m} vs 8 m_p"
            );
        }
        // The density each particle carries out of its first substep: p2g's gathered one, or (the fused
        // pipeline's rule) the grid's at its position advected by a divergence that is zero at rest.
        s.p2g(&params);
        s.grid_update(&params);
        s.g2p(&params);
        // Density of the outermost three particle layers along one line through the block. With nodes at
        // X = i and particles at X = i + 1/4, i + 3/4 the 1D sums give exactly 159/256, 869/1024 and
        // 997/1024 of rest density (docs/physics.md, "Rest").
        let rho0 = params.materials[0].rest_density;
        let line: Vec<(f32, f32)> = (0..s.particles.len())
            .filter(|&n| {
                (s.particles.x[n].y - 0.1225).abs() < 1e-4 && (s.particles.x[n].z - 0.1225).abs() < 1e-4
            })
            .map(|n| (s.particles.x[n].x, s.particles.rho[n] / rho0))
            .collect();
        let ratio_at = |x: f32| {
            line.iter()
                .find(|(px, _)| (px - x).abs() < 1e-4)
                .map(|&(_, r)| r)
                .unwrap()
        };
        let layers = [
            (0.0825, 159.0 / 256.0),
            (0.0875, 869.0 / 1024.0),
            (0.0925, 997.0 / 1024.0),
            (0.1175, 1.0),
        ];
        for (x, expected) in layers {
            let r = ratio_at(x);
            assert!(
                (r - expected).abs() < 1e-5,
                "{pipeline:?}: rho/rho0 at x = {x}: {r}, exact {expected}"
            );
        }

        let com0 = s.particles.x.iter().map(|x| x.as_dvec3()).sum::<glam::DVec3>() / s.particles.len() as f64;
        let mut max_motion = 0.0f32;
        for _ in 0..1000 {
            s.step(&params).unwrap();
            let vmax = s.particles.v.iter().map(|v| v.length()).fold(0.0, f32::max);
            max_motion = max_motion.max(vmax * params.dt / params.dx);
        }
        let com = s.particles.x.iter().map(|x| x.as_dvec3()).sum::<glam::DVec3>() / s.particles.len() as f64;
        assert!(
            max_motion < 1e-4,
            "max |v| dt/dx = {max_motion:e} over 1000 steps"
        );
        assert!(
            (com - com0).length() < 1e-7,
            "centre of mass drifted by {:e} m",
            (com - com0).length()
        );
    }
}

#[test]
fn free_fall_is_exact_and_keeps_the_shape() {
    let scene = common::scene(&common::water_box(
        48,
        "[time_step]\ndt = 1.6666667e-4\n[[block]]\nmin = [0.16, 0.28, 0.16]\nmax = [0.24, 0.36, 0.24]",
    ));
    let (mut s, params) = common::cpu(&scene, 1.6666667e-4);
    let x0 = s.particles.x.clone();
    let g = Vec3::from(params.gravity);
    let n = 300u32; // 0.05 s: the block falls 1.2 cm, far from the floor
    for _ in 0..n {
        s.step(&params).unwrap();
    }
    let dt = params.dt;
    let v_exact = g * (n as f32 * dt);
    let drop = g * (dt * dt * (n * (n + 1)) as f32 / 2.0);
    let (mut worst_v, mut worst_x) = (0.0f32, 0.0f32);
    for (k, (x, v)) in s.particles.x.iter().zip(&s.particles.v).enumerate() {
        worst_v = worst_v.max((*v - v_exact).length() / v_exact.length());
        worst_x = worst_x.max((*x - (x0[k] + drop)).length());
    }
    println!(
        "free fall after {n} steps: worst relative velocity error {worst_v:e}, position error {worst_x:e} m"
    );
    // Each step rounds v once in mv/m and once in the 27-term gather, so the relative error can grow
    // by about one f32 epsilon per step: n eps bounds it.
    let bound = n as f32 * f32::EPSILON;
    assert!(
        worst_v < bound,
        "velocity off the exact n dt g by {worst_v:e} (relative), over n eps = {bound:e}"
    );
    assert!(
        worst_x < 1e-6,
        "position off the exact free fall by {worst_x:e} m"
    );
}

/// A narrow column 0.5 m high at dx = 2 cm must hold the hydrostatic pressure profile of docs/physics.md
/// and be still.
///
/// Gravity is ramped in over 0.5 s (five acoustic periods, 4 h / c0 = 0.1 s) and then held for 1 s:
/// released at once from uniform density, the column would ring in its breathing mode at about
/// 0.2 m/s (its 3 mm hydrostatic compression times omega = 2 pi c0 / 4h), and nothing in water at
/// mu = 1e-3 Pa s damps that within seconds. Loading it slowly is how a hydrostatic state is reached
/// without dissipation.
#[test]
fn hydrostatic_column_settles_to_the_analytic_profile() {
    let scene = common::scene(
        r#"
[domain]
size = [0.22, 0.6, 0.22]
resolution = [11, 30, 11]
[material]
rest_density = 1000.0
sound_speed = 20.0
eos_power = 7.0
viscosity = 1.0e-3
[time_step]
dt = 3.0e-4
[[block]]
min = [0.02, 0.02, 0.02]
max = [0.18, 0.52, 0.18]
"#,
    );
    // Both density rules: the fused pipeline's (advected) and the report's (gathered).
    for pipeline in [Pipeline::Fused, Pipeline::Binned] {
        let scene = Scene {
            pipeline,
            ..scene.clone()
        };
        let mat = scene.material();
        let (g, h) = (9.81f32, 0.5f32);
        let dt = 3.0e-4;
        let (mut s, mut params) = common::cpu(&scene, dt);
        let gravity = Vec3::from(params.gravity);
        let (ramp, total) = ((0.5 / dt) as u32, (1.5 / dt) as u32);
        for n in 0..total {
            params.gravity = (gravity * (n as f32 / ramp as f32).min(1.0)).to_array();
            s.step(&params).unwrap();
        }
        let p = &s.particles;
        let vmax = p.v.iter().map(|v| v.length()).fold(0.0, f32::max);
        assert!(
            vmax < 0.01 * (g * h).sqrt(),
            "max |v| = {vmax} m/s after 1.5 s: not settled"
        );

        // Least-squares slope of p(y) over interior particles: 3 cells off the floor and the surface.
        let top = p.x.iter().map(|x| x.y).fold(0.0, f32::max);
        let (lo, hi) = (0.02 + 3.0 * 0.02, top - 3.0 * 0.02);
        let samples: Vec<(f64, f64)> = (0..p.len())
            .filter(|&n| p.x[n].y > lo && p.x[n].y < hi)
            .map(|n| (f64::from(p.x[n].y), f64::from(mat.pressure(p.rho[n]))))
            .collect();
        let count = samples.len() as f64;
        let (my, mp) = samples
            .iter()
            .fold((0.0, 0.0), |(a, b), (y, p)| (a + y / count, b + p / count));
        let cov: f64 = samples.iter().map(|(y, p)| (y - my) * (p - mp)).sum();
        let var: f64 = samples.iter().map(|(y, _)| (y - my) * (y - my)).sum();
        let slope = cov / var;
        let expected = -f64::from(mat.rest_density * g);
        println!("{pipeline:?}, hydrostatic column: max |v| = {vmax:.4} m/s, interior dp/dy = {slope:.1} Pa/m (expected {expected:.1})");
        assert!(
            (slope / expected - 1.0).abs() < 0.05,
            "interior dp/dy = {slope:.1} Pa/m, hydrostatics says {expected:.1} Pa/m"
        );

        // The Tait profile: (rho/rho0)^(gamma-1) = 1 + (gamma-1)/gamma rho0 g (h - z) / k.
        let gamma = mat.eos_power;
        let tait = |depth: f32| {
            (1.0 + (gamma - 1.0) / gamma * mat.rest_density * g * depth / mat.eos_stiffness)
                .powf(1.0 / (gamma - 1.0))
        };
        assert!(
            tait(h) > 1.011 && tait(h) < 1.013,
            "analytic bottom ratio {}, docs/physics.md says 1.012",
            tait(h)
        );
        let near_floor: Vec<f32> = (0..p.len())
            .filter(|&n| (p.x[n].y - lo).abs() < 0.01)
            .map(|n| p.rho[n])
            .collect();
        let measured = near_floor.iter().sum::<f32>() / near_floor.len() as f32 / mat.rest_density;
        assert!(
            (measured - tait(top - lo)).abs() < 0.003,
            "rho/rho0 three cells above the floor: {measured}, analytic {}",
            tait(top - lo)
        );
    }
}

#[test]
fn the_wall_mirror_gives_wall_particles_their_interior_density() {
    // A block flush against the floor and two walls, at rest: with the mirror, every particle that
    // touches a wall reads rest density exactly; without it, the outer layer reads 159/256 per wall.
    let toml = |mirror: bool| {
        common::water_box(
            24,
            &format!(
                "[solver]\ngravity = [0.0, 0.0, 0.0]\nmirror_wall_mass = {mirror}\n\
                 [[block]]\nmin = [0.01, 0.01, 0.01]\nmax = [0.08, 0.08, 0.08]"
            ),
        )
    };
    let outer: f32 = 159.0 / 256.0;
    for (mirror, pipeline) in [true, false]
        .into_iter()
        .flat_map(|m| [(m, Pipeline::Fused), (m, Pipeline::Binned)])
    {
        let mut scene = common::scene(&toml(mirror));
        scene.pipeline = pipeline;
        let (mut s, params) = common::cpu(&scene, 1.0e-4);
        s.clear_grid();
        s.p2g_init(&params);
        s.mirror_mass(&params);
        s.p2g(&params);
        s.mirror_momentum(&params);
        s.grid_update(&params);
        s.g2p(&params); // the density each particle carries on, under either rule
        let rho0 = params.materials[0].rest_density;
        // The particle in the corner of three walls, and one on the floor away from the other walls.
        for (at, walls) in [(Vec3::splat(0.0125), 3), (Vec3::new(0.0425, 0.0125, 0.0425), 1)] {
            let n = s
                .particles
                .x
                .iter()
                .position(|x| (*x - at).length() < 1e-5)
                .unwrap();
            let ratio = s.particles.rho[n] / rho0;
            let expected = if mirror { 1.0 } else { outer.powi(walls) };
            assert!(
                (ratio - expected).abs() < 1e-5,
                "{pipeline:?}, mirror {mirror}: rho/rho0 at {at} = {ratio}, expected {expected}"
            );
        }
    }
}

/// A 25 x 15 x 10 tank, the water in its low x corner: a small dam break under a CFL of 0.4.
const SMALL_DAM_BREAK: &str = common::tank!(
    [0.5, 0.3, 0.2],
    [25, 15, 10],
    r#"
[time_step]
cfl = 0.4
[[block]]
min = [0.04, 0.04, 0.04]
max = [0.2, 0.24, 0.14]
"#
);

/// The CFL number stays under its bound through the two ways a frame can speed up: a column collapsing
/// and hitting the far wall, and a ball hitting a pool (density, and c as rho^3, jump within a frame).
#[test]
fn cfl_number_stays_under_its_bound_in_a_dam_break_and_a_drop() {
    let dam_break = SMALL_DAM_BREAK;
    let drop = common::tank!(
        [0.3, 0.4, 0.3],
        [15, 20, 15],
        r#"
[time_step]
cfl = 0.4
[[block]]
min = [0.02, 0.02, 0.02]
max = [0.26, 0.08, 0.26]
[[sphere]]
center = [0.15, 0.25, 0.15]
radius = 0.06
velocity = [0.0, -2.0, 0.0]
"#
    );
    for (name, toml, frames) in [("dam break", dam_break, 45), ("drop", drop, 30)] {
        let scene = common::scene(toml);
        let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
        let (mut fastest, mut worst) = (0.0f32, 0.0f32);
        for _ in 0..frames {
            let stats = sim.advance_frame().unwrap();
            assert!(
                stats.max_cfl < 0.5,
                "{name}, frame {}: CFL {}",
                stats.frame,
                stats.max_cfl
            );
            fastest = fastest.max(stats.summary.max_speed);
            worst = worst.max(stats.max_cfl);
        }
        println!("{name}: max CFL {worst:.3}, max speed {fastest:.2} m/s");
        assert!(
            fastest > 1.0,
            "{name}: the fluid must really move (max speed {fastest} m/s)"
        );
    }
}

#[test]
fn every_preset_loads_and_steps_without_nan_inside_the_domain() {
    for name in presets::NAMES {
        let scene = Scene::load(name).unwrap_or_else(|e| panic!("{e}"));
        let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
        let (_, dt) = sim.next_frame_steps().unwrap();
        let mut params = *sim.params();
        params.dt = dt;
        for _ in 0..3 {
            sim.solver_mut().step(&params).unwrap();
        }
        let p = sim.solver_mut().read_particles().unwrap();
        assert_eq!(p.len(), scene.slots(), "{name}");
        let extent = Vec3::from(scene.grid_res.map(|r| r as f32)) * scene.dx;
        for n in 0..p.len() {
            assert!(
                p.x[n].is_finite() && p.v[n].is_finite() && p.rho[n].is_finite(),
                "{name}: NaN at {n}"
            );
            assert!(
                p.x[n].cmpge(Vec3::ZERO).all() && p.x[n].cmplt(extent).all(),
                "{name}: {} outside",
                p.x[n]
            );
        }
    }
}

/// A body at 50 m/s (Mach 5 at c0 = 10 m/s) hits the wall faster than the substep can follow: the
/// CFL number goes above 0.5 in the first frame. That may happen, but never unreported: every frame
/// whose CFL number is above the bound counts its substeps there, and the run ends with a warning.
#[test]
fn every_substep_above_the_cfl_bound_is_counted() {
    use mpm::sim::scene::MAX_CFL;
    let scene = common::scene(common::tank!(
        [0.4, 0.2, 0.2],
        [40, 20, 20],
        r#"
[solver]
gravity = [0.0, 0.0, 0.0]
[[sphere]]
center = [0.2, 0.1, 0.1]
radius = 0.05
velocity = [50.0, 0.0, 0.0]
"#
    ));
    // The binned pipeline (the report's density rule) rides this impact out with 12 substeps above
    // the bound; the fused pipeline's advected density lags it by a substep and blows up, which the
    // error names (checked below).
    let mut scene = scene;
    scene.pipeline = Pipeline::Binned;
    let mut fused = Simulation::new(
        Scene {
            pipeline: Pipeline::Fused,
            ..scene.clone()
        },
        mpm::backend::create(mpm::backend::BackendKind::Cpu, &scene).unwrap(),
    );
    if let Err(e) = (0..3).try_for_each(|_| fused.advance_frame().map(drop)) {
        assert!(format!("{e:#}").contains("--pipeline binned"), "{e:#}");
    }
    let solver = mpm::backend::create(mpm::backend::BackendKind::Cpu, &scene).unwrap();
    let mut sim = Simulation::new(scene, solver);
    let opts = mpm::runner::RunOptions::writing_nothing(3, std::time::Instant::now());
    let mut out = Vec::new();
    let all = mpm::runner::run(&mut sim, opts, &mut out).unwrap();
    for stats in &all {
        assert!(
            stats.max_cfl <= MAX_CFL || stats.substeps_over_cfl > 0,
            "frame {}: CFL {} above {MAX_CFL} uncounted",
            stats.frame,
            stats.max_cfl
        );
        assert!(stats.substeps_over_cfl <= stats.substeps);
    }
    let text = String::from_utf8(out).unwrap();
    if all.iter().any(|s| s.max_cfl > MAX_CFL) {
        assert!(
            text.contains("CFL>0.5 in") && text.contains("warning: the CFL number"),
            "{text}"
        );
    } else {
        assert!(!text.contains("warning"), "{text}");
    }
}

/// The viewer's way of stepping a slow frame: a piece at a time, each stopped by a deadline (here
/// one that has passed, so every call takes one substep), ending exactly where one call would.
#[test]
fn a_frame_can_be_stepped_a_substep_at_a_time() {
    let scene = common::scene(&common::water_box(
        16,
        "[[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.08, 0.1, 0.08]",
    ));
    let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
    let mut calls = 0;
    let steps = loop {
        calls += 1;
        match sim.step_frame_until(Some(std::time::Instant::now())).unwrap() {
            Some(steps) => break steps,
            None => {
                assert_eq!(sim.frame(), 0, "the frame is not complete yet");
                assert!(sim.time_stepped() > sim.time());
            }
        }
    };
    assert!(steps.substeps > 1);
    assert_eq!(calls, steps.substeps, "one substep per call");
    assert_eq!(sim.frame(), 1);
    assert!(
        (sim.time() - f64::from(mpm::sim::FRAME_DT)).abs() < 1e-9,
        "{}",
        sim.time()
    );
    assert_eq!(sim.time_stepped(), sim.time());
}

/// The viewer's overlapped frames (`Simulation::overlap_frames`): each frame's last stretch is left
/// in flight and accounted in the next. Frames still end exactly on the 60 Hz clock, the CFL bound
/// holds through a dam break, two runs take the same substeps to the same state, and `settle` gives
/// the clock back.
#[test]
fn overlapped_frames_keep_the_clock_and_the_cfl_bound() {
    let scene = common::scene(SMALL_DAM_BREAK);
    let run = |overlap: bool| {
        let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
        sim.overlap_frames(overlap).unwrap();
        let mut record = Vec::new();
        for frame in 1..=30u64 {
            let steps = sim.step_frame().unwrap();
            assert_eq!(sim.frame(), frame);
            let expected = frame as f64 * f64::from(mpm::sim::FRAME_DT);
            assert!(
                (sim.time() - expected).abs() < 1e-6,
                "frame {frame} ends at {}",
                sim.time()
            );
            assert!(steps.max_cfl < 0.5, "frame {frame}: CFL {}", steps.max_cfl);
            record.push((steps.substeps, steps.dt.to_bits()));
        }
        assert_eq!(
            sim.clock().is_some(),
            !overlap,
            "the clock waits for the trailing stretch"
        );
        sim.settle().unwrap();
        assert!(sim.clock().is_some());
        (record, sim.solver_mut().read_particles().unwrap().x)
    };
    let (overlapped, x) = run(true);
    let (again, y) = run(true);
    assert_eq!(overlapped, again, "overlapped runs choose the same substeps");
    assert!(x == y, "overlapped runs end in the same state");
    let (plain, _) = run(false);
    let total = |r: &[(u32, u32)]| r.iter().map(|s| s.0).sum::<u32>();
    println!(
        "substeps over 30 frames: overlapped {}, plain {}",
        total(&overlapped),
        total(&plain)
    );
}
