//! The decomposition over four GPUs of one host (the issue of the four-GPU tables): the checks of
//! tests/gpu_ranks_on_gpus.rs with a rank on each of four GPUs, in one process and as four
//! processes. Where fewer than four CUDA devices or no NCCL are found, every test is reported as
//! ignored, with the reason (tests/harness: `harness = false`).

use ranks_checks::On;

mod common;
mod harness;
mod ranks_checks;

fn main() -> std::process::ExitCode {
    harness::run(
        "four-GPU and NCCL",
        harness::four_cuda_devices_and_nccl,
        harness::tests![
            fixed_point_on_four_gpus_gives_one_gpu_s_bits,
            a_checkpoint_of_four_gpus_resumes_on_three_ranks,
            four_processes_give_one_gpu_s_bytes_and_resume_on_three_ranks,
            four_processes_resume_one_gpu_s_checkpoint_to_its_bytes,
            emitters_and_sinks_on_four_gpus_give_one_gpu_s_bytes,
        ],
    )
}

fn fixed_point_on_four_gpus_gives_one_gpu_s_bits() {
    ranks_checks::fixed_point_ranks_give_one_gpu_s_bits(On::FourGpus);
}

/// `mpm run --gpus 4`: frame 5 is one GPU's bytes, and its checkpoint resumes on 3 ranks of one GPU
/// to frame 10, one GPU's bytes again.
fn a_checkpoint_of_four_gpus_resumes_on_three_ranks() {
    common::ranks_checkpoint_resumes_on_another_rank_count("cuda", &["--gpus", "4"]);
}

/// `mpm run --processes` launched as four processes, a GPU each: rank 0 writes frame 5 with one
/// GPU's bytes, and its checkpoint resumes on 3 ranks of one GPU to frame 10.
fn four_processes_give_one_gpu_s_bytes_and_resume_on_three_ranks() {
    let out = common::split_checkpoint_resumes_on_three_ranks("cuda", &["--processes"], 4);
    assert!(out[0].contains("on 4 GPUs, a process each"), "{}", out[0]);
}

/// One GPU's checkpoint resumed by four processes, each reading only its share of the file.
fn four_processes_resume_one_gpu_s_checkpoint_to_its_bytes() {
    common::processes_resume_one_rank_s_checkpoint_to_its_bytes("cuda", 4);
}

/// `fountain` on four GPUs in one process and as four processes: one GPU's bytes.
fn emitters_and_sinks_on_four_gpus_give_one_gpu_s_bytes() {
    for (split, processes) in [(&["--gpus", "4"][..], 1), (&["--processes"][..], 4)] {
        common::fountain_on_ranks_gives_one_rank_s_bytes("cuda", split, processes);
    }
}
