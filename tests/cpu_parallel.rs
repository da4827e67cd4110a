//! The multi-threaded CPU backend against the single-thread reference: each phase on jittered
//! particles in a walled tank (mirror, band and clamp all active), a 200-substep dam break, and
//! determinism whatever the thread count.
//!
//! Tolerances: both compute the same per-particle expressions (the functions are shared), but the
//! parallel scatter adds a node's contributions tile by tile rather than in particle order. A node sum
//! of k terms then differs by a few ulps of its largest term: relative errors near 1e-7. The bounds
//! below are 1e-5 of each quantity's scale, as for the GPU's float scatter.

mod common;

use mpm::sim::cpu::CpuSolver;
use mpm::sim::cpu_parallel::ParallelCpuSolver;
use mpm::sim::{Particles, Scene, Solver};

/// A 32 x 24 x 24 tank, dx = 1/32 m, the block flush against the floor and two walls.
fn tank() -> Scene {
    common::scene(common::tank!(
        [1.0, 0.75, 0.75],
        [32, 24, 24],
        r#"
[[block]]
min = [0.03125, 0.03125, 0.03125]
max = [0.6, 0.5, 0.5]
"#
    ))
}

/// The scene's lattice jittered by up to 0.2 particle spacings, with random velocities and C.
fn jittered(scene: &Scene, seed: u64) -> Particles {
    let spacing = scene.lattice().spacing as f32;
    let mut p = scene.spawn();
    let noise = common::random_particles(p.len(), -1.0, 1.0, 1.0, 5.0, seed);
    let (lo, hi) = scene.fluid_region();
    for i in 0..p.len() {
        p.x[i] = (p.x[i] + noise.x[i] * 0.2 * spacing).clamp(lo.as_vec3(), hi.as_vec3());
        p.v[i] = noise.v[i];
        p.c[i] = noise.c[i];
    }
    p
}

#[test]
fn each_phase_matches_the_reference() {
    let scene = tank();
    let params = common::cfl_params(&scene);
    let particles = jittered(&scene, 7);
    let mut reference = CpuSolver::new(particles.clone(), scene.grid_res);
    let mut parallel = ParallelCpuSolver::new(particles, scene.grid_res);
    assert!(
        !parallel.sequential(),
        "the tank is large enough for the parallel path"
    );

    reference.clear_grid();
    reference.p2g_init(&params);
    reference.mirror_mass(&params);
    parallel.clear_grid();
    parallel.bin(&params);
    parallel.p2g_init(&params);
    let mass_scale = common::max_abs(reference.grid.mass.iter().copied());
    let mass_err = common::max_abs(
        reference
            .grid
            .mass
            .iter()
            .zip(&parallel.grid().mass)
            .map(|(a, b)| a - b),
    );
    assert!(
        mass_scale > 0.0 && mass_err <= 1e-5 * mass_scale,
        "mass {mass_err} of {mass_scale}"
    );

    reference.p2g(&params);
    parallel.p2g(&params);
    let rho_err = common::max_abs(
        reference
            .particles
            .rho
            .iter()
            .zip(&parallel.particles().rho)
            .map(|(a, b)| a - b),
    );
    assert!(rho_err <= 1e-5 * 1000.0, "density {rho_err}");
    let mv_scale = common::max_abs(reference.grid.momentum.iter().map(|v| v.abs().max_element()));
    let mv_err = common::max_diff_vec3(&reference.grid.momentum, &parallel.grid().momentum);
    assert!(mv_err <= 1e-5 * mv_scale, "momentum {mv_err} of {mv_scale}");

    reference.mirror_momentum(&params);
    reference.grid_update(&params);
    reference.g2p(&params);
    parallel.grid_update(&params);
    parallel.g2p(&params);
    let (a, b) = (&reference.particles, parallel.particles());
    let x_err = common::max_diff_vec3(&a.x, &b.x) / scene.dx;
    let v_scale = common::max_abs(a.v.iter().map(|v| v.abs().max_element()));
    let v_err = common::max_diff_vec3(&a.v, &b.v);
    let c_scale = common::max_abs(
        a.c.iter()
            .map(|c| c.abs().to_cols_array().into_iter().fold(0.0, f32::max)),
    );
    let c_err = common::max_diff_mat3(&a.c, &b.c);
    println!("x {x_err:.2e} dx, v {v_err:.2e} of {v_scale:.2e}, C {c_err:.2e} of {c_scale:.2e}");
    assert!(x_err <= 1e-5, "position {x_err} dx");
    assert!(v_err <= 1e-5 * v_scale, "velocity {v_err} of {v_scale}");
    assert!(c_err <= 1e-5 * c_scale, "C {c_err} of {c_scale}");
    let (a, b) = (
        reference.take_extremes().unwrap(),
        Solver::take_extremes(&mut parallel).unwrap(),
    );
    assert!(
        (a.max_density - b.max_density).abs() <= 1e-5 * a.max_density
            && (a.max_signal_speed - b.max_signal_speed).abs() <= 1e-5 * a.max_signal_speed,
        "extremes {a:?} vs {b:?}"
    );
}

/// 200 substeps of the tank's dam break: the trajectories stay within 1e-4 dx of each other.
#[test]
fn a_dam_break_follows_the_reference() {
    let scene = tank();
    let params = common::cfl_params(&scene);
    let mut reference = CpuSolver::new(scene.spawn(), scene.grid_res);
    let mut parallel = ParallelCpuSolver::new(scene.spawn(), scene.grid_res);
    for _ in 0..200 {
        reference.step(&params).unwrap();
        parallel.step(&params).unwrap();
    }
    let err = common::max_diff_vec3(&reference.particles.x, &parallel.particles().x) / scene.dx;
    let moved = common::max_diff_vec3(&reference.particles.x, &scene.spawn().x) / scene.dx;
    println!("after 200 substeps: moved up to {moved:.2} dx, apart by {err:.2e} dx");
    assert!(moved > 0.5, "the dam break did not move");
    assert!(err <= 1e-4, "parallel and reference apart by {err} dx");
}

/// The same state from 1, 2 and 3 threads, bit for bit.
#[test]
fn the_result_does_not_depend_on_the_thread_count() {
    let scene = tank();
    let params = common::cfl_params(&scene);
    let run = |threads: usize| -> Vec<u32> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut solver = ParallelCpuSolver::new(jittered(&scene, 3), scene.grid_res);
            for _ in 0..20 {
                solver.step(&params).unwrap();
            }
            common::particle_bits(solver.particles())
        })
    };
    let one = run(1);
    assert!(one == run(2), "2 threads differ from 1");
    assert!(one == run(3), "3 threads differ from 1");
}

/// `--backend auto` picks CUDA where a device works, else the multi-threaded CPU backend.
#[test]
fn auto_picks_cuda_or_else_the_parallel_cpu_backend() {
    let scene = tank();
    let solver = mpm::backend::create(mpm::backend::BackendKind::Auto, &scene).unwrap();
    let expected = match mpm::cuda::library::device_available() {
        Ok(()) => "cuda",
        Err(_) => "cpu-parallel",
    };
    assert_eq!(solver.name(), expected);
}

/// Below SEQUENTIAL_BELOW particles the backend is the reference itself: bit-identical states.
#[test]
fn a_small_scene_runs_the_reference_on_one_thread() {
    let scene = common::scene(&common::water_box(
        16,
        "[[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.08, 0.1, 0.08]",
    ));
    assert!(scene.num_particles < mpm::sim::cpu_parallel::SEQUENTIAL_BELOW);
    let params = common::cfl_params(&scene);
    let mut reference = CpuSolver::new(scene.spawn(), scene.grid_res);
    let mut parallel = ParallelCpuSolver::new(scene.spawn(), scene.grid_res);
    assert!(parallel.sequential());
    for _ in 0..20 {
        reference.step(&params).unwrap();
        parallel.step(&params).unwrap();
    }
    assert!(
        reference.particles.x == parallel.particles().x && reference.particles.v == parallel.particles().v
    );
}
