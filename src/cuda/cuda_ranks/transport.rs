//! What joins the ranks of a run (the parent module's `Transport`): what carries their halos and
//! particles, gathers the host's words from every rank and reduces their step counters, and how the
//! host waits on them. Three joins, one per way the ranks can lie:
//!
//! | transport | ranks | carries | the host's words | waits |
//! |---|---|---|---|---|
//! | [`DeviceCopies`] | every rank on one GPU (`--ranks`) | a copy on the receiver's stream, ordered by stream joins | already here | each stream |
//! | [`NcclInProcess`] | a rank per GPU of this process (`--gpus`) | NCCL's send and receive, every rank's posted in one group | already here | each stream |
//! | [`NcclPerProcess`] | a process per rank (`--processes`) | NCCL's send and receive | NCCL's all-gather | each stream, watching the others' heartbeats |
//!
//! Nothing writes into another rank's memory, so GPUs need no peer access. The CPU ranks' twin is
//! `dist::comm::Comm` (threads joined by channels, processes by sockets).

use super::{Link, Run};
use crate::cuda::halo::{Exchange, HaloBuffers};
use crate::cuda::solver::CudaSolver;
use crate::dist::launch::Watch;
use crate::dist::nccl::{Comm, DataType, Reduction};
use crate::sim::Params;
use anyhow::{bail, Context, Result};
use cudarc::driver::{sys, DevicePtr};
use std::time::{Duration, Instant};

/// What joins a run's ranks; `solvers` are always this process's ranks, the first of them the
/// run's rank `first` (`CudaRanks::first`).
pub(super) trait Transport: Send {
    /// How the ranks are joined, after the device's `name`, for `ranks` ranks.
    fn joined(&self, name: &str, ranks: usize, first: usize) -> String;

    /// Whether this process drives every rank of the run.
    fn in_one_process(&self) -> bool {
        true
    }

    /// Whether rank 0 reads every rank's particles where they lie (they share its GPU), rather than
    /// having them carried to it.
    fn reads_in_place(&self) -> bool {
        false
    }

    /// Carries each link's packed send buffer (`halos`, per rank of this process) to the
    /// neighbour's receive buffer, after the packing and before the unpacking in stream order.
    fn carry_halos(
        &self,
        solvers: &[CudaSolver],
        halos: &mut [HaloBuffers],
        links: &[Link],
        what: Exchange,
    ) -> Result<()>;

    /// Carries each run of particles from its sender's set to its receiver's (this process posting
    /// its ranks' ends of them).
    fn carry_particles(&self, solvers: &[CudaSolver], first: usize, runs: &[Run]) -> Result<()>;

    /// Every rank's `mine` (one list per rank of this process, of one length on every rank), on
    /// every process, in rank order: already here where this process drives every rank.
    fn gather_words(&self, _: &[CudaSolver], _first: usize, mine: Vec<Vec<u64>>) -> Result<Vec<Vec<u64>>> {
        Ok(mine)
    }

    /// Each rank's step counters reduced over every rank in place, in stream order, where the
    /// ranks' copies are not merged on one host (`StepExtremes::merge`).
    fn reduce_counters(&self, _solvers: &[CudaSolver]) -> Result<()> {
        Ok(())
    }

    /// The host waits for every rank of this process.
    fn wait_all(&self, solvers: &[CudaSolver]) -> Result<()> {
        wait_for(solvers)
    }

    /// Waits for this process's ranks before a download or an event wait of its own, where their
    /// streams hold transfers from other processes (which a plain wait could wait on forever).
    fn wait_watched(&self, _solvers: &[CudaSolver]) -> Result<()> {
        Ok(())
    }

    /// Polls `done` until it says so.
    fn watch_until(&self, done: &mut dyn FnMut() -> Result<bool>) -> Result<()> {
        while !done()? {
            std::hint::spin_loop();
        }
        Ok(())
    }
}

/// Every rank on one GPU: a device copy into the receiver's buffer.
pub(super) struct DeviceCopies;

/// A rank per GPU of this process: one NCCL communicator per rank (its `rank` the run's), every
/// rank's transfers posted in one group by the one thread that drives them.
pub(super) struct NcclInProcess {
    pub comms: Vec<Comm>,
}

/// This process's one rank of a run of a process per rank: its NCCL communicator, and the other
/// processes' heartbeats, which every wait on them watches.
pub(super) struct NcclPerProcess {
    /// Taken only by `drop`.
    comm: Option<Comm>,
    watch: Watch,
    /// The run's rank of this process.
    rank: usize,
}

impl NcclPerProcess {
    pub fn new(comm: Comm, watch: Watch) -> NcclPerProcess {
        NcclPerProcess {
            rank: comm.rank,
            comm: Some(comm),
            watch,
        }
    }
}

impl Transport for DeviceCopies {
    fn joined(&self, name: &str, ranks: usize, _first: usize) -> String {
        format!("{name}, {ranks} ranks")
    }

    fn reads_in_place(&self) -> bool {
        true
    }

    /// A copy on the receiver's stream once the sender has packed; the sender's next packing waits
    /// for the copy, by stream order, not by the host.
    fn carry_halos(
        &self,
        solvers: &[CudaSolver],
        halos: &mut [HaloBuffers],
        links: &[Link],
        what: Exchange,
    ) -> Result<()> {
        let params = *solvers[0].params();
        for link in links {
            let (words, _) = link.words(what, &params);
            if words == 0 {
                continue;
            }
            let (from, to) = pair(halos, link.rank, link.neighbour);
            let src = from.send[link.side as usize].slice(..words);
            let mut dst = to.recv[link.side.opposite() as usize].slice_mut(..words);
            let (sender, receiver) = (solvers[link.rank].stream(), solvers[link.neighbour].stream());
            receiver
                .join(sender)
                .context("ordering a halo's copy after its packing")?;
            receiver
                .memcpy_dtod(&src, &mut dst)
                .context("carrying a halo between ranks")?;
            sender
                .join(receiver)
                .context("ordering a halo's packing after its copy")?;
        }
        Ok(())
    }

    /// A copy of each array on the receiver's stream after the sender's work.
    fn carry_particles(&self, solvers: &[CudaSolver], _first: usize, runs: &[Run]) -> Result<()> {
        for run in runs {
            let (Some((from, sent)), Some((to, landed))) = (&run.sent, &run.landed) else {
                bail!(
                    "a run of particles from rank {} to rank {} lacks an end",
                    run.from,
                    run.to
                );
            };
            let (sender, receiver) = (solvers[run.from].stream(), solvers[run.to].stream());
            receiver
                .join(sender)
                .context("ordering a particle copy after its packing")?;
            let pieces = from.segments(sender, sent.clone())?;
            let into = to.segments(receiver, landed.clone())?;
            for (&(src, words), &(dst, _)) in pieces.iter().zip(&into) {
                // SAFETY: both ranges lie in live buffers of this device (`segments` checked the
                // places), of equal lengths as runs of one length.
                unsafe {
                    cudarc::driver::result::memcpy_dtod_async(dst, src, 4 * words, receiver.cu_stream())
                }
                .context("copying particles between ranks")?;
            }
            sender
                .join(receiver)
                .context("ordering a sender's next work after its copy")?;
        }
        Ok(())
    }
}

impl Transport for NcclInProcess {
    fn joined(&self, name: &str, ranks: usize, _first: usize) -> String {
        format!("{ranks} x {name}, a rank each (NCCL)")
    }

    fn carry_halos(
        &self,
        solvers: &[CudaSolver],
        halos: &mut [HaloBuffers],
        links: &[Link],
        what: Exchange,
    ) -> Result<()> {
        nccl_carry_halos(&self.comms, solvers, halos, links, what)
    }

    fn carry_particles(&self, solvers: &[CudaSolver], first: usize, runs: &[Run]) -> Result<()> {
        nccl_carry_particles(&self.comms, solvers, first, runs)
    }
}

impl Transport for NcclPerProcess {
    fn joined(&self, name: &str, ranks: usize, first: usize) -> String {
        format!("{name}, rank {first} of {ranks}, a process each (NCCL)")
    }

    fn in_one_process(&self) -> bool {
        false
    }

    fn carry_halos(
        &self,
        solvers: &[CudaSolver],
        halos: &mut [HaloBuffers],
        links: &[Link],
        what: Exchange,
    ) -> Result<()> {
        nccl_carry_halos(self.comm.as_slice(), solvers, halos, links, what)
    }

    fn carry_particles(&self, solvers: &[CudaSolver], first: usize, runs: &[Run]) -> Result<()> {
        nccl_carry_particles(self.comm.as_slice(), solvers, first, runs)
    }

    /// NCCL's all-gather on this rank's stream, waited for while watching the others.
    fn gather_words(
        &self,
        solvers: &[CudaSolver],
        first: usize,
        mine: Vec<Vec<u64>>,
    ) -> Result<Vec<Vec<u64>>> {
        let comm = self.comm.as_ref().context("a communicator already aborted")?;
        let (solver, len, ranks) = (&solvers[0], mine[0].len(), comm.size);
        let stream = solver.stream();
        let mut all = stream
            .alloc_zeros::<u64>(len * ranks)
            .context("allocating the gathered words")?;
        stream
            .memcpy_htod(&mine[0], &mut all.slice_mut(first * len..(first + 1) * len))
            .context("uploading words to gather")?;
        {
            let (base, _) = all.device_ptr(stream);
            let at = |r: usize| base + (r * len * std::mem::size_of::<u64>()) as u64;
            // SAFETY: `all` holds `len` words per rank, this rank's at its place (NCCL's in-place
            // gather), alive until the waits below; every rank gathers the same length.
            unsafe {
                comm.all_gather((at(first), base), len, DataType::U64, stream.cu_stream().cast())?;
            }
        }
        self.wait_all(solvers)?;
        let words = solver.download(&all)?;
        Ok(words.chunks(len).map(<[u64]>::to_vec).collect())
    }

    /// The largest density, speed and signal speed, the fixed-point overflows and backstop pushes
    /// summed, as `StepExtremes::merge` joins them on one host. The binned pipeline's words (a
    /// rebin asked for, tile misses) stay each rank's own.
    fn reduce_counters(&self, solvers: &[CudaSolver]) -> Result<()> {
        // (first word, words, reduction) of the eight u32 words (`StepCounters`, contract/items.rs).
        const REDUCED: [(u64, usize, Reduction); 4] = [
            (0, 2, Reduction::Max),
            (2, 1, Reduction::Sum),
            (3, 1, Reduction::Max),
            (6, 1, Reduction::Sum),
        ];
        let comm = self.comm.as_ref().context("a communicator already aborted")?;
        let solver = &solvers[0];
        comm.nccl().group(|| {
            let stream = solver.stream();
            let base = solver.step_counters_at();
            for (first, words, op) in REDUCED {
                let at = base + 4 * first;
                // SAFETY: the counters are eight u32 words on this rank's device, alive with the
                // solver; every rank reduces the same words in the same order.
                unsafe {
                    comm.all_reduce((at, at), words, DataType::U32, op, stream.cu_stream().cast())?;
                }
            }
            Ok(())
        })
    }

    /// A transfer from a rank that died never ends: each stream is polled while the others'
    /// heartbeats are watched.
    fn wait_all(&self, solvers: &[CudaSolver]) -> Result<()> {
        for solver in solvers {
            // SAFETY: queries a live stream of this process.
            self.watch_until(
                &mut || match unsafe { sys::cuStreamQuery(solver.stream().cu_stream()) } {
                    sys::CUresult::CUDA_SUCCESS => Ok(true),
                    sys::CUresult::CUDA_ERROR_NOT_READY => Ok(false),
                    error => bail!("its GPU failed while waiting on the other ranks: {error:?}"),
                },
            )?;
        }
        Ok(())
    }

    fn wait_watched(&self, solvers: &[CudaSolver]) -> Result<()> {
        self.wait_all(solvers)
    }

    /// Polls `done`, looking at the other processes' heartbeats every second; a rank gone or
    /// silent, a wait past `MPM_RANK_TIMEOUT`, or an error of `done` fails it, naming this rank.
    fn watch_until(&self, done: &mut dyn FnMut() -> Result<bool>) -> Result<()> {
        let start = Instant::now();
        let mut next_look = Duration::from_secs(1);
        let failed = |why: anyhow::Error| why.context(format!("rank {}", self.rank));
        loop {
            if done().map_err(failed)? {
                return Ok(());
            }
            let waited = start.elapsed();
            if waited > next_look {
                next_look += Duration::from_secs(1);
                self.watch.check().map_err(failed)?;
                if waited > self.watch.timeout {
                    return Err(failed(anyhow::anyhow!(
                        "waited {} s on the other ranks, which all still run: one of them hangs \
                         (MPM_RANK_TIMEOUT sets the limit)",
                        waited.as_secs()
                    )));
                }
            }
            // A substep's wait is a fraction of a millisecond: spin through it, as the driver's own
            // waits do (yielding the thread instead measured the same, BENCHMARKS.md M29); a long
            // one (rank 0 writing a checkpoint) sleeps between looks.
            if waited > Duration::from_millis(20) {
                std::thread::sleep(Duration::from_micros(200));
            } else {
                std::hint::spin_loop();
            }
        }
    }
}

impl Drop for NcclPerProcess {
    /// Aborted, always: this process may be dropped on an error the others do not share, and a
    /// destroy would wait for the transfers in flight, which a rank that stopped never completes.
    fn drop(&mut self) {
        if let Some(comm) = self.comm.take() {
            let _ = comm.abort();
        }
    }
}

/// NCCL's sends and receives of each link's halo, on each rank's stream after its packing and
/// before its unpacking; `comms` are this process's ranks', in the order of `solvers`.
fn nccl_carry_halos(
    comms: &[Comm],
    solvers: &[CudaSolver],
    halos: &[HaloBuffers],
    links: &[Link],
    what: Exchange,
) -> Result<()> {
    let params: Params = *solvers[0].params();
    comms[0].nccl().group(|| {
        for (comm, (solver, halo)) in comms.iter().zip(solvers.iter().zip(halos)) {
            let stream = solver.stream();
            let mut sends = Vec::new();
            let mut recvs = Vec::new();
            // The pointers stay valid: the buffers live as long as the ranks.
            for link in links.iter().filter(|link| link.rank == comm.rank) {
                let (send_words, recv_words) = link.words(what, &params);
                let side = link.side as usize;
                let (send, _) = halo.send[side].device_ptr(stream);
                let (recv, _) = halo.recv[side].device_ptr(stream);
                // An end without planes (`CudaRanks::carry_old_scatter`'s one-way transfers) posts
                // nothing; its peer knows the same.
                if send_words > 0 {
                    sends.push((link.neighbour, send, send_words));
                }
                if recv_words > 0 {
                    recvs.push((link.neighbour, recv, recv_words));
                }
            }
            // SAFETY: each buffer holds a block of planes of packed sums, more than either count;
            // the neighbour posts the matching receive and send in this group, from its own side of
            // the same link.
            unsafe {
                comm.send_recv(&sends, &recvs, DataType::U32, stream.cu_stream().cast())?;
            }
        }
        Ok(())
    })
}

/// NCCL's sends and receives of each array of each run, this process posting its ranks' ends.
fn nccl_carry_particles(comms: &[Comm], solvers: &[CudaSolver], first: usize, runs: &[Run]) -> Result<()> {
    comms[0].nccl().group(|| {
        for comm in comms {
            let stream = solvers[comm.rank - first].stream();
            let mut sends = Vec::new();
            let mut recvs = Vec::new();
            for run in runs {
                if let (Some((from, places)), true) = (&run.sent, run.from == comm.rank) {
                    let pieces = from.segments(stream, places.clone())?;
                    sends.extend(pieces.into_iter().map(|(at, words)| (run.to, at, words)));
                }
                if let (Some((to, places)), true) = (&run.landed, run.to == comm.rank) {
                    let pieces = to.segments(stream, places.clone())?;
                    recvs.extend(pieces.into_iter().map(|(at, words)| (run.from, at, words)));
                }
            }
            // SAFETY: `segments` checked every range against its set, which outlives the
            // transfers (the caller waits for them); the other end posts the same runs' ranges, of
            // the same lengths, in the same order.
            unsafe {
                comm.send_recv(&sends, &recvs, DataType::U32, stream.cu_stream().cast())?;
            }
        }
        Ok(())
    })
}

/// The host waits for every rank's stream.
fn wait_for(solvers: &[CudaSolver]) -> Result<()> {
    for solver in solvers {
        solver
            .stream()
            .synchronize()
            .context("waiting for a rank (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
    }
    Ok(())
}

/// Two distinct ranks' halo buffers, one to read and one to write.
fn pair(halos: &mut [HaloBuffers], from: usize, to: usize) -> (&HaloBuffers, &mut HaloBuffers) {
    if from < to {
        let (low, high) = halos.split_at_mut(to);
        (&low[from], &mut high[0])
    } else {
        let (low, high) = halos.split_at_mut(from);
        (&high[0], &mut low[to])
    }
}
