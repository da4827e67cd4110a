//! The checks `CudaRanks` answers to wherever its ranks run: on one GPU (tests/gpu_ranks.rs) and one
//! rank per GPU over NCCL (tests/gpu_ranks_on_gpus.rs, tests/gpu_ranks_on_four_gpus.rs). Each runs a split run against one CUDA solver.
//!
//! The fixed-point scatter sums integers, which do not care how they are split between ranks, so
//! N ranks must give one solver's bits slot for slot. The float scatter adds in whatever order the
//! atomics land, on one solver as on ranks: the yardstick for ranks is a second one-solver run.
#![allow(dead_code)]

use mpm::backend::BackendKind;
use mpm::cuda::{CudaOptions, CudaRanks, CudaSolver};
use mpm::dist::Slabs;
use mpm::sim::{Params, Particles, Phase, ScatterMode, Scene, Simulation, Solver};

use super::common;

/// Where the ranks run.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum On {
    /// Every rank on device 0, device copies between them: 2, 3 and 4 ranks.
    OneGpu,
    /// Rank r on device r, NCCL between them: 2 ranks on devices 0 and 1.
    TwoGpus,
    /// As `TwoGpus`, 4 ranks on devices 0 to 3.
    FourGpus,
}

impl On {
    /// The rank counts checked.
    fn rank_counts(self) -> &'static [usize] {
        match self {
            On::OneGpu => &[2, 3, 4],
            On::TwoGpus => &[2],
            On::FourGpus => &[4],
        }
    }

    /// `scene` placed here, split into `ranks`.
    fn place(self, scene: &Scene, ranks: usize) -> Scene {
        let mut scene = scene.clone();
        scene.gpus = if self == On::OneGpu { 1 } else { ranks };
        scene
    }
}

pub fn tank(scatter: ScatterMode) -> (Scene, Params) {
    let mut scene = common::scene(common::STIRRED_TANK);
    scene.scatter = scatter;
    let mut params = common::cfl_params(&scene);
    params.density_rule = scene.pipeline.density_rule().code();
    assert_eq!(params.scatter_mode, scatter.code());
    (scene, params)
}

/// [`tank`]'s block as two liquids side by side, water (1000 kg/m^3) and oil (800), in fixed point:
/// every particle's density gathered from the grid's volume, which the ranks sum and fill with the
/// mass and the velocities.
pub fn liquids_tank() -> (Scene, Params) {
    let mut scene = common::scene(common::STIRRED_LIQUIDS);
    scene.scatter = ScatterMode::FixedPoint;
    let mut params = common::cfl_params(&scene);
    params.density_rule = scene.pipeline.density_rule().code();
    assert_eq!(params.volume_density, 1, "two rest densities");
    (scene, params)
}

/// [`common::STIRRED_SOLIDS`]: water, a jelly, snow and sand side by side across the cuts, in fixed
/// point, at their fastest material's step.
pub fn solids_tank() -> (Scene, Params) {
    let scene = common::scene(common::STIRRED_SOLIDS);
    assert!(scene.has_deformation());
    let mut params = common::cfl_params_of_fastest(&scene);
    params.density_rule = scene.pipeline.density_rule().code();
    assert_eq!(params.scatter_mode, ScatterMode::FixedPoint.code());
    (scene, params)
}

pub fn one_gpu(scene: &Scene) -> CudaSolver {
    CudaSolver::from_particles(scene, &common::stirred(scene), CudaOptions::default()).unwrap()
}

/// 2 ranks on even slabs (their first rebin moves the cut), or `ranks` balanced ones, placed `on`.
pub fn ranks(scene: &Scene, ranks: usize, on: On) -> CudaRanks {
    let particles = common::stirred(scene);
    let slabs = if ranks == 2 {
        Slabs::even(glam::UVec3::from(scene.grid_res), 2).unwrap()
    } else {
        mpm::dist::starting_slabs(scene, &particles, ranks).unwrap()
    };
    CudaRanks::with_slabs(
        &on.place(scene, ranks),
        &particles,
        None,
        slabs,
        CudaOptions::default(),
    )
    .unwrap()
}

pub fn run(solver: &mut dyn Solver, params: &Params, substeps: u32) -> Particles {
    for _ in 0..substeps {
        solver.step(params).unwrap();
    }
    solver.read_particles().unwrap()
}

pub fn max_gap(a: &Particles, b: &Particles, dx: f32) -> f32 {
    a.x.iter()
        .zip(&b.x)
        .fold(0.0f32, |m, (a, b)| m.max((*a - *b).abs().max_element()))
        / dx
}

/// 200 stirred substeps (the surge moves 10 cells, thousands of particles cross the cuts both ways,
/// the even slabs are rebalanced): the split run gives one GPU's bits, slot for slot.
pub fn fixed_point_ranks_give_one_gpu_s_bits(on: On) {
    let (scene, params) = tank(ScatterMode::FixedPoint);
    split_runs_give_one_gpu_s_bits(&scene, &params, on);
}

/// [`fixed_point_ranks_give_one_gpu_s_bits`] with two liquids of different rest densities
/// ([`liquids_tank`]): the grid's volume crosses the cuts as the mass does.
pub fn two_liquids_on_ranks_give_one_gpu_s_bits(on: On) {
    let (scene, params) = liquids_tank();
    split_runs_give_one_gpu_s_bits(&scene, &params, on);
}

/// [`fixed_point_ranks_give_one_gpu_s_bits`] with solids ([`solids_tank`]): each migrant carries
/// its deformation gradient and plastic scalar, and the readers' set takes them, so every slot's
/// deformation is one GPU's bits too ([`common::particle_bits`] holds it).
pub fn solids_on_ranks_give_one_gpu_s_bits(on: On) {
    let (scene, params) = solids_tank();
    split_runs_give_one_gpu_s_bits(&scene, &params, on);
}

/// 200 substeps of `scene` split `on` its rank counts give one GPU's bits, slot for slot, after
/// thousands of particles crossed the cuts and the even slabs moved; each rank holds its own
/// particles, growing its buffers where it receives more than they have room for.
fn split_runs_give_one_gpu_s_bits(scene: &Scene, params: &Params, on: On) {
    let (scene, params) = (scene.clone(), *params);
    let mut one = one_gpu(&scene);
    let expected = run(&mut one, &params, 200);
    let whole = one.summary(&params).unwrap();
    let again = run(&mut one_gpu(&scene), &params, 200);
    assert!(
        common::particle_bits(&again) == common::particle_bits(&expected),
        "one GPU is not deterministic in fixed point"
    );
    let moved = max_gap(&expected, &scene.spawn(), scene.dx);
    assert!(moved > 2.0, "the water did not move: {moved} dx");
    for &n in on.rank_counts() {
        let mut split = ranks(&scene, n, on);
        let start = split.slabs().bounds.clone();
        let room_at_start = split.capacities();
        let got = run(&mut split, &params, 200);
        let (migrations, migrated) = split.migrated();
        println!(
            "{n} ranks: {migrations} migrations moved {} particles, bounds {start:?} -> {:?}, counts {:?}, \
             places {room_at_start:?} -> {:?} ({} growths)",
            migrated.sent,
            split.slabs().bounds,
            split.counts(),
            split.capacities(),
            split.growths()
        );
        // Even slabs give rank 0 the whole block and rank 1 none: the first rebalance hands rank 1
        // half of it, more than its spare places, so it grows. Balanced ones hold their share and
        // room (on this grid's 12 block layers, a share is 41 to 44 % of the run).
        let slots = expected.len();
        assert!(n != 2 || split.growths() > 0, "rank 1 never grew");
        assert!(
            n != 3 || split.capacities().iter().all(|&places| places < 2 * slots / 3),
            "a rank of 3 holds two thirds of the run's {slots} slots or more: {:?}",
            split.capacities()
        );
        assert!(
            migrated.sent > 1000,
            "few particles crossed a cut: {}",
            migrated.sent
        );
        assert!(
            n != 2 || split.slabs().bounds != start,
            "the even slabs never moved"
        );
        // Each rank's grid holds its slab and ghost planes as they are now, the slabs moved since.
        let slabs = split.slabs().clone();
        let across: usize = scene.grid_res.iter().map(|&r| r as usize).product::<usize>()
            / scene.grid_res[slabs.axis] as usize;
        for held in split.holdings().expect("the CUDA ranks say what they hold").ranks {
            let planes = slabs.held(held.rank);
            assert_eq!(held.slab, slabs.owned(held.rank), "rank {}'s slab", held.rank);
            assert_eq!(
                held.grid_nodes,
                planes.len() * across,
                "rank {}'s grid is not its planes {planes:?}",
                held.rank
            );
        }
        assert_eq!(got.num_live(), expected.num_live(), "particles lost or gained");
        let gap = max_gap(&got, &expected, scene.dx);
        assert!(
            common::particle_bits(&got) == common::particle_bits(&expected),
            "{n} ranks differ from one GPU in fixed point (positions up to {gap} dx apart)"
        );
        // The same particles: each rank's statistics joined give one GPU's, the sums to rounding.
        let parts = split.summary(&params).unwrap();
        assert_eq!(
            (
                parts.particles,
                parts.max_speed,
                parts.density_ratio_min,
                parts.density_ratio_max
            ),
            (
                whole.particles,
                whole.max_speed,
                whole.density_ratio_min,
                whole.density_ratio_max
            )
        );
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs().max(1e-3);
        assert!(
            close(parts.kinetic_energy, whole.kinetic_energy)
                && close(parts.density_ratio_mean.into(), whole.density_ratio_mean.into())
                && (0..3).all(|a| close(parts.centre_of_mass[a], whole.centre_of_mass[a])),
            "{n} ranks' statistics {parts:?} differ from one GPU's {whole:?}"
        );
    }
}

/// The float scatter: one substep within 1e-5 dx, 200 within 4 times the gap between two one-GPU
/// runs (or 1e-4 dx where those happen to agree).
pub fn float_ranks_follow_one_gpu(on: On) {
    let (scene, params) = tank(ScatterMode::Float);
    for (substeps, floor) in [(1, 1e-5), (200, 1e-4)] {
        let expected = run(&mut one_gpu(&scene), &params, substeps);
        let yardstick = max_gap(&run(&mut one_gpu(&scene), &params, substeps), &expected, scene.dx);
        for &n in on.rank_counts() {
            let got = run(&mut ranks(&scene, n, on), &params, substeps);
            let gap = max_gap(&got, &expected, scene.dx);
            println!(
                "{substeps} substeps, {n} ranks: {gap:.2e} dx from one GPU (one GPU twice: {yardstick:.2e})"
            );
            assert_eq!(got.num_live(), expected.num_live());
            assert!(
                gap <= (4.0 * yardstick).max(floor),
                "{n} ranks apart from one GPU by {gap} dx after {substeps} substeps (one GPU twice: {yardstick})"
            );
        }
    }
}

/// A moving box that the first rebin's cut crosses: its boundary acts on nodes of both slabs and its
/// backstop on particles of both ranks; 2 ranks still give one GPU's bits and backstop count.
pub fn a_moving_collider_across_the_cut_gives_one_gpu_s_bits(on: On) {
    let scene = common::scene(&common::stirred_tank_with_moving_box());
    let mut params = common::cfl_params(&scene);
    params.density_rule = scene.pipeline.density_rule().code();
    let mut one = one_gpu(&scene);
    let mut split = ranks(&scene, 2, on);
    let (mut pushes_one, mut pushes_split) = (0, 0);
    for n in 1..=200 {
        let frame = scene.colliders.frame(f64::from(n) * f64::from(params.dt));
        for solver in [&mut one as &mut dyn Solver, &mut split] {
            solver.set_colliders(&frame).unwrap();
            solver.step(&params).unwrap();
        }
        pushes_one += one.take_extremes().unwrap().backstop_pushes;
        pushes_split += split.take_extremes().unwrap().backstop_pushes;
    }
    let cut = split.slabs().bounds[1] as f32 * 4.0 * scene.dx;
    println!("cut at x = {cut} m; backstop pushes {pushes_one} / {pushes_split}");
    assert!(
        (0.2..=0.3).contains(&cut),
        "the cut is not inside the box (x 0.2 to 0.3 m): {cut}"
    );
    assert!(pushes_one > 0, "the box never pushed a particle back");
    assert_eq!(pushes_split, pushes_one);
    let (a, b) = (one.read_particles().unwrap(), split.read_particles().unwrap());
    assert!(
        common::particle_bits(&a) == common::particle_bits(&b),
        "2 ranks differ from one GPU"
    );
}

/// Through `Simulation`, as the runner drives a solver: the dam-break preset, coarse, in fixed point,
/// frame by frame (each substep's time step chosen from the ranks' merged extremes).
pub fn a_dam_break_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame(on: On) {
    a_preset_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame("dam-break-coarse", 20, on);
}

/// [`a_dam_break_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame`] with sand (`sand-column`), a
/// plastic solid: each frame's last substep scatters its stress as a resumed run's first does
/// (`Solver::ends_frame_next`), on every rank as on one GPU, and only that substep.
pub fn a_plastic_solid_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame(on: On) {
    a_preset_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame("sand-column", 10, on);
}

/// `name` in fixed point, driven frame by frame by a `Simulation` (the frames' time steps chosen
/// from the ranks' extremes), on one GPU and on 2 ranks: the same bits at every frame.
fn a_preset_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame(name: &str, frames: u64, on: On) {
    let mut scene = Scene::load(name).unwrap();
    scene.scatter = ScatterMode::FixedPoint;
    let one = mpm::backend::create(BackendKind::Cuda, &scene).unwrap();
    let split = CudaRanks::new(
        &on.place(&scene, 2),
        &scene.spawn(),
        None,
        2,
        CudaOptions::default(),
    )
    .unwrap();
    println!("slabs {:?}, counts {:?}", split.slabs().bounds, split.counts());
    let mut one = Simulation::new(scene.clone(), one);
    let mut split = Simulation::new(scene.clone(), Box::new(split));
    for frame in 1..=frames {
        one.advance_frame().unwrap();
        split.advance_frame().unwrap();
        let (a, b) = (
            one.solver_mut().read_particles().unwrap(),
            split.solver_mut().read_particles().unwrap(),
        );
        assert!(
            common::particle_bits(&a) == common::particle_bits(&b),
            "{name}, frame {frame}: 2 ranks differ from one GPU"
        );
    }
}

/// A particle that moves more than a cell in a substep leaves its rank's ghost planes, and its
/// stencil the grid its rank holds: the run stops at the next substep, naming the fix, rather than
/// step on with sums outside the grid. A push of 4 cells a substep along the slab axis, given to
/// every particle of the balanced 3-rank tank (a uniform shift: no pressure builds before the
/// check), carries those beside a cut past it; the substeps before the push run as ever.
pub fn a_particle_leaving_its_rank_s_grid_stops_the_run(on: On) {
    let (scene, params) = tank(ScatterMode::FixedPoint);
    let mut split = ranks(&scene, 3, on);
    for _ in 0..5 {
        split.step(&params).expect("the tank steps at its CFL step");
    }
    let mut along = glam::Vec3::ZERO;
    along[split.slabs().axis] = 1.0;
    let domain = glam::Vec3::from(scene.grid_res.map(|r| r as f32)) * scene.dx;
    let behind = domain * 0.5 - along * domain;
    let push = mpm::sim::Push::new(
        behind,
        along,
        100.0 * domain.length(),
        along * (4.0 * scene.dx / params.dt),
    );
    split.apply_push(&push).unwrap();
    let stopped = (0..4).find_map(|_| split.step(&params).err());
    let text = format!(
        "{:#}",
        stopped.expect("particles moved 4 cells a substep and the ranks stepped on")
    );
    assert!(
        text.contains("moved past its ghost planes") && text.contains("lower time_step.cfl"),
        "{text}"
    );
}

/// The exchanges are phases of their own, timed; every migration's books balance (checked inside
/// each one: a run whose counts disagree fails the step).
pub fn the_halo_phases_are_timed_and_migrations_counted(on: On) {
    let (scene, params) = tank(ScatterMode::Float);
    let mut split = ranks(&scene, 2, on);
    run(&mut split, &params, 20);
    let t = split.take_step_timings().unwrap().unwrap();
    assert_eq!(t.len(), 20);
    assert!(
        t.iter()
            .all(|t| t[Phase::HaloSum] > 0.0 && t[Phase::HaloFill] > 0.0),
        "{:?}",
        t[0]
    );
    let (migrations, migrated) = split.migrated();
    assert!(migrations > 0 && migrated.sent > 0 && migrated.sent == migrated.received);
    assert_eq!(split.counts().iter().sum::<usize>(), scene.spawn().num_live());
}
