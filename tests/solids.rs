//! Solids on the grid against physics (docs/physics.md, "Solids"), on the CPU: an elastic bar's
//! longitudinal wave at sqrt(E / rho), two jelly cubes colliding with their total momentum kept, a
//! light jelly floating in water at Archimedes' depth while a heavy one rests on the floor. Each is
//! coarse enough for CI's two cores and prints what it measured
//! (`cargo test --release --test solids -- --nocapture`); the GPU runs them against this oracle
//! (tests/gpu_solids.rs).

mod common;
mod materials_checks;
mod solids_checks;

use glam::Vec3;
use materials_checks::{particles, simulation};
use mpm::backend::BackendKind;
use mpm::sim::{Material, Particles, Solver};
use solids_checks::{colliding_cubes, float_blocks, floating_blocks, jelly};

// ---------------------------------------------------------------------------------------------
// Elastic waves
// ---------------------------------------------------------------------------------------------

/// A free bar, 40 x 4 x 4 cells, of a Poisson's ratio 0 solid (E = 100 kPa, rho = 1000 kg/m^3:
/// sqrt(E / rho) = 10 m/s), without gravity, started in its first longitudinal mode, v(x) = v0
/// cos(pi x / L) (the ends moving in at v0 = 5 cm/s, a strain of 5e-3). Its length oscillates with
/// the period 2 L / c of that mode: the wave speed measured from the time between the length's
/// crossings of its mean over two and a half periods is sqrt(E / rho) within 5 %.
#[test]
fn a_longitudinal_wave_runs_along_an_elastic_bar_at_sqrt_e_over_rho() {
    let (dx, rho, e, v0) = (0.01f32, 1000.0f32, 1.0e5f32, 0.05f32);
    let (x0, length) = (0.1f32, 0.4f32);
    let scene = common::scene(&format!(
        "[domain]\nsize = [0.6, 0.1, 0.1]\nresolution = [60, 10, 10]\n{}\
         [solver]\ngravity = [0.0, 0.0, 0.0]\n\
         [[block]]\nmin = [{x0}, 0.03, 0.03]\nmax = [{}, 0.07, 0.07]\n",
        jelly("bar", rho, e, 0.0),
        x0 + length
    ));
    let c = (e / rho).sqrt();
    let dt = 0.3 * dx / c;
    let (mut solver, mut params) = common::cpu(&scene, dt);
    params.dt = dt;
    let p = &mut solver.particles;
    for n in 0..p.len() {
        p.v[n] = Vec3::new(
            v0 * (std::f32::consts::PI * (p.x[n].x - x0) / length).cos(),
            0.0,
            0.0,
        );
    }
    // The bar's ends: the particles of its first and last layer of cells. Their velocities, v0 cos(pi
    // x / L) cos(omega t) at the start, swing opposite ways: the difference of their means crosses 0 at
    // a quarter period and every half period after, whatever the drift of the bar as a whole.
    let start = p.x.clone();
    let first: Vec<usize> = (0..p.len()).filter(|&n| start[n].x < x0 + dx).collect();
    let last: Vec<usize> = (0..p.len()).filter(|&n| start[n].x > x0 + length - dx).collect();
    let spread = |v: &[Vec3]| {
        let mean = |set: &[usize]| set.iter().map(|&n| v[n].x).sum::<f32>() / set.len() as f32;
        mean(&last) - mean(&first)
    };
    let period = 2.0 * length / c;
    let steps = (2.5 * period / dt).ceil() as usize;
    let mut spreads = Vec::with_capacity(steps + 1);
    spreads.push(spread(&solver.particles.v));
    for _ in 0..steps {
        solver.step(&params).unwrap();
        spreads.push(spread(&solver.particles.v));
    }
    let crossings: Vec<f32> = spreads
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[0] * w[1] < 0.0)
        .map(|(k, w)| (k as f32 + w[0] / (w[0] - w[1])) * dt)
        .collect();
    assert!(
        crossings.len() >= 4,
        "the ends' velocities crossed {} times",
        crossings.len()
    );
    let half_periods = (crossings.len() - 1) as f32;
    let measured_period = 2.0 * (crossings[crossings.len() - 1] - crossings[0]) / half_periods;
    let measured = 2.0 * length / measured_period;
    let amplitude = spreads.iter().fold(0.0f32, |a, s| a.max(s.abs()));
    println!(
        "elastic bar: period {measured_period:.5} s over {} crossings (2 L / c = {period:.5} s), wave speed \
         {measured:.3} m/s against sqrt(E / rho) = {c:.3} m/s ({:+.2} %); the ends' velocities {amplitude:.3} m/s apart at most",
        crossings.len(),
        100.0 * (measured / c - 1.0)
    );
    assert!(
        (measured / c - 1.0).abs() < 0.05,
        "the wave runs at {measured:.3} m/s, sqrt(E / rho) = {c:.3} m/s (5 % allowed)"
    );
}

// ---------------------------------------------------------------------------------------------
// Momentum
// ---------------------------------------------------------------------------------------------

/// Total momentum sum m_p v_p, in f64.
fn momentum(p: &Particles, params: &mpm::sim::Params) -> [f64; 3] {
    let mut total = [0.0f64; 3];
    for n in (0..p.len()).filter(|&n| p.live[n]) {
        let m = f64::from(Material::of(params, p.material[n]).particle_mass);
        for (a, t) in total.iter_mut().enumerate() {
            *t += m * f64::from(p.v[n][a]);
        }
    }
    total
}

/// Two 6 cm jelly cubes ([`colliding_cubes`]), one flying at +1 m/s into one at -0.5 m/s, without
/// gravity and clear of the walls: they meet and squash, and the total momentum stays within 1e-5
/// of what it was (relative), the transfers' conservation in the solids' stress.
#[test]
fn colliding_jelly_cubes_keep_their_total_momentum() {
    let scene = colliding_cubes("");
    let mut sim = simulation(&scene, BackendKind::Cpu);
    let params = *sim.params();
    let before = momentum(&particles(&mut sim), &params);
    let scale = before.iter().map(|m| m * m).sum::<f64>().sqrt();
    let mut worst = 0.0f64;
    let mut first_speed = 0.0f32;
    for frame in 1..=12 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        let p = particles(&mut sim);
        let now = momentum(&p, &params);
        let drift = (0..3).map(|a| (now[a] - before[a]).powi(2)).sum::<f64>().sqrt() / scale;
        worst = worst.max(drift);
        // The first cube's mean velocity (it was spawned first: the lower half of the slots).
        let half = p.len() / 2;
        first_speed = (0..half).map(|n| p.v[n].x).sum::<f32>() / half as f32;
        println!(
            "  frame {frame}: momentum ({:.6}, {:.2e}, {:.2e}) kg m/s, drift {drift:.2e}; first cube at {first_speed:+.3} m/s",
            now[0], now[1], now[2]
        );
    }
    println!(
        "colliding cubes: momentum {:.6} kg m/s at the start, worst drift {worst:.2e}",
        before[0]
    );
    // On one grid the cubes meet through the nodes both reach, which holds them together (no contact
    // model: they part slowly, not elastically): the first keeps about a fiftieth of its speed.
    assert!(
        first_speed < 0.5,
        "the first cube still moves at {first_speed:+.3} m/s: the cubes never met"
    );
    assert!(
        worst < 1e-5,
        "the total momentum drifted by {worst:.2e} of itself (1e-5 allowed)"
    );
}

// ---------------------------------------------------------------------------------------------
// Buoyancy
// ---------------------------------------------------------------------------------------------

/// [`floating_blocks`] at a cell of 1 cm: the light block bobs to Archimedes' depth, half its
/// height under the surface (the ratio of the densities), within 5 %, averaged over the last second
/// of 3 s; the heavy one sinks 3 cells and rests on the floor: its lowest particles within 1.5 cells
/// of it (the shared grid keeps about a cell of water under a body resting on a wall), still.
#[test]
fn a_light_jelly_floats_at_archimedes_depth_and_a_heavy_one_sinks() {
    let dx = 0.01f32;
    let scene = floating_blocks(dx, "");
    let mut sim = simulation(&scene, BackendKind::CpuParallel);
    let floating = float_blocks(&mut sim, dx);
    println!(
        "buoyancy: the light block {:.2} % under over the last second (Archimedes 50 %); the heavy \
         block's bottom {:.2} cells above the floor, at {:.1e} m/s",
        100.0 * floating.fraction,
        floating.heavy_bottom_cells,
        floating.heavy_speed
    );
    assert!(
        (floating.fraction / 0.5 - 1.0).abs() < 0.05,
        "the light block floats {:.1} % under, Archimedes 50 % (5 % allowed)",
        100.0 * floating.fraction
    );
    assert!(
        floating.heavy_bottom_cells < 1.5 && floating.heavy_speed < 1e-3,
        "the heavy block's bottom is {:.2} cells above the floor, moving at {:.1e} m/s",
        floating.heavy_bottom_cells,
        floating.heavy_speed
    );
}
