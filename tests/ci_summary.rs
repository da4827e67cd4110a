//! `.ci/not-run-summary`, which ends CI with what did not run: one line per kind of hardware, the
//! counts added up, each reason said once (issue 39, item 4: it printed 47 where 57 did not run, and
//! put the NCCL and two-GPU tests on a line that repeated "not run:" and the reason three times).

use std::process::Command;

fn summary(log: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("log");
    std::fs::write(&path, log).unwrap();
    let out = Command::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.ci/not-run-summary"))
        .arg(&path)
        .output()
        .expect("running .ci/not-run-summary (bash, sed, awk)");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn every_kind_is_counted_once_with_its_reason_once() {
    let why = "no usable CUDA device: the NVIDIA driver library (libcuda.so) was not found";
    let log = format!(
        "test a ... ok\n\
         not run: 40 GPU tests of gpu_kernels: {why}\n\n\
         not run: 7 GPU tests of gpu_physics: {why}\n\
         not run: 6 GPU and NCCL tests of gpu_nccl: {why}\n\
         not run: 1 two-GPU and NCCL test of gpu_nccl_pair: {why}\n\
         not run: 3 two-GPU and NCCL tests of gpu_ranks_on_gpus: {why}\n\
         not run: 1 viewer test of viewer_window: no display\n"
    );
    let text = summary(&log);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 5, "{text}");
    assert_eq!(
        lines[0],
        format!("ci: not run here: 47 GPU tests (gpu_kernels, gpu_physics): {why}")
    );
    assert_eq!(
        lines[1],
        "ci: not run here: 6 GPU and NCCL tests (gpu_nccl): as the GPU tests"
    );
    assert_eq!(
        lines[2],
        "ci: not run here: 4 two-GPU and NCCL tests (gpu_nccl_pair, gpu_ranks_on_gpus): as the GPU tests"
    );
    assert_eq!(
        lines[3],
        "ci: not run here: 1 viewer test (viewer_window): no display"
    );
    assert!(lines[4].starts_with("ci: 58 tests did not run in all"), "{text}");
    assert_eq!(text.matches(why).count(), 1, "{text}");
    assert!(!text.contains("not run: not run"), "{text}");
}

#[test]
fn a_log_where_everything_ran_says_so() {
    assert_eq!(
        summary("test a ... ok\ntest result: ok\n"),
        "ci: every test ran\n"
    );
}
