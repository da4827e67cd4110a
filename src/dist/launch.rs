//! A run of one rank per process (`--processes`): where this process stands, from the environment
//! its launcher set, and the rendezvous that hands rank 0's NCCL id to every other rank.
//!
//! **Launchers** (the first whose variables are set wins): Open MPI's `mpirun`
//! (`OMPI_COMM_WORLD_RANK`, `_SIZE`, `_LOCAL_RANK`), MPICH's and Intel MPI's Hydra (`PMI_RANK`,
//! `PMI_SIZE`, `MPI_LOCALRANKID`), Slurm's `srun` (`SLURM_PROCID`, `SLURM_NTASKS`, `SLURM_LOCALID`),
//! and torch's launcher or anything that sets its variables (`RANK`, `WORLD_SIZE`, `LOCAL_RANK`).
//! A process drives the GPU of its local rank among those it sees, or the one it sees where the
//! launcher gave each process a GPU of its own (`CUDA_VISIBLE_DEVICES`).
//!
//! **The rendezvous** is a file: rank 0 writes its NCCL unique id (128 bytes) to
//! `<folder>/mpm-nccl-<run>.id` (written whole, then renamed into place), every other rank reads it,
//! and rank 0 removes it once every rank has joined. The folder is `MPM_RENDEZVOUS`, which every
//! process must see (a shared file system across hosts); on one host it defaults to the temporary
//! folder. `<run>` names the launch, the same in each of its processes: `MPM_RUN_ID`, else the job
//! the launcher names (Slurm's job and step, Open MPI's or PMIx's namespace, torch's run id and
//! port), else, on one host, the launching process (the processes' parent). This is torch's file
//! rendezvous (`init_method="file://..."`) in spirit: no socket protocol of our own.

use anyhow::{bail, ensure, Context, Result};
use std::os::linux::net::SocketAddrExt;
use std::os::unix::net::{SocketAddr, UnixListener};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

/// One process's place in a run of one rank per process.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Process {
    /// Its rank, 0 to `size - 1`: the slab it owns (rank 0 also writes every output).
    pub rank: usize,
    /// The run's processes.
    pub size: usize,
    /// Its rank among the processes on its host: which of the host's GPUs it drives.
    pub local_rank: usize,
    /// Whether every process runs on this host (the rendezvous may then use the temporary folder).
    pub one_host: bool,
    /// The launcher whose variables said so.
    pub launcher: &'static str,
}

/// A launcher's variables: rank, size, local rank, and what says whether every process runs on
/// one host.
struct Variables {
    launcher: &'static str,
    names: [&'static str; 3],
    hosts: Hosts,
}

/// How a launcher says whether its processes share one host.
enum Hosts {
    /// The processes on this host: one host where they are all of them.
    LocalSize(&'static str),
    /// The hosts of the launch.
    Count(&'static str),
}

const LAUNCHERS: [Variables; 4] = [
    Variables {
        launcher: "Open MPI (mpirun)",
        names: [
            "OMPI_COMM_WORLD_RANK",
            "OMPI_COMM_WORLD_SIZE",
            "OMPI_COMM_WORLD_LOCAL_RANK",
        ],
        hosts: Hosts::LocalSize("OMPI_COMM_WORLD_LOCAL_SIZE"),
    },
    Variables {
        launcher: "Hydra (MPICH or Intel MPI mpirun)",
        names: ["PMI_RANK", "PMI_SIZE", "MPI_LOCALRANKID"],
        hosts: Hosts::LocalSize("MPI_LOCALNRANKS"),
    },
    Variables {
        launcher: "Slurm (srun)",
        names: ["SLURM_PROCID", "SLURM_NTASKS", "SLURM_LOCALID"],
        hosts: Hosts::Count("SLURM_NNODES"),
    },
    Variables {
        launcher: "torch's launcher (RANK, WORLD_SIZE)",
        names: ["RANK", "WORLD_SIZE", "LOCAL_RANK"],
        hosts: Hosts::LocalSize("LOCAL_WORLD_SIZE"),
    },
];

/// The variables that name a launch, per launcher, joined into the run's name.
const RUN_NAMES: [&[&str]; 4] = [
    &["OMPI_MCA_ess_base_jobid", "PMIX_NAMESPACE"],
    &["PMIX_NAMESPACE"],
    &["SLURM_JOB_ID", "SLURM_STEP_ID"],
    &["TORCHELASTIC_RUN_ID", "MASTER_ADDR", "MASTER_PORT"],
];

impl Process {
    /// This process's place, from the first launcher whose variables `var` finds; an error naming
    /// every launcher's where none is set, or where one's are not numbers that fit.
    pub fn from_env(var: &dyn Fn(&str) -> Option<String>) -> Result<Process> {
        let found = LAUNCHERS.iter().find(|v| var(v.names[0]).is_some());
        let Some(vars) = found else {
            let names: Vec<String> = LAUNCHERS
                .iter()
                .map(|v| format!("{} ({} and {})", v.launcher, v.names[0], v.names[1]))
                .collect();
            bail!(
                "--processes runs one rank per process as a launcher starts them, and no launcher's \
                 variables are set: {}. Launch it with mpirun -n N, srun -n N or torchrun \
                 --nproc-per-node N, or drop --processes (--gpus N runs every GPU of this host from one \
                 process)",
                names.join(", ")
            );
        };
        let number = |name: &str| -> Result<Option<usize>> {
            var(name)
                .map(|text| {
                    text.trim()
                        .parse::<usize>()
                        .with_context(|| format!("{name}={text}, set by {}: not a count", vars.launcher))
                })
                .transpose()
        };
        let [rank, size, local] = vars.names;
        let size = number(size)?.with_context(|| {
            format!(
                "{} sets {rank} but not {size}: a rank without the run's size",
                vars.launcher
            )
        })?;
        let rank = number(rank)?.context("the rank is set")?;
        ensure!(
            size >= 1 && rank < size,
            "{}: rank {rank} of a run of {size} processes ({}): not a rank of that run",
            vars.launcher,
            vars.names[0]
        );
        let local_rank = number(local)?.unwrap_or(rank);
        // Where the launcher does not say how many processes share the host, one host is assumed
        // (a wait on the rendezvous across hosts then says to set MPM_RENDEZVOUS).
        let one_host = match vars.hosts {
            Hosts::LocalSize(name) => number(name)?.is_none_or(|local_size| local_size == size),
            Hosts::Count(name) => number(name)?.is_none_or(|hosts| hosts == 1),
        };
        Ok(Process {
            rank,
            size,
            local_rank,
            one_host,
            launcher: vars.launcher,
        })
    }

    /// The settings a join reads (`MPM_RENDEZVOUS`, the run's name, `MPM_RANK_TIMEOUT`), checked
    /// before any work, so a bad one fails at once rather than after the scene is made.
    pub fn check_settings(&self, var: &dyn Fn(&str) -> Option<String>) -> Result<()> {
        self.rendezvous_folder(var)?;
        self.run_name(var)?;
        rank_timeout(var).map(drop)
    }

    /// The name of this launch, the same in each of its processes: `MPM_RUN_ID`, the launcher's
    /// job, or on one host the launching process.
    pub fn run_name(&self, var: &dyn Fn(&str) -> Option<String>) -> Result<String> {
        if let Some(id) = var("MPM_RUN_ID") {
            return Ok(clean(&id));
        }
        let at = LAUNCHERS
            .iter()
            .position(|v| v.launcher == self.launcher)
            .unwrap_or(0);
        let parts: Vec<String> = RUN_NAMES[at].iter().filter_map(|name| var(name)).collect();
        if !parts.is_empty() {
            return Ok(clean(&parts.join("-")));
        }
        ensure!(
            self.one_host,
            "{}: nothing names this launch in every process's environment (looked for MPM_RUN_ID \
             and {}): set MPM_RUN_ID to one name for the whole launch",
            self.launcher,
            RUN_NAMES[at].join(", ")
        );
        Ok(format!("parent-{}", std::os::unix::process::parent_id()))
    }

    /// The folder of the rendezvous file: `MPM_RENDEZVOUS`, or on one host the temporary folder.
    pub fn rendezvous_folder(&self, var: &dyn Fn(&str) -> Option<String>) -> Result<PathBuf> {
        match var("MPM_RENDEZVOUS") {
            Some(folder) => {
                let folder = PathBuf::from(folder);
                ensure!(
                    folder.is_dir(),
                    "MPM_RENDEZVOUS={}: not a folder; point it at a folder every process of the run \
                     can read and write",
                    folder.display()
                );
                Ok(folder)
            }
            None => {
                ensure!(
                    self.one_host,
                    "a run of {} processes across hosts meets in a folder they all see: set \
                     MPM_RENDEZVOUS to one on a shared file system",
                    self.size
                );
                Ok(std::env::temp_dir())
            }
        }
    }
}

/// Turns NCCL's cuMem (virtual memory) buffers between processes off, unless `NCCL_CUMEM_ENABLE`
/// is set already: with them, two processes of ranks on two H200s stepped the dam break at 1.03 ms a
/// substep, their host threads slower in every call; without, at 0.31, against one process's 0.28
/// (BENCHMARKS.md M29, call 8). Called before NCCL is loaded, while the process has one thread.
pub fn prefer_nccl_without_cumem() {
    if std::env::var_os("NCCL_CUMEM_ENABLE").is_none() {
        std::env::set_var("NCCL_CUMEM_ENABLE", "0");
    }
}

/// A run name fit for a file name.
fn clean(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// How long the other ranks wait for rank 0's id: rank 0 may still be spawning a large scene.
pub const RENDEZVOUS_WAIT: Duration = Duration::from_secs(600);

/// The rendezvous file of run `run` in `folder`.
pub fn rendezvous_file(folder: &Path, run: &str) -> PathBuf {
    folder.join(format!("mpm-nccl-{run}.id"))
}

/// Rank 0's side: writes `id` to `file` whole, then renames it into place, so no reader sees part
/// of it.
pub fn publish_id(file: &Path, id: &[u8]) -> Result<()> {
    let part = file.with_extension("id.part");
    std::fs::write(&part, id).with_context(|| format!("writing the rendezvous file {}", part.display()))?;
    std::fs::rename(&part, file).with_context(|| format!("publishing the rendezvous file {}", file.display()))
}

/// Another rank's side: the id of `len` bytes in `file`, waited for until `wait` has passed. A file
/// older than `not_before` is an earlier run's, left behind where it failed, and is not taken.
pub fn read_id(file: &Path, len: usize, not_before: SystemTime, wait: Duration) -> Result<Vec<u8>> {
    let start = Instant::now();
    loop {
        let fresh = std::fs::metadata(file)
            .and_then(|m| m.modified())
            .is_ok_and(|modified| modified >= not_before);
        if fresh {
            let id = std::fs::read(file).with_context(|| format!("reading {}", file.display()))?;
            ensure!(
                id.len() == len,
                "the rendezvous file {} holds {} bytes, not an NCCL id's {len}: another program's \
                 file? Remove it, or set MPM_RUN_ID to a name of this launch's own",
                file.display(),
                id.len()
            );
            return Ok(id);
        }
        if start.elapsed() > wait {
            bail!(
                "rank 0 did not publish the NCCL id at {} within {} s: it failed, or it runs with \
                 another run name or folder (MPM_RUN_ID), or on another host (set MPM_RENDEZVOUS to \
                 a folder every host sees); see rank 0's output",
                file.display(),
                wait.as_secs()
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// When this process started, less the time a launcher may take between starting its processes:
/// a rendezvous file older than this is not this launch's.
pub fn launch_time() -> SystemTime {
    static STARTED: std::sync::OnceLock<SystemTime> = std::sync::OnceLock::new();
    *STARTED.get_or_init(SystemTime::now) - Duration::from_secs(30)
}

/// How often a process says it is alive, and how long a silence means it is not.
const BEAT: Duration = Duration::from_secs(1);
const SILENCE: Duration = Duration::from_secs(10);

/// The processes of a run watching each other, so that one that dies or stops stops the rest: each
/// touches a file of its own in the rendezvous folder every second (a thread of its own, so a long
/// wait or a long write of rank 0's does not silence it), and a process waiting on the others looks
/// at theirs (`Watch::check`). A file gone (its process ended) or ten seconds old (killed, or
/// stopped) names its rank.
///
/// Before its heartbeat starts, a process claims its rank's name (`rank_address`) for the run: a
/// second launch under a running launch's name is refused there, before it writes, or on failing
/// removes, the heartbeat file that the running rank of its number keeps.
pub struct Watch {
    folder: PathBuf,
    run: String,
    rank: usize,
    size: usize,
    /// How long a wait may last while every process beats: past it, one hangs.
    pub timeout: Duration,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    beating: Option<std::thread::JoinHandle<()>>,
    /// This rank's name, held for the run (the CPU processes' sockets take connections on it).
    listener: UnixListener,
}

/// The name rank `rank` of run `run` listens under, in Linux's abstract namespace: nothing on disk,
/// and the name is free again as soon as its process ends, however it ends.
pub fn rank_address(run: &str, rank: usize) -> Result<SocketAddr> {
    SocketAddr::from_abstract_name(format!("mpm-{run}.rank{rank}").as_bytes())
        .context("naming a rank's socket")
}

impl Watch {
    /// Starts this process's heartbeat for run `run` in `folder`.
    pub fn start(process: &Process, folder: &Path, run: &str, timeout: Duration) -> Result<Watch> {
        let listener = UnixListener::bind_addr(&rank_address(run, process.rank)?).with_context(|| {
            format!(
                "rank {} of run {run}: another process already runs as this rank (a launch under the \
                 same name still runs?); set MPM_RUN_ID to a name of this launch's own",
                process.rank
            )
        })?;
        let mine = heartbeat_file(folder, run, process.rank);
        std::fs::write(&mine, b"")
            .with_context(|| format!("writing the heartbeat file {}", mine.display()))?;
        let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let beating = {
            let stop = stop.clone();
            std::thread::Builder::new()
                .name("mpm-heartbeat".into())
                .spawn(move || {
                    while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                        std::thread::sleep(BEAT);
                        // A failed touch shows as silence to the others, who then stop.
                        let _ = std::fs::write(&mine, b"");
                    }
                })
                .context("starting the heartbeat thread")?
        };
        Ok(Watch {
            folder: folder.to_path_buf(),
            run: run.to_string(),
            rank: process.rank,
            size: process.size,
            timeout,
            stop,
            beating: Some(beating),
            listener,
        })
    }

    /// This rank's listener, under `rank_address`.
    pub fn listener(&self) -> &UnixListener {
        &self.listener
    }

    /// An error naming the first other rank whose heartbeat is gone or silent.
    pub fn check(&self) -> Result<()> {
        let now = SystemTime::now();
        for rank in (0..self.size).filter(|&r| r != self.rank) {
            let file = heartbeat_file(&self.folder, &self.run, rank);
            let age = std::fs::metadata(&file)
                .and_then(|m| m.modified())
                .map(|modified| now.duration_since(modified).unwrap_or_default());
            match age {
                Err(_) => bail!(
                    "rank {rank} has ended (its heartbeat file {} is gone): the run stops; see rank \
                     {rank}'s output for why",
                    file.display()
                ),
                Ok(age) if age > SILENCE => bail!(
                    "rank {rank} has not answered for {} s (killed or stopped): the run stops",
                    age.as_secs()
                ),
                Ok(_) => {}
            }
        }
        Ok(())
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(beating) = self.beating.take() {
            let _ = beating.join();
        }
        let _ = std::fs::remove_file(heartbeat_file(&self.folder, &self.run, self.rank));
    }
}

/// What a process sets up before it joins the others, whatever carries their exchanges: the
/// rendezvous folder, the join's name and its heartbeat.
pub struct Joining {
    pub folder: PathBuf,
    /// The run's name and the join's count: a process may join several times (a benchmark of
    /// several scenes), each time under a name of its own, the same in every process, since each
    /// joins as often as the others.
    pub run: String,
    pub watch: Watch,
}

impl Joining {
    /// Starts this process's heartbeat under its next join's name.
    pub fn start(process: &Process) -> Result<Joining> {
        static JOINS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let join = JOINS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let var = |name: &str| std::env::var(name).ok();
        let folder = process.rendezvous_folder(&var)?;
        let run = format!("{}-{join}", process.run_name(&var)?);
        let watch = Watch::start(process, &folder, &run, rank_timeout(&var)?)?;
        Ok(Joining { folder, run, watch })
    }
}

fn heartbeat_file(folder: &Path, run: &str, rank: usize) -> PathBuf {
    folder.join(format!("mpm-{run}.alive.{rank}"))
}

/// `MPM_RANK_TIMEOUT` (seconds), else 300: how long a wait on the other ranks may last while they
/// all beat (rank 0 writing a large checkpoint is one).
pub fn rank_timeout(var: &dyn Fn(&str) -> Option<String>) -> Result<Duration> {
    match var("MPM_RANK_TIMEOUT") {
        None => Ok(Duration::from_secs(300)),
        Some(text) => match text.trim().parse::<u64>() {
            Ok(seconds) if seconds > 0 => Ok(Duration::from_secs(seconds)),
            _ => bail!("MPM_RANK_TIMEOUT={text}: give the seconds a wait on the other ranks may last"),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let map: HashMap<String, String> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |name| map.get(name).cloned()
    }

    #[test]
    fn a_second_launch_under_a_running_name_leaves_its_heartbeat_alone() {
        let folder = tempfile::tempdir().unwrap();
        let run = format!("unit-{}-claim", std::process::id());
        let process = Process {
            rank: 1,
            size: 2,
            local_rank: 1,
            one_host: true,
            launcher: "a test",
        };
        let timeout = Duration::from_secs(60);
        let running = Watch::start(&process, folder.path(), &run, timeout).unwrap();
        let err = Watch::start(&process, folder.path(), &run, timeout)
            .err()
            .map(|e| format!("{e:#}"))
            .expect("a second rank 1 of the same run started");
        assert!(
            err.contains("rank 1 of run") && err.contains("MPM_RUN_ID"),
            "{err}"
        );
        let beat = heartbeat_file(folder.path(), &run, 1);
        assert!(
            beat.exists(),
            "the running rank's heartbeat went with the refused launch"
        );
        drop(running);
        assert!(!beat.exists(), "a rank that ends removes its heartbeat");
        // Its name is free again: a later launch under it starts.
        Watch::start(&process, folder.path(), &run, timeout).unwrap();
    }

    #[test]
    fn each_launcher_s_variables_give_the_process_its_place() {
        let ompi = env(&[
            ("OMPI_COMM_WORLD_RANK", "3"),
            ("OMPI_COMM_WORLD_SIZE", "4"),
            ("OMPI_COMM_WORLD_LOCAL_RANK", "1"),
            ("OMPI_COMM_WORLD_LOCAL_SIZE", "2"),
        ]);
        let p = Process::from_env(&ompi).unwrap();
        assert_eq!((p.rank, p.size, p.local_rank, p.one_host), (3, 4, 1, false));
        let slurm = env(&[
            ("SLURM_PROCID", "1"),
            ("SLURM_NTASKS", "2"),
            ("SLURM_LOCALID", "1"),
            ("SLURM_NNODES", "1"),
            ("SLURM_JOB_ID", "77"),
            ("SLURM_STEP_ID", "0"),
        ]);
        let p = Process::from_env(&slurm).unwrap();
        assert_eq!((p.rank, p.size, p.local_rank, p.one_host), (1, 2, 1, true));
        assert_eq!(p.run_name(&slurm).unwrap(), "77-0");
        let two_nodes = env(&[
            ("SLURM_PROCID", "3"),
            ("SLURM_NTASKS", "4"),
            ("SLURM_NNODES", "2"),
        ]);
        assert!(!Process::from_env(&two_nodes).unwrap().one_host);
        let torch = env(&[("RANK", "0"), ("WORLD_SIZE", "2"), ("LOCAL_RANK", "0")]);
        let p = Process::from_env(&torch).unwrap();
        assert_eq!((p.rank, p.size, p.local_rank, p.one_host), (0, 2, 0, true));
        assert!(p.run_name(&torch).unwrap().starts_with("parent-"));
        let named = env(&[("RANK", "0"), ("WORLD_SIZE", "2"), ("MPM_RUN_ID", "a b/c")]);
        assert_eq!(
            Process::from_env(&named).unwrap().run_name(&named).unwrap(),
            "a_b_c"
        );
    }

    #[test]
    fn no_launcher_or_a_bad_rank_is_refused_with_the_fix() {
        let none = Process::from_env(&env(&[])).unwrap_err().to_string();
        assert!(
            none.contains("mpirun -n N") && none.contains("SLURM_PROCID"),
            "{none}"
        );
        let past = Process::from_env(&env(&[("RANK", "2"), ("WORLD_SIZE", "2")]));
        assert!(past.unwrap_err().to_string().contains("rank 2 of a run of 2"));
        let words = Process::from_env(&env(&[("PMI_RANK", "x"), ("PMI_SIZE", "2")]));
        assert!(words.unwrap_err().to_string().contains("PMI_RANK=x"));
        let hosts = env(&[
            ("RANK", "0"),
            ("WORLD_SIZE", "4"),
            ("LOCAL_RANK", "0"),
            ("LOCAL_WORLD_SIZE", "2"),
        ]);
        let p = Process::from_env(&hosts).unwrap();
        let why = p.rendezvous_folder(&hosts).unwrap_err().to_string();
        assert!(why.contains("MPM_RENDEZVOUS"), "{why}");
    }

    #[test]
    fn the_rendezvous_hands_rank_0_s_id_to_a_reader_that_started_first() {
        let dir = tempfile::tempdir().unwrap();
        let file = rendezvous_file(dir.path(), "test");
        let reader = {
            let file = file.clone();
            std::thread::spawn(move || read_id(&file, 128, launch_time(), Duration::from_secs(10)))
        };
        std::thread::sleep(Duration::from_millis(50));
        publish_id(&file, &[7u8; 128]).unwrap();
        assert_eq!(reader.join().unwrap().unwrap(), vec![7u8; 128]);
        // An earlier run's file is not taken: the reader waits, then says what it waited for.
        let later = SystemTime::now() + Duration::from_secs(3600);
        let stale = read_id(&file, 128, later, Duration::from_millis(60)).unwrap_err();
        assert!(stale.to_string().contains("did not publish"), "{stale}");
    }

    #[test]
    fn a_rank_whose_heartbeat_is_gone_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let place = |rank| Process {
            rank,
            size: 2,
            local_rank: rank,
            one_host: true,
            launcher: "test",
        };
        let timeout = Duration::from_secs(5);
        let zero = Watch::start(&place(0), dir.path(), "run", timeout).unwrap();
        let one = Watch::start(&place(1), dir.path(), "run", timeout).unwrap();
        zero.check().unwrap();
        drop(one);
        let why = zero.check().unwrap_err().to_string();
        assert!(why.contains("rank 1 has ended"), "{why}");
    }
}
