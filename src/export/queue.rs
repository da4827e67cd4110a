//! Worker threads fed by a bounded queue: how an export runs beside the simulation. The simulation
//! hands a frame's data over ([`Workers::submit`]) and steps on; it waits only while the queue is
//! full, which bounds the frames held in memory on a long run. The surface meshes
//! (`--export-surface`) and the USD cache (`--export-usd`) both run on it.

use anyhow::{bail, Result};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// `workers` threads that run `work` on each job handed to them, and what they returned, in the
/// order they finished.
pub struct Workers<J, D> {
    /// What the threads do, for messages and thread names ("surface", "usd").
    what: &'static str,
    /// `None` once closed: the threads then end when the queue is empty.
    jobs: Option<SyncSender<J>>,
    done: Receiver<Result<D>>,
    threads: Vec<JoinHandle<()>>,
    /// Set on the first failure, and on drop: the threads skip what is left.
    stop: Arc<AtomicBool>,
    submitted: u64,
    finished: u64,
    /// How long [`Self::submit`] waited for room in the queue.
    waited: Duration,
}

impl<J: Send + 'static, D: Send + 'static> Workers<J, D> {
    /// Starts `workers` threads (at least one) named `{what}-N`; at most `waiting` more jobs wait
    /// for a free thread before [`Self::submit`] blocks. After the first job that fails, the
    /// threads skip the jobs still queued: its error ends the run.
    pub fn start(
        what: &'static str,
        workers: usize,
        waiting: usize,
        work: impl Fn(J) -> Result<D> + Send + Sync + 'static,
    ) -> Result<Workers<J, D>> {
        let (jobs, receiver) = mpsc::sync_channel::<J>(waiting);
        let (results, done) = mpsc::channel();
        let receiver = Arc::new(Mutex::new(receiver));
        let stop = Arc::new(AtomicBool::new(false));
        let work = Arc::new(work);
        let threads = (0..workers.max(1))
            .map(|i| {
                let (receiver, results, stop, work) =
                    (receiver.clone(), results.clone(), stop.clone(), work.clone());
                std::thread::Builder::new()
                    .name(format!("{what}-{i}"))
                    .spawn(move || loop {
                        // The lock is held only while taking a job (the guard is a temporary).
                        let job = receiver.lock().map(|r| r.recv());
                        let Ok(Ok(job)) = job else { break };
                        if stop.load(Ordering::Relaxed) {
                            continue;
                        }
                        let result = work(job);
                        if result.is_err() {
                            stop.store(true, Ordering::Relaxed);
                        }
                        if results.send(result).is_err() {
                            break;
                        }
                    })
                    .map_err(|e| anyhow::anyhow!("cannot start a {what} worker thread: {e}"))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Workers {
            what,
            jobs: Some(jobs),
            done,
            threads,
            stop,
            submitted: 0,
            finished: 0,
            waited: Duration::ZERO,
        })
    }

    /// Hands a job to the threads, calling `on_done` for each job finished meanwhile. Waits only
    /// while the queue is full. A failure of an earlier job (a full disk) is returned here, so the
    /// run stops at its next exported frame.
    pub fn submit(&mut self, job: J, on_done: &mut dyn FnMut(D)) -> Result<()> {
        self.collect(on_done, false)?;
        let jobs = self.jobs.as_ref().expect("submit after finish");
        let job = match jobs.try_send(job) {
            Ok(()) => None,
            Err(TrySendError::Full(job)) => Some(job),
            Err(TrySendError::Disconnected(_)) => bail!("the {} worker threads ended early", self.what),
        };
        if let Some(job) = job {
            let start = Instant::now();
            let sent = jobs.send(job);
            self.waited += start.elapsed();
            if sent.is_err() {
                // Every thread stopped, which happens only after a failure: report it.
                self.collect(on_done, true)?;
                bail!("the {} worker threads ended early", self.what);
            }
        }
        self.submitted += 1;
        Ok(())
    }

    /// Takes the jobs finished so far, calling `on_done` for each; with `wait`, until every
    /// submitted job is done. The first failure is returned.
    pub fn collect(&mut self, on_done: &mut dyn FnMut(D), wait: bool) -> Result<()> {
        while self.finished < self.submitted {
            let result = if wait {
                match self.done.recv() {
                    Ok(result) => result,
                    Err(_) => bail!("the {} worker threads ended early", self.what),
                }
            } else {
                match self.done.try_recv() {
                    Ok(result) => result,
                    Err(_) => return Ok(()),
                }
            };
            let done = result?;
            self.finished += 1;
            on_done(done);
        }
        Ok(())
    }

    /// Waits for every submitted job, calling `on_done` for each, then ends the threads.
    pub fn finish(mut self, on_done: &mut dyn FnMut(D)) -> Result<()> {
        self.jobs = None;
        self.collect(on_done, true)
    }

    /// Jobs handed over.
    pub fn submitted(&self) -> u64 {
        self.submitted
    }

    /// Jobs handed over and not yet reported done (in a thread's hands or waiting for one).
    pub fn queued(&self) -> u64 {
        self.submitted - self.finished
    }

    /// How long [`Self::submit`] waited for room in the queue, in all.
    pub fn waited(&self) -> Duration {
        self.waited
    }

    /// How many threads there are.
    pub fn threads(&self) -> usize {
        self.threads.len()
    }
}

impl<J, D> Drop for Workers<J, D> {
    /// Without [`Workers::finish`] (the run failed): the threads drop what is queued, finish the
    /// job in hand, and end.
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        self.jobs = None;
        for thread in self.threads.drain(..) {
            let _ = thread.join();
        }
    }
}
