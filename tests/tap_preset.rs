//! The `tap` preset: its glass is a closed, outward-wound mesh embedded with the presets, a copy of
//! the scene saved beside glass.obj loads the same glass, the tap pours into the glass's opening, and
//! on the CPU the water it brings stays in the glass.

use glam::{Vec2, Vec3};
use mpm::backend::{self, BackendKind};
use mpm::sim::colliders::Shape;
use mpm::sim::{mesh, presets, Scene, Simulation};
use std::path::Path;

/// The glass in the world: its axis (x, z), inner radius, inner bottom and rim heights, m.
struct Glass {
    axis: Vec2,
    inner_radius: f32,
    inner_bottom: f32,
    rim: f32,
}

fn glass(scene: &Scene) -> Glass {
    let [collider] = &scene.colliders.list[..] else {
        panic!("the tap has one collider, the glass");
    };
    let Shape::Mesh(sdf) = &collider.shape else {
        panic!("the glass is a mesh collider");
    };
    assert_eq!(collider.rotation, glam::DQuat::IDENTITY);
    let center = collider.center.as_vec3();
    let world: Vec<Vec3> = sdf.vertices.iter().map(|v| *v + center).collect();
    let axis = Vec2::new(center.x, center.z);
    let radial = |p: &Vec3| (Vec2::new(p.x, p.z) - axis).length();
    let rim = world.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    // The inner wall's top ring: the rim's vertices nearest the axis.
    let inner_radius = world
        .iter()
        .filter(|p| (p.y - rim).abs() < 1e-6)
        .map(radial)
        .fold(f32::MAX, f32::min);
    // The inner bottom: the lowest vertex on the axis above the outer bottom.
    let outer_bottom = world.iter().map(|p| p.y).fold(f32::MAX, f32::min);
    let inner_bottom = world
        .iter()
        .filter(|p| radial(p) < 1e-6 && p.y > outer_bottom + 1e-6)
        .map(|p| p.y)
        .fold(f32::MAX, f32::min);
    Glass {
        axis,
        inner_radius,
        inner_bottom,
        rim,
    }
}

#[test]
fn the_glass_is_closed_and_the_tap_pours_into_its_opening() {
    let text = presets::mesh("glass.obj").expect("the preset's glass is embedded");
    let (vertices, triangles) = mesh::parse_triangles(Path::new("glass.obj"), text.as_bytes(), 1.0).unwrap();
    mesh::check_closed(&triangles).expect("the project's own closedness check");
    // Wound outward: the divergence theorem's volume is positive, and it is the glass's solid (an
    // open-topped 48-gon cylinder: outer radius 6.5 cm, inner 4.5 cm, 12 cm high, 2 cm base).
    let volume: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    let polygon = 0.5 * 48.0 * (std::f64::consts::TAU / 48.0).sin();
    let expected = polygon * (0.065f64.powi(2) * 0.12 - 0.045f64.powi(2) * 0.10);
    assert!(
        (volume / expected - 1.0).abs() < 1e-3,
        "the glass's signed volume is {volume:e} m^3, not {expected:e}"
    );

    let scene = Scene::load("tap").unwrap();
    let glass = glass(&scene);
    assert!(
        (glass.inner_radius - 0.045).abs() < 1e-5,
        "{}",
        glass.inner_radius
    );
    let (lo, _) = scene.fluid_region();
    assert!(
        glass.inner_bottom > lo.y as f32,
        "the glass stands on the floor, its inside above it"
    );
    let [tap] = &scene.flow.emitters[..] else {
        panic!("the tap is one emitter");
    };
    assert!(tap.normal.y < -0.999, "the tap points down: {}", tap.normal);
    let nozzle = tap.center.as_vec3();
    assert!(
        nozzle.y > glass.rim,
        "the tap at {nozzle} is below the rim {}",
        glass.rim
    );
    for p in &tap.points {
        let off_axis = (Vec2::new(p.x, p.z) - glass.axis).length();
        assert!(
            off_axis < 0.5 * glass.inner_radius,
            "nozzle point {p} is {off_axis} m off the glass's axis: the stream would hit the rim"
        );
    }
    for sink in &scene.flow.sinks {
        assert!(
            sink.max.y < glass.inner_bottom,
            "a sink reaches into the glass: {sink:?}"
        );
    }
}

#[test]
fn the_scene_saved_beside_glass_obj_loads_the_same_glass_and_needs_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tap.toml");
    std::fs::write(&path, presets::get("tap").unwrap()).unwrap();
    let missing = Scene::load(path.to_str().unwrap()).unwrap_err().to_string();
    assert!(
        missing.contains("collider[0].file") && missing.contains("glass.obj"),
        "{missing}"
    );
    std::fs::write(dir.path().join("glass.obj"), presets::mesh("glass.obj").unwrap()).unwrap();
    let saved = Scene::load(path.to_str().unwrap()).unwrap();
    let preset = Scene::load("tap").unwrap();
    let triangles = |s: &Scene| match &s.colliders.list[0].shape {
        Shape::Mesh(sdf) => (sdf.triangles.clone(), sdf.values.clone()),
        _ => unreachable!(),
    };
    assert!(triangles(&saved) == triangles(&preset));
}

#[test]
fn the_tap_fills_the_glass_on_the_cpu() {
    let scene = Scene::load("tap").unwrap();
    let glass = glass(&scene);
    let start = scene.num_particles as u64;
    let solver = backend::create(BackendKind::CpuParallel, &scene).unwrap();
    let mut sim = Simulation::new(scene, solver);
    let mut emitted = 0;
    // Half a second: the stream reaches the water in the glass after about 0.15 s.
    for _ in 0..30 {
        let stats = sim.advance_frame().unwrap();
        let flow = stats.flow.expect("the tap reports its flow");
        assert!(flow.emitted > emitted, "frame {}: the tap stopped", stats.frame);
        emitted = flow.emitted;
        assert_eq!(flow.drained, 0, "frame {}: water reached the floor", stats.frame);
        assert_eq!(flow.exhausted, 0);
        assert_eq!(flow.live, start + flow.emitted, "frame {}", stats.frame);
    }
    let p = sim.solver_mut().read_particles().unwrap();
    let live: Vec<Vec3> =
        p.x.iter()
            .zip(&p.live)
            .filter(|(_, &l)| l)
            .map(|(x, _)| *x)
            .collect();
    assert_eq!(live.len() as u64, start + emitted);
    // A particle of the glass's water or of the stream above it: within the inner wall (by half a
    // particle spacing), above the inner bottom (by as much).
    let h = sim.scene().lattice().spacing as f32;
    let in_glass = live
        .iter()
        .filter(|x| {
            (Vec2::new(x.x, x.z) - glass.axis).length() < glass.inner_radius + 0.5 * h
                && x.y > glass.inner_bottom - 0.5 * h
        })
        .count();
    let in_cup = live.iter().filter(|x| x.y < glass.rim).count();
    println!(
        "after 0.5 s: {} live particles ({emitted} emitted), {in_glass} inside the glass's radius, \
         {in_cup} below its rim",
        live.len()
    );
    assert!(
        in_glass as f64 >= 0.99 * live.len() as f64,
        "only {in_glass} of {} particles are inside the glass",
        live.len()
    );
    assert!(
        in_cup as f64 > 0.5 * live.len() as f64,
        "the water is not in the glass"
    );
}
