//! `--processes` under a real MPI launcher: `mpirun -n 2 mpm run --backend cpu --processes` finds
//! each process's place and the run's name in the variables `mpirun` sets (Open MPI's, or Hydra's
//! for MPICH and Intel MPI), and writes one rank's bytes. The other process tests
//! (tests/cpu_ranks.rs, tests/gpu_ranks_on_gpus.rs) set torch's variables by hand. Where no `mpirun`
//! is on the PATH, the tests are reported as ignored, with the reason (tests/harness).

mod common;
mod harness;

fn main() -> std::process::ExitCode {
    harness::run(
        "MPI launcher",
        harness::mpirun,
        harness::tests![mpirun_s_two_processes_give_one_rank_s_bytes],
    )
}

/// `mpirun -n N` and what this `mpirun` needs to start N processes on a machine of fewer cores, as
/// root where the tests run as root (CI's containers).
fn mpirun(n: usize) -> std::process::Command {
    let version = std::process::Command::new("mpirun")
        .arg("--version")
        .output()
        .unwrap();
    let open_mpi = String::from_utf8_lossy(&version.stdout).contains("Open MPI");
    let mut command = std::process::Command::new("mpirun");
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
    command
}

/// The fixed-point coarse dam break on one rank, and launched by `mpirun` as two processes of the
/// CPU reference: frame 5's PLY files are the same bytes, and rank 0 says how it was launched.
fn mpirun_s_two_processes_give_one_rank_s_bytes() {
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
    let one = std::process::Command::new(common::mpm_binary())
        .current_dir(dir.path())
        .args(args("whole"))
        .output()
        .unwrap();
    assert!(one.status.success(), "{}", String::from_utf8_lossy(&one.stderr));
    let split = mpirun(2)
        .current_dir(dir.path())
        .arg(common::mpm_binary())
        .args(args("split"))
        .arg("--processes")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&split.stdout).to_string() + &String::from_utf8_lossy(&split.stderr);
    assert!(split.status.success(), "mpirun: {text}");
    assert!(
        text.contains("on 2 ranks, a process each (Open MPI (mpirun))")
            || text.contains("on 2 ranks, a process each (Hydra"),
        "{text}"
    );
    let read = |path: &str| std::fs::read(dir.path().join(path)).unwrap();
    assert!(
        read("whole/frame_000005.ply") == read("split/frame_000005.ply"),
        "frame 5 of mpirun's two processes differs from one rank's"
    );
}
