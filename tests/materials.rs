//! Liquids beyond water against published results (docs/physics.md, "Materials" and "Several
//! liquids"), on the CPU: a viscous gravity current against Huppert's similarity solution, a Bingham
//! slump against its static profile, power-law films down an incline against their velocity profile,
//! and oil over water settling into two layers with the floor's hydrostatic pressure; and the
//! viewer's live controls acting on the liquid they name. Each check of physics is a
//! quasi-2D slab, 5 cells thick in z between the free-slip walls (the fewest a grid of 8 nodes, the
//! smallest allowed, leaves), on a coarse grid; each prints what it measured
//! (`cargo test --release --test materials -- --nocapture`).

mod common;
mod materials_checks;

use glam::Vec3;
use materials_checks::{
    area, axisymmetric_slump, box_vortex, film, no_slip_floor, particles, quantile, simulation, G,
    THICKENING, THINNING,
};
use mpm::backend::BackendKind;
use mpm::sim::cpu::{grid_density, CpuSolver, Stencil};
use mpm::sim::material::MaterialTable;
use mpm::sim::simulation::StepLimit;
use mpm::sim::{Material, Particles, Scene};

// ---------------------------------------------------------------------------------------------
// Viscous gravity current (Huppert 1982)
// ---------------------------------------------------------------------------------------------

/// A 20 x 20 cm column of a liquid of 10 Pa s on a no-slip floor ([`no_slip_floor`]), released
/// against the low x wall. After the first slump its front (the 99.9th percentile of the
/// particles' x, from the wall's mirror plane) follows Huppert's similarity solution for a fixed
/// volume in 2D, x_N = 1.411 (rho g A^3 t / (3 mu))^(1/5), within 10 % over a decade of time, 0.5
/// to 5 s.
///
/// Dimensions: dx = 1 cm; the current's mean thickness A / x_N falls from 7 to 4.5 cells over the
/// decade. The reduced Reynolds number rho U h^2 / (mu x_N) (lubrication theory's measure of
/// inertia, U = 0.2 x_N / t) is 0.2 at 0.5 s and under 0.1 from 1 s on. The sound speed of 5 m/s
/// compresses the column by g h / c0^2 = 8 % at the start, 3 % from 0.5 s on.
#[test]
fn a_viscous_current_spreads_as_huppert_s_similarity_solution() {
    let (dx, mu, rho) = (0.01f32, 10.0f32, 1000.0f32);
    let floor = dx; // the floor wall's mirror plane, node 1
    let scene = common::scene(&format!(
        "[domain]\nsize = [0.97, 0.25, 0.08]\nresolution = [97, 25, 8]\n\
         [material]\nrest_density = {rho}\nsound_speed = 5.0\nviscosity = {mu}\n\
         [time_step]\ncfl = 0.4\n{}\
         [[block]]\nmin = [0.01, {floor}, 0.01]\nmax = [0.21, {}, 0.06]\nparticles_per_cell = 8",
        no_slip_floor(0.97, 0.08, dx),
        floor + 0.2
    ));
    let mut sim = simulation(&scene, BackendKind::CpuParallel);
    let count = particles(&mut sim).num_live();
    let a = area(count, dx, 8.0, 0.05);
    let wall = dx; // the low x wall's mirror plane, node 1
    let constant = rho * G * a * a * a / (3.0 * mu);
    println!("viscous current: A = {a:.5} m^2, mu = {mu} Pa s, {count} particles");
    let mut worst = 0.0f32;
    let mut frame = 0u64;
    for t_check in [0.5f32, 1.0, 2.0, 3.5, 5.0] {
        while (frame as f32) < t_check * 60.0 - 0.5 {
            sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
            frame += 1;
        }
        let p = particles(&mut sim);
        let xs: Vec<f32> = p.x.iter().map(|x| x.x - wall).collect();
        let front = quantile(xs.clone(), 0.999);
        let front_99 = quantile(xs, 0.99);
        let t = frame as f32 / 60.0;
        let predicted = 1.411 * (constant * t).powf(0.2);
        let error = front / predicted - 1.0;
        worst = worst.max(error.abs());
        println!(
            "  t = {t:.2} s: front (99.9th percentile of x) {front:.4} m (99th {front_99:.4}), \
             Huppert {predicted:.4} m, {:+.1} %",
            100.0 * error
        );
    }
    assert!(
        worst < 0.10,
        "the front strays {:.1} % from Huppert's x_N (10 % allowed)",
        100.0 * worst
    );
}

// ---------------------------------------------------------------------------------------------
// The viscous stress alone: a box vortex
// ---------------------------------------------------------------------------------------------

/// A box vortex ([`box_vortex`]: 10 cm square, 32 cells across, free-slip walls, no gravity) in
/// liquids of 4 and 11 Pa s decays at its Stokes rate, the kinetic energy as exp(-4 nu k^2 t), within
/// 3 %. The 11 Pa s run's substep sits at nu dt / dx^2 = 0.14, as the Stokes sphere's does at 10 cells
/// (tests/gpu_bodies.rs), so the bulk viscous stress is exact to a few percent there and what that
/// check misses lies at the bodies' boundaries. CPU, 2026-11-29: +1.3 % and -0.1 % (what the transfers
/// dissipate on their own, 0.65 per second at 0.001 Pa s, is the first one's excess).
#[test]
fn a_box_vortex_decays_at_its_viscous_rate() {
    for viscosity in [4.0, 11.0] {
        let d = box_vortex(BackendKind::CpuParallel, 32, viscosity, "float", 6);
        let error = d.rate / d.expected - 1.0;
        println!(
            "box vortex, {viscosity} Pa s: energy decays at {:.3} per second against 4 nu k^2 = {:.3}: {:+.1} % \
             (substep {:.1} us, nu dt / dx^2 = {:.3})",
            d.rate,
            d.expected,
            100.0 * error,
            1e6 * d.dt,
            d.viscous_number
        );
        assert!(
            error.abs() < 0.03,
            "{viscosity} Pa s: the vortex decays {:+.1} % off its rate",
            100.0 * error
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Bingham slump
// ---------------------------------------------------------------------------------------------

/// The top of the liquid in the column of cells `[x0, x0 + dx)`, above the floor at `floor`: the
/// highest particle plus a quarter cell (half the spacing of 8 particles per cell); 0 where the
/// column is empty.
fn height_at(p: &Particles, x0: f32, dx: f32, floor: f32) -> f32 {
    let top =
        p.x.iter()
            .filter(|x| x.x >= x0 && x.x < x0 + dx)
            .map(|x| x.y)
            .fold(f32::NEG_INFINITY, f32::max);
    if top.is_finite() {
        top + 0.25 * dx - floor
    } else {
        0.0
    }
}

/// A 0.5 x 1 m column of a Bingham liquid (Herschel-Bulkley with n = 1: yield stress 800 Pa,
/// plastic viscosity 10 Pa s, 1000 kg/m^3) released against the low x wall on a no-slip floor, at
/// dx = 5 cm. It slumps and stops where the yield stress holds its weight: the shallow static
/// profile h(x)^2 = 2 tau_y (x_f - x) / (rho g), whose area A = (2/3) sqrt(2 tau_y / (rho g))
/// x_f^(3/2) fixes the runout x_f (1.51 m here, the mound 0.5 m high at the wall). After 2.5 s the
/// runout and the height at a quarter and at half of it must match within 10 %, and the front move
/// less than a cell in the last second. The height at three quarters is printed, not asserted: the
/// nose is a few cells high there and blunter than the shallow theory's sqrt(x_f - x) (25 % above
/// it, where the rest is within 3 %).
///
/// The ceiling max_viscosity is the bi-viscous regularisation: below the shear rate
/// tau_y / max_viscosity the liquid is a Newtonian one of max_viscosity, so it never stops but
/// creeps, its surface at about tau_y h / (2 max_viscosity), while the explicit viscous limit takes
/// substeps of rho0 dx^2 / (6 max_viscosity). 3000 Pa s (0.14 ms, 120 substeps a frame) is the
/// choice: its front creeps 2.5 cm (0.5 cells) in the last second and its mound keeps the profile;
/// 2000 Pa s (with K = 1 Pa s) crept 2.6 cm in the fourth second and flattened the mound to 16 %
/// under the profile at the wall, and twice the ceiling costs twice the substeps. The kinetic
/// energy does not fall to 1e-6 of its peak: it levels off at about 1.7e-4 of it (printed;
/// docs/physics.md, "Yield stress", says why a higher ceiling does not help). The elastic
/// regularisation comes to rest: the next test.
#[test]
fn a_bingham_slump_stops_on_its_yield_stress_profile() {
    let (dx, rho, tau, ceiling) = (0.05f32, 1000.0f32, 800.0f32, 3000.0f32);
    let floor = dx;
    let scene = common::scene(&format!(
        "[domain]\nsize = [2.0, 1.2, 0.4]\nresolution = [40, 24, 8]\n\
         [material]\nlaw = \"herschel-bulkley\"\nrest_density = {rho}\nsound_speed = 20.0\n\
         consistency = 10.0\nflow_index = 1.0\nyield_stress = {tau}\nmax_viscosity = {ceiling}\n\
         [time_step]\ncfl = 0.4\n{}\
         [[block]]\nmin = [0.05, {floor}, 0.05]\nmax = [0.55, {}, 0.3]\nparticles_per_cell = 8",
        no_slip_floor(2.0, 0.4, dx),
        floor + 1.0
    ));
    let mut sim = simulation(&scene, BackendKind::CpuParallel);
    let count = particles(&mut sim).num_live();
    let a = area(count, dx, 8.0, 0.25);
    let scale = 2.0 * tau / (rho * G); // h^2 = scale (x_f - x)
    let runout = (1.5 * a / scale.sqrt()).powf(2.0 / 3.0);
    println!(
        "Bingham slump: A = {a:.4} m^2, tau_y = {tau} Pa, max_viscosity = {ceiling} Pa s, predicted runout {runout:.4} m, height at the wall {:.4} m",
        (scale * runout).sqrt()
    );
    let wall = dx;
    let front = |p: &Particles| quantile(p.x.iter().map(|x| x.x - wall).collect(), 0.999);
    let (checks, frames_per_check) = (10u64, 15u64); // 2.5 s
    let mut peak = 0.0f64;
    let mut fronts = Vec::new();
    let mut energy = 0.0f64;
    for check in 1..=checks {
        for _ in 0..frames_per_check {
            let stats = sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
            energy = stats.summary.kinetic_energy;
            peak = peak.max(energy);
        }
        let p = particles(&mut sim);
        fronts.push(front(&p));
        println!(
            "  t = {:.2} s: front {:.4} m, kinetic energy {energy:.3e} J ({:.2e} of its peak), {} substeps a frame",
            check as f32 * frames_per_check as f32 / 60.0,
            fronts.last().unwrap(),
            energy / peak,
            sim.next_frame_steps().unwrap().0
        );
    }
    let p = particles(&mut sim);
    let measured = *fronts.last().unwrap();
    let moved = measured - fronts[fronts.len() - 5]; // over the last second
    let runout_error = measured / runout - 1.0;
    println!(
        "  runout {measured:.4} m against {runout:.4} m ({:+.1} %); the front moved {moved:.4} m in the last second; kinetic energy {:.2e} of its peak",
        100.0 * runout_error,
        energy / peak
    );
    let mut worst = runout_error.abs();
    for fraction in [0.25f32, 0.5, 0.75] {
        let x0 = wall + (fraction * runout / dx).floor() * dx;
        let x = x0 + 0.5 * dx - wall;
        let h = height_at(&p, x0, dx, floor);
        let predicted = (scale * (runout - x)).sqrt();
        let error = h / predicted - 1.0;
        if fraction <= 0.5 {
            worst = worst.max(error.abs());
        }
        println!(
            "  h({x:.3} m) = {h:.4} m against {predicted:.4} m ({:+.1} %)",
            100.0 * error
        );
    }
    assert!(
        moved.abs() < dx,
        "the front moved {moved} m in the last second (a cell is {dx} m)"
    );
    assert!(
        worst < 0.10,
        "the profile strays {:.1} % from the static one (10 % allowed)",
        100.0 * worst
    );
}

/// The slump test of rheometry with the elastic regularisation ([`axisymmetric_slump`], which
/// gives the set-up and the theory), at 1 cm: at rest after 6 s, its runout within 10 % of
/// Roussel and Coussot's.
#[test]
fn an_elastoviscoplastic_slump_comes_to_rest_at_its_yield_stress_runout() {
    axisymmetric_slump(BackendKind::CpuParallel, 0.01).assert_at_rest_at_its_runout();
}

// ---------------------------------------------------------------------------------------------
// Power-law film down an incline
// ---------------------------------------------------------------------------------------------

/// Shear-thinning (n = 0.5) and shear-thickening (n = 1.5) films falling down a no-slip wall: the
/// velocity profile against u(y) proportional to 1 - (1 - y/h)^((n+1)/n).
///
/// 10 cells across ([`THINNING`], [`THICKENING`]; tests/gpu_materials.rs checks both at 40).
///
/// The target is 5 %. n = 1.5 meets it (1.4 %). n = 0.5 does not at this cell: its worst layer is
/// 7.3 % of U off, the film shearing too little at the wall and too much in its upper half (its amplitude 1.12
/// of the developed film's surface speed). Its bound here is 8 %, what it reaches, so that a change
/// for the worse fails; docs/physics.md, "Materials", says so. (10.9 % and 2.1 % before the viscous
/// stress took the rest volume: the film's first layers, on the collider, read 0.62 and 0.85 of the
/// rest density.)
#[test]
fn power_law_films_have_the_power_law_velocity_profile() {
    for law in [THINNING, THICKENING] {
        let n = law.n;
        let (worst, amplitude) = film(BackendKind::CpuParallel, 10, law);
        let allowed = if n < 1.0 { 0.08 } else { 0.05 };
        assert!(
            worst < allowed,
            "n = {n}: the profile strays {:.1} % of U from the power law's ({:.0} % allowed)",
            100.0 * worst,
            100.0 * allowed
        );
        assert!(
            amplitude > 0.5,
            "n = {n}: U is {amplitude} of the developed film's surface speed: the film barely moved"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Two liquids
// ---------------------------------------------------------------------------------------------

/// The pressure at the floor of a tank (the wall's mirror plane at y = `floor`) from the particles of
/// the bottom layer, a liquid of rest density `rho` (`bottom(n)`): the mean over them of Tait's law
/// of `density(n)` plus the hydrostatic rho g (y - floor) that takes each to the floor.
///
/// Why a mean over the whole layer and not a line fitted to p(y): a gathered density reads a lattice
/// of particles that the weight has compressed off the grid's spacing alternately high and low, layer
/// by layer (the layers' phase against the nodes drifts), with a period of two cells at 2.9 %
/// compression, and a soft liquid turns that into a large pressure ripple: at c0 = 6 m/s the
/// water's half-cell layers read 842, 1190, 1137, 686, 599, 1035, 999, 472, 303, 890, 888 and 271 Pa
/// up from the floor, where hydrostatics goes from 1035 to 495 Pa. A line fitted over a part of the
/// layer takes the ripple's phase for a slope (1.7 rho g here); the mean over the whole layer, three
/// periods, takes it out.
fn floor_pressure(
    p: &Particles,
    params: &mpm::sim::Params,
    bottom: impl Fn(usize) -> bool,
    density: impl Fn(usize) -> f32,
    floor: f32,
    rho: f32,
) -> f64 {
    let (mut count, mut sum) = (0.0f64, 0.0f64);
    for n in (0..p.len()).filter(|&n| bottom(n)) {
        let material = Material::of(params, p.material[n]);
        let depth = f64::from(p.x[n].y - floor);
        sum += f64::from(material.pressure(density(n))) + f64::from(rho * G) * depth;
        count += 1.0;
    }
    sum / count
}

/// The density each particle of `p` would gather from the grid's mass (`grid_density` after the
/// CPU reference's p2g_init and the walls' mirror mass): what a scene of one rest density reads.
fn gathered_densities(p: &Particles, scene: &Scene, params: &mpm::sim::Params) -> Vec<f32> {
    let mut solver = CpuSolver::new(p.clone(), scene.grid_res);
    solver.p2g_init(params);
    solver.mirror_mass(params);
    (0..p.len())
        .map(|n| {
            let st = Stencil::new(p.x[n], params.inv_dx);
            grid_density(params, &st, solver.grid.shape, &solver.grid.mass)
        })
        .collect()
}

/// Oil (800 kg/m^3) over water (1000 kg/m^3), 6 cm of each, in a closed tank, both 3 Pa s, from rest
/// density with gravity ramped in over 0.5 s and held for 1.5 s: both compress under their weight
/// and settle. Then:
/// - the interface is flat within a cell, and no oil particle lies below it (nor water above);
/// - the pressure at the floor is g (rho1 h1 + rho2 h2), the weight of both layers per unit area
///   (known exactly from the particles' masses), within 2 %, the pressure being Tait's law of the
///   water's densities as the solver has them (gathered from the grid's volume), taken to the floor
///   over the whole water layer ([`floor_pressure`]); the same from the densities the grid's mass
///   would give is printed beside it (the mass's smear reaches 1.5 cells below the interface);
/// - the solver's density is within 1 % of the mass's in the water's interior (where the grid holds
///   water alone, and the two are the same gather);
/// - the particles by the interface have densities within 3 % of their own rest density, while the
///   density the grid's mass gives is printed beside: the smear that the volume avoids.
#[test]
fn oil_and_water_settle_into_two_flat_layers_under_the_right_pressure() {
    let dx = 0.01f32;
    let (water_rho, oil_rho, mu, depth) = (1000.0f32, 800.0f32, 3.0f32, 0.06f32);
    let scene = common::scene(&format!(
        "[domain]\nsize = [0.23, 0.18, 0.08]\nresolution = [23, 18, 8]\n\
         [[material]]\nname = \"water\"\nrest_density = {water_rho}\nsound_speed = 6.0\nviscosity = {mu}\n\
         [[material]]\nname = \"oil\"\nrest_density = {oil_rho}\nsound_speed = 6.0\nviscosity = {mu}\n\
         [time_step]\ncfl = 0.4\n\
         [[block]]\nmaterial = \"water\"\nmin = [0.01, 0.01, 0.01]\nmax = [0.21, {}, 0.06]\n\
         [[block]]\nmaterial = \"oil\"\nmin = [0.01, {}, 0.01]\nmax = [0.21, {}, 0.06]",
        dx + depth,
        dx + depth,
        dx + 2.0 * depth
    ));
    let mut sim = simulation(&scene, BackendKind::CpuParallel);
    let params = *sim.params();
    let floor = dx;
    let interface_at_rest = floor + depth;
    let is_oil = |p: &Particles, n: usize| Material::of(&params, p.material[n]).rest_density == oil_rho;
    let start = particles(&mut sim);
    let mass: f64 = (0..start.len())
        .map(|n| f64::from(Material::of(&params, start.material[n]).particle_mass))
        .sum();
    let weight = f64::from(G) * mass / f64::from(0.20f32 * 0.05);
    println!("two liquids: g (rho1 h1 + rho2 h2) = {weight:.1} Pa at the floor");
    let mut max_speed = 0.0;
    let mut last = (0.0, 0.0, 0.0);
    // Gravity ramped in over 0.5 s, as in the hydrostatic column of tests/scenarios.rs: released at
    // once, the layers ring in their acoustic mode for seconds.
    let mut frame = 0;
    for second in 2..=4 {
        while frame < second * 30 {
            frame += 1;
            let ramp = (frame as f32 / 30.0).min(1.0);
            sim.set_gravity(Vec3::new(0.0, -G * ramp, 0.0)).unwrap();
            let stats = sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
            max_speed = stats.summary.max_speed;
        }
        let p = particles(&mut sim);
        let gathered = gathered_densities(&p, &scene, &params);
        let water = |n: usize| !is_oil(&p, n);
        let below = interface_at_rest - 1.5 * dx;
        let from_gathered = floor_pressure(&p, &params, water, |n| gathered[n], floor, water_rho);
        let from_solver = floor_pressure(&p, &params, water, |n| p.rho[n], floor, water_rho);
        // The solver's density over the mass's in the water's interior (a cell and a half from the
        // floor and from the interface, where the grid holds water alone).
        let interior: Vec<usize> = (0..p.len())
            .filter(|&n| water(n) && p.x[n].y > floor + 1.5 * dx && p.x[n].y < below)
            .collect();
        let drift = interior
            .iter()
            .map(|&n| f64::from(p.rho[n] / gathered[n]))
            .sum::<f64>()
            / interior.len() as f64
            - 1.0;
        println!(
            "  t = {:.1} s: floor pressure {from_gathered:.1} Pa from the mass's densities ({:+.2} %), {from_solver:.1} Pa from the solver's ({:+.2} %); solver's over mass's density in the water's interior {:+.3} %; max speed {max_speed:.2e} m/s",
            second as f32 * 0.5,
            100.0 * (from_gathered / weight - 1.0),
            100.0 * (from_solver / weight - 1.0),
            100.0 * drift
        );
        last = (from_gathered / weight - 1.0, from_solver / weight - 1.0, drift);
    }
    let p = particles(&mut sim);
    let gathered = gathered_densities(&p, &scene, &params);
    let material = |n: usize| Material::of(&params, p.material[n]);
    // The interface in each column of cells: midway between its highest water particle and its
    // lowest oil particle.
    let columns = 20;
    let mut interfaces = Vec::new();
    for c in 0..columns {
        let x0 = dx + c as f32 * dx;
        let inside = |n: usize| p.x[n].x >= x0 && p.x[n].x < x0 + dx;
        let water_top = (0..p.len())
            .filter(|&n| inside(n) && !is_oil(&p, n))
            .map(|n| p.x[n].y)
            .fold(f32::NEG_INFINITY, f32::max);
        let oil_bottom = (0..p.len())
            .filter(|&n| inside(n) && is_oil(&p, n))
            .map(|n| p.x[n].y)
            .fold(f32::INFINITY, f32::min);
        interfaces.push(0.5 * (water_top + oil_bottom));
    }
    let (low, high) = interfaces
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &y| {
            (a.min(y), b.max(y))
        });
    let mean = interfaces.iter().sum::<f32>() / columns as f32;
    let oil_below = (0..p.len()).filter(|&n| is_oil(&p, n) && p.x[n].y < low).count();
    let water_above = (0..p.len())
        .filter(|&n| !is_oil(&p, n) && p.x[n].y > high)
        .count();
    println!(
        "  interface at {mean:.4} m (columns from {low:.4} to {high:.4} m: {:.2} cells); {oil_below} oil particles below the lowest column's interface, {water_above} water particles above the highest",
        (high - low) / dx
    );
    // The mass's density against the solver's by the interface.
    let (mut gathered_range, mut solver_range) = (
        [(f32::INFINITY, f32::NEG_INFINITY); 2],
        [(f32::INFINITY, f32::NEG_INFINITY); 2],
    );
    for n in (0..p.len()).filter(|&n| (p.x[n].y - mean).abs() < 1.5 * dx) {
        let rest = material(n).rest_density;
        let (g, c, k) = (gathered[n] / rest, p.rho[n] / rest, usize::from(is_oil(&p, n)));
        gathered_range[k] = (gathered_range[k].0.min(g), gathered_range[k].1.max(g));
        solver_range[k] = (solver_range[k].0.min(c), solver_range[k].1.max(c));
    }
    for (k, name) in ["water", "oil"].iter().enumerate() {
        println!(
            "  {name} within 1.5 cells of the interface: the mass's density {:.3} to {:.3} of its rest density, the solver's {:.3} to {:.3}",
            gathered_range[k].0, gathered_range[k].1, solver_range[k].0, solver_range[k].1
        );
    }
    let solver_worst = solver_range
        .iter()
        .map(|&(a, b)| (a - 1.0).abs().max((b - 1.0).abs()))
        .fold(0.0, f32::max);

    let still = 0.01 * (G * 2.0 * depth).sqrt();
    assert!(
        max_speed < still,
        "not settled: {max_speed} m/s (at most {still})"
    );
    assert!(
        high - low <= dx,
        "the interface spans {} m over the columns",
        high - low
    );
    assert_eq!(oil_below, 0, "oil particles below the interface");
    assert_eq!(water_above, 0, "water particles above the interface");
    let (_, solver_error, drift) = last;
    assert!(
        solver_error.abs() < 0.02,
        "the floor's pressure is {:.2} % off the layers' weight",
        100.0 * solver_error
    );
    assert!(
        drift.abs() < 0.01,
        "the solver's density is {:.2} % off the mass's in the water's interior",
        100.0 * drift
    );
    assert!(
        solver_worst < 0.03,
        "a density {solver_worst} off rest by the interface"
    );
}

/// A 5 x 6 cell block of oil (850 kg/m^3, 0.05 Pa s) released under 16 cm of water (1 mPa s), both
/// at c0 = 12 m/s, dx = 1 cm: the oil rises and stays on top. After 3 s (the carried density this
/// replaced had it back on the floor by then, docs/physics.md, "Several liquids"):
/// - no oil particle lies in the lower half of the liquid, and the oil's median height is in its top
///   quarter (it started at 5 cm, in the lowest third): it floats. (The water's upper decile is no
///   bound: the water beside the spreading lens reaches the surface.)
/// - the liquid's surface (the 99th percentile of every particle's height) has fallen by less than
///   half the particles' spacing, a quarter of a cell (the carried density lost 1.35 cm, 8.6 % of
///   the depth, where the column's compression under its own weight, g h^2 / (2 c0^2), is 0.9 mm):
///   the densities still measure the particles' spacing.
#[test]
fn a_submerged_oil_block_rises_and_stays_on_top() {
    let scene = common::scene(
        "[domain]\nsize = [0.2, 0.22, 0.08]\nresolution = [20, 22, 8]\n\
         [[material]]\nname = \"water\"\nrest_density = 1000.0\nsound_speed = 12.0\nviscosity = 1.0e-3\n\
         [[material]]\nname = \"oil\"\nrest_density = 850.0\nsound_speed = 12.0\nviscosity = 0.05\n\
         [time_step]\ncfl = 0.4\n\
         [[block]]\nmaterial = \"water\"\nmin = [0.01, 0.01, 0.01]\nmax = [0.07, 0.17, 0.06]\n\
         [[block]]\nmaterial = \"water\"\nmin = [0.12, 0.01, 0.01]\nmax = [0.18, 0.17, 0.06]\n\
         [[block]]\nmaterial = \"water\"\nmin = [0.07, 0.01, 0.01]\nmax = [0.12, 0.03, 0.06]\n\
         [[block]]\nmaterial = \"water\"\nmin = [0.07, 0.09, 0.01]\nmax = [0.12, 0.17, 0.06]\n\
         [[block]]\nmaterial = \"oil\"\nmin = [0.07, 0.03, 0.01]\nmax = [0.12, 0.09, 0.06]",
    );
    let mut sim = simulation(&scene, BackendKind::CpuParallel);
    let params = *sim.params();
    assert_eq!(
        params.volume_density, 1,
        "two rest densities: the density from the grid's volume"
    );
    let (floor, depth) = (0.01f32, 0.16f32);
    let surface = |p: &Particles| quantile(p.x.iter().map(|x| x.y).collect(), 0.99);
    let start = surface(&particles(&mut sim));
    for _ in 0..180 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
    }
    let p = particles(&mut sim);
    let is_oil = |n: usize| Material::of(&params, p.material[n]).rest_density < 900.0;
    let heights = |oil: bool| -> Vec<f32> {
        (0..p.len())
            .filter(|&n| is_oil(n) == oil)
            .map(|n| p.x[n].y)
            .collect()
    };
    let (oil, water) = (heights(true), heights(false));
    let lowest_oil = oil.iter().copied().fold(f32::INFINITY, f32::min);
    let (oil_median, water_median) = (quantile(oil, 0.5), quantile(water, 0.5));
    let end = surface(&p);
    // Tait's law to first order, d rho / rho0 = dp / (rho0 c0^2): at depth z the strain is g z / c0^2,
    // and the column of depth h shortens by g h^2 / (2 c0^2).
    let (dx, c0) = (0.01f32, 12.0f32);
    let compression = G * depth * depth / (2.0 * c0 * c0);
    println!(
        "submerged oil after 3 s: lowest oil particle {:.2} cm above the floor, oil median {:.2} cm, water median {:.2} cm; surface {:.2} -> {:.2} cm (hydrostatic compression {:.2} mm)",
        100.0 * (lowest_oil - floor),
        100.0 * (oil_median - floor),
        100.0 * (water_median - floor),
        100.0 * (start - floor),
        100.0 * (end - floor),
        1000.0 * compression
    );
    assert!(
        lowest_oil > floor + 0.5 * depth,
        "oil at {:.2} cm, in the lower half of the liquid",
        100.0 * (lowest_oil - floor)
    );
    assert!(
        oil_median > floor + 0.75 * depth,
        "the oil's median height, {:.2} cm, is below the liquid's top quarter",
        100.0 * (oil_median - floor)
    );
    assert!(
        start - end < 0.25 * dx,
        "the surface fell {:.2} mm, more than a quarter of a cell (the column's compression is {:.2} mm)",
        1000.0 * (start - end),
        1000.0 * compression
    );
}

/// The viewer's live controls change the material row they name and no other; the substep's viscous
/// limit follows a row's new viscosity; a row the table lacks is refused with the table's size.
#[test]
fn live_controls_change_the_liquid_they_name() {
    let scene = common::scene(
        "[domain]\nsize = [0.2, 0.2, 0.2]\nresolution = [20, 20, 20]\n\
         [[material]]\nname = \"water\"\nrest_density = 1000.0\nsound_speed = 20.0\n\
         [[material]]\nname = \"oil\"\nrest_density = 850.0\nsound_speed = 20.0\nviscosity = 0.05\n\
         [[block]]\nmaterial = \"water\"\nmin = [0.03, 0.03, 0.03]\nmax = [0.08, 0.08, 0.08]\n\
         [[block]]\nmaterial = \"oil\"\nmin = [0.1, 0.03, 0.03]\nmax = [0.15, 0.08, 0.08]",
    );
    let mut sim = simulation(&scene, BackendKind::Cpu);
    let before = *sim.params();
    sim.set_viscosity(1, 1000.0).unwrap();
    sim.set_sound_speed(1, 30.0).unwrap();
    let after = *sim.params();
    assert_eq!(after.materials[0], before.materials[0], "water changed");
    assert_eq!(after.materials[1].viscosity, 1000.0);
    assert_eq!(
        after.materials[1].max_viscosity, 1000.0,
        "a Newtonian row's ceiling is its viscosity"
    );
    assert!((after.materials[1].sound_speed() - 30.0).abs() < 1e-3);
    // 1000 Pa s (the slider's top) at dx = 1 cm: the viscous limit, rho0 dx^2 / (6 mu), is 14 us,
    // under the acoustic limit (0.13 ms at 30 m/s).
    let stats = sim.advance_frame().unwrap();
    let viscous = MaterialTable::viscous_dt(&after, after.dx);
    println!(
        "substep {:.3e} s ({:?}), the viscous limit {viscous:.3e} s",
        stats.dt, stats.limit
    );
    assert_eq!(stats.limit, StepLimit::Viscous);
    assert!(
        viscous < 2e-5 && stats.dt <= viscous,
        "the substep {} ignores the new viscosity",
        stats.dt
    );
    let refused = sim.set_viscosity(2, 1.0).unwrap_err().to_string();
    assert!(refused.contains("2 materials"), "{refused}");
}
