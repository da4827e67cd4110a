//! Ranks that are processes of one host, joined by Unix sockets: what carries the CPU reference's
//! ranks under `--processes` (NCCL carries the CUDA ranks'), so a machine without a GPU runs the
//! same launch, rendezvous, outputs and failure handling as a run on GPUs.
//!
//! Each pair of ranks shares one stream. A message is its length (8 bytes, so that ranks which
//! disagree on a step's sizes say so rather than read each other's bytes as particles) and then its
//! bytes; the kernel's sockets do the rest, with no protocol of ours beyond that. The sockets live
//! in Linux's abstract namespace under the run's name: no file to clean up, and none left behind by
//! a killed run (a name is free again once its process is gone). Every wait looks at the other
//! processes' heartbeats each second (`launch::Watch`), so a rank that dies or stops is named
//! within seconds, not at the end of the rank timeout.

use super::comm::Comm;
use super::launch::{rank_address, Process, Watch};
use anyhow::{bail, ensure, Context, Result};
use std::io::{ErrorKind, Read, Write};
use std::os::unix::net::UnixStream;
use std::time::{Duration, Instant};

/// How long one read or write waits before the heartbeats are looked at again.
const POLL: Duration = Duration::from_secs(1);

/// The first words a rank sends to a peer it connects to: what it is, who, and the run's size.
const HELLO: u64 = u64::from_le_bytes(*b"mpm-rank");

/// This process's rank, and a stream to each other rank of its run.
pub struct SocketComm {
    rank: usize,
    /// Per rank of the run, the stream to it (none to this one).
    peers: Vec<Option<UnixStream>>,
    /// Holds this rank's name for the run (`Watch::listener`), on which the higher ranks connected.
    watch: Watch,
}

impl SocketComm {
    /// Joins the other processes of run `run`: listens under this rank's name, connects to every
    /// lower rank's and takes a connection from every higher one, waiting up to `wait` for each
    /// (a process may still be making a large scene).
    pub fn join(process: &Process, run: &str, watch: Watch, wait: Duration) -> Result<SocketComm> {
        ensure!(
            process.one_host,
            "the CPU reference's ranks as processes meet over Unix sockets, on one host, and {} \
             says this run of {} processes spans several: run them on one host, or use the CUDA \
             backend across hosts",
            process.launcher,
            process.size
        );
        let (me, size) = (process.rank, process.size);
        let listener = watch.listener();
        let mut peers: Vec<Option<UnixStream>> = (0..size).map(|_| None).collect();
        let deadline = Instant::now() + wait;
        let late = |what: &str| {
            format!(
                "rank {me} of {size} waited {} s for {what}: it failed, or runs under another run \
                 name (MPM_RUN_ID) or on another host; see its output",
                wait.as_secs()
            )
        };
        for (peer, slot) in peers.iter_mut().enumerate().take(me) {
            let stream = loop {
                match UnixStream::connect_addr(&rank_address(run, peer)?) {
                    Ok(stream) => break stream,
                    Err(_) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(20)),
                    Err(e) => return Err(e).context(late(&format!("rank {peer} to listen"))),
                }
            };
            let hello: Vec<u8> = [HELLO, me as u64, size as u64]
                .iter()
                .flat_map(|w| w.to_le_bytes())
                .collect();
            (&stream)
                .write_all(&hello)
                .with_context(|| format!("rank {me} greeting rank {peer}"))?;
            *slot = Some(stream);
        }
        listener
            .set_nonblocking(true)
            .context("polling the rank's socket")?;
        for _ in me + 1..size {
            let stream = loop {
                match listener.accept() {
                    Ok((stream, _)) => break stream,
                    Err(e) if e.kind() == ErrorKind::WouldBlock && Instant::now() < deadline => {
                        std::thread::sleep(Duration::from_millis(20))
                    }
                    Err(e) => return Err(e).context(late("the higher ranks to connect")),
                }
            };
            stream.set_nonblocking(false).context("a rank's stream")?;
            stream.set_read_timeout(Some(wait)).context("a rank's stream")?;
            let mut hello = [0u8; 24];
            (&stream)
                .read_exact(&mut hello)
                .with_context(|| format!("rank {me} reading a higher rank's greeting"))?;
            let word = |i: usize| u64::from_le_bytes(hello[i * 8..i * 8 + 8].try_into().unwrap());
            let (peer, their_size) = (word(1) as usize, word(2) as usize);
            ensure!(
                word(0) == HELLO && peer > me && peer < size && peers[peer].is_none(),
                "rank {me} of run {run}: a connection that is not one of this run's ranks; set \
                 MPM_RUN_ID to a name of this launch's own"
            );
            ensure!(
                their_size == size,
                "rank {peer} says the run has {their_size} processes, rank {me} says {size}: the \
                 launcher's variables disagree"
            );
            peers[peer] = Some(stream);
        }
        for stream in peers.iter().flatten() {
            stream.set_read_timeout(Some(POLL)).context("a rank's stream")?;
            stream.set_write_timeout(Some(POLL)).context("a rank's stream")?;
        }
        Ok(SocketComm {
            rank: me,
            peers,
            watch,
        })
    }

    fn stream(&self, peer: usize) -> Result<&UnixStream> {
        self.peers
            .get(peer)
            .and_then(Option::as_ref)
            .with_context(|| format!("rank {} has no rank {peer} to talk to", self.rank))
    }

    /// Every message of `messages` to `peer`, in order, each after its length.
    fn send(&self, peer: usize, messages: &[&[u8]]) -> Result<()> {
        let stream = self.stream(peer)?;
        for bytes in messages {
            self.write(peer, &(bytes.len() as u64).to_le_bytes(), stream)?;
            self.write(peer, bytes, stream)?;
        }
        Ok(())
    }

    /// The next message from `peer` into `into`, which must be its length.
    fn receive(&self, peer: usize, into: &mut [u8]) -> Result<()> {
        let stream = self.stream(peer)?;
        let mut length = [0u8; 8];
        self.fill(peer, &mut length, stream)?;
        let length = u64::from_le_bytes(length);
        if length != into.len() as u64 {
            bail!(
                "rank {} expected {} bytes from rank {peer} and got {length}: the ranks disagree on \
                 the step",
                self.rank,
                into.len()
            );
        }
        self.fill(peer, into, stream)
    }

    /// All of `into` from `peer`, watching the others while the socket is empty.
    fn fill(&self, peer: usize, into: &mut [u8], stream: &UnixStream) -> Result<()> {
        let mut done = 0;
        let mut since = Instant::now();
        while done < into.len() {
            let mut s = stream;
            match s.read(&mut into[done..]) {
                Ok(0) => bail!("rank {} lost rank {peer}: it stopped", self.rank),
                Ok(n) => (done, since) = (done + n, Instant::now()),
                Err(e) => self.waited(peer, e, since)?,
            }
        }
        Ok(())
    }

    /// All of `bytes` to `peer`, watching the others while the socket is full.
    fn write(&self, peer: usize, mut bytes: &[u8], stream: &UnixStream) -> Result<()> {
        let mut since = Instant::now();
        while !bytes.is_empty() {
            let mut s = stream;
            match s.write(bytes) {
                Ok(0) => bail!("rank {} lost rank {peer}: it stopped", self.rank),
                Ok(n) => (bytes, since) = (&bytes[n..], Instant::now()),
                Err(e) => self.waited(peer, e, since)?,
            }
        }
        Ok(())
    }

    /// After a read or write that did not move a byte: fine where it only timed out and every
    /// process still beats within the rank timeout; else an error naming the peer.
    fn waited(&self, peer: usize, e: std::io::Error, since: Instant) -> Result<()> {
        match e.kind() {
            ErrorKind::Interrupted => Ok(()),
            ErrorKind::WouldBlock | ErrorKind::TimedOut => {
                self.watch.check()?;
                ensure!(
                    since.elapsed() < self.watch.timeout,
                    "rank {} waited {} s for rank {peer}, which beats but neither sent nor read: it \
                     hangs (MPM_RANK_TIMEOUT sets this wait)",
                    self.rank,
                    self.watch.timeout.as_secs()
                );
                Ok(())
            }
            ErrorKind::BrokenPipe | ErrorKind::ConnectionReset | ErrorKind::UnexpectedEof => {
                bail!("rank {} lost rank {peer}: it stopped", self.rank)
            }
            _ => Err(e).with_context(|| format!("rank {} talking to rank {peer}", self.rank)),
        }
    }
}

impl Comm for SocketComm {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.peers.len()
    }

    fn exchange(&mut self, sends: &[(usize, &[u8])], recvs: &mut [(usize, &mut [u8])]) -> Result<()> {
        // Each peer's messages from a thread of their own: two ranks sending each other more than a
        // socket holds must both be reading too.
        let mut by_peer: Vec<Vec<&[u8]>> = vec![Vec::new(); self.size()];
        for (peer, bytes) in sends {
            by_peer
                .get_mut(*peer)
                .with_context(|| format!("rank {} has no rank {peer} to send to", self.rank))?
                .push(bytes);
        }
        let this = &*self;
        std::thread::scope(|s| {
            let sending: Vec<_> = by_peer
                .iter()
                .enumerate()
                .filter(|(_, messages)| !messages.is_empty())
                .map(|(peer, messages)| s.spawn(move || this.send(peer, messages)))
                .collect();
            let received = recvs
                .iter_mut()
                .try_for_each(|(peer, into)| this.receive(*peer, into));
            // A receive's error first: a sender's is often only that the peer stopped.
            let sent: Result<()> = sending
                .into_iter()
                .try_for_each(|s| s.join().unwrap_or_else(|_| bail!("a sending thread panicked")));
            received.and(sent)
        })
    }

    fn all_gather(&mut self, mine: &[u8], all: &mut [u8]) -> Result<()> {
        let (n, me, size) = (mine.len(), self.rank, self.size());
        ensure!(
            all.len() == n * size,
            "all_gather: {} bytes for {size} ranks of {n}",
            all.len()
        );
        if n == 0 {
            return Ok(());
        }
        let sends: Vec<(usize, &[u8])> = (0..size).filter(|&p| p != me).map(|p| (p, mine)).collect();
        let mut recvs: Vec<(usize, &mut [u8])> = all.chunks_mut(n).enumerate().collect();
        recvs.remove(me).1.copy_from_slice(mine);
        self.exchange(&sends, &mut recvs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dist::comm::all_sum;

    /// `size` ranks of run `run` joined over sockets, each on a thread of this process as if it were
    /// a process of its own, running `body`.
    fn on_ranks<T: Send>(size: usize, run: &str, body: impl Fn(SocketComm) -> T + Sync) -> Vec<T> {
        let folder = tempfile::tempdir().unwrap();
        std::thread::scope(|s| {
            let running: Vec<_> = (0..size)
                .map(|rank| {
                    let (folder, body) = (folder.path(), &body);
                    s.spawn(move || {
                        let process = Process {
                            rank,
                            size,
                            local_rank: rank,
                            one_host: true,
                            launcher: "a test",
                        };
                        let watch = Watch::start(&process, folder, run, Duration::from_secs(60)).unwrap();
                        body(SocketComm::join(&process, run, watch, Duration::from_secs(60)).unwrap())
                    })
                })
                .collect();
            running.into_iter().map(|r| r.join().unwrap()).collect()
        })
    }

    #[test]
    fn processes_exchange_more_than_a_socket_holds_and_gather() {
        let run = format!("unit-{}-exchange", std::process::id());
        let results = on_ranks(3, &run, |mut comm| {
            let me = comm.rank();
            // Each rank sends 3 MB to each other rank at once: far past what a socket buffers.
            let mine = vec![me as u8 + 1; 3 << 20];
            let peers: Vec<usize> = (0..3).filter(|&p| p != me).collect();
            let sends: Vec<(usize, &[u8])> = peers.iter().map(|&p| (p, mine.as_slice())).collect();
            let mut got = vec![vec![0u8; 3 << 20]; 2];
            let mut recvs: Vec<(usize, &mut [u8])> = peers
                .iter()
                .copied()
                .zip(got.iter_mut().map(Vec::as_mut_slice))
                .collect();
            comm.exchange(&sends, &mut recvs).unwrap();
            let received: Vec<bool> = peers
                .iter()
                .zip(&got)
                .map(|(&p, g)| g.iter().all(|&b| b == p as u8 + 1))
                .collect();
            (all_sum(&mut comm, &[me as u64, 1]).unwrap(), received)
        });
        for (sum, received) in results {
            assert_eq!(sum, vec![3, 3]);
            assert_eq!(received, vec![true, true]);
        }
    }

    #[test]
    fn ranks_that_disagree_on_a_size_or_stop_are_named() {
        let run = format!("unit-{}-disagree", std::process::id());
        let errors = on_ranks(2, &run, |mut comm| {
            let me = comm.rank();
            let mut into = [0u8; 8];
            let sent = [0u8; 4 + 4];
            // Rank 1 sends 8 bytes where rank 0 expects 8, then 4 where it expects 8.
            let first = match me {
                0 => comm.exchange(&[], &mut [(1, &mut into)]),
                _ => comm.exchange(&[(0, &sent)], &mut []),
            };
            first.unwrap();
            let second = match me {
                0 => comm.exchange(&[], &mut [(1, &mut into)]),
                _ => comm.exchange(&[(0, &sent[..4])], &mut []),
            };
            second.err().map(|e| e.to_string())
        });
        let err = errors[0].clone().unwrap();
        assert!(err.contains("expected 8 bytes from rank 1 and got 4"), "{err}");
        // Rank 1 has ended and dropped its socket: a further wait on it says it stopped.
        let run = format!("unit-{}-stopped", std::process::id());
        let errors = on_ranks(2, &run, |mut comm| match comm.rank() {
            0 => {
                std::thread::sleep(Duration::from_millis(200));
                all_sum(&mut comm, &[1]).err().map(|e| e.to_string())
            }
            _ => None,
        });
        let err = errors[0].clone().unwrap();
        assert!(err.contains("rank 1") && err.contains("stopped"), "{err}");
    }

    #[test]
    fn a_second_launch_under_a_running_name_is_refused_at_once() {
        let run = format!("unit-{}-twice", std::process::id());
        let started = std::time::Instant::now();
        let errors = on_ranks(2, &run, |comm| {
            if comm.rank() != 0 {
                return None;
            }
            // Rank 0 of another launch of the same name, while this one runs: refused as it
            // claims the name, before its heartbeat (launch.rs tests that the running one's stays).
            let folder = tempfile::tempdir().unwrap();
            let process = Process {
                rank: 0,
                size: 2,
                local_rank: 0,
                one_host: true,
                launcher: "a test",
            };
            Watch::start(&process, folder.path(), &run, Duration::from_secs(60))
                .err()
                .map(|e| format!("{e:#}"))
        });
        let err = errors[0].clone().expect("the second rank 0 joined");
        assert!(err.contains("already runs as this rank"), "{err}");
        assert!(
            started.elapsed() < Duration::from_secs(30),
            "refused only after a wait"
        );
    }
}
