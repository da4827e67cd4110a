//! The CUDA kernels against the CPU reference, headless, for both GPU pipelines. Where no CUDA device
//! and driver are usable, every test is reported as ignored, with the reason (tests/harness:
//! `harness = false`).
//!
//! Why the tolerances are what they are: the kernels compute the CPU reference's expressions in the
//! same order, but (a) float atomics add a node's contributions in whatever order threads arrive, so a
//! node sum of k terms differs by up to ~k ulps of its largest term, and (b) NVRTC contracts a*b+c into
//! fused multiply-adds, which round once instead of twice. Both are relative errors near 1e-7 per
//! operation; the bounds below allow 1e-5..1e-4 of the quantity's own scale, well above that noise
//! and far below any real bug (a wrong weight, index or sign is an O(1) error).

use glam::{Mat3, Vec3};
use mpm::cuda::{CudaOptions, CudaSolver, FloatScatter};
use mpm::sim::cpu::{CpuSolver, Stencil};
use mpm::sim::params::{Pipeline, ScatterMode};
use mpm::sim::{presets, Params, Particles, Phase, Scene, Solver};

mod common;
mod harness;

fn main() -> std::process::ExitCode {
    harness::run(
        "GPU",
        harness::cuda_device,
        harness::tests![
            p2g_init_matches_cpu,
            p2g_matches_cpu,
            grid_update_and_g2p_match_cpu,
            both_float_scatter_forms_match_cpu,
            fused_grid_update_mirrors_as_mirror_walls_does,
            transfers_conserve_mass_and_momentum,
            dam_break_follows_cpu_trajectory,
            fixed_point_is_byte_identical_and_float_is_close,
            particles_in_bin_order_run_as_particles_in_place,
            fixed_point_overflow_is_reported,
            fixed_point_scatter_past_the_tile_adds_the_same_integers,
            fixed_point_tile_wraps_are_caught_after_the_adds,
            device_spawn_matches_scene_spawn,
            phase_timings_are_measured,
            sort_orders_particles_by_cell,
            binned_bins_hold_each_particle_once_and_follow_the_flow,
            binned_fixed_point_is_byte_identical_across_rebins,
            graphed_substeps_match_launched_ones,
            binned_pipeline_follows_the_report_pipeline,
            device_statistics_match_a_host_reduction,
            colliders_grid_update_and_backstop_match_cpu,
            colliders_trajectory_follows_cpu,
            colliders_fixed_point_runs_are_byte_identical,
            a_block_leaving_a_wall_keeps_its_speed,
            a_push_moves_the_water_on_every_pipeline,
        ],
    )
}

/// The viewer's push moves the water on every pipeline. The fused pipeline keeps the next substep's
/// scatter on its grid, made from the velocities before a push, and its next pass gathers over it:
/// a push between substeps must reach that scatter. After 3 substeps of the drop, a push along x;
/// a substep later, the particles it pushed hardest move along x faster than without it by at
/// least half of what it gave them.
fn a_push_moves_the_water_on_every_pipeline() {
    for pipeline in [Pipeline::Fused, Pipeline::Binned, Pipeline::Report] {
        let mut scene = Scene::load("drop").expect("preset");
        scene.pipeline = pipeline;
        let mut params = common::cfl_params(&scene);
        params.density_rule = pipeline.density_rule().code();
        let (lo, hi) = scene.fluid_region();
        let centre = (0.5 * (lo + hi)).as_vec3();
        let push = mpm::sim::Push::new(
            centre - Vec3::new(0.0, 0.0, 2.0),
            Vec3::Z,
            0.3 * (hi - lo).as_vec3().max_element(),
            Vec3::new(1.5, 0.0, 0.0),
        );
        let after = |pushed: bool| {
            let mut solver = CudaSolver::new(&scene, CudaOptions::default()).expect("CUDA solver");
            for _ in 0..3 {
                solver.step(&params).unwrap();
            }
            if pushed {
                solver.apply_push(&push).unwrap();
            }
            solver.step(&params).unwrap();
            solver.read_particles().unwrap()
        };
        let (plain, pushed) = (after(false), after(true));
        let hard: Vec<usize> = (0..plain.len())
            .filter(|&i| push.velocity_change(plain.x[i]).x >= 1.0)
            .collect();
        assert!(
            hard.len() > 100,
            "{pipeline:?}: the push met {} particles",
            hard.len()
        );
        let gained = hard.iter().map(|&i| pushed.v[i].x - plain.v[i].x).sum::<f32>() / hard.len() as f32;
        println!(
            "{pipeline:?}: {} particles pushed hardest gained {gained:.3} m/s along x",
            hard.len()
        );
        assert!(
            gained > 0.5,
            "{pipeline:?}: the push of at least 1 m/s left them {gained} m/s faster"
        );
    }
}

/// A small closed tank, 32 x 24 x 24 nodes, dx = 1/32 m, water at c0 = 10 m/s; the block is flush
/// against the floor and two walls, so the wall mirror (and its edges and corner) is exercised.
const SMALL_TANK: &str = common::tank!(
    "small-tank",
    [1.0, 0.75, 0.75],
    [32, 24, 24],
    r#"
[solver]
scatter = "float"
[time_step]
cfl = 0.4
[[block]]
min = [0.03125, 0.03125, 0.03125]
max = [0.6, 0.5, 0.5]
"#
);

fn small_tank_in(pipeline: Pipeline, scatter: ScatterMode) -> Scene {
    tank_in(SMALL_TANK, "small-tank", pipeline, scatter)
}

/// The scene of `toml` (its source named `source`) with its pipeline and scatter set.
fn tank_in(toml: &str, source: &str, pipeline: Pipeline, scatter: ScatterMode) -> Scene {
    let mut scene = Scene::from_toml(toml, source).expect("the test scene is valid");
    scene.scatter = scatter;
    scene.pipeline = pipeline;
    scene
}

/// Every GPU pipeline with both scatter modes: every phase test runs each against the CPU oracle
/// (which follows the pipeline's density rule through `Params::density_rule`), so the tiled and
/// fused scatters are held to the same bounds as the report's global-atomic ones.
const VARIANTS: [(Pipeline, ScatterMode); 6] = [
    (Pipeline::Report, ScatterMode::Float),
    (Pipeline::Report, ScatterMode::FixedPoint),
    (Pipeline::Binned, ScatterMode::Float),
    (Pipeline::Binned, ScatterMode::FixedPoint),
    (Pipeline::Fused, ScatterMode::Float),
    (Pipeline::Fused, ScatterMode::FixedPoint),
];

/// A deterministic generator (no dependency needed for test noise): xorshift64*.
struct Noise(u64);
impl Noise {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40;
        bits as f32 / (1u64 << 24) as f32 * 2.0 - 1.0 // [-1, 1)
    }
    fn vec3(&mut self, scale: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * scale
    }
}

/// The scene's lattice, each particle jittered by up to 0.2 of the particle spacing, with random
/// velocities (|v| up to 1 m/s per axis), affine matrices (up to 5 1/s per entry) and carried
/// densities (rest +- 3 %, which the fused pipeline's scatter reads): every term of every kernel is
/// exercised, and the density stays within tens of percent of rest.
fn random_particles(scene: &Scene, seed: u64) -> Particles {
    let mut noise = Noise(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
    let spacing = scene.lattice().spacing as f32;
    let mut p = scene.spawn();
    for i in 0..p.len() {
        p.x[i] += noise.vec3(0.2 * spacing);
        p.v[i] = noise.vec3(1.0);
        p.c[i] = Mat3::from_cols(noise.vec3(5.0), noise.vec3(5.0), noise.vec3(5.0));
        p.rho[i] *= 1.0 + 0.03 * noise.next();
    }
    p
}

/// How far into a substep [`run_phases`] goes. Each phase includes the wall mirror pass after it.
#[derive(Clone, Copy, PartialEq, PartialOrd)]
enum Through {
    P2gInit,
    P2g,
    GridUpdate,
}

/// The substep's phases, from a clear grid through `last`, on both backends.
fn run_phases(cpu: &mut CpuSolver, gpu: &mut CudaSolver, params: &Params, last: Through) {
    cpu.clear_grid();
    cpu.p2g_init(params);
    cpu.mirror_mass(params);
    gpu.p2g_init(params).unwrap();
    gpu.mirror_mass(params).unwrap();
    if last >= Through::P2g {
        cpu.p2g(params);
        cpu.mirror_momentum(params);
        gpu.p2g(params).unwrap();
        gpu.mirror_momentum(params).unwrap();
    }
    if last >= Through::GridUpdate {
        cpu.grid_update(params);
        gpu.grid_update(params).unwrap();
    }
}

/// The scatter's grid sums on the GPU against the CPU's ([`assert_sums_close`]).
fn assert_scatter_matches_cpu(gpu: &mut CudaSolver, cpu: &CpuSolver, params: &Params, what: &str) {
    let (mass, momentum) = gpu.read_grid_accumulators(params).unwrap();
    assert_sums_close(&mass, &momentum, &cpu.grid.mass, &cpu.grid.momentum, what);
}

/// Grid sums against reference sums: mass within 1e-5 and momentum within 1e-4 of the reference's
/// largest (the tolerances of this file's note); prints both errors after `what`.
fn assert_sums_close(mass: &[f32], momentum: &[Vec3], ref_mass: &[f32], ref_momentum: &[Vec3], what: &str) {
    let (mass_err, mass_scale) = mass_error(mass, ref_mass);
    let (momentum_err, momentum_scale) = momentum_error(momentum, ref_momentum);
    println!(
        "{what}: max mass error {:.2e}, max momentum error {:.2e} of the largest",
        mass_err / mass_scale,
        momentum_err / momentum_scale
    );
    assert!(
        mass_scale > 0.0 && mass_err <= 1e-5 * mass_scale,
        "{what}: mass error {mass_err} vs {mass_scale}"
    );
    assert!(
        momentum_err <= 1e-4 * momentum_scale,
        "{what}: momentum error {momentum_err} vs {momentum_scale}"
    );
}

/// The largest difference of node masses from the reference's, and the reference's largest.
fn mass_error(mass: &[f32], ref_mass: &[f32]) -> (f32, f32) {
    (
        common::max_abs(mass.iter().zip(ref_mass).map(|(a, b)| a - b)),
        common::max_abs(ref_mass.iter().copied()),
    )
}

/// The largest difference of node momenta from the reference's, and the reference's largest
/// component. The momentum sums large, cancelling stress impulses, so the error is judged against
/// the largest node momentum rather than each node's own (possibly near-zero) value.
fn momentum_error(momentum: &[Vec3], ref_momentum: &[Vec3]) -> (f32, f32) {
    (
        common::max_diff_vec3(momentum, ref_momentum),
        common::max_abs(ref_momentum.iter().map(|m| m.abs().max_element())),
    )
}

/// `err` at most `bound` times `scale` (its quantity's largest value, as this file's note says):
/// prints the ratio and asserts it, `what` naming the case and the quantity.
fn assert_relative(what: &str, err: f32, scale: f32, bound: f32) {
    println!("{what}: max error {:.2e} of the largest", err / scale);
    assert!(err <= bound * scale, "{what}: error {err} vs {scale}");
}

/// The particles' densities within 1e-5 of the reference's, relative.
fn assert_rho_close(what: &str, rho: &[f32], ref_rho: &[f32]) {
    let err = common::max_abs(rho.iter().zip(ref_rho).map(|(a, b)| (a - b) / b));
    println!("{what}: max relative rho error {err:.2e}");
    assert!(err <= 1e-5, "{what}: density error {err}");
}

fn pair(scene: &Scene, particles: &Particles) -> (CpuSolver, CudaSolver) {
    let cpu = CpuSolver::new(particles.clone(), scene.grid_res);
    let gpu = CudaSolver::from_particles(scene, particles, CudaOptions::default()).expect("CUDA solver");
    (cpu, gpu)
}

/// The small tank in one of the [`VARIANTS`], its particles [`random_particles`] of `seed`, on both
/// backends through `last`.
fn phases_through(
    (pipeline, scatter): (Pipeline, ScatterMode),
    seed: u64,
    last: Through,
) -> (Scene, Params, CpuSolver, CudaSolver) {
    let scene = small_tank_in(pipeline, scatter);
    let particles = random_particles(&scene, seed);
    let params = common::cfl_params(&scene);
    let (mut cpu, mut gpu) = pair(&scene, &particles);
    run_phases(&mut cpu, &mut gpu, &params, last);
    (scene, params, cpu, gpu)
}

/// The GPU's grid velocities after the grid update against the CPU's (which its update leaves in
/// `grid.momentum`): within 1e-4 of the largest, beyond `allowance(mass, velocity)` at each node.
/// Returns that largest velocity.
fn assert_grid_velocity_close(
    what: &str,
    scene: &Scene,
    cpu: &CpuSolver,
    gpu: &mut CudaSolver,
    allowance: impl Fn(f32, Vec3) -> f32,
) -> f32 {
    let (_, velocity) = gpu.read_grid_velocity().unwrap();
    // v = mv / m: at a node that only a stencil's edge touches, m is a tiny weight and the ratio
    // amplifies the momentum's rounding; nodes under 1 % of a particle's mass are left out.
    let m_min = 0.01 * scene.material().particle_mass;
    let vmax = common::max_abs(cpu.grid.momentum.iter().map(|v| v.abs().max_element()));
    let mut err = 0.0f32;
    for ((&m, v), cpu_v) in cpu.grid.mass.iter().zip(&velocity).zip(&cpu.grid.momentum) {
        if m > m_min {
            err = err.max((*v - *cpu_v).abs().max_element() - allowance(m, *cpu_v));
        }
    }
    assert_relative(&format!("{what}: grid velocity"), err, vmax, 1e-4);
    vmax
}

/// g2p on both backends after the grid update: the particles' velocities within 1e-4 of the grid's
/// largest velocity `vmax`, their positions within 1e-5 dx. Returns the GPU's particles.
fn assert_g2p_close(
    what: &str,
    scene: &Scene,
    params: &Params,
    cpu: &mut CpuSolver,
    gpu: &mut CudaSolver,
    vmax: f32,
) -> Particles {
    cpu.g2p(params);
    gpu.g2p(params).unwrap();
    let p = gpu.read_particles().unwrap();
    let dv = common::max_diff_vec3(&p.v, &cpu.particles.v);
    let dxp = common::max_diff_vec3(&p.x, &cpu.particles.x) / scene.dx;
    println!("{what}: max |dv| {dv:.2e} m/s, max |dx| {dxp:.2e} dx");
    assert!(dv <= 1e-4 * vmax, "{what}: particle velocity error {dv}");
    assert!(dxp <= 1e-5, "{what}: position error {dxp} dx");
    p
}

fn p2g_init_matches_cpu() {
    for variant @ (pipeline, scatter) in VARIANTS {
        let (_, params, cpu, mut gpu) = phases_through(variant, 1, Through::P2gInit);
        let (mass, _) = gpu.read_grid_accumulators(&params).unwrap();
        let (err, scale) = mass_error(&mass, &cpu.grid.mass);
        let what = format!("p2g_init {pipeline:?} {scatter:?}: node mass");
        assert_relative(&what, err, scale, 1e-5);
    }
}

fn p2g_matches_cpu() {
    for variant @ (pipeline, scatter) in VARIANTS {
        let (_, params, cpu, mut gpu) = phases_through(variant, 2, Through::P2g);
        let (_, momentum) = gpu.read_grid_accumulators(&params).unwrap();
        let rho = gpu.read_particles().unwrap().rho;
        let what = format!("p2g {pipeline:?} {scatter:?}");
        assert_rho_close(&what, &rho, &cpu.particles.rho);
        let (err, scale) = momentum_error(&momentum, &cpu.grid.momentum);
        assert_relative(&format!("{what}: momentum"), err, scale, 1e-4);
    }
}

fn grid_update_and_g2p_match_cpu() {
    for variant @ (pipeline, scatter) in VARIANTS {
        let (scene, params, mut cpu, mut gpu) = phases_through(variant, 3, Through::GridUpdate);
        let what = format!("{pipeline:?} {scatter:?}");
        let vmax =
            assert_grid_velocity_close(&format!("grid_update {what}"), &scene, &cpu, &mut gpu, |_, _| 0.0);
        let p = assert_g2p_close(&format!("g2p {what}"), &scene, &params, &mut cpu, &mut gpu, vmax);
        let dc = common::max_diff_mat3(&p.c, &cpu.particles.c);
        let cmax = common::max_abs(cpu.particles.c.iter().flat_map(|m| m.to_cols_array()));
        assert_relative(&format!("g2p {what}: C"), dc, cmax, 1e-3);
        // The density the particles carry on: p2g's, or (fused) the grid's advected by tr C.
        assert_rho_close(&format!("g2p {what}"), &p.rho, &cpu.particles.rho);

        // The extremes the time step is chosen from: each particle's own c(rho) + |v|, and the rest.
        // powf on the device and the host may differ in the last bits, hence relative 1e-5.
        let (e_cpu, e_gpu) = (cpu.take_extremes().unwrap(), gpu.take_extremes().unwrap());
        println!("g2p {what}: extremes CPU {e_cpu:?}, GPU {e_gpu:?}");
        for (quantity, a, b) in [
            ("max signal speed", e_cpu.max_signal_speed, e_gpu.max_signal_speed),
            ("max speed", e_cpu.max_speed, e_gpu.max_speed),
            ("max density", e_cpu.max_density, e_gpu.max_density),
        ] {
            assert!(
                a > 0.0 && (a - b).abs() <= 1e-5 * a,
                "{what}: {quantity} CPU {a} vs GPU {b}"
            );
        }
        assert!(
            e_cpu.max_signal_speed
                <= scene.material().sound_speed_at(e_cpu.max_density) + e_cpu.max_speed * (1.0 + 1e-6),
            "each particle's signal speed is bounded by the paired maxima"
        );
    }
}

/// The fused pipeline's float scatter has two forms (one_pass_float node by node, one_pass_float_planes
/// a plane of nodes at a time), the scene's size choosing; the small tank gets the first. Each, fixed:
/// the scatter of particles as they are against the CPU's, and the substep's g2p with the next
/// scatter after it against the other form's (the same sums, added in another order).
fn both_float_scatter_forms_match_cpu() {
    let scene = small_tank_in(Pipeline::Fused, ScatterMode::Float);
    let particles = random_particles(&scene, 8);
    let params = common::cfl_params(&scene);
    let mut next_scatters = Vec::new();
    for form in [FloatScatter::Runs, FloatScatter::Planes] {
        let options = CudaOptions {
            float_scatter: form,
            ..CudaOptions::default()
        };
        let mut cpu = CpuSolver::new(particles.clone(), scene.grid_res);
        let mut gpu = CudaSolver::from_particles(&scene, &particles, options).expect("CUDA solver");
        run_phases(&mut cpu, &mut gpu, &params, Through::P2g);
        assert_scatter_matches_cpu(&mut gpu, &cpu, &params, &format!("{form:?}"));
        gpu.grid_update(&params).unwrap();
        gpu.g2p(&params).unwrap();
        next_scatters.push(gpu.read_grid_accumulators(&params).unwrap());
    }
    let [(mass_a, momentum_a), (mass_b, momentum_b)] = &next_scatters[..] else {
        unreachable!("one scatter per form")
    };
    assert_sums_close(
        mass_b,
        momentum_b,
        mass_a,
        momentum_a,
        "the next substep's scatter, planes against runs",
    );
}

/// A tank whose water touches every wall, on 32 x 26 x 25 nodes: the high walls' reach (nodes R - 3
/// to R - 1) spans two node blocks in y and z, not in x, so the fused grid update's mirror meets
/// orbits inside one node block and orbits that cross two.
const CROSSING_TANK: &str = common::tank!(
    "crossing-tank",
    [1.0, 0.8125, 0.78125],
    [32, 26, 25],
    r#"
[time_step]
cfl = 0.4
[[block]]
min = [0.03125, 0.03125, 0.03125]
max = [0.6, 0.75, 0.71875]
"#
);

/// The fused pipeline's grid update adds the walls' images itself: the same grid as mirror_walls
/// (mass, then momentum) and the grid update after it, bit for bit in fixed point, within float
/// atomics' ordering noise in float, over two substeps (so the nodes the update leaves to
/// clear_crossing_orbits must have been cleared). Compared on every node block the scatter touched:
/// mirror_walls also writes images into blocks no particle reads, which the fused update skips.
fn fused_grid_update_mirrors_as_mirror_walls_does() {
    for (toml, name) in [(SMALL_TANK, "small tank"), (CROSSING_TANK, "crossing tank")] {
        for scatter in [ScatterMode::FixedPoint, ScatterMode::Float] {
            let scene = tank_in(toml, "tank", Pipeline::Fused, scatter);
            let particles = random_particles(&scene, 7);
            let params = common::cfl_params(&scene);
            let solver = || CudaSolver::from_particles(&scene, &particles, CudaOptions::default()).unwrap();
            let (mut separate, mut fused) = (solver(), solver());
            for substep in 0..2 {
                if substep == 0 {
                    separate.p2g_init(&params).unwrap();
                    fused.p2g_init(&params).unwrap();
                } else {
                    separate.g2p(&params).unwrap();
                    fused.g2p(&params).unwrap();
                }
                let (scattered, _) = fused.read_grid_accumulators(&params).unwrap();
                separate.mirror_mass(&params).unwrap();
                separate.mirror_momentum(&params).unwrap();
                separate.grid_update(&params).unwrap();
                fused.mirror_and_grid_update(&params).unwrap();

                let touched = touched_node_blocks(&scattered, scene.grid_res);
                let (mass_a, vel_a) = separate.read_grid_velocity().unwrap();
                let (mass_b, vel_b) = fused.read_grid_velocity().unwrap();
                let (mut compared, mut worst) = (0usize, 0.0f32);
                let vmax = common::max_abs(vel_a.iter().map(|v| v.abs().max_element()));
                let mmax = common::max_abs(mass_a.iter().copied());
                for node in 0..mass_a.len() {
                    if !touched[node_block_of(node, scene.grid_res)] {
                        continue;
                    }
                    compared += 1;
                    if scatter == ScatterMode::FixedPoint {
                        assert!(
                            mass_a[node].to_bits() == mass_b[node].to_bits() && vel_a[node] == vel_b[node],
                            "{name}, substep {substep}, node {node}: mirror_walls gave mass {} velocity {}, \
                             the fused update {} {}",
                            mass_a[node],
                            vel_a[node],
                            mass_b[node],
                            vel_b[node]
                        );
                    } else {
                        worst = worst
                            .max((mass_a[node] - mass_b[node]).abs() / mmax)
                            .max((vel_a[node] - vel_b[node]).abs().max_element() / vmax);
                    }
                }
                println!(
                    "{name} {scatter:?}, substep {substep}: {compared} nodes compared, largest difference \
                     {worst:.1e} of the largest value"
                );
                assert!(compared > 0);
                assert!(
                    worst <= 1e-5,
                    "{name} {scatter:?}: the fused update differs by {worst:.1e}"
                );
                let (mass, momentum) = fused.read_grid_accumulators(&params).unwrap();
                assert!(
                    mass.iter().all(|&m| m == 0.0) && momentum.iter().all(|&p| p == Vec3::ZERO),
                    "{name} {scatter:?}: the fused update left sums in the grid"
                );
            }
        }
    }
}

/// Per node block (4 x 4 x 4 nodes), whether the scatter put mass on any of its nodes.
fn touched_node_blocks(mass: &[f32], res: [u32; 3]) -> Vec<bool> {
    let blocks = res.map(|r| r.div_ceil(4) as usize);
    let mut touched = vec![false; blocks.iter().product()];
    for (node, &m) in mass.iter().enumerate() {
        if m != 0.0 {
            touched[node_block_of(node, res)] = true;
        }
    }
    touched
}

fn node_block_of(node: usize, res: [u32; 3]) -> usize {
    let res = res.map(|r| r as usize);
    let c = [node % res[0], node / res[0] % res[1], node / (res[0] * res[1])];
    let blocks = res.map(|r| r.div_ceil(4));
    c[0] / 4 + blocks[0] * (c[1] / 4 + blocks[1] * (c[2] / 4))
}

fn transfers_conserve_mass_and_momentum() {
    for pipeline in Pipeline::ALL {
        let scene = small_tank_in(pipeline, ScatterMode::Float);
        let particles = random_particles(&scene, 4);
        let params = common::cfl_params(&scene);
        let (_, mut gpu) = pair(&scene, &particles);
        gpu.p2g_init(&params).unwrap();
        gpu.p2g(&params).unwrap();
        let (mass, momentum) = gpu.read_grid_accumulators(&params).unwrap();
        let m_p = f64::from(scene.material().particle_mass);
        let grid_mass: f64 = mass.iter().map(|&m| f64::from(m)).sum();
        let particle_mass = particles.len() as f64 * m_p;
        let grid_p = momentum.iter().fold(glam::DVec3::ZERO, |s, m| s + m.as_dvec3());
        let particle_p = particles
            .v
            .iter()
            .fold(glam::DVec3::ZERO, |s, v| s + v.as_dvec3() * m_p);
        // sum_i w = 1 and sum_i w d = 0 per particle, so both totals are exact up to rounding; the scale
        // of the momentum rounding is the particles' summed |m v|.
        let p_scale: f64 = particles.v.iter().map(|v| f64::from(v.length()) * m_p).sum();
        let mass_err = (grid_mass - particle_mass).abs() / particle_mass;
        let p_err = (grid_p - particle_p).abs().max_element() / p_scale;
        println!("{pipeline:?}: mass error {mass_err:.2e}, momentum error {p_err:.2e} of sum |m v|");
        assert!(
            mass_err <= 1e-5,
            "grid mass {grid_mass} vs particle mass {particle_mass}"
        );
        assert!(
            p_err <= 1e-4,
            "grid momentum {grid_p} vs particle momentum {particle_p}"
        );
    }
}

/// A few hundred steps of the small tank's dam break on both backends, in units of dx.
/// Every pipeline with the walls' mirror, and the fused one without it (its grid update, which adds
/// the mirror itself, then only updates).
fn dam_break_follows_cpu_trajectory() {
    const STEPS: usize = 300;
    let cases = Pipeline::ALL
        .into_iter()
        .map(|p| (p, true))
        .chain([(Pipeline::Fused, false)]);
    for (pipeline, mirror) in cases {
        let mut scene = small_tank_in(pipeline, ScatterMode::FixedPoint);
        scene.mirror_wall_mass = mirror;
        let (_, mut gpu) = follow_cpu(&scene, STEPS, false, &format!("{pipeline:?} (mirror {mirror})"));
        let extremes = gpu.take_extremes().unwrap();
        assert!(extremes.max_density > scene.material().rest_density * 0.9 && extremes.max_speed > 0.0);
    }
}

/// `steps` substeps of `scene` on both backends, the colliders moved to each substep's start if
/// `moving_colliders`; every 100 substeps the GPU's particles are held to the CPU's
/// ([`assert_on_track`]), `what` naming the run. Returns both solvers.
fn follow_cpu(scene: &Scene, steps: usize, moving_colliders: bool, what: &str) -> (CpuSolver, CudaSolver) {
    let params = common::cfl_params(scene);
    let mut cpu = CpuSolver::new(scene.spawn(), scene.grid_res);
    let mut gpu = CudaSolver::new(scene, CudaOptions::default()).unwrap();
    for step in 1..=steps {
        if moving_colliders {
            let frame = scene.colliders.frame(step as f64 * f64::from(params.dt));
            cpu.set_colliders(&frame).unwrap();
            gpu.set_colliders(&frame).unwrap();
        }
        cpu.step(&params).unwrap();
        gpu.step(&params).unwrap();
        if step % 100 == 0 {
            let p = gpu.read_particles().unwrap();
            let (max, rms) = common::position_gap(&p.x, &cpu.particles.x, scene.dx);
            let what = format!("{what} step {step}");
            println!("{what}: position error max {max:.3e} dx, rms {rms:.3e} dx");
            assert_on_track(&what, (max, rms));
        }
    }
    (cpu, gpu)
}

/// A run on the track of its reference ([`common::position_gap`]). Rounding differences (see the top of the
/// file) grow along the trajectory; a wrong term would move particles by whole cells within these
/// steps.
fn assert_on_track(what: &str, (max, rms): (f32, f64)) {
    assert!(max <= 0.1 && rms <= 0.01, "{what}: max {max} dx, rms {rms} dx");
}

/// `steps` substeps of `scene` on a solver made with `options`, the substep varying as the CFL
/// policy's does (the scene's own in the first half of every `period` substeps, 0.75 of it in the
/// second), the fixed-point momentum units alternating substep by substep between the scene's own
/// and twice as fine (`mpm run` changes them between stretches, `Simulation::momentum_scale`: here
/// every substep changes them, and the fused pipeline's grid update reads sums made in the other
/// units), and the extremes taken every `choose_every` substeps, as `mpm run` chooses; after each
/// substep, `after(solver, step, params)`.
fn varying_run(
    scene: &Scene,
    options: CudaOptions,
    steps: usize,
    (period, choose_every): (usize, usize),
    mut after: impl FnMut(&mut CudaSolver, usize, &Params),
) -> CudaSolver {
    let mut params = common::cfl_params(scene);
    let mut gpu = CudaSolver::new(scene, options).unwrap();
    for step in 1..=steps {
        let own = common::cfl_params(scene);
        params.dt = own.dt * if step % period < period / 2 { 1.0 } else { 0.75 };
        params.fixed_momentum_scale = own.fixed_momentum_scale * if step % 2 == 0 { 1.0 } else { 2.0 };
        gpu.step(&params).unwrap();
        if step % choose_every == 0 {
            gpu.take_extremes().unwrap();
        }
        after(&mut gpu, step, &params);
    }
    gpu
}

fn run_steps(scene: &Scene, steps: usize) -> Particles {
    let params = common::cfl_params(scene);
    let mut gpu = CudaSolver::new(scene, CudaOptions::default()).unwrap();
    for _ in 0..steps {
        gpu.step(&params).unwrap();
    }
    gpu.take_extremes().unwrap();
    gpu.read_particles().unwrap()
}

/// The fused pipeline stores its particles in bin order (kernels/bin_order.cu), moving them in
/// memory at every binning, and readers get them back by slot. In fixed point that run must be, word
/// for word, the run whose particles stay at their slots; and the particles must really have moved.
fn particles_in_bin_order_run_as_particles_in_place() {
    const STEPS: usize = 200;
    let scene = small_tank_in(Pipeline::Fused, ScatterMode::FixedPoint);
    let params = common::cfl_params(&scene);
    let run = |bin_order: bool| {
        let options = CudaOptions {
            bin_order,
            ..CudaOptions::default()
        };
        let mut gpu = CudaSolver::new(&scene, options).unwrap();
        for _ in 0..STEPS {
            gpu.step(&params).unwrap();
        }
        gpu.take_extremes().unwrap();
        (gpu.read_particles().unwrap(), gpu.read_particle_slots().unwrap())
    };
    let (sorted, slots) = run(true);
    let (in_place, identity) = run(false);
    assert!(identity.iter().enumerate().all(|(i, &s)| s as usize == i));
    let moved = slots
        .iter()
        .enumerate()
        .filter(|&(i, &s)| s as usize != i)
        .count();
    println!("{moved} of {} particles stored away from their slot", slots.len());
    assert!(
        moved > slots.len() / 2,
        "only {moved} of {} particles stored away from their slot: were they gathered into bin order?",
        slots.len()
    );
    assert!(
        common::same_particles(&sorted, &in_place),
        "the run with its particles in bin order differs from the one with them in place"
    );
}

fn fixed_point_is_byte_identical_and_float_is_close() {
    const STEPS: usize = 200;
    for pipeline in Pipeline::ALL {
        let fixed = small_tank_in(pipeline, ScatterMode::FixedPoint);
        let first = run_steps(&fixed, STEPS);
        let second = run_steps(&fixed, STEPS);
        assert!(
            common::particle_bits(&first) == common::particle_bits(&second),
            "{pipeline:?}: two fixed-point runs differ"
        );
        let float = run_steps(&small_tank_in(pipeline, ScatterMode::Float), STEPS);
        let max = common::max_diff_vec3(&float.x, &first.x) / fixed.dx;
        println!("{pipeline:?}, after {STEPS} steps: fixed-point runs identical; float vs fixed-point max |dx| {max:.3e} dx");
        assert!(
            max <= 0.05,
            "float and fixed-point scatter drifted {max} dx apart"
        );
    }
}

fn fixed_point_overflow_is_reported() {
    for pipeline in Pipeline::ALL {
        let scene = small_tank_in(pipeline, ScatterMode::FixedPoint);
        let mut particles = scene.spawn();
        particles.v[0] = Vec3::new(1e9, 0.0, 0.0); // far past any speed the scales allow for
        let params = common::cfl_params(&scene);
        let mut gpu = CudaSolver::from_particles(&scene, &particles, CudaOptions::default()).unwrap();
        gpu.step(&params).unwrap();
        assert_overflow_reported(&mut gpu, &format!("{pipeline:?}: a particle at 1e9 m/s"));
    }
}

/// The fixed-point tile adds without reading the atomics' returns and settles after the adds whether
/// a 32-bit sum may have wrapped (kernels/tiles.cuh). Piles of particles on one grid node, in the
/// air, in a lattice of one particle per cell (a particle is a cell's mass, 2^27 tile units), each
/// pile one chunk of a bin (fused pipeline): 30 at half the sound speed, in the tile, and 30 at 1.5
/// times it, whose momentum would wrap the tile's node (19 cells' mass at the reference speed, past
/// 16) and which the tile leaves to the grid, both match the CPU's scatter; 60 at 0.8 times it (the
/// momentum of 20 cells' mass at the reference speed) and 90 at rest (38 cells' mass, past 2^32
/// tile units, read as 6) are reported.
fn fixed_point_tile_wraps_are_caught_after_the_adds() {
    let block = "max = [0.6, 0.5, 0.5]";
    assert!(SMALL_TANK.contains(block));
    let lattice = SMALL_TANK.replace(block, &format!("{block}\nparticles_per_cell = 1"));
    let scene = tank_in(
        &lattice,
        "small-tank-lattice-1",
        Pipeline::Fused,
        ScatterMode::FixedPoint,
    );
    let params = common::cfl_params(&scene);
    // A grid node 6 cells past the water's end: each particle on it gives it 0.75^3 of its mass.
    let node = Vec3::new(26.0, 12.0, 12.0) * scene.dx;
    let pile = |count: usize, speed: f32| {
        let mut particles = scene.spawn();
        assert!(particles.len() > count, "the lattice has particles to pile");
        for i in 0..count {
            particles.x[i] = node;
            particles.v[i] = Vec3::new(speed, 0.0, 0.0);
            particles.c[i] = Mat3::ZERO;
            particles.rho[i] = scene.material().rest_density;
        }
        particles
    };
    let c0 = scene.material().sound_speed();

    for speed in [0.5 * c0, 1.5 * c0] {
        let what = format!("30 particles at {speed} m/s on one node");
        let (mut cpu, mut gpu) = pair(&scene, &pile(30, speed));
        run_phases(&mut cpu, &mut gpu, &params, Through::P2g);
        assert_scatter_matches_cpu(&mut gpu, &cpu, &params, &what);
        gpu.take_extremes()
            .unwrap_or_else(|e| panic!("{what}: no overflow expected, got {e:#}"));
    }
    for (count, speed, what) in [
        (60, 0.8 * c0, "the node's momentum may pass 2^31 tile units"),
        (90, 0.0, "the node's mass past 2^32 tile units"),
    ] {
        let mut gpu =
            CudaSolver::from_particles(&scene, &pile(count, speed), CudaOptions::default()).unwrap();
        gpu.p2g_init(&params).unwrap();
        gpu.p2g(&params).unwrap();
        assert_overflow_reported(
            &mut gpu,
            &format!("{count} particles at {speed} m/s on one node ({what})"),
        );
    }
}

/// The substeps `gpu` has run overflowed the fixed-point sums, and its extremes say so.
fn assert_overflow_reported(gpu: &mut CudaSolver, what: &str) {
    let err = gpu
        .take_extremes()
        .expect_err(&format!("{what}: the overflow must be reported"));
    println!("{what}: {err:#}");
    assert!(format!("{err:#}").contains("overflowed"), "{what}: {err:#}");
}

/// The fused pipeline's fixed-point scatter adds to the grid what its shared tile does not take: a
/// particle faster than the tile's 32-bit sums are checked for, and one whose stencil left its tile
/// since the binning. A slab of water thrown at 40 times the sound speed is too fast for the tile
/// (its first scatter is held to the CPU's); one substep later it has left its tiles (misses
/// counted), and the scatter at the end of that substep leaves the integers that the same particles,
/// uploaded again and so binned afresh, leave: no sum depends on which particles a tile held.
fn fixed_point_scatter_past_the_tile_adds_the_same_integers() {
    let scene = small_tank_in(Pipeline::Fused, ScatterMode::FixedPoint);
    let mut particles = random_particles(&scene, 9);
    let fast = Vec3::new(40.0 * scene.material().sound_speed(), 0.0, 0.0);
    let mut thrown = 0;
    for i in 0..particles.len() {
        if particles.x[i].x < 0.25 {
            particles.v[i] = fast;
            thrown += 1;
        }
    }
    assert!(thrown > 0, "the slab holds particles");
    let params = common::cfl_params(&scene);
    let (mut cpu, mut gpu) = pair(&scene, &particles);
    run_phases(&mut cpu, &mut gpu, &params, Through::P2g);
    let what = format!("{thrown} particles at {} m/s, the first scatter", fast.x);
    assert_scatter_matches_cpu(&mut gpu, &cpu, &params, &what);

    gpu.grid_update(&params).unwrap();
    gpu.g2p(&params).unwrap();
    let stale = gpu.read_grid_accumulators(&params).unwrap();
    gpu.take_extremes().unwrap();
    println!(
        "the next scatter, with the bins of the substep's start: {} tile misses",
        gpu.tile_misses()
    );
    assert!(gpu.tile_misses() > 0, "the thrown slab must leave its tiles");
    let moved = gpu.read_particles().unwrap();
    let mut fresh = CudaSolver::from_particles(&scene, &moved, CudaOptions::default()).unwrap();
    fresh.p2g_init(&params).unwrap();
    fresh.p2g(&params).unwrap();
    let rebinned = fresh.read_grid_accumulators(&params).unwrap();
    fresh.take_extremes().unwrap();
    assert_eq!(
        fresh.tile_misses(),
        0,
        "particles binned where they are fit their tiles"
    );
    let same_mass = stale
        .0
        .iter()
        .zip(&rebinned.0)
        .all(|(a, b)| a.to_bits() == b.to_bits());
    let same_momentum = (stale.1.iter().zip(&rebinned.1))
        .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits));
    assert!(
        same_mass && same_momentum,
        "scattered past their tiles and binned afresh, the same particles must leave the same sums"
    );
}

fn device_spawn_matches_scene_spawn() {
    // Overlapping bodies: the sphere must skip what the blocks cover, the second block what the
    // first covers.
    const OVERLAPS: &str = common::tank!(
        [1.0, 1.0, 1.0],
        [40, 40, 40],
        r#"
[[block]]
min = [0.1, 0.1, 0.1]
max = [0.5, 0.4, 0.5]
velocity = [1.0, 0.0, 0.0]
[[block]]
min = [0.3, 0.2, 0.3]
max = [0.7, 0.6, 0.9]
particles_per_cell = 8
[[sphere]]
center = [0.5, 0.6, 0.5]
radius = 0.2
velocity = [0.0, -2.0, 0.0]
"#
    );
    let mut scenes = vec![Scene::from_toml(OVERLAPS, "overlaps").unwrap()];
    scenes.extend(presets::NAMES.iter().map(|name| Scene::load(name).unwrap()));
    for scene in &scenes {
        let host = scene.spawn();
        let mut gpu = CudaSolver::new(scene, CudaOptions::default()).unwrap();
        let device = gpu.read_particles().unwrap();
        assert_eq!(device.len(), host.len(), "{}: particle count", scene.name);
        let first_diff = (0..host.len()).find(|&i| device.x[i] != host.x[i] || device.v[i] != host.v[i]);
        assert!(
            first_diff.is_none(),
            "{}: particle {:?} differs",
            scene.name,
            first_diff.map(|i| (i, device.x[i], host.x[i]))
        );
        assert!(
            device.c.iter().all(|c| *c == Mat3::ZERO) && device.rho == host.rho,
            "{}",
            scene.name
        );
        println!(
            "{}: {} particles spawned on the device, identical to Scene::spawn()",
            scene.name,
            host.len()
        );
    }
}

fn phase_timings_are_measured() {
    for pipeline in Pipeline::ALL {
        let scene = small_tank_in(pipeline, ScatterMode::Float);
        let params = common::cfl_params(&scene);
        let mut gpu = CudaSolver::new(&scene, CudaOptions::default()).unwrap();
        for _ in 0..10 {
            gpu.step(&params).unwrap();
        }
        gpu.take_extremes().unwrap(); // waits for the device, so all ten steps are complete
        let timings = gpu.take_timings().unwrap().expect("CUDA measures timings");
        println!("{pipeline:?}: {timings:?}");
        assert_eq!(timings.steps, 10);
        // Substeps 0, 7, ... time their phases (one in mpm::cuda::PHASE_SAMPLE), the rest only whole.
        let phased = 10usize.div_ceil(mpm::cuda::PHASE_SAMPLE as usize);
        assert_eq!(
            timings.phased() as usize,
            phased,
            "the phases of one substep in {}",
            mpm::cuda::PHASE_SAMPLE
        );
        assert!(timings.unphased_ms > 0.0, "the substeps timed whole are measured");
        for phase in Phase::ALL {
            match phase {
                Phase::GridClear => assert_eq!(timings[phase], 0.0, "the grid update clears the grid"),
                Phase::HaloSum | Phase::HaloFill => assert_eq!(timings[phase], 0.0, "one GPU, no ranks"),
                // The fused pipeline scatters the momentum with the mass: nothing runs in p2g, which
                // takes no timing event and reads 0.
                Phase::P2g if pipeline == Pipeline::Fused => {
                    assert_eq!(timings[phase], 0.0, "{phase:?} holds no pass")
                }
                // The first substep sorts, and the sort has its own slot.
                _ => assert!(timings[phase] > 0.0, "{phase:?} measured"),
            }
        }
        let again = gpu.take_timings().unwrap().expect("timings");
        assert_eq!(again.steps, 0, "timings are taken once");
    }
}

/// The sort's order is a permutation with the particles' cells non-decreasing, on a grid whose scan
/// needs two levels (block 128) and three (block 32).
fn sort_orders_particles_by_cell() {
    let mut scene = Scene::load("bench-655k").unwrap();
    scene.pipeline = Pipeline::Report;
    let particles = random_particles(&scene, 5);
    let params = common::cfl_params(&scene);
    let shape = mpm::sim::cpu::GridShape::whole(glam::UVec3::from(scene.grid_res));
    let cell = |i: u32| shape.index(Stencil::new(particles.x[i as usize], params.inv_dx).base);
    for block_size in [128, 32] {
        let options = CudaOptions {
            block_size,
            ..CudaOptions::default()
        };
        let mut gpu = CudaSolver::from_particles(&scene, &particles, options).unwrap();
        gpu.sort_particles(&params).unwrap();
        let order = gpu.read_order().unwrap();
        let mut seen = vec![false; order.len()];
        for &p in &order {
            assert!(
                !std::mem::replace(&mut seen[p as usize], true),
                "particle {p} twice"
            );
        }
        let unsorted = order.windows(2).filter(|w| cell(w[0]) > cell(w[1])).count();
        println!(
            "block {block_size}: {} particles sorted, {unsorted} out of cell order",
            order.len()
        );
        assert_eq!(unsorted, 0);
    }
}

/// The binned pipeline's bins (kernels/bins.cu) after a violent stretch of the dam break: `order` is
/// a permutation, the bin list covers it exactly once in runs, every particle sits within its bin's
/// tile, and the bins were rebuilt as particles moved (choices every 4 substeps, as `mpm run` makes).
fn binned_bins_hold_each_particle_once_and_follow_the_flow() {
    for pipeline in [Pipeline::Binned, Pipeline::Fused] {
        let scene = small_tank_in(pipeline, ScatterMode::Float);
        let params = common::cfl_params(&scene);
        let mut gpu = CudaSolver::new(&scene, CudaOptions::default()).unwrap();
        for step in 1..=400 {
            gpu.step(&params).unwrap();
            if step % 4 == 0 {
                gpu.take_extremes().unwrap();
            }
        }
        let particles = gpu.read_particles().unwrap();
        let order = gpu.read_order().unwrap();
        let list = gpu.read_bin_list().unwrap();
        // `order` and the list give places in memory; the fused pipeline stores particles in bin
        // order, the slot of each place in `slots` (the identity in the binned pipeline).
        let slots = gpu.read_particle_slots().unwrap();
        let n = particles.len();
        let blocks = scene.grid_res.map(|r| r.div_ceil(4));
        let mut seen = vec![false; n];
        let mut covered = 0usize;
        let mut far = 0usize;
        for &[bin, start, count] in &list {
            assert!(
                count > 0 && count <= 128,
                "a chunk of bin {bin} lists {count} particles (1 to 128)"
            );
            let b = [
                bin % blocks[0],
                (bin / blocks[0]) % blocks[1],
                bin / (blocks[0] * blocks[1]),
            ];
            for &p in &order[start as usize..(start + count) as usize] {
                assert!(
                    !std::mem::replace(&mut seen[p as usize], true),
                    "particle {p} twice"
                );
                let base = Stencil::new(particles.x[slots[p as usize] as usize], params.inv_dx).base;
                for a in 0..3 {
                    let local = base[a] - 4 * b[a] as i32;
                    assert!(
                        (-2..=5).contains(&local),
                        "particle {p} (base {base}) is outside the tile of bin {b:?}"
                    );
                    far += usize::from(!(-1..=4).contains(&local));
                }
            }
            covered += count as usize;
        }
        println!(
        "{} chunks of bins hold {covered} of {n} particles; {} binnings in 400 substeps; {far} particle axes \
         past the bins' reach awaiting a rebin; {} tile misses",
        list.len(),
        gpu.binnings(),
        gpu.tile_misses()
    );
        assert_eq!(covered, n, "the bin list covers every particle once");
        assert!(seen.iter().all(|&s| s));
        assert!(
            gpu.binnings() >= 3,
            "the dam break moves particles by cells: bins must be rebuilt"
        );
        assert_eq!(gpu.tile_misses(), 0, "no particle left its tile at CFL 0.4");
    }
}

/// Fixed-point runs of the binned pipeline whose bins differ (one bins as `mpm run` does, every
/// SORT_INTERVAL substeps and when a particle moved a cell; the other is rebinned every 3 substeps on
/// top, so its tiles hold other particles at other times) stay byte-identical: every sum is the same
/// integer whatever the bin order and tile partition.
fn binned_fixed_point_is_byte_identical_across_rebins() {
    for pipeline in [Pipeline::Binned, Pipeline::Fused] {
        const STEPS: usize = 600;
        let scene = small_tank_in(pipeline, ScatterMode::FixedPoint);
        let mut runs = Vec::new();
        for extra_rebins in [false, true] {
            let mut snapshots = Vec::new();
            // A varying substep, as the CFL policy makes: the mass g2p2g scattered must not care.
            let mut gpu = varying_run(
                &scene,
                CudaOptions::default(),
                STEPS,
                (8, 4),
                |gpu, step, params| {
                    if extra_rebins && step % 3 == 0 {
                        gpu.sort_particles(params).unwrap();
                    }
                    if step % 200 == 0 {
                        snapshots.push(common::particle_bits(&gpu.read_particles().unwrap()));
                    }
                },
            );
            gpu.take_extremes().unwrap();
            println!(
                "extra rebins {extra_rebins}: {} binnings, {} tile misses",
                gpu.binnings(),
                gpu.tile_misses()
            );
            runs.push((gpu.binnings(), snapshots));
        }
        assert_ne!(runs[0].0, runs[1].0, "the two runs must bin differently");
        for (k, (a, b)) in runs[0].1.iter().zip(&runs[1].1).enumerate() {
            assert!(a == b, "the runs differ after {} substeps", 200 * (k + 1));
        }
    }
}

/// Substeps replayed as CUDA graphs (the default) do exactly what substeps launched kernel by kernel
/// do: fixed-point runs byte-identical in both pipelines, through stretches of changing dt (new
/// captures), momentum units changing every substep (replays of substeps whose grid update reads
/// sums made in the units before: a replay must leave the host's note of those units as the
/// captured run did), sorts and replays, with the same binnings and a timing record for every
/// substep.
fn graphed_substeps_match_launched_ones() {
    const STEPS: usize = 300;
    for pipeline in Pipeline::ALL {
        let scene = small_tank_in(pipeline, ScatterMode::FixedPoint);
        let mut runs = Vec::new();
        for graphs in [false, true] {
            let options = CudaOptions {
                graphs,
                ..CudaOptions::default()
            };
            let mut snapshots = Vec::new();
            let mut timed = 0;
            let mut phased = 0;
            let mut gpu = varying_run(&scene, options, STEPS, (20, 5), |gpu, step, _| {
                if step % 5 == 0 {
                    let timings = gpu.take_timings().unwrap().expect("CUDA measures timings");
                    for phase in [Phase::P2g, Phase::GridUpdate, Phase::G2p] {
                        // The fused pipeline's p2g has no work and no timing event; a stretch
                        // without a sampled substep times no phase.
                        let empty =
                            (phase == Phase::P2g && pipeline == Pipeline::Fused) || timings.phased() == 0;
                        assert_eq!(timings[phase] > 0.0, !empty, "{phase:?} measured");
                    }
                    assert!(timings.steps == 0 || timings.total() > 0.0, "every substep timed");
                    timed += timings.steps;
                    phased += timings.phased();
                }
                if step % 100 == 0 {
                    snapshots.push(common::particle_bits(&gpu.read_particles().unwrap()));
                }
            });
            gpu.take_extremes().unwrap();
            let last = gpu.take_timings().unwrap().expect("timings");
            timed += last.steps;
            phased += last.phased();
            assert_eq!(
                timed as usize, STEPS,
                "{pipeline:?}, graphs {graphs}: a timing record per substep"
            );
            // Substeps 0, 7, 14, ... time their phases, graphed or not.
            assert_eq!(
                phased as usize,
                STEPS.div_ceil(mpm::cuda::PHASE_SAMPLE as usize),
                "{pipeline:?}, graphs {graphs}: the phases of one substep in {}",
                mpm::cuda::PHASE_SAMPLE
            );
            println!("{pipeline:?}, graphs {graphs}: {} binnings", gpu.binnings());
            runs.push((gpu.binnings(), snapshots));
        }
        assert_eq!(
            runs[0].0, runs[1].0,
            "{pipeline:?}: graphs changed when the bins were rebuilt"
        );
        for (k, (a, b)) in runs[0].1.iter().zip(&runs[1].1).enumerate() {
            assert!(
                a == b,
                "{pipeline:?}: graphed and launched substeps differ after {} substeps",
                100 * (k + 1)
            );
        }
    }
}

/// The binned pipeline against the report's over a long fixed-point dam break (choices every 4
/// substeps, varying dt). Their per-particle code is the same source, but compiled into different
/// kernels its float rounding may differ in the last bit (contracted multiply-adds), and the flow
/// amplifies that; so particles are held to the CPU comparison's bounds over the first 300 substeps,
/// and the flow as a whole (centre of mass, kinetic energy) after 1200.
fn binned_pipeline_follows_the_report_pipeline() {
    const STEPS: usize = 1200;
    let mut runs = Vec::new();
    for pipeline in [Pipeline::Report, Pipeline::Binned] {
        let scene = small_tank_in(pipeline, ScatterMode::FixedPoint);
        let mut states = Vec::new();
        varying_run(&scene, CudaOptions::default(), STEPS, (8, 4), |gpu, step, _| {
            if step % 300 == 0 {
                states.push((
                    gpu.read_particles().unwrap(),
                    gpu.summary(&scene.params()).unwrap(),
                ));
            }
        });
        runs.push(states);
    }
    let dx = small_tank_in(Pipeline::Binned, ScatterMode::FixedPoint).dx;
    for (k, ((report, report_summary), (binned, binned_summary))) in runs[0].iter().zip(&runs[1]).enumerate()
    {
        let step = 300 * (k + 1);
        let (max, rms) = common::position_gap(&report.x, &binned.x, dx);
        let com = (0..3)
            .map(|a| (report_summary.centre_of_mass[a] - binned_summary.centre_of_mass[a]).abs())
            .fold(0.0, f64::max)
            / f64::from(dx);
        let ke = (report_summary.kinetic_energy - binned_summary.kinetic_energy).abs()
            / report_summary.kinetic_energy;
        println!(
            "substep {step}: position error max {max:.3e} dx, rms {rms:.3e} dx; centre of mass {com:.3e} dx \
             apart; kinetic energy {ke:.3e} apart"
        );
        if step <= 300 {
            assert_on_track(&format!("substep {step}"), (max, rms));
        }
        assert!(com <= 0.05, "substep {step}: centres of mass {com} dx apart");
        assert!(ke <= 0.02, "substep {step}: kinetic energies {ke} apart");
    }
}

/// The per-frame statistics reduced on the device against `Summary::of` on a host copy.
fn device_statistics_match_a_host_reduction() {
    let scene = small_tank_in(Pipeline::Binned, ScatterMode::Float);
    let params = common::cfl_params(&scene);
    let mut gpu = CudaSolver::new(&scene, CudaOptions::default()).unwrap();
    for _ in 0..150 {
        gpu.step(&params).unwrap();
    }
    let device = gpu.summary(&params).unwrap();
    let host = mpm::sim::Summary::of(&gpu.read_particles().unwrap(), &params);
    println!("device {device:?}\nhost   {host:?}");
    assert_eq!(device.particles, host.particles);
    let close = |a: f64, b: f64, what: &str| {
        assert!(
            (a - b).abs() <= 1e-6 * b.abs().max(1e-12),
            "{what}: device {a} vs host {b}"
        );
    };
    close(device.kinetic_energy, host.kinetic_energy, "kinetic energy");
    for a in 0..3 {
        close(device.centre_of_mass[a], host.centre_of_mass[a], "centre of mass");
    }
    close(
        f64::from(device.density_ratio_mean),
        f64::from(host.density_ratio_mean),
        "mean density",
    );
    assert_eq!(device.density_ratio_min, host.density_ratio_min);
    assert_eq!(device.density_ratio_max, host.density_ratio_max);
    close(
        f64::from(device.max_speed),
        f64::from(host.max_speed),
        "max speed",
    );
    assert!(device.kinetic_energy > 0.0, "the block is falling");
}

/// The small tank with one collider of every kind: a friction sphere, a tilted slip box, a moving
/// stick capsule, a cylinder, a piston (box) and a closed mesh (a cube, written to `dir` as OBJ).
fn collider_tank(dir: &std::path::Path, pipeline: Pipeline, scatter: ScatterMode) -> Scene {
    let mut obj = String::new();
    for i in 0..8 {
        let c = |bit: usize| if i >> bit & 1 == 1 { 0.05 } else { -0.05 };
        obj += &format!("v {} {} {}\n", c(0), c(1), c(2));
    }
    obj += "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
    std::fs::write(dir.join("cube.obj"), obj).unwrap();
    let colliders = r#"
[[collider]]
shape = "sphere"
center = [0.3, 0.2, 0.35]
radius = 0.08
friction = 0.4
[[collider]]
shape = "box"
center = [0.15, 0.1, 0.15]
size = [0.12, 0.05, 0.2]
rotation = [10.0, 0.0, 25.0]
[[collider]]
shape = "capsule"
center = [0.45, 0.25, 0.2]
radius = 0.04
length = 0.15
axis_angle = [1.0, 0.0, 0.0, 90.0]
boundary = "stick"
[collider.motion]
velocity = [0.2, 0.0, 0.0]
angular_velocity = [0.0, 45.0, 0.0]
[[collider]]
shape = "cylinder"
center = [0.5, 0.1, 0.5]
radius = 0.05
length = 0.2
[[collider]]
shape = "box"
center = [0.7, 0.3, 0.37]
size = [0.03, 0.6, 0.8]
[collider.motion]
piston = { direction = [1.0, 0.0, 0.0], amplitude = 0.02, period = 0.4, phase = 30.0 }
[[collider]]
shape = "mesh"
file = "cube.obj"
center = [0.25, 0.38, 0.5]
rotation = [0.0, 30.0, 0.0]
"#;
    let path = dir.join("colliders.toml");
    std::fs::write(&path, SMALL_TANK.to_string() + colliders).unwrap();
    let mut scene = Scene::load(path.to_str().unwrap()).unwrap_or_else(|e| panic!("{e}"));
    scene.scatter = scatter;
    scene.pipeline = pipeline;
    scene
}

/// The grid update with colliders and g2p with the backstop, on the binned pipeline against the CPU
/// reference, to the bounds of grid_update_and_g2p_match_cpu. A few particles are put inside the
/// colliders, so the backstop runs; its count must agree.
fn colliders_grid_update_and_backstop_match_cpu() {
    for pipeline in [Pipeline::Fused, Pipeline::Binned] {
        let dir = tempfile::tempdir().unwrap();
        for scatter in [ScatterMode::Float, ScatterMode::FixedPoint] {
            let scene = collider_tank(dir.path(), pipeline, scatter);
            let mut particles = random_particles(&scene, 5);
            for (k, x) in [
                [0.3, 0.2, 0.35],
                [0.15, 0.1, 0.15],
                [0.7, 0.3, 0.37],
                [0.25, 0.38, 0.5],
            ]
            .iter()
            .enumerate()
            {
                particles.x[k * 97] = Vec3::from(*x) + 0.003;
            }
            let params = common::cfl_params(&scene);
            let frame = scene.colliders.frame(0.0);
            let (mut cpu, mut gpu) = pair(&scene, &particles);
            cpu.set_colliders(&frame).unwrap();
            gpu.set_colliders(&frame).unwrap();
            run_phases(&mut cpu, &mut gpu, &params, Through::GridUpdate);
            // In fixed point the binned pipeline's tiles round every contribution to 2^13 global units
            // (kernels/tiles.cuh, TILE_UNIT_SHIFT): up to half a unit of momentum and of mass per
            // contribution, which at the lightest nodes compared (1 % of a particle's mass) is what sets
            // the error, not the colliders. Each node may be off by that rounding over 64 contributions,
            // over its mass, on top of the float bound (measured on the H200: 1.1e-4 of the largest
            // velocity at the worst node, 5e-5 without colliders).
            let (mass_scale, momentum_scale) = (params.fixed_mass_scale, params.fixed_momentum_scale);
            let rounding = |m: f32, v: Vec3| match scatter {
                ScatterMode::Float => 0.0,
                ScatterMode::FixedPoint => {
                    let unit = (1u32 << 13) as f32;
                    32.0 * (unit / momentum_scale + v.abs().max_element() * unit / mass_scale) / m
                }
            };
            let what = format!("colliders, {pipeline:?} {scatter:?}");
            let vmax = assert_grid_velocity_close(
                &format!("{what}, grid_update beyond the scatter's rounding"),
                &scene,
                &cpu,
                &mut gpu,
                rounding,
            );
            assert_g2p_close(&format!("{what}, g2p"), &scene, &params, &mut cpu, &mut gpu, vmax);
            let (e_cpu, e_gpu) = (cpu.take_extremes().unwrap(), gpu.take_extremes().unwrap());
            println!(
                "{what}, g2p: backstop CPU {} GPU {}",
                e_cpu.backstop_pushes, e_gpu.backstop_pushes
            );
            assert!(
                e_cpu.backstop_pushes >= 4,
                "the particles put inside colliders were pushed out"
            );
            // A particle that ends within rounding (1e-7 of a metre) of a surface may be counted by one
            // side only; more than one such is a bug, not rounding.
            assert!(
                e_cpu.backstop_pushes.abs_diff(e_gpu.backstop_pushes) <= 1,
                "{what}: backstop counts CPU {} GPU {}",
                e_cpu.backstop_pushes,
                e_gpu.backstop_pushes
            );
        }
    }
}

/// 300 substeps of the collider tank's dam break, colliders moving, on both backends (as
/// dam_break_follows_cpu_trajectory, whose bounds it keeps).
fn colliders_trajectory_follows_cpu() {
    const STEPS: usize = 300;
    let dir = tempfile::tempdir().unwrap();
    let scene = collider_tank(dir.path(), Pipeline::Fused, ScatterMode::FixedPoint);
    let (mut cpu, mut gpu) = follow_cpu(&scene, STEPS, true, "colliders");
    let (e_cpu, e_gpu) = (cpu.take_extremes().unwrap(), gpu.take_extremes().unwrap());
    println!(
        "backstop pushes over the run: CPU {}, GPU {}",
        e_cpu.backstop_pushes, e_gpu.backstop_pushes
    );
}

/// Colliders keep the fixed-point scatter's determinism: two runs of the collider tank with moving
/// colliders, 200 substeps each, are byte-identical.
fn colliders_fixed_point_runs_are_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    let scene = collider_tank(dir.path(), Pipeline::Fused, ScatterMode::FixedPoint);
    let params = common::cfl_params(&scene);
    let run = || {
        let mut gpu = CudaSolver::new(&scene, CudaOptions::default()).unwrap();
        for step in 1..=200 {
            gpu.set_colliders(&scene.colliders.frame(step as f64 * f64::from(params.dt)))
                .unwrap();
            gpu.step(&params).unwrap();
        }
        gpu.take_extremes().unwrap();
        gpu.read_particles().unwrap()
    };
    let (first, second) = (run(), run());
    assert!(
        common::particle_bits(&first) == common::particle_bits(&second),
        "two fixed-point runs with colliders differ"
    );
}

/// The walls' mirror pushes fluid off a wall and never pulls it back (tests/walls.rs holds the CPU
/// backends to the same): a block leaving the low x wall at 1 m/s keeps its speed, on average and in
/// its wall layer, to 5 %, in both pipelines and both scatter modes.
fn a_block_leaving_a_wall_keeps_its_speed() {
    for (pipeline, scatter) in VARIANTS {
        let mut scene = common::block_leaving_the_low_x_wall(1.0);
        (scene.pipeline, scene.scatter) = (pipeline, scatter);
        let what = format!("{pipeline:?} {scatter:?}");
        common::assert_block_keeps_its_speed(&scene, mpm::backend::BackendKind::Cuda, &what);
    }
}
