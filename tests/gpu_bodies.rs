//! Rigid bodies on the GPU (docs/physics.md, "Rigid bodies"): the device's bodies against the CPU
//! reference's, bodies dropped into a running scene among them, fixed point byte-identical run to
//! run, and the floating logs of tests/bodies.rs at finer cells. Run with `cargo test --release --test gpu_bodies`; without a GPU each case reports
//! itself as not run.

use glam::DVec3;
use mpm::backend::BackendKind;

mod bodies_checks;
mod common;
mod harness;
mod materials_checks;

fn main() -> std::process::ExitCode {
    harness::run(
        "GPU",
        harness::cuda_device,
        harness::tests![
            bodies_follow_the_cpu,
            bodies_in_fixed_point_are_byte_identical,
            a_pile_of_boxes_follows_the_cpu,
            dropped_bodies_follow_the_cpu,
            a_sphere_settles_at_stokes_velocity,
            logs_float_at_their_draft_and_angle_at_finer_cells,
        ],
    )
}

/// A log of half the water's density settling into the water (1 cm cells, both scatters) and a log
/// pushed into still water without gravity: after 30 frames the device's body is where the CPU's is
/// within a tenth of a cell, and moves at its velocity within 2 cm/s.
fn bodies_follow_the_cpu() {
    let dx = 0.01f32;
    let scenes = [
        (
            "float",
            bodies_checks::log_in_water(dx, 0.1, 500.0, 5.0, 0.0, "[solver]\nscatter = \"float\"\n"),
        ),
        (
            "fixed-point",
            bodies_checks::log_in_water(dx, 0.1, 500.0, 5.0, 0.0, "[solver]\nscatter = \"fixed-point\"\n"),
        ),
        (
            "into still water",
            bodies_checks::log_into_still_water(dx, "fixed-point"),
        ),
    ];
    for (name, scene) in scenes {
        let run = |kind| {
            let mut sim = materials_checks::simulation(&scene, kind);
            for _ in 0..30 {
                sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
            }
            sim.bodies()[0]
        };
        let (cpu, gpu) = (run(BackendKind::Cpu), run(BackendKind::Cuda));
        let gap = (DVec3::from_array(cpu.center) - DVec3::from_array(gpu.center)).length();
        let speed_gap = (DVec3::from_array(cpu.velocity) - DVec3::from_array(gpu.velocity)).length();
        println!(
            "{name}: CPU at {:?}, GPU at {:?}: {:.3} cells apart, velocities {speed_gap:.4} m/s apart",
            cpu.center,
            gpu.center,
            gap / f64::from(dx)
        );
        assert!(
            gap < 0.1 * f64::from(dx),
            "{name}: the GPU's body is {gap} m from the CPU's"
        );
        assert!(
            speed_gap < 0.02,
            "{name}: the GPU's body moves {speed_gap} m/s apart from the CPU's"
        );
    }
}

/// Three cubes dropped in a pile into shallow water (tests/bodies.rs' scene, fixed point) rest on the
/// device where they rest on the CPU, within a fifth of a cell, after two seconds of contacts with
/// the floor and each other; and a second device run gives the same bytes.
fn a_pile_of_boxes_follows_the_cpu() {
    let (dx, side) = (0.01f32, 0.06);
    let scene = bodies_checks::box_pile(dx, side as f32, "[solver]\nscatter = \"fixed-point\"\n");
    let run = |kind| {
        let mut sim = materials_checks::simulation(&scene, kind);
        for _ in 0..120 {
            sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        }
        sim.bodies().to_vec()
    };
    let (cpu, gpu, again) = (
        run(BackendKind::Cpu),
        run(BackendKind::Cuda),
        run(BackendKind::Cuda),
    );
    for (k, (c, g)) in cpu.iter().zip(&gpu).enumerate() {
        let gap = (DVec3::from_array(c.center) - DVec3::from_array(g.center)).length();
        println!(
            "cube {k}: CPU at {:?}, GPU at {:?}: {:.3} cells apart",
            c.center,
            g.center,
            gap / f64::from(dx)
        );
        assert!(
            gap < 0.2 * f64::from(dx),
            "cube {k}: the GPU's is {gap} m from the CPU's"
        );
    }
    let overlap = bodies_checks::deepest_cube_overlap(&gpu, side);
    assert!(
        overlap < 1e-3,
        "on the GPU a corner is {overlap} m inside another cube"
    );
    assert!(
        bytemuck::cast_slice::<_, u8>(&gpu) == bytemuck::cast_slice::<_, u8>(&again),
        "two fixed-point runs of the pile differ"
    );
}

/// A box and a ball dropped at the tenth frame ([`bodies_checks::drop_box_and_ball`], 1 cm cells,
/// fixed point) into the tank of still water, the run's first bodies (the drop turns the device's
/// exchange on, and their collider slots are new), and either side of the floating log of
/// [`bodies_checks::log_in_water`] (its state and pending sums read back and kept, its slot placed
/// again): 20 frames later each of the device's bodies is where the CPU's is within a tenth of a
/// cell and moves at its velocity within 2 cm/s; a second device run gives the same bytes, bodies
/// and particles. H200, 2026-11-29: at most 0.002 cells and 0.0001 m/s apart; with the device's
/// collider states left as they were uploaded before the drop (no slot placed for the new bodies),
/// the log's scene missed by 1.4 cells.
fn dropped_bodies_follow_the_cpu() {
    let dx = 0.01f32;
    let fixed = "[solver]\nscatter = \"fixed-point\"\n";
    let scenes = [
        ("into still water", bodies_checks::tank_of_water(dx, fixed)),
        (
            "beside a floating log",
            bodies_checks::log_in_water(dx, 0.1, 500.0, 5.0, 0.0, fixed),
        ),
    ];
    for (name, scene) in scenes {
        let (cpu, _) = bodies_checks::drop_box_and_ball(&scene, BackendKind::Cpu);
        let (gpu, gpu_particles) = bodies_checks::drop_box_and_ball(&scene, BackendKind::Cuda);
        let (again, again_particles) = bodies_checks::drop_box_and_ball(&scene, BackendKind::Cuda);
        assert_eq!(gpu.len(), cpu.len(), "{name}: the GPU has {} bodies", gpu.len());
        for (k, (c, g)) in cpu.iter().zip(&gpu).enumerate() {
            let gap = (DVec3::from_array(c.center) - DVec3::from_array(g.center)).length();
            let speed_gap = (DVec3::from_array(c.velocity) - DVec3::from_array(g.velocity)).length();
            println!(
                "{name}, body {k}: CPU at {:?}, GPU at {:?}: {:.3} cells apart, velocities {speed_gap:.4} m/s apart",
                c.center,
                g.center,
                gap / f64::from(dx)
            );
            assert!(
                gap < 0.1 * f64::from(dx),
                "{name}: the GPU's body {k} is {gap} m from the CPU's"
            );
            assert!(
                speed_gap < 0.02,
                "{name}: the GPU's body {k} moves {speed_gap} m/s apart from the CPU's"
            );
        }
        assert!(
            bytemuck::cast_slice::<_, u8>(&gpu) == bytemuck::cast_slice::<_, u8>(&again),
            "{name}: two fixed-point runs' bodies differ"
        );
        assert!(
            common::same_particles(&gpu_particles, &again_particles),
            "{name}: two fixed-point runs' particles differ"
        );
    }
}

/// Stokes' law: a sphere 2 cm across of 2000 kg/m^3 let go in a liquid of 15 Pa s and 1000 kg/m^3
/// on the axis of a test tube five of its radii wide ([`bodies_checks::sphere_in_tube`]) settles
/// at Stokes' terminal velocity 2 (rho_s - rho) g a^2 / (9 mu) = 14.5 mm/s (Reynolds number 0.02)
/// over Haberman and Sayre's wall correction for lambda = 0.2 (1.677): 8.67 mm/s, within 10 %, at 8
/// cells across the radius. Gravity comes in over the first 0.1 s (the column then settles without
/// ringing); the speed is the sphere's fall over the last quarter of two tube-filling times
/// (R^2 / nu) over that time, which averages out what sound is left. `MPM_STOKES_CELLS` (a
/// comma-separated list; default 6,8) sets the resolutions run; the finest is asserted;
/// `MPM_STOKES_FILLS` the tube-filling times run (default 2); `MPM_STOKES_CFL` the CFL number
/// (default 0.2); `MPM_STOKES_SCATTER` the scatter (default fixed point, so a run gives the same
/// numbers every time).
///
/// H200, 2026-11-29 (BENCHMARKS.md M12, M14, M15, M17), CFL 0.2: fixed point -4.9 % at 8 cells
/// (M17) and -12.3 % at 10 (M15); the float scatter -3.7 and -4.2 % at 8 cells in two runs (+4.1 to
/// +10.1 % from run to run at CFL 0.4, not converged in the substep there) and -13.9 % at 10. So 8
/// cells pass and 10 cells do not, in either scatter: not converged in the resolution, and not
/// explained yet (docs/physics.md, "Stokes' settling"). Until the momentum units followed the flow's
/// speed in scenes with bodies too (M17), fixed point read -14.3 and -18.3 %: units made for the
/// sound speed damp this slow flow.
fn a_sphere_settles_at_stokes_velocity() {
    let (radius, viscosity) = (0.01, 15.0);
    let cells: Vec<u32> = std::env::var("MPM_STOKES_CELLS")
        .unwrap_or_else(|_| "6,8".into())
        .split(',')
        .map(|c| {
            c.trim()
                .parse()
                .expect("MPM_STOKES_CELLS: cells across the radius")
        })
        .collect();
    let fills: f64 = std::env::var("MPM_STOKES_FILLS")
        .map(|f| f.parse().expect("MPM_STOKES_FILLS: tube-filling times to run"))
        .unwrap_or(2.0);
    let cfl: f64 = std::env::var("MPM_STOKES_CFL")
        .map(|f| f.parse().expect("MPM_STOKES_CFL: the time step's CFL number"))
        .unwrap_or(0.2);
    let stokes = 2.0 * (2000.0 - 1000.0) * 9.81 * radius * radius / (9.0 * viscosity);
    let correction = bodies_checks::haberman_sayre(0.2);
    let want = stokes / correction;
    let mut last = 0.0;
    for &n in &cells {
        let dir = tempfile::tempdir().unwrap();
        let scatter = std::env::var("MPM_STOKES_SCATTER").unwrap_or_else(|_| "fixed-point".into());
        let scatter = format!("[solver]\nscatter = \"{scatter}\"\n");
        let (scene, fill) = bodies_checks::sphere_in_tube(n, radius, viscosity, cfl, &scatter, dir.path());
        let mut sim = materials_checks::simulation(&scene, BackendKind::Cuda);
        let frames = (fills * fill * 60.0).ceil() as u32;
        let window_start = frames - frames / 4;
        let mut start_height = 0.0;
        let sphere_start = sim.bodies()[0].center[1];
        for frame in 1..=frames {
            let ramp = (frame as f32 / 6.0).min(1.0);
            sim.set_gravity(glam::Vec3::new(0.0, -9.81 * ramp, 0.0)).unwrap();
            let stats = sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
            if frame == window_start {
                start_height = sim.bodies()[0].center[1];
            }
            if frame % 5 == 0 {
                // With the liquid's density ratios: a column still settling, or liquid squeezed
                // under the sphere, shows there.
                let (v, s) = (-sim.bodies()[0].velocity[1], &stats.summary);
                println!(
                    "  {n} cells, t = {:.3} s: falling {:.3} mm/s, {:.2} mm below its start; density \
                     ratio mean {:.5}, max {:.4}; substep {:.2} us ({})",
                    f64::from(frame) / 60.0,
                    1e3 * v,
                    1e3 * (sphere_start - sim.bodies()[0].center[1]),
                    s.density_ratio_mean,
                    s.density_ratio_max,
                    1e6 * stats.dt,
                    stats.limit.name()
                );
            }
        }
        let fallen = start_height - sim.bodies()[0].center[1];
        let speed = fallen / (f64::from(frames - window_start) / 60.0);
        println!(
            "RESULT {n} cells across the radius: {:.3} mm/s, Stokes {:.3}, wall-corrected {:.3}: {:+.1} %",
            1e3 * speed,
            1e3 * stokes,
            1e3 * want,
            100.0 * (speed / want - 1.0)
        );
        last = speed;
    }
    assert!(
        (last / want - 1.0).abs() < 0.1,
        "the sphere settles at {:.3} mm/s, not within 10 % of {:.3}",
        1e3 * last,
        1e3 * want
    );
}

/// Two fixed-point runs of a floating log give the same bytes: its state and every particle.
fn bodies_in_fixed_point_are_byte_identical() {
    let scene = bodies_checks::log_in_water(
        0.01,
        0.1,
        500.0,
        5.0,
        0.0,
        "[solver]\nscatter = \"fixed-point\"\n",
    );
    let run = || {
        let mut sim = materials_checks::simulation(&scene, BackendKind::Cuda);
        for _ in 0..40 {
            sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        }
        (sim.bodies().to_vec(), materials_checks::particles(&mut sim))
    };
    let (first, second) = (run(), run());
    assert!(
        bytemuck::cast_slice::<_, u8>(&first.0) == bytemuck::cast_slice::<_, u8>(&second.0),
        "two fixed-point runs' bodies differ: {:?} vs {:?}",
        first.0[0].center,
        second.0[0].center
    );
    assert!(
        common::same_particles(&first.1, &second.1),
        "two fixed-point runs' particles differ"
    );
}

/// The square logs of tests/bodies.rs, 10 cm across, at cells of 5 and 2.5 mm (and 1.25 mm for the
/// 150 kg/m^3 log, whose 15 mm draft is six cells at 2.5 mm), started tipped 5 degrees: the
/// submerged share of the section as a draft against Archimedes' (the density over the water's times
/// the side: 25, 50 and 75 mm for 250, 500 and 750 kg/m^3) within 5 %, and the tilt against the
/// metacentric stability of a square log (flat below a relative density of 0.21 and above 0.79, 45
/// degrees at 0.5), within 5 degrees, each log at its finest cells. In fixed point, so a run gives
/// the same numbers every time (in float the sums' order varies, and the 150 log's draft and the 850
/// log's tilt came within a hair of their bounds in some runs); `MPM_LOGS_SCATTER=float` runs the
/// float scatter; `MPM_LOGS_DX` and `MPM_LOGS_DENSITIES` (comma-separated) run those cells for those
/// densities instead. H200, 2026-11-29 (BENCHMARKS.md M17), fixed point: at 2.5 mm drafts +5.4, +0.2,
/// -0.5, +0.2 and +0.2 % for 150, 250, 500, 750 and 850 kg/m^3, tilts 0.6, 43.6 and 3.2 degrees for
/// 150, 500 and 850; the 150 log's draft +6.0, +5.4 and +3.6 % at 5, 2.5 and 1.25 mm (tilt 3.3
/// degrees at 1.25 mm). Until the momentum units followed the flow's speed in scenes with bodies
/// too, the 150 log read +1.9 % at 2.5 mm: the coarse units' rounding, not the resolution.
fn logs_float_at_their_draft_and_angle_at_finer_cells() {
    let side = 0.1f32;
    let list = |var: &str| -> Option<Vec<f32>> {
        let text = std::env::var(var).ok()?;
        Some(text.split(',').map(|x| x.trim().parse().expect(var)).collect())
    };
    let densities = list("MPM_LOGS_DENSITIES").unwrap_or_else(|| vec![150.0, 250.0, 500.0, 750.0, 850.0]);
    let cells = |rho: f32| match list("MPM_LOGS_DX") {
        Some(cells) => cells,
        None if rho < 200.0 => vec![0.005, 0.0025, 0.00125],
        None => vec![0.005, 0.0025],
    };
    let mut failures = Vec::new();
    for rho in densities {
        let cells = cells(rho);
        let finest = cells.iter().copied().fold(f32::INFINITY, f32::min);
        for dx in cells {
            let scatter = std::env::var("MPM_LOGS_SCATTER").unwrap_or_else(|_| "fixed-point".into());
            let scatter = format!("[solver]\nscatter = \"{scatter}\"\n");
            let scene =
                bodies_checks::log_in_water(dx, side, rho, 5.0, side * rho / 1000.0 - 0.5 * side, &scatter);
            let mut sim = materials_checks::simulation(&scene, BackendKind::Cuda);
            let f = bodies_checks::settle_log(&mut sim, dx, side, 4.0);
            let want_draft = f64::from(side * rho / 1000.0);
            // 250 and 750 kg/m^3 settle between flat and 45 degrees: only their draft is checked.
            let want_tilt = match rho as u32 {
                500 => Some(45.0),
                150 | 850 => Some(0.0),
                _ => None,
            };
            let draft_error = f.draft / want_draft - 1.0;
            println!(
                "RESULT dx = {dx} m, {rho} kg/m^3: draft {:.2} mm (Archimedes {:.1}, {:+.1} %), tilt {:.1} degrees \
                 (stability {want_tilt:?}), swings {:.2} degrees, {:.2} mm",
                1e3 * f.draft,
                1e3 * want_draft,
                100.0 * draft_error,
                f.tilt,
                f.tilt_swing,
                1e3 * f.draft_swing
            );
            if dx == finest {
                if draft_error.abs() > 0.05 {
                    failures.push(format!(
                        "{rho} kg/m^3 at {dx} m: draft {:+.1} %",
                        100.0 * draft_error
                    ));
                }
                if let Some(want) = want_tilt.filter(|want| (f.tilt - want).abs() > 5.0) {
                    failures.push(format!(
                        "{rho} kg/m^3 at {dx} m: tilt {:.1} degrees, want {want}",
                        f.tilt
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("; "));
}
