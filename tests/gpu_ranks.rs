//! The decomposition on the CUDA backend with every rank on one GPU: `CudaRanks`, several CUDA
//! solvers as the ranks of one run (slabs, ghost exchange by halo kernels, migration, rebalancing),
//! against one CUDA solver (the checks: tests/ranks_checks). Where no CUDA device and driver are
//! usable, every test is reported as ignored, with the reason (tests/harness: `harness = false`).

use mpm::cuda::{CudaOptions, CudaRanks};
use mpm::sim::{Pipeline, ScatterMode};
use ranks_checks::{tank, On};

mod common;
mod harness;
mod ranks_checks;

fn main() -> std::process::ExitCode {
    harness::run(
        "GPU",
        harness::cuda_device,
        harness::tests![
            fixed_point_ranks_give_one_gpu_s_bits,
            two_liquids_on_ranks_give_one_gpu_s_bits,
            solids_on_ranks_give_one_gpu_s_bits,
            float_ranks_follow_one_gpu,
            a_moving_collider_across_the_cut_gives_one_gpu_s_bits,
            a_dam_break_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame,
            a_plastic_solid_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame,
            the_halo_phases_are_timed_and_migrations_counted,
            a_checkpoint_of_two_ranks_resumes_on_three,
            emitters_and_sinks_on_ranks_give_one_gpu_s_bytes,
            ranks_refuse_what_they_do_not_run,
            a_particle_leaving_its_rank_s_grid_stops_the_run,
        ],
    )
}

fn fixed_point_ranks_give_one_gpu_s_bits() {
    ranks_checks::fixed_point_ranks_give_one_gpu_s_bits(On::OneGpu);
}

fn a_particle_leaving_its_rank_s_grid_stops_the_run() {
    ranks_checks::a_particle_leaving_its_rank_s_grid_stops_the_run(On::OneGpu);
}

fn float_ranks_follow_one_gpu() {
    ranks_checks::float_ranks_follow_one_gpu(On::OneGpu);
}

fn a_moving_collider_across_the_cut_gives_one_gpu_s_bits() {
    ranks_checks::a_moving_collider_across_the_cut_gives_one_gpu_s_bits(On::OneGpu);
}

fn a_dam_break_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame() {
    ranks_checks::a_dam_break_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame(On::OneGpu);
}

fn a_plastic_solid_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame() {
    ranks_checks::a_plastic_solid_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame(On::OneGpu);
}

fn the_halo_phases_are_timed_and_migrations_counted() {
    ranks_checks::the_halo_phases_are_timed_and_migrations_counted(On::OneGpu);
}

/// `mpm run --ranks`: a checkpoint of 2 ranks resumes on 3 and ends on one GPU's bytes.
fn a_checkpoint_of_two_ranks_resumes_on_three() {
    common::ranks_checkpoint_resumes_on_another_rank_count("cuda", &["--ranks", "2"]);
}

/// `fountain` on 2 ranks of one GPU: one GPU's bytes at frame 5, with particles emitted and
/// drained, and its checkpoint resumes on 3 ranks to one GPU's bytes at frame 10.
fn emitters_and_sinks_on_ranks_give_one_gpu_s_bytes() {
    common::fountain_on_ranks_gives_one_rank_s_bytes("cuda", &["--ranks", "2"], 1);
}

fn ranks_refuse_what_they_do_not_run() {
    let (mut scene, _) = tank(ScatterMode::Float);
    scene.pipeline = Pipeline::Binned;
    let err = CudaRanks::new(&scene, &scene.spawn(), None, 2, CudaOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("fused pipeline"), "{err}");
    scene.pipeline = Pipeline::Fused;
    let err = CudaRanks::new(&scene, &scene.spawn(), None, 7, CudaOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("at most 6 ranks"), "{err}");
}

fn two_liquids_on_ranks_give_one_gpu_s_bits() {
    ranks_checks::two_liquids_on_ranks_give_one_gpu_s_bits(On::OneGpu);
}

fn solids_on_ranks_give_one_gpu_s_bits() {
    ranks_checks::solids_on_ranks_give_one_gpu_s_bits(On::OneGpu);
}
