//! The walls' boundary: fluid at rest against a wall stays there (tests/scenarios.rs's hydrostatic
//! column), and fluid leaving a wall leaves it as freely as it would leave a collider: the mirror image
//! beyond the wall pushes, never pulls (docs/physics.md, "Walls: the mirror boundary").

mod common;

use mpm::backend::BackendKind;

#[test]
fn a_block_leaving_a_wall_keeps_its_speed() {
    for backend in [BackendKind::Cpu, BackendKind::CpuParallel] {
        let scene = common::block_leaving_the_low_x_wall(1.0);
        common::assert_block_keeps_its_speed(&scene, backend, &format!("{backend:?}"));
    }
}

/// A sheet two cells thick thrown along the ceiling at 1 m/s: nothing holds it there, so it falls
/// away as gravity says, its mean vertical speed after 0.05 s being g t (to 5 %).
#[test]
fn a_sheet_thrown_along_the_ceiling_falls_away_from_it() {
    let scene = common::scene(common::tank!(
        [0.4, 0.4, 0.4],
        [20, 20, 20],
        r#"
[time_step]
cfl = 0.35
[[block]]
min = [0.04, 0.32, 0.12]
max = [0.24, 0.36, 0.28]
velocity = [1.0, 0.0, 0.0]
"#
    ));
    let (_, top) = scene.fluid_region();
    assert!(
        (top.y - 0.36).abs() < 1e-6,
        "the fluid region ends at {top}, not at the sheet's top"
    );
    for backend in [BackendKind::Cpu, BackendKind::CpuParallel] {
        let solver = mpm::backend::create(backend, &scene).expect("backend");
        let mut sim = mpm::sim::Simulation::new(scene.clone(), solver);
        for _ in 0..3 {
            sim.advance_frame().expect("frame");
        }
        let p = sim.solver_mut().read_particles().expect("particles");
        let vy = p.v.iter().map(|v| v.y).sum::<f32>() / p.len() as f32;
        let free_fall = -9.81 * sim.time() as f32;
        println!(
            "{backend:?}: mean vy {vy:.4} m/s after {:.4} s (free fall: {free_fall:.4})",
            sim.time()
        );
        assert!(
            (vy / free_fall - 1.0).abs() < 0.05,
            "{backend:?}: the sheet's mean vy is {vy} m/s, free fall {free_fall}"
        );
    }
}
