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
use mpm::sim::dropped::{DropShape, DroppedBody};

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

/// A square log 10 cm across of 500 kg/m^3 dropped into the still water of the floating checks'
/// tank (1 cm cells, quasi-2D), where `Simulation::drop_center` lets it go: its bottom above the
/// surface over the tank's middle. It falls in and, within 3 s, comes to rest floating with half its
/// section under the surface: the draft over the last half second within 10 % of 50 mm (measured
/// 46.4 mm, -7.1 %: the 1 cm cells' miss of `square_logs_float_at_archimedes_draft`, which a log let
/// go at its draft meets too), moving at under 5 cm/s.
#[test]
fn a_light_box_dropped_into_still_water_floats_at_half_its_height() {
    let (dx, side) = (0.01f32, 0.1f32);
    let scene = bodies_checks::tank_of_water(dx, "");
    let mut sim = materials_checks::simulation(&scene, BackendKind::Cpu);
    bodies_checks::calm(&mut sim, 45);
    let log = bodies_checks::dropped_log(dx, side, 500.0, DVec3::ZERO);
    let center = sim.drop_center(&log.shape, (0.2, 3.5 * f64::from(dx))).unwrap();
    sim.drop_body(DroppedBody { center, ..log }).unwrap();
    let start = sim.bodies()[0];
    let (surface, _) = bodies_checks::surface_and_draft(&mut sim, &start, dx, side);
    println!("let go at {center}, the surface at {surface:.4} m");
    assert!(
        center.y - 0.5 * f64::from(side) > surface,
        "the log was let go with its bottom at {:.4} m, under the surface at {surface:.4} m",
        center.y - 0.5 * f64::from(side)
    );
    let (mut drafts, mut fastest) = (Vec::new(), 0.0f64);
    for frame in 1..=180 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        let last_half = frame > 150;
        if !last_half && frame % 15 != 0 {
            continue;
        }
        let body = sim.bodies()[0];
        let speed = DVec3::from_array(body.velocity).length();
        let (surface, draft) = bodies_checks::surface_and_draft(&mut sim, &body, dx, side);
        if last_half {
            drafts.push(draft);
            fastest = fastest.max(speed);
        }
        if frame % 15 == 0 {
            println!(
                "  t = {:.2} s after the drop: surface {surface:.4} m, log at ({:.4}, {:.4}) m, tilted \
                 {:.1} degrees, draft {:.1} mm, moving {speed:.3} m/s",
                frame as f64 / 60.0,
                body.center[0],
                body.center[1],
                bodies_checks::tilt_degrees(&body),
                1e3 * draft,
            );
        }
    }
    let draft = drafts.iter().sum::<f64>() / drafts.len() as f64;
    let want = 0.5 * f64::from(side);
    println!(
        "RESULT draft {:.2} mm ({:+.1} % of {:.1}), at most {fastest:.3} m/s over the last half second",
        1e3 * draft,
        100.0 * (draft / want - 1.0),
        1e3 * want
    );
    assert!(
        (draft / want - 1.0).abs() < 0.1,
        "the dropped log floats {:.1} mm deep, not within 10 % of {:.1}",
        1e3 * draft,
        1e3 * want
    );
    assert!(fastest < 0.05, "the dropped log still moves at {fastest:.3} m/s");
}

/// A ball 4 cm across of 2000 kg/m^3 dropped into the same tank sinks through the 15 cm of water
/// and comes to rest on the floor: over the last quarter of its 1.5 s its centre within half a
/// millimetre of the floor plus its radius (measured: on it from 1.0 s on), barely moving down or up.
#[test]
fn a_dense_ball_dropped_into_still_water_sinks_to_the_floor() {
    let (dx, radius) = (0.01f32, 0.02);
    let scene = bodies_checks::tank_of_water(dx, "");
    let mut sim = materials_checks::simulation(&scene, BackendKind::Cpu);
    bodies_checks::calm(&mut sim, 45);
    let shape = DropShape::Ball { radius };
    let center = sim.drop_center(&shape, (0.2, 3.5 * f64::from(dx))).unwrap();
    sim.drop_body(DroppedBody {
        shape,
        density: 2000.0,
        center,
    })
    .unwrap();
    let rest = sim.scene().body_walls().lo[1] + radius;
    println!("let go at {center}; on the floor its centre is at y = {rest:.4} m");
    let (mut worst_height, mut worst_rise) = (0.0f64, 0.0f64);
    for frame in 1..=90 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        let body = sim.bodies()[0];
        if frame > 67 {
            worst_height = worst_height.max((body.center[1] - rest).abs());
            worst_rise = worst_rise.max(body.velocity[1].abs());
        }
        if frame % 10 == 0 {
            println!(
                "  t = {:.2} s: ball at y = {:.4} m, moving {:.4} m/s ({:+.4} up)",
                frame as f64 / 60.0,
                body.center[1],
                DVec3::from_array(body.velocity).length(),
                body.velocity[1]
            );
        }
    }
    println!(
        "RESULT over the last quarter: at most {:.3} mm from the floor, {:.4} m/s up or down",
        1e3 * worst_height,
        worst_rise
    );
    assert!(
        worst_height < 5e-4,
        "the ball is {:.2} mm off the floor",
        1e3 * worst_height
    );
    assert!(
        worst_rise < 0.005,
        "the ball still moves {worst_rise:.4} m/s up or down"
    );
}

/// Two runs that drop the same box and ball at the same frame into the tank of still water
/// ([`bodies_checks::drop_box_and_ball`]: its first bodies) give the same bytes 20 frames later: the
/// bodies' states and every particle (the CPU reference, whose sums have one order).
#[test]
fn the_same_drops_at_the_same_frame_give_the_same_bytes() {
    let scene = bodies_checks::tank_of_water(0.01, "");
    let run = || bodies_checks::drop_box_and_ball(&scene, BackendKind::Cpu);
    let (first, second) = (run(), run());
    assert_eq!(first.0.len(), 2);
    println!("box at {:?}, ball at {:?}", first.0[0].center, first.0[1].center);
    // Let go at 0.22 and 0.2 m: each fell into the water (measured: 5.5 and 6.3 cm).
    for (body, let_go) in first.0.iter().zip([0.22, 0.2]) {
        assert!(
            let_go - body.center[1] > 0.02,
            "a dropped body did not fall: it is at {:?}",
            body.center
        );
    }
    assert!(
        bytemuck::cast_slice::<_, u8>(&first.0) == bytemuck::cast_slice::<_, u8>(&second.0),
        "two runs' dropped bodies differ: {:?} vs {:?}",
        first.0,
        second.0
    );
    assert!(
        common::same_particles(&first.1, &second.1),
        "two runs' particles differ"
    );
}

/// What cannot be dropped is refused with what to do, and leaves the run as it was (no collider, no
/// body, no dropped body; it steps on): on a backend that moves no bodies (cpu-parallel), in a run
/// split into ranks, past the walls, too light for the explicit coupling, of no size, and into a run
/// that holds as many colliders as the solvers take.
#[test]
fn a_drop_that_cannot_be_made_is_refused_with_the_fix_and_changes_nothing() {
    use mpm::sim::colliders::MAX_COLLIDERS;
    let dx = 0.01f32;
    let scene = bodies_checks::tank_of_water(dx, "");
    let z = 3.5 * f64::from(dx);
    let ball = |x: f64, density: f64, radius: f64| DroppedBody {
        shape: DropShape::Ball { radius },
        density,
        center: DVec3::new(x, 0.22, z),
    };
    let refused = |sim: &mut mpm::sim::Simulation, body: DroppedBody, words: &[&str]| {
        let Err(e) = sim.drop_body(body) else {
            panic!("dropped {body:?}");
        };
        let text = format!("{e:#}");
        for w in words {
            assert!(text.contains(w), "{w:?} is not in: {text}");
        }
        println!("refused: {text}");
    };
    let unchanged = |sim: &mut mpm::sim::Simulation| {
        assert!(sim.dropped().is_empty() && sim.bodies().is_empty());
        assert_eq!(sim.scene().colliders.len(), 0);
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
    };

    let mut parallel = materials_checks::simulation(&scene, BackendKind::CpuParallel);
    refused(
        &mut parallel,
        ball(0.2, 2000.0, 0.02),
        &[
            "cannot drop a ball",
            "cpu-parallel backend does not move rigid bodies",
            "--backend cpu or cuda",
        ],
    );
    unchanged(&mut parallel);

    let mut split = scene.clone();
    split.ranks = 2;
    let mut ranks = materials_checks::simulation(&split, BackendKind::Cpu);
    refused(
        &mut ranks,
        ball(0.2, 2000.0, 0.02),
        &["split into 2 ranks", "drop --ranks"],
    );

    let mut sim = materials_checks::simulation(&scene, BackendKind::Cpu);
    refused(
        &mut sim,
        ball(0.02, 2000.0, 0.02),
        &["the walls hold the bodies within", "let it go further inside"],
    );
    refused(
        &mut sim,
        bodies_checks::dropped_log(dx, 0.1, 10.0, DVec3::new(0.2, 0.22, z)),
        &[
            "cannot drop a box of 10 kg/m^3",
            "lighter than the liquid its boundary band would hold",
            "denser or larger",
        ],
    );
    refused(
        &mut sim,
        ball(0.2, 2000.0, -0.02),
        &["radius = -0.02 must be a positive number"],
    );
    unchanged(&mut sim);

    // As many balls as the solvers take colliders, side by side above the water: one more is refused.
    for k in 0..MAX_COLLIDERS {
        sim.drop_body(ball(0.03 + 0.02 * k as f64, 2000.0, 0.01)).unwrap();
    }
    assert_eq!(sim.bodies().len(), MAX_COLLIDERS);
    refused(
        &mut sim,
        ball(0.2, 2000.0, 0.01),
        &[
            &format!("the most the solvers take ({MAX_COLLIDERS})"),
            "restart the scene",
        ],
    );
    assert_eq!(sim.dropped().len(), MAX_COLLIDERS);
}
