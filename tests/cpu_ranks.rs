//! The decomposition on the CPU: the reference split into 2 and 3 thread ranks (slabs, ghost
//! exchange, migration, load balancing, all-reduced extremes) against the one-rank reference.
//!
//! Tolerances: each rank computes the reference's own per-particle and per-node expressions; only a
//! boundary node's sum adds its terms in another order (the neighbour's part arrives as one partial
//! sum), so the runs agree to float rounding. After one substep that is 1e-5 dx. Over 200 substeps of
//! a stirred dam break rounding grows (to about 1e-4 dx): the yardstick there is cpu-parallel, whose
//! tiles reorder the same sums, on the same run. A wrong ghost or mirror moves particles by
//! hundredths of a cell from the first substep.

mod common;

use glam::Vec3;
use mpm::dist::{CpuRanks, Slabs};
use mpm::sim::cpu::CpuSolver;
use mpm::sim::cpu_parallel::ParallelCpuSolver;
use mpm::sim::{Phase, Pipeline, Scene, Solver};

/// `source` (a scene's TOML) in `pipeline`.
fn tank(source: &str, pipeline: Pipeline) -> Scene {
    let mut scene = common::scene(source);
    scene.pipeline = pipeline;
    scene
}

fn max_diff(a: &[Vec3], b: &[Vec3]) -> f32 {
    a.iter()
        .zip(b)
        .fold(0.0, |m, (a, b)| m.max((*a - *b).abs().max_element()))
}

/// `ranks` ranks against the reference over `substeps` of the scene `source`: (position gap in dx,
/// cpu-parallel's gap in dx, largest move in dx, the ranks).
fn compare(source: &str, pipeline: Pipeline, ranks: usize, substeps: u32) -> (f32, f32, f32, CpuRanks) {
    let scene = tank(source, pipeline);
    let mut params = common::cfl_params(&scene);
    params.density_rule = pipeline.density_rule().code();
    let mut reference = CpuSolver::new(common::stirred(&scene), scene.grid_res);
    let mut parallel = ParallelCpuSolver::new(common::stirred(&scene), scene.grid_res);
    let mut split = CpuRanks::new(&scene, common::stirred(&scene), ranks).unwrap();
    for _ in 0..substeps {
        reference.step(&params).unwrap();
        parallel.step(&params).unwrap();
        split.step(&params).unwrap();
    }
    let (a, b) = (&reference.particles, split.read_particles().unwrap());
    assert_eq!(b.num_live(), a.num_live(), "particles lost or gained");
    assert!(b.live.iter().all(|&l| l), "a particle is missing from every rank");
    let dx = scene.dx;
    let gap = max_diff(&a.x, &b.x) / dx;
    let yardstick = max_diff(&a.x, &parallel.particles().x) / dx;
    let moved = max_diff(&a.x, &scene.spawn().x) / dx;
    let e = (reference.take_extremes().unwrap(), split.take_extremes().unwrap());
    assert!(
        (e.0.max_speed - e.1.max_speed).abs() <= 1e-4 * e.0.max_speed
            && (e.0.max_signal_speed - e.1.max_signal_speed).abs() <= 1e-4 * e.0.max_signal_speed,
        "extremes {:?} vs {:?}",
        e.0,
        e.1
    );
    (gap, yardstick, moved, split)
}

/// One substep, both density rules, 2 and 3 ranks: rounding apart.
#[test]
fn one_substep_on_ranks_is_the_reference_s() {
    for pipeline in [Pipeline::Fused, Pipeline::Binned] {
        for ranks in [2, 3] {
            let (gap, _, _, _) = compare(common::STIRRED_TANK, pipeline, ranks, 1);
            assert!(
                gap <= 1e-5,
                "{pipeline:?}, {ranks} ranks: apart by {gap} dx after one substep"
            );
        }
    }
}

/// 200 substeps of the scene `source`: within 4 times cpu-parallel's rounding gap on the same run.
fn follows_the_reference(source: &str, pipeline: Pipeline, ranks: usize) {
    let (gap, yardstick, moved, split) = compare(source, pipeline, ranks, 200);
    let (rebins, migrated) = split.migrated();
    println!(
        "{pipeline:?}, {ranks} ranks: moved up to {moved:.2} dx, apart by {gap:.2e} dx (cpu-parallel: \
         {yardstick:.2e}); {rebins} rebins moved {} particles; slabs {:?}, counts {:?}",
        migrated.sent,
        split.slabs().bounds,
        split.counts()
    );
    assert!(moved > 2.0, "the water did not move");
    assert!(
        rebins > 0 && migrated.sent > 0,
        "no particle crossed a slab bound"
    );
    assert!(
        gap <= (4.0 * yardstick).max(1e-5) && gap <= 1e-3,
        "{ranks} ranks and one apart by {gap} dx, cpu-parallel by {yardstick}"
    );
}

#[test]
fn two_and_three_ranks_follow_the_reference_with_the_advected_density() {
    follows_the_reference(common::STIRRED_TANK, Pipeline::Fused, 2);
    follows_the_reference(common::STIRRED_TANK, Pipeline::Fused, 3);
}

#[test]
fn two_ranks_follow_the_reference_with_the_gathered_density() {
    follows_the_reference(common::STIRRED_TANK, Pipeline::Binned, 2);
}

/// Water and oil side by side: the grid's volume, from which both read their densities, summed
/// across the cut and filled into the ghosts with the mass, under either density rule.
#[test]
fn two_ranks_follow_the_reference_with_two_liquids() {
    follows_the_reference(common::STIRRED_LIQUIDS, Pipeline::Fused, 2);
    follows_the_reference(common::STIRRED_LIQUIDS, Pipeline::Binned, 2);
}

/// Whole block layers are the finest step a bound takes: the busiest rank within 10 % of the mean,
/// or within half the fullest layer of it.
fn balanced(split: &CpuRanks) -> bool {
    let counts = split.counts();
    let mean = counts.iter().sum::<usize>() as f64 / counts.len() as f64;
    let layer = *split.layer_counts().iter().max().unwrap() as f64;
    (*counts.iter().max().unwrap() as f64) <= (1.1 * mean).max(mean + layer / 2.0)
}

/// The water starts in the low third (4 of 12 block layers): `CpuRanks::new` cuts the slabs where it
/// lies, as finely as the thinnest slab (2 layers) allows.
#[test]
fn the_slabs_start_where_the_water_is() {
    let scene = tank(common::STIRRED_TANK, Pipeline::Fused);
    let two = CpuRanks::new(&scene, scene.spawn(), 2).unwrap();
    println!(
        "2 ranks: bounds {:?}, counts {:?}",
        two.slabs().bounds,
        two.counts()
    );
    assert!(balanced(&two), "{:?}", two.counts());
    let three = CpuRanks::new(&scene, scene.spawn(), 3).unwrap();
    println!(
        "3 ranks: bounds {:?}, counts {:?}",
        three.slabs().bounds,
        three.counts()
    );
    assert_eq!(three.slabs().bounds, vec![0, 2, 4, 12]);
}

/// Even slabs over water in the low third: the first rebin moves the bounds and migrates the
/// particles to their new owners, nothing lost.
#[test]
fn the_first_rebin_balances_even_slabs() {
    let scene = tank(common::STIRRED_TANK, Pipeline::Fused);
    let mut params = common::cfl_params(&scene);
    params.density_rule = Pipeline::Fused.density_rule().code();
    let even = Slabs::even(glam::UVec3::from(scene.grid_res), 2).unwrap();
    let mut split = CpuRanks::with_slabs(&scene, common::stirred(&scene), even.clone()).unwrap();
    let before = split.counts();
    for _ in 0..mpm::dist::MIGRATION_INTERVAL {
        split.step(&params).unwrap();
    }
    let after = split.counts();
    println!(
        "bounds {:?} -> {:?}, counts {before:?} -> {after:?}",
        even.bounds,
        split.slabs().bounds
    );
    assert!(
        before[1] * 10 < before[0],
        "the start is not out of balance: {before:?}"
    );
    assert_ne!(split.slabs().bounds, even.bounds, "the bounds never moved");
    assert!(balanced(&split), "{after:?}");
    assert_eq!(after.iter().sum::<usize>(), before.iter().sum::<usize>());
    assert!(split.migrated().1.sent as usize >= before[0] - after[0]);
}

/// Each rank's grid stores its slab and ghost planes alone, and follows them when the cut moves:
/// what `mpm bench` reports of each rank (`Solver::holdings`).
#[test]
fn each_rank_s_grid_holds_its_slab_and_ghost_planes() {
    let scene = tank(common::STIRRED_TANK, Pipeline::Fused);
    let params = common::cfl_params(&scene);
    let mut split = stirred_on(&scene, 2);
    let even = split.slabs().clone();
    let res = glam::UVec3::from(scene.grid_res);
    let across = (res.element_product() / res[even.axis]) as usize;
    let holds_its_planes = |split: &CpuRanks| {
        let (held, slabs) = (split.holdings().unwrap(), split.slabs());
        assert_eq!(held.axis, slabs.axis);
        for r in &held.ranks {
            assert_eq!(r.slab, slabs.owned(r.rank));
            assert_eq!(
                r.grid_nodes,
                slabs.held(r.rank).len() * across,
                "rank {} of {:?}",
                r.rank,
                slabs.bounds
            );
            assert_eq!(r.particles, split.counts()[r.rank]);
            // Its particles' 64 bytes a slot at least, and 16 a node of its grid.
            assert!(r.bytes >= 64 * r.places + 16 * r.grid_nodes, "{r:?}");
        }
        let nodes: usize = held.ranks.iter().map(|r| r.grid_nodes).sum();
        println!("bounds {:?}: {held:?}", slabs.bounds);
        // The whole grid once, and one block of ghost planes each side of the cut.
        assert_eq!(nodes, (res[slabs.axis] as usize + 2 * 4) * across);
    };
    split.step(&params).unwrap();
    holds_its_planes(&split);
    for _ in 1..mpm::dist::MIGRATION_INTERVAL {
        split.step(&params).unwrap();
    }
    assert_ne!(split.slabs().bounds, even.bounds, "the cut never moved");
    holds_its_planes(&split);
}

/// The exchanges are phases of their own: timed on ranks, zero on one.
#[test]
fn the_halo_phases_are_timed() {
    let scene = tank(common::STIRRED_TANK, Pipeline::Fused);
    let params = common::cfl_params(&scene);
    let mut split = CpuRanks::new(&scene, scene.spawn(), 2).unwrap();
    split.step(&params).unwrap();
    let t = split.take_step_timings().unwrap().unwrap();
    assert_eq!(t.len(), 1);
    assert!(
        t[0][Phase::HaloSum] > 0.0 && t[0][Phase::HaloFill] > 0.0,
        "{:?}",
        t[0]
    );
}

#[test]
fn more_ranks_than_the_grid_holds_is_a_clear_error() {
    let scene = tank(common::STIRRED_TANK, Pipeline::Fused);
    let err = CpuRanks::new(&scene, scene.spawn(), 7).err().unwrap().to_string();
    assert!(err.contains("at most 6 ranks"), "{err}");
}

/// `scene` stirred (`common::stirred`) on `ranks` ranks: 2 on even slabs (their first rebin moves
/// the cut), more on balanced ones.
fn stirred_on(scene: &Scene, ranks: usize) -> CpuRanks {
    if ranks == 2 {
        let even = Slabs::even(glam::UVec3::from(scene.grid_res), 2).unwrap();
        CpuRanks::with_slabs(scene, common::stirred(scene), even).unwrap()
    } else {
        CpuRanks::new(scene, common::stirred(scene), ranks).unwrap()
    }
}

/// The fixed-point scatter sums integers, whose sums do not depend on their order nor on how they
/// are split between ranks: 2 and 3 ranks give the one-rank reference's bits exactly, particle by
/// particle (by id), through 200 stirred substeps with migrations, under both density rules. The 2
/// ranks start on even slabs, so their first rebin also moves the bounds.
#[test]
fn fixed_point_ranks_are_byte_identical_to_one() {
    for pipeline in [Pipeline::Fused, Pipeline::Binned] {
        let mut scene = tank(common::STIRRED_TANK, pipeline);
        scene.scatter = mpm::sim::ScatterMode::FixedPoint;
        let mut params = common::cfl_params(&scene);
        params.density_rule = pipeline.density_rule().code();
        assert_eq!(params.scatter_mode, mpm::sim::ScatterMode::FixedPoint.code());
        let mut one = CpuSolver::new(common::stirred(&scene), scene.grid_res);
        let mut float = CpuSolver::new(common::stirred(&scene), scene.grid_res);
        let mut float_params = params;
        float_params.scatter_mode = mpm::sim::ScatterMode::Float.code();
        for _ in 0..200 {
            one.step(&params).unwrap();
            float.step(&float_params).unwrap();
        }
        let reference = common::particle_bits(&one.particles);
        let gap = max_diff(&one.particles.x, &float.particles.x) / scene.dx;
        println!("{pipeline:?}: fixed point and float apart by {gap:.2e} dx after 200 substeps");
        assert!(
            gap > 0.0,
            "the fixed-point scatter gave the float one's bits: was it used?"
        );
        assert!(
            gap < 1e-3,
            "the fixed-point scatter is not the float one: {gap} dx apart"
        );
        for ranks in [2, 3] {
            let mut split = stirred_on(&scene, ranks);
            let start = split.slabs().bounds.clone();
            for _ in 0..200 {
                split.step(&params).unwrap();
            }
            let (rebins, migrated) = split.migrated();
            println!(
                "{pipeline:?}, {ranks} ranks: {rebins} rebins moved {} particles, bounds {start:?} -> {:?}",
                migrated.sent,
                split.slabs().bounds
            );
            assert!(migrated.sent > 0);
            assert!(
                ranks != 2 || split.slabs().bounds != start,
                "the even slabs never moved"
            );
            assert!(
                common::particle_bits(&split.read_particles().unwrap()) == reference,
                "{pipeline:?}: {ranks} ranks differ from one in fixed point"
            );
        }
    }
}

/// Water, a jelly, snow and sand side by side across the cuts (`common::STIRRED_SOLIDS`), in fixed
/// point: 200 stirred substeps on 2 and 3 ranks give one rank's bits, every slot's deformation
/// gradient and plastic scalar included, after particles of every material crossed the cuts.
#[test]
fn solids_on_ranks_are_byte_identical_to_one() {
    let scene = common::scene(common::STIRRED_SOLIDS);
    let params = common::cfl_params_of_fastest(&scene);
    let mut one = CpuSolver::new(common::stirred(&scene), scene.grid_res);
    for _ in 0..200 {
        one.step(&params).unwrap();
    }
    let reference = common::particle_bits(&one.particles);
    let deformed = one
        .particles
        .deformation
        .iter()
        .filter(|d| !d.f.abs_diff_eq(glam::Mat3::IDENTITY, 1e-3))
        .count();
    assert!(
        deformed > 1000,
        "only {deformed} particles deformed: did the solids move?"
    );
    for ranks in [2, 3] {
        let mut split = stirred_on(&scene, ranks);
        for _ in 0..200 {
            split.step(&params).unwrap();
        }
        let (rebins, migrated) = split.migrated();
        println!(
            "{ranks} ranks: {rebins} rebins moved {} particles, bounds {:?}",
            migrated.sent,
            split.slabs().bounds
        );
        assert!(
            migrated.sent > 1000,
            "few particles crossed a cut: {}",
            migrated.sent
        );
        assert!(
            common::particle_bits(&split.read_particles().unwrap()) == reference,
            "{ranks} ranks differ from one in fixed point"
        );
    }
}

/// A moving box across the cut between two ranks (after the first rebin moves the cut into it):
/// its boundary acts on nodes of both slabs and its backstop on particles of both ranks, and the
/// fixed-point run on 2 ranks still gives one rank's bits, backstop counts included.
#[test]
fn a_moving_collider_across_the_cut_gives_one_rank_s_bits() {
    let scene = common::scene(&common::stirred_tank_with_moving_box());
    let mut params = common::cfl_params(&scene);
    params.density_rule = Pipeline::Fused.density_rule().code();
    assert_eq!(params.scatter_mode, mpm::sim::ScatterMode::FixedPoint.code());
    let mut one = CpuSolver::new(common::stirred(&scene), scene.grid_res);
    let even = Slabs::even(glam::UVec3::from(scene.grid_res), 2).unwrap();
    let mut split = CpuRanks::with_slabs(&scene, common::stirred(&scene), even).unwrap();
    let (mut pushes_one, mut pushes_split) = (0, 0);
    for n in 1..=200 {
        let frame = scene.colliders.frame(f64::from(n) * f64::from(params.dt));
        one.set_colliders(&frame).unwrap();
        split.set_colliders(&frame).unwrap();
        one.step(&params).unwrap();
        split.step(&params).unwrap();
        pushes_one += one.take_extremes().unwrap().backstop_pushes;
        pushes_split += split.take_extremes().unwrap().backstop_pushes;
    }
    let bounds = split.slabs().bounds.clone();
    let cut = bounds[1] as f32 * 4.0 * scene.dx;
    println!("cut at x = {cut} m (bounds {bounds:?}); backstop pushes {pushes_one} / {pushes_split}");
    assert!(
        (0.2..=0.3).contains(&cut),
        "the cut is not inside the box (x 0.2 to 0.3 m): {cut}"
    );
    assert_eq!(pushes_one, pushes_split);
    assert!(
        common::particle_bits(&one.particles) == common::particle_bits(&split.read_particles().unwrap()),
        "2 ranks differ from one with a collider across the cut"
    );
}

/// `mpm run --ranks`: a checkpoint of 2 ranks resumes on 3 and ends on one rank's bytes.
#[test]
fn a_checkpoint_of_two_ranks_resumes_on_three() {
    common::ranks_checkpoint_resumes_on_another_rank_count("cpu", &["--ranks", "2"]);
}

/// `mpm run --processes --backend cpu` launched as two processes (as torch's launcher starts them):
/// rank 0 writes frame 5 with one rank's bytes, and its checkpoint resumes on 3 thread ranks to
/// frame 10, one rank's bytes again.
#[test]
fn two_processes_give_one_rank_s_bytes_and_resume_on_three_ranks() {
    let out = common::split_checkpoint_resumes_on_three_ranks("cpu", &["--processes"], 2);
    assert!(out[0].contains("on 2 ranks, a process each"), "{}", out[0]);
    assert!(out[1].is_empty(), "rank 1 wrote lines of its own: {}", out[1]);
}

/// Four processes (the four-GPU launch's shape, on the CPU reference): rank 0 writes frame 5 with
/// one rank's bytes, the other three print nothing, and the checkpoint resumes on 3 thread ranks to
/// one rank's bytes at frame 10.
#[test]
fn four_processes_give_one_rank_s_bytes_and_resume_on_three_ranks() {
    let out = common::split_checkpoint_resumes_on_three_ranks("cpu", &["--processes"], 4);
    assert!(out[0].contains("on 4 ranks, a process each"), "{}", out[0]);
    for (rank, text) in out.iter().enumerate().skip(1) {
        assert!(text.is_empty(), "rank {rank} wrote lines of its own: {text}");
    }
}

/// A jet into a basin with a floor drain (`fountain`) on 2 thread ranks and as two processes gives
/// one rank's bytes, and resumes on 3 ranks to them (`fountain_on_ranks_gives_one_rank_s_bytes`).
#[test]
fn emitters_and_sinks_on_ranks_give_one_rank_s_bytes() {
    for (split, processes) in [(&["--ranks", "2"][..], 1), (&["--processes"][..], 2)] {
        common::fountain_on_ranks_gives_one_rank_s_bytes("cpu", split, processes);
    }
}

/// One rank's checkpoint resumed by two processes (each reads the file and keeps its share): frame
/// 8 is one rank's bytes, and rank 1 prints nothing (rank 0 says which checkpoint it resumed).
#[test]
fn two_processes_resume_one_rank_s_checkpoint_to_its_bytes() {
    common::processes_resume_one_rank_s_checkpoint_to_its_bytes("cpu", 2);
}

/// Two processes whose rank 1 is killed mid-run: rank 0 stops within 30 s, naming rank 1, and its
/// latest checkpoint resumes.
#[test]
fn a_killed_process_stops_the_other_within_30_s() {
    let took = common::a_failed_process_stops_the_run("cpu", "KILL");
    eprintln!("rank 0 stopped {took:.1} s after rank 1 was killed");
}

/// As above, rank 1 stopped (`SIGSTOP`, a hang): its heartbeat falls silent and rank 0 names it.
#[test]
fn a_stopped_process_stops_the_other_within_30_s() {
    let took = common::a_failed_process_stops_the_run("cpu", "STOP");
    eprintln!("rank 0 stopped {took:.1} s after rank 1 was stopped");
}
