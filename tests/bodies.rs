//! Rigid bodies against physics (docs/physics.md, "Rigid bodies"), on the CPU at 1 cm cells in CI:
//! a body pushed into still water keeps the total momentum, and square logs float at Archimedes'
//! draft (ignored: 1 cm cells miss it by 6.4 % for one of them; tests/gpu_bodies.rs checks them at
//! 2.5 mm).
//! `cargo test --release --test bodies -- --nocapture` prints what each measured.

mod bodies_checks;
mod common;
mod materials_checks;

use glam::DVec3;
use mpm::backend::BackendKind;

/// Without gravity, a log of 500 kg/m^3 at 0.3 m/s runs into a still block of water
/// ([`bodies_checks::log_into_still_water`], fixed-point scatter): over a second, through the
/// impact, the momentum of body and water together stays within 1e-4 of the start's, while the
/// body hands a good part of its own to the water.
#[test]
fn a_body_entering_still_water_keeps_the_total_momentum() {
    let scene = bodies_checks::log_into_still_water(0.01, "fixed-point");
    let mut sim = materials_checks::simulation(&scene, BackendKind::Cpu);
    let start = bodies_checks::total_momentum(&mut sim);
    let body_start = DVec3::from_array(sim.bodies()[0].velocity) / sim.bodies()[0].inv_mass;
    let mut worst = 0.0f64;
    for frame in 1..=60 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        if frame % 6 == 0 {
            let total = bodies_checks::total_momentum(&mut sim);
            let drift = (total - start).length() / start.length();
            worst = worst.max(drift);
            let body = sim.bodies()[0];
            println!(
                "  t = {:.2} s: body at x = {:.4} m moving {:.4} m/s; total momentum {:.5?} kg m/s, drift {drift:.2e}",
                frame as f64 / 60.0,
                body.center[0],
                body.velocity[0],
                total
            );
        }
    }
    let body_end = DVec3::from_array(sim.bodies()[0].velocity) / sim.bodies()[0].inv_mass;
    assert!(
        body_end.x < 0.8 * body_start.x,
        "the body kept {:.1} % of its momentum: it never met the water",
        100.0 * body_end.x / body_start.x
    );
    assert!(
        worst < 1e-4,
        "the total momentum drifted by {worst:.2e} of the start's"
    );
}

/// Three cubes 6 cm across dropped crooked, one above the other, into shallow water
/// ([`bodies_checks::box_pile`], 1 cm cells) come to rest stacked: each on the one below, its centre
/// where the stack puts it within 2 mm, still, and no corner more than 1 mm inside another cube.
#[test]
fn boxes_dropped_in_a_pile_come_to_rest_stacked() {
    let side = 0.06;
    let scene = bodies_checks::box_pile(0.01, side as f32, "");
    let mut sim = materials_checks::simulation(&scene, BackendKind::Cpu);
    let mut worst_overlap: f64 = 0.0;
    let mut settled = Vec::new();
    for frame in 1..=120 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        worst_overlap = worst_overlap.max(bodies_checks::deepest_cube_overlap(sim.bodies(), side));
        if frame == 90 {
            settled = sim.bodies().to_vec();
        }
        if frame % 20 == 0 {
            let heights: Vec<String> = sim
                .bodies()
                .iter()
                .map(|b| format!("{:.4}", b.center[1]))
                .collect();
            println!(
                "  t = {:.2} s: centres at y = {} m",
                frame as f64 / 60.0,
                heights.join(", ")
            );
        }
    }
    let floor = 0.01;
    for (k, (body, before)) in sim.bodies().iter().zip(&settled).enumerate() {
        let want = floor + side * (k as f64 + 0.5);
        assert!(
            (body.center[1] - want).abs() < 2e-3,
            "cube {k} rests at y = {:.4} m, not {want:.4}",
            body.center[1]
        );
        let moved = DVec3::from_array(body.center).distance(DVec3::from_array(before.center));
        assert!(moved < 5e-4, "cube {k} moved {moved} m in the last half second");
    }
    assert!(
        worst_overlap < 1e-3,
        "a corner went {:.2} mm into another cube",
        1e3 * worst_overlap
    );
}

/// The `water-wheel` preset: its wheel is a closed, outward-wound mesh, and on the CPU the tap's
/// stream, falling right of the axle, turns the hinged wheel clockwise (seen from +z) and only about
/// its axle. Over its first second it spins up past 5 rad/s, and its paddles never outrun the water
/// that drives them: at the stream's nearest radius (its edge, 3.8 cm from the axle) the paddles move
/// slower than the stream can fall to them, at most sqrt(v0^2 + 2 g h) = 2.35 m/s from the nozzle to
/// the wheel's lowest point: 62 rad/s.
#[test]
fn the_water_wheel_turns_with_the_stream() {
    use mpm::sim::{mesh, presets, Scene};
    let text = presets::mesh("water-wheel.obj").expect("the preset's wheel is embedded");
    let path = std::path::Path::new("water-wheel.obj");
    let (vertices, triangles) = mesh::parse_triangles(path, text.as_bytes(), 1.0).unwrap();
    mesh::check_closed(&triangles).expect("the wheel is one closed surface");
    // Wound outward: the volume the wheel's mass comes from is positive, and its centroid on the axle.
    let wheel = mpm::sim::colliders::triangles_mass_properties(&vertices, &triangles);
    let volume = wheel.volume;
    assert!(
        wheel.centroid.length() < 1e-9,
        "the wheel's centroid is off its axle: {}",
        wheel.centroid
    );
    assert!(
        volume > 0.0,
        "the wheel is wound inward: signed volume {volume:e} m^3"
    );

    let scene = Scene::load("water-wheel").unwrap();
    let mut sim = materials_checks::simulation(&scene, BackendKind::Cpu);
    for frame in 1..=60 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        if frame % 15 == 0 {
            let w = sim.bodies()[0].angular_velocity;
            println!(
                "  t = {:.2} s: turning {:.2} rad/s about z",
                frame as f64 / 60.0,
                w[2]
            );
        }
    }
    let wheel = sim.bodies()[0];
    let [wx, wy, wz] = wheel.angular_velocity;
    assert!(
        wx == 0.0 && wy == 0.0,
        "the hinged wheel turns off its axle: {:?}",
        wheel.angular_velocity
    );
    assert!(
        wz < -5.0,
        "the wheel turns at {wz:.2} rad/s, not clockwise past 5"
    );
    assert!(
        wz > -62.0,
        "the wheel turns at {wz:.2} rad/s, faster than the stream can drive it"
    );
    let axle = DVec3::new(0.2, 0.19, 0.06);
    assert!(
        DVec3::from_array(wheel.center).distance(axle) < 1e-9,
        "the wheel left its axle"
    );
}

/// A square log 10 cm across (quasi-2D, 1 cm cells) of relative density 0.25, 0.5 and 0.75 settles
/// with the submerged share of its section as a draft of 25, 50 and 75 mm, within 5 %.
#[test]
#[ignore = "at 1 cm cells the logs float at 25.9, 46.8 and 76.6 mm (CPU, 4 s): the 500 kg/m^3 one 6.4 % short; tests/gpu_bodies.rs checks them at 2.5 mm, where all are within 5 %"]
fn square_logs_float_at_archimedes_draft() {
    let (dx, side) = (0.01f32, 0.1f32);
    let mut failures = Vec::new();
    for rho in [250.0f32, 500.0, 750.0] {
        let scene = bodies_checks::log_in_water(dx, side, rho, 0.0, side * rho / 1000.0 - 0.5 * side, "");
        let mut sim = materials_checks::simulation(&scene, BackendKind::Cpu);
        let f = bodies_checks::settle_log(&mut sim, dx, side, 4.0);
        let want = f64::from(side * rho / 1000.0);
        println!(
            "{rho} kg/m^3: draft {:.2} mm, Archimedes {:.1}",
            1e3 * f.draft,
            1e3 * want
        );
        if (f.draft / want - 1.0).abs() > 0.05 {
            failures.push(format!("{rho} kg/m^3: {:.1} mm", 1e3 * f.draft));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("; "));
}
