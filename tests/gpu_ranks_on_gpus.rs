//! The decomposition over two GPUs of one host: `CudaRanks` with a rank per GPU (`--gpus 2`), the
//! ghost exchanges over NCCL, particles moved between the GPUs' memories, against one CUDA solver
//! (the checks: tests/ranks_checks, which tests/gpu_ranks.rs runs with every rank on one GPU).
//! Where fewer than two CUDA devices or no NCCL are found, every test is reported as ignored, with
//! the reason (tests/harness: `harness = false`).

use cudarc::driver::CudaContext;
use mpm::cuda::{CudaOptions, CudaRanks};
use mpm::sim::ScatterMode;
use ranks_checks::{tank, On};

mod common;
mod harness;
mod ranks_checks;

fn main() -> std::process::ExitCode {
    harness::run(
        "two-GPU and NCCL",
        harness::two_cuda_devices_and_nccl,
        harness::tests![
            fixed_point_on_two_gpus_gives_one_gpu_s_bits,
            two_liquids_on_two_gpus_give_one_gpu_s_bits,
            solids_on_two_gpus_give_one_gpu_s_bits,
            float_on_two_gpus_follows_one_gpu,
            a_moving_collider_across_the_gpus_cut_gives_one_gpu_s_bits,
            a_dam_break_on_two_gpus_gives_one_gpu_s_bits_frame_by_frame,
            the_halo_phases_run_over_nccl_and_are_timed,
            a_checkpoint_of_two_gpus_resumes_on_one,
            two_processes_give_one_gpu_s_bytes_and_resume_on_three_ranks,
            two_processes_resume_one_gpu_s_checkpoint_to_its_bytes,
            emitters_and_sinks_on_two_gpus_give_one_gpu_s_bytes,
            a_killed_rank_stops_the_other_within_30_s,
            a_stopped_rank_stops_the_other_within_30_s,
            more_gpus_than_the_host_has_are_refused,
        ],
    )
}

fn fixed_point_on_two_gpus_gives_one_gpu_s_bits() {
    ranks_checks::fixed_point_ranks_give_one_gpu_s_bits(On::TwoGpus);
}

fn float_on_two_gpus_follows_one_gpu() {
    ranks_checks::float_ranks_follow_one_gpu(On::TwoGpus);
}

fn a_moving_collider_across_the_gpus_cut_gives_one_gpu_s_bits() {
    ranks_checks::a_moving_collider_across_the_cut_gives_one_gpu_s_bits(On::TwoGpus);
}

fn a_dam_break_on_two_gpus_gives_one_gpu_s_bits_frame_by_frame() {
    ranks_checks::a_dam_break_on_two_ranks_gives_one_gpu_s_bits_frame_by_frame(On::TwoGpus);
}

fn the_halo_phases_run_over_nccl_and_are_timed() {
    ranks_checks::the_halo_phases_are_timed_and_migrations_counted(On::TwoGpus);
    let (scene, _) = tank(ScatterMode::Float);
    let split = ranks_checks::ranks(&scene, 2, On::TwoGpus);
    let name = split.device_name();
    assert!(name.contains("2 x") && name.contains("NCCL"), "{name}");
}

/// `mpm run --gpus 2`: frame 5 is one GPU's bytes, and its checkpoint resumes on 3 ranks of one GPU
/// to frame 10, one GPU's bytes again.
fn a_checkpoint_of_two_gpus_resumes_on_one() {
    common::ranks_checkpoint_resumes_on_another_rank_count("cuda", &["--gpus", "2"]);
}

/// `mpm run --processes` launched as two processes, a GPU each: rank 0 writes frame 5 with one
/// GPU's bytes, and its checkpoint resumes on 3 ranks of one GPU to frame 10, one GPU's bytes again.
fn two_processes_give_one_gpu_s_bytes_and_resume_on_three_ranks() {
    let out = common::split_checkpoint_resumes_on_three_ranks("cuda", &["--processes"], 2);
    assert!(out[0].contains("on 2 GPUs, a process each"), "{}", out[0]);
}

/// One GPU's checkpoint resumed by two processes, a GPU each, each reading only its share of the
/// file's particles: frame 8 is one GPU's bytes.
fn two_processes_resume_one_gpu_s_checkpoint_to_its_bytes() {
    common::processes_resume_one_rank_s_checkpoint_to_its_bytes("cuda", 2);
}

/// `fountain` on two GPUs in one process and as two processes: one GPU's bytes at frame 5, with
/// particles emitted and drained, and each checkpoint resumes on 3 ranks of one GPU to one GPU's
/// bytes at frame 10.
fn emitters_and_sinks_on_two_gpus_give_one_gpu_s_bytes() {
    for (split, processes) in [(&["--gpus", "2"][..], 1), (&["--processes"][..], 2)] {
        common::fountain_on_ranks_gives_one_rank_s_bytes("cuda", split, processes);
    }
}

/// A run of two processes whose rank 1 is killed mid-run: rank 0 stops within 30 s, naming rank 1,
/// and its latest checkpoint resumes.
fn a_killed_rank_stops_the_other_within_30_s() {
    let took = common::a_failed_process_stops_the_run("cuda", "KILL");
    eprintln!("rank 0 stopped {took:.1} s after rank 1 was killed");
}

/// As above, rank 1 stopped (`SIGSTOP`, a hang) rather than killed.
fn a_stopped_rank_stops_the_other_within_30_s() {
    let took = common::a_failed_process_stops_the_run("cuda", "STOP");
    eprintln!("rank 0 stopped {took:.1} s after rank 1 was stopped");
}

fn more_gpus_than_the_host_has_are_refused() {
    let count = CudaContext::device_count().unwrap() as usize;
    let (mut scene, _) = tank(ScatterMode::Float);
    scene.ranks = count + 1;
    scene.gpus = count + 1;
    let particles = common::stirred(&scene);
    let slabs = mpm::dist::starting_slabs(&scene, &particles, count + 1).unwrap();
    let err = CudaRanks::with_slabs(&scene, &particles, None, slabs, CudaOptions::default())
        .err()
        .map(|e| format!("{e:#}"))
        .unwrap_or_default();
    assert!(
        err.contains("this machine has") && err.contains("mpm devices"),
        "{err}"
    );
}

fn two_liquids_on_two_gpus_give_one_gpu_s_bits() {
    ranks_checks::two_liquids_on_ranks_give_one_gpu_s_bits(On::TwoGpus);
}

fn solids_on_two_gpus_give_one_gpu_s_bits() {
    ranks_checks::solids_on_ranks_give_one_gpu_s_bits(On::TwoGpus);
}
