//! The test harness of the test files that need hardware this machine may lack (a CUDA device, a
//! display): a test that cannot run is reported as *ignored, with the reason*, in cargo test's own
//! counts, never as a pass.
//!
//! How a test file uses it (tests/gpu_kernels.rs is one):
//!
//! 1. In Cargo.toml, give the file a `[[test]]` entry with `harness = false`.
//! 2. In the file: `mod harness;`, plain `fn name() { ... }` test functions (no `#[test]`; they panic
//!    on failure as usual), and a `main` that lists them:
//!
//! ```ignore
//! fn main() -> std::process::ExitCode {
//!     harness::run("GPU", harness::cuda_device, harness::tests![p2g_init_matches_cpu, p2g_matches_cpu])
//! }
//! ```
//!
//! A new test is a new function plus its name in that list.
//!
//! The requirement (`cuda_device` here) is checked once, when the first test starts. Where it fails,
//! every test of the file prints `ignored (<reason>)`, the summary counts them as ignored, and a last
//! line `not run: N GPU tests of <file>: <reason>` gives the count (`.ci/run` adds these up). Filters,
//! `--list`, `--nocapture` and `--test-threads` work as with the built-in harness.
#![allow(dead_code)]

use libtest_mimic::{Arguments, Completion, Trial};
use std::process::ExitCode;
use std::sync::{Arc, Mutex, OnceLock};

/// A test: its name and its body (which panics on failure).
pub type Test = (&'static str, fn());

/// The list of tests for [`run`], from the names of their functions.
macro_rules! tests {
    ($($test:ident),* $(,)?) => {
        &[$((stringify!($test), $test as fn())),*]
    };
}
pub(crate) use tests;

/// Runs `tests` where `requirement` holds; reports them as ignored, with its reason, where it does not.
/// `kind` names what they need in the closing line ("GPU", "viewer").
pub fn run(kind: &str, requirement: fn() -> Result<(), String>, tests: &[Test]) -> ExitCode {
    let args = Arguments::from_args();
    let gate: Arc<OnceLock<Result<(), String>>> = Arc::new(OnceLock::new());
    let not_run = Arc::new(Mutex::new(0usize));
    let trials = tests
        .iter()
        .map(|&(name, body)| {
            let gate = Arc::clone(&gate);
            let not_run = Arc::clone(&not_run);
            Trial::ignorable_test(name, move || match gate.get_or_init(requirement) {
                Ok(()) => {
                    body();
                    Ok(Completion::Completed)
                }
                Err(why) => {
                    *not_run.lock().unwrap_or_else(|e| e.into_inner()) += 1;
                    // The short reason on each test's line; the whole of it once, at the end.
                    let short = why.split(": ").next().unwrap_or(why);
                    Ok(Completion::ignored_with(short))
                }
            })
        })
        .collect();
    let conclusion = libtest_mimic::run(&args, trials);
    let not_run = *not_run.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(Err(why)) = gate.get() {
        let suite = std::env::args()
            .next()
            .map(|exe| {
                let stem = std::path::Path::new(&exe)
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned());
                // Cargo names test executables `<file>-<hash>`.
                let stem = stem.unwrap_or_default();
                stem.rsplit_once('-')
                    .map_or(stem.clone(), |(file, _)| file.to_string())
            })
            .unwrap_or_default();
        let s = if not_run == 1 { "" } else { "s" };
        println!("not run: {not_run} {kind} test{s} of {suite}: {why}\n");
    }
    conclusion.exit_code()
}

/// A usable CUDA device and driver.
pub fn cuda_device() -> Result<(), String> {
    mpm::cuda::library::device_available().map_err(|why| format!("no usable CUDA device: {why:#}"))
}

/// A CUDA device and NCCL (`mpm::dist::nccl`).
pub fn cuda_device_and_nccl() -> Result<(), String> {
    cuda_device()?;
    mpm::dist::nccl::Nccl::get()
        .map(drop)
        .map_err(|why| format!("no NCCL: {why:#}"))
}

/// Two CUDA devices or more, and NCCL.
pub fn two_cuda_devices_and_nccl() -> Result<(), String> {
    cuda_devices_and_nccl(2)
}

/// Four CUDA devices or more, and NCCL.
pub fn four_cuda_devices_and_nccl() -> Result<(), String> {
    cuda_devices_and_nccl(4)
}

fn cuda_devices_and_nccl(needed: i32) -> Result<(), String> {
    cuda_device_and_nccl()?;
    let count =
        cudarc::driver::CudaContext::device_count().map_err(|e| format!("counting CUDA devices: {e:?}"))?;
    if count < needed {
        return Err(format!(
            "{count} CUDA device{}; {needed} are needed",
            if count == 1 { "" } else { "s" }
        ));
    }
    Ok(())
}

/// A CUDA device and a headless OpenGL context on an EGL device.
pub fn cuda_device_and_headless_gl() -> Result<(), String> {
    cuda_device()?;
    headless_gl()
}

/// A headless OpenGL context on an EGL device: a GPU driver's, or Mesa's software one.
pub fn headless_gl() -> Result<(), String> {
    mpm::render::headless::HeadlessGl::new(64, 64)
        .map(drop)
        .map_err(|why| format!("no headless OpenGL: {why:#}"))
}

/// An MPI launcher: `mpirun` on the PATH (Open MPI's, or MPICH's Hydra), or MPICH's wheel where
/// .ci/run installs it (.ci-cache/mpich).
pub fn mpirun() -> Result<(), String> {
    let wheel = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(".ci-cache/mpich/bin/mpiexec");
    let works = |launcher: &std::path::Path| {
        std::process::Command::new(launcher)
            .arg("--version")
            .output()
            .is_ok_and(|out| out.status.success())
    };
    if works("mpirun".as_ref()) || works(&wheel) {
        return Ok(());
    }
    Err("no mpirun on the PATH: install Open MPI or MPICH (Debian: apt install openmpi-bin)".into())
}
