//! Several liquids on the GPU against the CPU oracle: a tank of water, a shear-thinning syrup, a
//! Bingham mud and a lighter oil, each particle carrying its material row (v.w on the device), the
//! oil's lower rest density switching every pipeline to the density gathered from the grid's volume.
//! Every pipeline and scatter must follow the reference's trajectory, keep each particle's material,
//! and run byte for byte again in fixed point (the ranks' check of two liquids is
//! tests/ranks_checks' `two_liquids_on_ranks_give_one_gpu_s_bits`). The mud regularised
//! elastically (each particle carrying its deformation) does the same in the fused pipeline, pours
//! from an emitter as on the CPU, and comes to rest in the slump test at finer cells than CI's. Where
//! no CUDA device and driver are usable, every test is reported as ignored, with the reason
//! (tests/harness).

use glam::Vec3;
use mpm::contract::VOLUME_UNITS_PER_WEIGHT;
use mpm::cuda::{CudaOptions, CudaSolver};
use mpm::sim::cpu::CpuSolver;
use mpm::sim::{Params, Particles, Pipeline, ScatterMode, Scene, Solver};

mod common;
mod harness;
mod materials_checks;

fn main() -> std::process::ExitCode {
    harness::run(
        "GPU",
        harness::cuda_device,
        harness::tests![
            every_pipeline_follows_the_cpu_with_several_liquids,
            each_law_alone_follows_the_cpu,
            several_liquids_in_fixed_point_are_byte_identical,
            the_volume_follows_the_cpu_to_a_unit_a_contribution,
            emitters_pour_their_own_liquid,
            power_law_films_forty_cells_across_have_the_power_law_profile,
            the_honey_preset_s_rope_coils,
            an_elastoviscoplastic_mud_follows_the_cpu,
            an_elastoviscoplastic_mud_in_fixed_point_is_byte_identical,
            an_emitted_mud_particle_starts_undeformed_as_on_the_cpu,
            the_slump_test_at_5_and_2_5_mm_comes_to_rest_at_its_runout,
            a_box_vortex_decays_at_its_viscous_rate,
            a_box_vortex_decays_at_its_viscous_rate_in_fixed_point,
        ],
    )
}

/// The materials of the tanks below: water, a Carreau-Yasuda syrup, a Bingham mud and an oil.
const MATERIALS: &str = r#"
[[material]]
name = "water"
rest_density = 1000.0
sound_speed = 10.0
[[material]]
name = "syrup"
law = "carreau-yasuda"
rest_density = 1000.0
sound_speed = 10.0
viscosity = 0.5
min_viscosity = 0.01
relaxation_time = 0.2
flow_index = 0.5
[[material]]
name = "mud"
law = "herschel-bulkley"
rest_density = 1000.0
sound_speed = 10.0
consistency = 0.1
yield_stress = 20.0
max_viscosity = 2.0
[[material]]
name = "oil"
rest_density = 800.0
sound_speed = 10.0
viscosity = 0.05
"#;

/// [`MATERIALS`] with the mud regularised elastically in place of the bi-viscous ceiling (it yields
/// past a deviatoric strain of 7e-3), its particles carrying their deformation: the fused
/// pipeline's only.
fn with_elastic_mud() -> String {
    MATERIALS.replace("max_viscosity = 2.0", "shear_modulus = 2000.0")
}

/// A 32 x 24 x 24 tank at dx = 1/32 m with four blocks side by side, one of each material (or
/// `only`'s for all four), stirred by their starting velocities so every term of the laws works.
fn tank(pipeline: Pipeline, scatter: ScatterMode, only: Option<&str>) -> Scene {
    tank_of(MATERIALS, pipeline, scatter, only)
}

/// [`tank`] of the liquids `materials`.
fn tank_of(materials: &str, pipeline: Pipeline, scatter: ScatterMode, only: Option<&str>) -> Scene {
    let names = ["water", "syrup", "mud", "oil"];
    let mut toml = format!(
        "name = \"liquids\"\n[domain]\nsize = [1.0, 0.75, 0.75]\nresolution = [32, 24, 24]\n{materials}"
    );
    for (k, name) in names.iter().enumerate() {
        let x0 = 0.03125 + 0.15 * k as f64;
        let speed = if k % 2 == 0 { 1.0 } else { -1.0 };
        toml += &format!(
            "[[block]]\nmin = [{x0}, 0.03125, 0.03125]\nmax = [{}, 0.4, 0.5]\nmaterial = \"{}\"\nvelocity = [{speed}, 0.0, 0.5]\n",
            x0 + 0.14,
            only.unwrap_or(name)
        );
    }
    let mut scene = common::scene(&toml);
    scene.pipeline = pipeline;
    scene.scatter = scatter;
    scene
}

/// The substep of the tanks: the CFL policy's at c0 + 2 m/s, within the viscous limit.
fn params_of(scene: &Scene) -> Params {
    let mut params = common::cfl_params(scene);
    params.dt = params
        .dt
        .min(mpm::sim::material::MaterialTable::viscous_dt(&params, params.dx));
    params
}

/// Every pipeline and scatter: four liquids, the oil's rest density making the density gathered from
/// the grid's volume.
///
/// A flake this check had under the carried density: on H100s it failed 2 of 6 runs after the
/// viscous stress took the rest volume (49a2b96) and 2 of 8 on 2026-11-27 (3077037's tree), a float
/// scatter at step 300 each time, once
/// the fused pipeline and once the binned, and both times the same particle (9942, syrup, 1 dx above
/// the floor at the edge of the liquid, 0.78 of its rest density): GPU 795.24 against the CPU's
/// 783.17 kg/m^3, 1.5 % apart (the bound is 0.1 %) while its position is 0.003 dx from the CPU's.
/// A discrete event, then, not drift, and found: the CPU reference gives the GPU's value to the
/// digit (795.2413, and its position to 1e-7 m) when it counts a node of less than 1e-6 kg (a
/// particle is 3.8e-3 kg) as empty in the fluid divergence (`density_after_g2p`: `mass[i] > 0`),
/// and 783.17 again at 1e-9 kg. So a node at the liquid's edge whose mass is a neighbour's weight
/// at the very end of its stencil is filled on one side and empty on the other once the positions
/// are a few thousandths of a cell apart; while filled, it brings that neighbour's velocity into
/// this particle's divergence at full weight. A gathered density forgets such a substep; the
/// carried density kept its jump for good. The density gathered from the volume (2026-11-28)
/// re-gathers it every substep, so such a jump lasts a substep, as in the scenes of one rest
/// density.
fn every_pipeline_follows_the_cpu_with_several_liquids() {
    for pipeline in Pipeline::ALL {
        for scatter in [ScatterMode::FixedPoint, ScatterMode::Float] {
            let scene = tank(pipeline, scatter, None);
            assert_eq!(scene.params().volume_density, 1);
            let p = common::follow_cpu(
                &scene,
                &params_of(&scene),
                300,
                1.0,
                &format!("{pipeline:?} {scatter:?}"),
            );
            let rows: Vec<usize> = (0..4)
                .map(|r| p.material.iter().filter(|&&m| m == r).count())
                .collect();
            assert!(rows.iter().all(|&n| n > 1000), "particles per material {rows:?}");
        }
    }
}

/// Each law as the scene's only liquid (one rest density: the gathered or advected density, the
/// kernels' path of a single material): fused and binned against the CPU.
fn each_law_alone_follows_the_cpu() {
    for name in ["syrup", "mud", "oil"] {
        for pipeline in [Pipeline::Fused, Pipeline::Binned] {
            let scene = tank(pipeline, ScatterMode::FixedPoint, Some(name));
            assert_eq!(
                scene.params().volume_density,
                0,
                "{name}: one rest density in use"
            );
            common::follow_cpu(
                &scene,
                &params_of(&scene),
                300,
                1.0,
                &format!("{name} alone, {pipeline:?}"),
            );
        }
    }
}

fn run(scene: &Scene, steps: usize) -> Particles {
    let params = params_of(scene);
    let mut gpu = CudaSolver::new(scene, CudaOptions::default()).unwrap();
    for _ in 0..steps {
        gpu.step(&params).unwrap();
    }
    gpu.read_particles().unwrap()
}

/// The elastoviscoplastic mud in all four blocks (a table of four liquids), the fused pipeline in
/// each scatter: its elastic part (the return to the yield surface, the deviatoric stress, the
/// signal speed) follows the CPU.
fn an_elastoviscoplastic_mud_follows_the_cpu() {
    for scatter in [ScatterMode::FixedPoint, ScatterMode::Float] {
        let scene = tank_of(&with_elastic_mud(), Pipeline::Fused, scatter, Some("mud"));
        assert!(scene.has_deformation());
        let p = common::follow_cpu(
            &scene,
            &params_of(&scene),
            300,
            1.0,
            &format!("elastoviscoplastic mud, {scatter:?}"),
        );
        // At yield, the elastic part's von Mises stress is sqrt(3) tau_y.
        let mud = &scene.materials[2].law;
        assert_eq!(scene.materials[2].name, "mud");
        let at_yield = 0.99 * 3.0f32.sqrt() * mud.yield_stress;
        let yielded = p
            .deformation
            .iter()
            .filter(|d| mpm::sim::solid::von_mises(mud, d.f, d.plastic) >= at_yield)
            .count();
        println!(
            "{scatter:?}: {yielded} of {} particles at the yield stress",
            p.len()
        );
        assert!(
            yielded > 100,
            "{scatter:?}: {yielded} particles yielded: the return went untested"
        );
    }
}

/// Two fixed-point runs of the elastoviscoplastic mud: the same bits, the deformation included.
fn an_elastoviscoplastic_mud_in_fixed_point_is_byte_identical() {
    let scene = tank_of(
        &with_elastic_mud(),
        Pipeline::Fused,
        ScatterMode::FixedPoint,
        Some("mud"),
    );
    let (first, second) = (run(&scene, 200), run(&scene, 200));
    assert!(
        common::same_particles(&first, &second)
            && bytemuck::cast_slice::<_, u8>(&first.deformation)
                == bytemuck::cast_slice::<_, u8>(&second.deformation),
        "two fixed-point runs of the elastoviscoplastic mud differ"
    );
}

/// tests/materials.rs's slump test at a half and a quarter of its cell (5 and 2.5 mm: 8 and 64
/// times the particles): at rest after 6 s, its runout within 10 % of Roussel and Coussot's.
fn the_slump_test_at_5_and_2_5_mm_comes_to_rest_at_its_runout() {
    for dx in [0.005, 0.0025] {
        materials_checks::axisymmetric_slump(mpm::backend::BackendKind::Cuda, dx)
            .assert_at_rest_at_its_runout();
    }
}

/// An emitter of the elastoviscoplastic mud on the GPU, from a state whose every slot holds a
/// strain (as a slot drained from a deformed particle does): the particles it emits start
/// undeformed, the rest keep what they held, and the emission is the CPU's, slot for slot.
fn an_emitted_mud_particle_starts_undeformed_as_on_the_cpu() {
    use mpm::sim::flow::{FlowState, Lifecycle, Slots};
    let scene = common::scene(&common::elastic_mud_jet());
    let mut particles = scene.spawn();
    let stale = mpm::sim::Deformation {
        f: glam::Mat3::from_diagonal(Vec3::new(1.2, 0.9, 1.0)),
        plastic: 0.0,
    };
    particles.deformation.iter_mut().for_each(|d| *d = stale);
    let state = FlowState::start(&scene.flow, scene.num_particles);
    let mut gpu = CudaSolver::restore(&scene, &particles, Some(&state), CudaOptions::default()).unwrap();
    gpu.emit(&common::cfl_params(&scene), 1).unwrap();
    let on_gpu = gpu.read_particles().unwrap();
    let mut lifecycle = Lifecycle::new(&scene, state);
    lifecycle.emit(Slots::of(&mut particles), 1);
    let emitted = lifecycle.state.counts.emitted;
    println!("{emitted} particles emitted");
    assert!(emitted > 0, "nothing was emitted");
    assert_eq!(on_gpu.live, particles.live, "the GPU emitted into other slots");
    assert!(
        on_gpu.deformation == particles.deformation,
        "an emitted particle's deformation differs from the CPU's (at rest)"
    );
}

fn several_liquids_in_fixed_point_are_byte_identical() {
    for pipeline in Pipeline::ALL {
        let scene = tank(pipeline, ScatterMode::FixedPoint, None);
        let (first, second) = (run(&scene, 200), run(&scene, 200));
        assert!(
            common::same_particles(&first, &second),
            "{pipeline:?}: two fixed-point runs of several liquids differ"
        );
    }
}

/// The grid's volume on the GPU follows the CPU reference's from each pipeline's scatter (the
/// report's warp runs, the tiles of the binned and fused pipelines) and the walls' mirror, after 100
/// substeps of four liquids have moved the particles off their lattice: node by node within a unit
/// a contribution. Not to the unit: NVRTC contracts the stencil's weights into fused multiply-adds,
/// so a weight's last bit, and then its rounding to units, may differ from the CPU's (on an H100,
/// 2026-11-28: 1,079 to 1,127 of about 7,250 nodes differed, by 4 units at most, of some 3e7). A node
/// of V weights takes about 27 V contributions (a particle's 27 weights sum to 1), hence the bound
/// 27 (V + 1) units.
fn the_volume_follows_the_cpu_to_a_unit_a_contribution() {
    for pipeline in Pipeline::ALL {
        let scene = tank(pipeline, ScatterMode::Float, None);
        let params = params_of(&scene);
        let mut gpu = CudaSolver::new(&scene, CudaOptions::default()).unwrap();
        for _ in 0..100 {
            gpu.step(&params).unwrap();
        }
        let particles = gpu.read_particles().unwrap();
        let volume = gpu.scatter_and_read_volume(&params).unwrap();
        let mut cpu = CpuSolver::new(particles, scene.grid_res);
        cpu.scatter_volume(&params);
        cpu.mirror_mass(&params);
        let filled = cpu.grid.volume.iter().filter(|&&v| v > 0).count();
        let (mut differing, mut worst) = (0, 0i64);
        for (&gpu_units, &cpu_units) in volume.iter().zip(&cpu.grid.volume) {
            let gap = (gpu_units - cpu_units).abs();
            differing += usize::from(gap > 0);
            worst = worst.max(gap);
            let contributions = 27 * (cpu_units / VOLUME_UNITS_PER_WEIGHT as i64 + 1);
            assert!(
                gap <= contributions,
                "{pipeline:?}: a node's volume is {gpu_units} units on the GPU, {cpu_units} on the CPU"
            );
        }
        println!(
            "{pipeline:?}: {filled} nodes hold volume; {differing} differ from the CPU's, by {worst} units at most"
        );
        assert!(
            filled > 1000,
            "{pipeline:?}: the volume is nearly empty ({filled} nodes)"
        );
    }
}

/// An emitter of oil into water: the emitted particles are oil on the GPU as on the CPU, at the
/// oil's rest density, and the runs agree.
fn emitters_pour_their_own_liquid() {
    let toml = format!(
        "name = \"pour\"\n[domain]\nsize = [0.5, 0.5, 0.5]\nresolution = [32, 32, 32]\n{MATERIALS}\n\
         [particles]\ncapacity = 60000\n\
         [[block]]\nmin = [0.03125, 0.03125, 0.03125]\nmax = [0.46, 0.15, 0.46]\nmaterial = \"water\"\n\
         [[emitter]]\nshape = \"disc\"\ncenter = [0.25, 0.4, 0.25]\nnormal = [0.0, -1.0, 0.0]\nradius = 0.04\nspeed = 1.0\nmaterial = \"oil\"\n"
    );
    for backend in ["cpu", "cuda"] {
        let scene = common::scene(&toml);
        let solver = mpm::backend::create(backend_kind(backend), &scene).unwrap();
        let mut sim = mpm::sim::Simulation::new(scene, solver);
        for _ in 0..20 {
            sim.advance_frame().unwrap();
        }
        let p = sim.solver_mut().read_particles().unwrap();
        let oil: Vec<usize> = (0..p.len())
            .filter(|&i| p.live[i] && p.material[i] == 3)
            .collect();
        println!("{backend}: {} oil particles emitted", oil.len());
        assert!(oil.len() > 500, "{backend}: only {} oil particles", oil.len());
        let water = (0..p.len()).filter(|&i| p.live[i] && p.material[i] == 0).count();
        assert_eq!(
            water + oil.len(),
            p.num_live(),
            "{backend}: a live particle of another material"
        );
    }
}

/// The `honey` preset (10 Pa s, a 3 mm nozzle with a pipe, 1.8 cm above a plate): once the heap has
/// formed, the foot of the rope circles the axis, always the same way round, a few turns a second.
/// The foot is the lowest tenth of the particles falling faster than half the nozzle's speed; its
/// centroid's angle about the nozzle's axis is sampled every three frames (20 Hz), each step
/// unwrapped to the nearest turn. An H200 measured 3.6 turns a second on a circle of 4 cells (2 mm)
/// from 2.4 s to 4 s, every step 49 to 84 degrees the same way (docs/physics.md, "Pouring a viscous
/// rope"). A rope that buckled now and then without coiling, or piled straight up, would not turn.
///
/// In the fixed-point scatter, so that it gives the same turns every run: the preset's own float
/// scatter sums in an order that varies run to run, and the coiling is chaotic. On an H200
/// (2026-11-28) the float scatter failed this check 1 of 10 runs, the foot wandering both ways
/// (1.04 turns in the 1.2 s) where the other nine turned 3.7 to 4.2 times one way or the other; in
/// fixed point two runs turned -4.12 times each, steps -102 to -38 degrees (BENCHMARKS.md M8).
fn the_honey_preset_s_rope_coils() {
    let mut scene = Scene::load("honey").unwrap();
    scene.scatter = ScatterMode::FixedPoint;
    let emitter = &scene.flow.emitters[0];
    let (axis, speed, dx) = (emitter.center.as_vec3(), emitter.speed, scene.dx);
    let solver = mpm::backend::create(mpm::backend::BackendKind::Cuda, &scene).unwrap();
    let mut sim = mpm::sim::Simulation::new(scene, solver);
    for _ in 0..144 {
        sim.advance_frame().unwrap(); // 2.4 s: the heap has formed and the coiling set in
    }
    let mut angles = Vec::new();
    let mut radii = Vec::new();
    for _ in 0..24 {
        for _ in 0..3 {
            sim.advance_frame().unwrap();
        }
        let p = sim.solver_mut().read_particles().unwrap();
        let mut falling: Vec<Vec3> = (0..p.len())
            .filter(|&i| p.live[i] && p.v[i].y < -0.5 * speed)
            .map(|i| p.x[i])
            .collect();
        falling.sort_by(|a, b| a.y.total_cmp(&b.y));
        let foot = &falling[..falling.len() / 10];
        let centroid = foot.iter().copied().sum::<Vec3>() / foot.len() as f32 - axis;
        angles.push(centroid.z.atan2(centroid.x).to_degrees());
        radii.push(centroid.x.hypot(centroid.z) / dx);
    }
    let steps: Vec<f32> = angles
        .windows(2)
        .map(|w| (w[1] - w[0] + 540.0).rem_euclid(360.0) - 180.0)
        .collect();
    let turns = steps.iter().sum::<f32>() / 360.0;
    let radius = radii.iter().sum::<f32>() / radii.len() as f32;
    println!(
        "the rope's foot: {turns:.2} turns in 1.2 s on a circle of {radius:.2} cells; steps {:.0} to {:.0} degrees",
        steps.iter().copied().fold(f32::MAX, f32::min),
        steps.iter().copied().fold(f32::MIN, f32::max)
    );
    let one_way = steps.iter().all(|&s| s > 0.0) || steps.iter().all(|&s| s < 0.0);
    assert!(one_way, "the foot does not circle one way round: {steps:?}");
    assert!(turns.abs() >= 2.0, "{turns} turns in 1.2 s");
    assert!(
        radius >= 2.0,
        "the foot circles {radius} cells from the axis: it does not coil"
    );
}

fn backend_kind(name: &str) -> mpm::backend::BackendKind {
    match name {
        "cpu" => mpm::backend::BackendKind::Cpu,
        _ => mpm::backend::BackendKind::Cuda,
    }
}

/// tests/materials.rs's power-law films at four times its resolution, 40 cells across the film: both
/// within 5 % of U of the power law's velocity profile, the target the CPU's 10 cells miss for the
/// shear-thinning film (7.3 %). Its error falls with the cell (the shear rate it thins with is the
/// particles' affine velocity gradient, an average over three cells): 5.5 % at 20 cells, 4.5 % at 40
/// on an H100 (2026-11-27). 154,000 substeps of the viscous limit over 205,000 particles: about 10 s.
/// Not finer: at 80 cells the substep (0.16 us) moves a particle by a few units in the last place of
/// its single-precision position, and the profile strays 14 %.
fn power_law_films_forty_cells_across_have_the_power_law_profile() {
    use materials_checks::{film, THICKENING, THINNING};
    for law in [THINNING, THICKENING] {
        let (worst, amplitude) = film(mpm::backend::BackendKind::Cuda, 40, law);
        assert!(
            worst < 0.05,
            "n = {}: the profile strays {:.1} % of U from the power law's (5 % allowed)",
            law.n,
            100.0 * worst
        );
        assert!(
            amplitude > 0.5,
            "n = {}: U is {amplitude} of the developed film's surface speed: the film barely moved",
            law.n
        );
    }
}

/// tests/materials.rs's box vortex on the GPU at 32 and 64 cells across: 4 and 11 Pa s decay at the
/// Stokes rate 4 nu k^2 (the kinetic energy) within 3 %, the bulk viscous stress that the Stokes
/// sphere (tests/gpu_bodies.rs) moves through. H200, 2026-11-29 (BENCHMARKS.md M14): the float
/// scatter +1.2, -0.1, -0.1, -0.1 % (the CPU's figures at 32 cells, digit for digit).
fn a_box_vortex_decays_at_its_viscous_rate() {
    box_vortex_decays("float");
}

/// The same in the fixed-point scatter: +1.2, -0.1, -0.1, -0.1 %, the float scatter's digits (H200,
/// 2026-11-29, BENCHMARKS.md M15). Its momentum units used to be made for the sound speed (10 m/s
/// here), and the tiles' rounding step, a cell's mass at that speed over 2^27, is coarse beside this
/// vortex's 1 cm/s: it decayed +5.4 and +6.7 % fast at 32 cells, +9.1 and +28.6 % at 64 (M14). The
/// units now follow the flow's own speed (docs/physics.md, "Determinism on the GPU").
fn a_box_vortex_decays_at_its_viscous_rate_in_fixed_point() {
    box_vortex_decays("fixed-point");
}

fn box_vortex_decays(scatter: &str) {
    let mut failures = Vec::new();
    for cells in [32, 64] {
        for viscosity in [4.0, 11.0] {
            let d =
                materials_checks::box_vortex(mpm::backend::BackendKind::Cuda, cells, viscosity, scatter, 6);
            let error = d.rate / d.expected - 1.0;
            println!(
                "RESULT box vortex, {cells} cells, {scatter}, {viscosity} Pa s: {:.3} per second against {:.3}: \
                 {:+.1} % (nu dt / dx^2 = {:.3})",
                d.rate,
                d.expected,
                100.0 * error,
                d.viscous_number
            );
            if error.abs() >= 0.03 {
                failures.push(format!(
                    "{cells} cells, {viscosity} Pa s: {:+.1} %",
                    100.0 * error
                ));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "the vortex in the {scatter} scatter decays off its rate: {failures:?}"
    );
}
