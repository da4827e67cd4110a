//! Solids on the grid against physics (docs/physics.md, "Solids"), on the CPU: an elastic bar's
//! longitudinal wave at sqrt(E / rho), two jelly cubes colliding with their total momentum kept, a
//! light jelly floating in water while a heavy one rests on the floor, sand standing at its angle of
//! repose, a snowball stopping on a wall where a jelly ball bounces; and, ignored at this file's 1 cm
//! (tests/gpu_solids.rs checks them finer), sand columns against Lube et al.'s runout. Each is coarse enough for
//! CI's two cores and prints what it measured (`cargo test --release --test solids -- --nocapture`);
//! tests/gpu_solids.rs runs the floating block, the sand bank and the snowball finer (the snowball
//! breaks only there), and the GPU against this oracle.

mod common;
mod materials_checks;
mod solids_checks;

use glam::Vec3;
use materials_checks::{particles, simulation};
use mpm::backend::BackendKind;
use mpm::sim::{Material, Particles, Solver};
use solids_checks::{
    ball_at_wall, block_in_water, colliding_cubes, jelly, lube_runout, repose_angle, sand_behind_gate,
    sand_column, sand_runout, settle_block, throw_at_wall,
};

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
    let scene = colliding_cubes("float");
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

/// A light jelly block ([`block_in_water`], 500 kg/m^3) at a cell of 1 cm floats: averaged over the
/// last 1.5 s of 3 it has between a quarter and three quarters of its height under the
/// surface (it neither sinks nor rides on top). Archimedes' half its height within 5 % is the GPU's
/// check, at 2.5 mm (tests/gpu_solids.rs): at 1 cm the block floats 15 % high (42.2 % under; 45.9 %
/// at 5 mm, 47.6 to 50.6 % at 2.5 mm on the H200), because the water's pressure reaches it through the nodes
/// both share, about half a cell below its lowest particles, an error of the order of dx over its
/// depth under water; the 5 mm run takes CI's two cores over four minutes.
#[test]
fn a_light_jelly_floats() {
    let dx = 0.01f32;
    let mut sim = simulation(&block_in_water(dx, 500.0, ""), BackendKind::CpuParallel);
    let settled = settle_block(&mut sim, dx);
    println!(
        "buoyancy at 1 cm: the light block {:.2} % under over the last 1.5 s (Archimedes 50 %)",
        100.0 * settled.fraction
    );
    assert!(
        (0.25..0.75).contains(&settled.fraction),
        "the light block is {:.1} % under: it does not float",
        100.0 * settled.fraction
    );
}

/// A heavy jelly block ([`block_in_water`], 1500 kg/m^3) at a cell of 1 cm, set 3 cells above the
/// floor, sinks and rests on it: its lowest particles within two and a half cells of it (the shared
/// grid leaves a film of water about two cells thick under a body resting on a wall; 1.78 cells
/// here).
#[test]
fn a_heavy_jelly_sinks_to_the_floor() {
    let dx = 0.01f32;
    let mut sim = simulation(&block_in_water(dx, 1500.0, ""), BackendKind::CpuParallel);
    let settled = settle_block(&mut sim, dx);
    println!(
        "sinking: the heavy block's bottom {:.2} cells above the floor",
        settled.bottom_cells
    );
    assert!(
        settled.bottom_cells < 2.5,
        "the heavy block's bottom is {:.2} cells above the floor",
        settled.bottom_cells
    );
}

// ---------------------------------------------------------------------------------------------
// Sand
// ---------------------------------------------------------------------------------------------

/// Two quasi-2D columns of dry sand (friction angle 30 degrees) collapse on a floor of their own
/// friction: a low one (aspect ratio a = height / length 0.5, 20 x 10 cm) and a tall one (a = 3,
/// 8 x 24 cm). Their runouts (L_inf - L_0) / L_0, once stopped, follow Lube et al. (2005): 1.2 a
/// below a = 1.8 and 1.9 a^(2/3) above, within 15 %. Met at 2.5 and 1.25 mm cells, which
/// tests/gpu_solids.rs checks; not at this test's 1 cm.
#[test]
#[ignore = "at 1 cm cells the columns run out 37 and 28 % short of Lube et al. (the low one is ten cells high); \
            tests/gpu_solids.rs checks them within 15 % at 2.5 and 1.25 mm; `cargo test --release --test solids -- \
            --ignored` measures them here"]
fn sand_columns_run_out_as_lube_et_al_found() {
    let dx = 0.01f32;
    let mut worst = 0.0f32;
    for (length, height) in [(0.2f32, 0.1f32), (0.08, 0.24)] {
        let a = height / length;
        let scene = sand_column(dx, length, height);
        let mut sim = simulation(&scene, BackendKind::CpuParallel);
        let runout = sand_runout(&mut sim, dx, length, 1.5);
        let expected = lube_runout(a);
        println!(
            "sand column a = {a:.2}: runout (L_inf - L_0) / L_0 = {runout:.3}, Lube et al. {expected:.3} ({:+.1} %)",
            100.0 * (runout / expected - 1.0)
        );
        worst = worst.max((runout / expected - 1.0).abs());
    }
    assert!(
        worst < 0.15,
        "a runout strays {:.1} % from Lube et al.'s (15 % allowed)",
        100.0 * worst
    );
}

/// The angle of repose by the lifting-gate (draining) test: a quasi-2D bank of sand 10 cm square
/// (friction angle 30 degrees) held against the wall by a gate that lifts at 5 cm/s runs out under
/// it and leaves a slope standing at the friction angle within 3 degrees ([`sand_behind_gate`],
/// [`repose_angle`]; 1 cm cells: 28.6 degrees on a 2-core CPU; tests/gpu_solids.rs measures 1 cm
/// to 1.25 mm on the GPU).
#[test]
fn sand_left_by_a_lifted_gate_stands_at_its_friction_angle() {
    let dx = 0.01f32;
    let scene = sand_behind_gate(dx);
    let mut sim = simulation(&scene, BackendKind::CpuParallel);
    let angle = repose_angle(&mut sim, dx, 4.0);
    println!("the bank stands at {angle:.1} degrees, its friction angle 30");
    assert!(
        (angle - 30.0).abs() <= 3.0,
        "the bank stands at {angle:.1} degrees, not 30 +- 3"
    );
}

// ---------------------------------------------------------------------------------------------
// Snow
// ---------------------------------------------------------------------------------------------

/// A snowball 10 cm across thrown at a wall at 8 m/s ([`ball_at_wall`], 1 cm cells) stops on it
/// where a jelly ball of the same stiffness bounces off whole: after half a second the snow's mean x
/// velocity is under a third of the jelly's rebound, no particle is lost, and every snow particle's
/// elastic singular values stay inside their clamp with J_p positive ([`throw_at_wall`]). Ten cells
/// across are too few for it to break: tests/gpu_solids.rs throws it at 2.5 mm cells, where it does.
#[test]
fn a_snowball_stops_on_a_wall_inside_its_clamp_where_a_jelly_ball_bounces_off_whole() {
    let dx = 0.01f32;
    let [snow, jelly] = ["snow", "fixed-corotated"].map(|law| {
        println!("a {law} ball:");
        let scene = ball_at_wall(dx, law);
        let mut sim = simulation(&scene, BackendKind::CpuParallel);
        throw_at_wall(&mut sim, &scene, dx, 0.5)
    });
    assert_eq!(
        jelly.pieces.len(),
        1,
        "the jelly ball broke into {} pieces",
        jelly.pieces.len()
    );
    assert!(
        jelly.mean_vx < -2.0,
        "the jelly ball has not bounced: {:+.3} m/s",
        jelly.mean_vx
    );
    assert!(
        snow.mean_vx.abs() < jelly.mean_vx.abs() / 3.0,
        "the snowball bounced like the jelly: {:+.3} against {:+.3} m/s",
        snow.mean_vx,
        jelly.mean_vx
    );
}
