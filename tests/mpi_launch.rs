//! `--processes` under real MPI launchers: `mpirun -n 2 mpm run --backend cpu --processes` finds
//! each process's place and the run's name in the variables the launcher sets (Open MPI's, or
//! Hydra's for MPICH and Intel MPI), and writes one rank's bytes. The other process tests
//! (tests/cpu_ranks.rs, tests/gpu_ranks_on_gpus.rs) set torch's variables by hand. The launchers:
//! `mpirun` on the PATH, and MPICH's `mpiexec` where .ci/run installed it (pip's `mpich` wheel, in
//! .ci-cache/mpich). Where there is none, the test is reported as ignored, with the reason
//! (tests/harness).

use std::path::PathBuf;
use std::process::Command;

mod common;
mod harness;

fn main() -> std::process::ExitCode {
    harness::run(
        "MPI launcher",
        harness::mpirun,
        harness::tests![each_launcher_s_two_processes_give_one_rank_s_bytes],
    )
}

/// The launchers found: `mpirun` on the PATH, and MPICH's wheel in .ci-cache.
fn launchers() -> Vec<PathBuf> {
    let wheel = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(".ci-cache/mpich/bin/mpiexec");
    let on_path = Command::new("mpirun")
        .arg("--version")
        .output()
        .is_ok_and(|out| out.status.success());
    let mut found: Vec<PathBuf> = Vec::new();
    if on_path {
        found.push("mpirun".into());
    }
    if wheel.is_file() {
        found.push(wheel);
    }
    found
}

/// `launcher -n N`, with what Open MPI needs to start N processes on a machine of fewer cores, as
/// root where the tests run as root (CI's containers); and whether it is Open MPI's.
fn launch(launcher: &PathBuf, n: usize) -> (Command, bool) {
    let version = Command::new(launcher).arg("--version").output().unwrap();
    let open_mpi = String::from_utf8_lossy(&version.stdout).contains("Open MPI");
    let mut command = Command::new(launcher);
    command.args(["-n", &n.to_string()]);
    if open_mpi {
        command
            .arg("--oversubscribe")
            .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
            .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1");
    }
    // The variables of another launch this test runs inside (torch's, say) are not this one's.
    for name in ["RANK", "WORLD_SIZE", "LOCAL_RANK", "MPM_RUN_ID", "MPM_RENDEZVOUS"] {
        command.env_remove(name);
    }
    (command, open_mpi)
}

/// The fixed-point coarse dam break on one rank, and launched by each launcher as two processes of
/// the CPU reference: frame 5's PLY files are the same bytes, and rank 0 says how it was launched.
fn each_launcher_s_two_processes_give_one_rank_s_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let args = |export: &str| {
        [
            "run",
            "--backend",
            "cpu",
            "--scatter",
            "fixed-point",
            "--scene",
            "dam-break-coarse",
            "--frames",
            "5",
            "--export",
            export,
        ]
        .map(String::from)
    };
    let one = Command::new(common::mpm_binary())
        .current_dir(dir.path())
        .args(args("whole"))
        .output()
        .unwrap();
    assert!(one.status.success(), "{}", String::from_utf8_lossy(&one.stderr));
    let read = |path: String| std::fs::read(dir.path().join(path)).unwrap();
    for (n, launcher) in launchers().iter().enumerate() {
        let (mut command, open_mpi) = launch(launcher, 2);
        let export = format!("split-{n}");
        let split = command
            .current_dir(dir.path())
            .arg(common::mpm_binary())
            .args(args(&export))
            .arg("--processes")
            .output()
            .unwrap();
        let text =
            String::from_utf8_lossy(&split.stdout).to_string() + &String::from_utf8_lossy(&split.stderr);
        assert!(split.status.success(), "{}: {text}", launcher.display());
        let named = if open_mpi { "Open MPI (mpirun)" } else { "Hydra" };
        assert!(
            text.contains(&format!("on 2 ranks, a process each ({named}")),
            "{}: {text}",
            launcher.display()
        );
        assert!(
            read("whole/frame_000005.ply".into()) == read(format!("{export}/frame_000005.ply")),
            "frame 5 of {}'s two processes differs from one rank's",
            launcher.display()
        );
        eprintln!("{}: one rank's bytes", launcher.display());
    }
}
