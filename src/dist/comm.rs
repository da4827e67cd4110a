//! What the ranks say to each other: grouped point-to-point transfers and an all-gather, the two
//! operations the decomposition needs (NCCL's `ncclGroupStart/Send/Recv/GroupEnd` and
//! `ncclAllGather`). Reductions are built on the all-gather and folded in rank order, so every rank
//! gets the same bits whatever the transport.
//!
//! [`LocalComm`] joins ranks that are threads of one process (the CPU ranks, and the tests in CI).

use anyhow::{anyhow, bail, Result};
use bytemuck::Pod;
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::time::Duration;

pub trait Comm: Send {
    fn rank(&self) -> usize;
    fn size(&self) -> usize;

    /// One group of transfers: each buffer of `sends` goes to its peer, each of `recvs` is filled from
    /// its peer, whose matching send has the same length. Sends and receives of one group never wait
    /// on each other's order, so no two ranks deadlock over it.
    fn exchange(&mut self, sends: &[(usize, &[u8])], recvs: &mut [(usize, &mut [u8])]) -> Result<()>;

    /// Every rank's `mine` (all of one length) into `all`, in rank order.
    fn all_gather(&mut self, mine: &[u8], all: &mut [u8]) -> Result<()>;
}

/// Every rank's `mine` (all of one length), in rank order.
pub fn all_gather<T: Pod>(comm: &mut dyn Comm, mine: &[T]) -> Result<Vec<T>> {
    let mut all = vec![T::zeroed(); mine.len() * comm.size()];
    comm.all_gather(bytemuck::cast_slice(mine), bytemuck::cast_slice_mut(&mut all))?;
    Ok(all)
}

/// The element-wise sum of every rank's `mine`, exact (integers).
pub fn all_sum(comm: &mut dyn Comm, mine: &[u64]) -> Result<Vec<u64>> {
    let all = all_gather(comm, mine)?;
    let mut sum = vec![0u64; mine.len()];
    for chunk in all.chunks(mine.len().max(1)) {
        for (s, v) in sum.iter_mut().zip(chunk) {
            *s += v;
        }
    }
    Ok(sum)
}

/// Whether any rank says `mine`.
pub fn any(comm: &mut dyn Comm, mine: bool) -> Result<bool> {
    Ok(all_sum(comm, &[u64::from(mine)])?[0] > 0)
}

/// How long a thread rank waits for a peer before it calls the peer dead.
pub const LOCAL_TIMEOUT: Duration = Duration::from_secs(300);

/// Ranks that are threads of one process, joined by channels.
pub struct LocalComm {
    rank: usize,
    /// The channel to each other rank (none to itself).
    to: Vec<Option<Sender<Vec<u8>>>>,
    from: Vec<Option<Receiver<Vec<u8>>>>,
    timeout: Duration,
}

impl LocalComm {
    /// `size` ranks, one communicator each, in rank order.
    pub fn group(size: usize) -> Vec<LocalComm> {
        let mut comms: Vec<LocalComm> = (0..size)
            .map(|rank| LocalComm {
                rank,
                to: (0..size).map(|_| None).collect(),
                from: (0..size).map(|_| None).collect(),
                timeout: LOCAL_TIMEOUT,
            })
            .collect();
        for a in 0..size {
            for b in (0..size).filter(|&b| b != a) {
                let (tx, rx) = channel();
                comms[a].to[b] = Some(tx);
                comms[b].from[a] = Some(rx);
            }
        }
        comms
    }

    /// The same group with another patience (the tests' dead-rank check).
    pub fn with_timeout(mut self, timeout: Duration) -> LocalComm {
        self.timeout = timeout;
        self
    }

    fn send(&self, peer: usize, bytes: &[u8]) -> Result<()> {
        let channel = self
            .to
            .get(peer)
            .and_then(Option::as_ref)
            .ok_or_else(|| anyhow!("rank {} has no rank {peer} to send to", self.rank))?;
        // A peer that already stopped has dropped its end; its own error says why.
        channel
            .send(bytes.to_vec())
            .map_err(|_| anyhow!("rank {} could not reach rank {peer}: it stopped", self.rank))
    }

    fn receive(&self, peer: usize, into: &mut [u8]) -> Result<()> {
        let channel = self
            .from
            .get(peer)
            .and_then(Option::as_ref)
            .ok_or_else(|| anyhow!("rank {} has no rank {peer} to receive from", self.rank))?;
        let bytes = channel.recv_timeout(self.timeout).map_err(|e| match e {
            RecvTimeoutError::Timeout => anyhow!(
                "rank {} waited {} s for rank {peer}, which neither sent nor stopped: it hangs",
                self.rank,
                self.timeout.as_secs()
            ),
            RecvTimeoutError::Disconnected => {
                anyhow!("rank {} lost rank {peer}: it stopped", self.rank)
            }
        })?;
        if bytes.len() != into.len() {
            bail!(
                "rank {} expected {} bytes from rank {peer} and got {}: the ranks disagree on the step",
                self.rank,
                into.len(),
                bytes.len()
            );
        }
        into.copy_from_slice(&bytes);
        Ok(())
    }
}

impl Comm for LocalComm {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.to.len()
    }

    fn exchange(&mut self, sends: &[(usize, &[u8])], recvs: &mut [(usize, &mut [u8])]) -> Result<()> {
        // Channels buffer, so every send completes before any receive waits.
        for (peer, bytes) in sends {
            self.send(*peer, bytes)?;
        }
        for (peer, into) in recvs.iter_mut() {
            self.receive(*peer, into)?;
        }
        Ok(())
    }

    fn all_gather(&mut self, mine: &[u8], all: &mut [u8]) -> Result<()> {
        let (n, me) = (mine.len(), self.rank);
        if all.len() != n * self.size() {
            bail!("all_gather: {} bytes for {} ranks of {n}", all.len(), self.size());
        }
        for peer in (0..self.size()).filter(|&p| p != me) {
            self.send(peer, mine)?;
        }
        for peer in 0..self.size() {
            let into = &mut all[peer * n..(peer + 1) * n];
            if peer == me {
                into.copy_from_slice(mine);
            } else {
                self.receive(peer, into)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thread_ranks_exchange_and_gather() {
        let comms = LocalComm::group(3);
        let results: Vec<(Vec<u64>, u32)> = std::thread::scope(|s| {
            let handles: Vec<_> = comms
                .into_iter()
                .map(|mut comm| {
                    s.spawn(move || {
                        let me = comm.rank();
                        let sum = all_sum(&mut comm, &[me as u64, 1]).unwrap();
                        // A ring: send to the next rank, receive from the previous.
                        let (next, prev) = ((me + 1) % 3, (me + 2) % 3);
                        let mut got = [0u8; 4];
                        comm.exchange(&[(next, &(me as u32).to_le_bytes())], &mut [(prev, &mut got)])
                            .unwrap();
                        (sum, u32::from_le_bytes(got))
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for (rank, (sum, got)) in results.into_iter().enumerate() {
            assert_eq!(sum, vec![3, 3]);
            assert_eq!(got as usize, (rank + 2) % 3);
        }
    }

    #[test]
    fn a_rank_that_stops_is_named_not_waited_for() {
        let mut comms = LocalComm::group(2);
        let stopped = comms.pop().unwrap();
        drop(stopped);
        let mut comm = comms.pop().unwrap().with_timeout(Duration::from_millis(200));
        let err = all_sum(&mut comm, &[1]).unwrap_err().to_string();
        assert!(err.contains("rank 1") && err.contains("stopped"), "{err}");
    }
}
