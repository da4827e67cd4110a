//! Worker threads fed by a bounded queue, for the exports whose files take long to build (surface
//! meshes, volumes): the simulation hands an exported frame's particles over and steps on, and
//! waits only when the queue is full, which keeps memory bounded on long runs. A failure on a
//! worker (a full disk) stops the others and is returned at the next hand-over, so the run stops
//! with it.

use anyhow::{bail, Result};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// An export whose files are built on worker threads.
pub trait Export: Send + Sync + 'static {
    /// One frame's input, handed to a worker.
    type Job: Send + 'static;
    /// What one file is, and several, in progress lines: `("surface mesh", "surface meshes")`.
    const NOUN: (&'static str, &'static str);
    /// The short noun of "0.84 s per mesh".
    const SHORT: &'static str;
    /// The worker threads' name, and the export's in messages: `surface`.
    const THREAD: &'static str;
    /// Builds and writes one frame's file, here and now.
    fn export(&self, job: &Self::Job) -> Result<Done>;
}

/// One finished file.
#[derive(Debug, Clone)]
pub struct Done {
    pub frame: u64,
    pub path: PathBuf,
    /// The file's size in the export's own unit (triangles, active voxels).
    pub items: u64,
    /// What the file holds, for the user: `20100 triangles`.
    pub what: String,
    /// Wall time of building the file's content (a reconstruction, grids).
    pub build: Duration,
    /// Wall time of writing the file.
    pub write: Duration,
}

/// Where an export's files stand: counts and times so far.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    /// Files handed to the workers.
    pub submitted: u64,
    /// Files written.
    pub done: u64,
    /// [`Done::items`], summed over the files written.
    pub items: u64,
    /// Summed over the files written.
    pub build: Duration,
    pub write: Duration,
    /// How long the simulation waited for room in the queue.
    pub waited: Duration,
    /// How many worker threads there are.
    pub workers: usize,
    /// [`Export::NOUN`] and [`Export::SHORT`].
    pub noun: (&'static str, &'static str),
    pub short: &'static str,
}

impl Progress {
    fn new<E: Export>() -> Progress {
        Progress {
            submitted: 0,
            done: 0,
            items: 0,
            build: Duration::ZERO,
            write: Duration::ZERO,
            waited: Duration::ZERO,
            workers: 0,
            noun: E::NOUN,
            short: E::SHORT,
        }
    }

    /// Files handed over and not yet written (in a worker's hands or waiting for one).
    pub fn queued(&self) -> u64 {
        self.submitted - self.done
    }

    /// Mean wall time per file (building and writing), s.
    pub fn seconds_per_file(&self) -> f64 {
        if self.done == 0 {
            return 0.0;
        }
        (self.build + self.write).as_secs_f64() / self.done as f64
    }

    /// "3/5 surface meshes written, 2 queued, 0.84 s per mesh".
    pub fn status(&self) -> String {
        format!(
            "{}/{} {} written, {} queued, {:.2} s per {}",
            self.done,
            self.submitted,
            self.noun.1,
            self.queued(),
            self.seconds_per_file(),
            self.short
        )
    }
}

/// An export's worker threads and the bounded queue that feeds them.
pub struct Queue<E: Export> {
    exporter: Arc<E>,
    /// `None` once closed: the workers then end when the queue is empty.
    jobs: Option<SyncSender<E::Job>>,
    done: Receiver<Result<Done>>,
    workers: Vec<JoinHandle<()>>,
    /// Set on the first failure, and on drop: the workers skip what is left.
    stop: Arc<AtomicBool>,
    progress: Progress,
}

impl<E: Export> Queue<E> {
    /// Starts `workers` threads that export the jobs [`Queue::submit`] hands them; at most
    /// `waiting` more jobs wait for a free worker before `submit` blocks.
    pub fn start(exporter: E, workers: usize, waiting: usize) -> Result<Queue<E>> {
        let (jobs, receiver) = mpsc::sync_channel::<E::Job>(waiting);
        let (results, done) = mpsc::channel();
        let receiver = Arc::new(Mutex::new(receiver));
        let stop = Arc::new(AtomicBool::new(false));
        let exporter = Arc::new(exporter);
        let workers = (0..workers.max(1))
            .map(|i| {
                let (receiver, results, stop, exporter) =
                    (receiver.clone(), results.clone(), stop.clone(), exporter.clone());
                std::thread::Builder::new()
                    .name(format!("{}-{i}", E::THREAD))
                    .spawn(move || loop {
                        // The lock is held only while taking a job (the guard is a temporary).
                        let job = receiver.lock().map(|r| r.recv());
                        let Ok(Ok(job)) = job else { break };
                        if stop.load(Ordering::Relaxed) {
                            continue;
                        }
                        let result = exporter.export(&job);
                        if result.is_err() {
                            stop.store(true, Ordering::Relaxed);
                        }
                        if results.send(result).is_err() {
                            break;
                        }
                    })
                    .map_err(|e| anyhow::anyhow!("cannot start a {} worker thread: {e}", E::THREAD))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Queue {
            exporter,
            jobs: Some(jobs),
            done,
            workers,
            stop,
            progress: Progress::new::<E>(),
        })
    }

    pub fn exporter(&self) -> &E {
        &self.exporter
    }

    pub fn progress(&self) -> Progress {
        Progress {
            workers: self.workers.len(),
            ..self.progress
        }
    }

    /// Hands a frame to the workers. Waits only while the queue is full. A failure of an earlier
    /// file (a full disk) is returned here, so the run stops at the next exported frame.
    pub fn submit(&mut self, job: E::Job, on_done: &mut dyn FnMut(&Done, Progress)) -> Result<()> {
        self.collect(on_done, false)?;
        let jobs = self.jobs.as_ref().expect("submit after finish");
        let job = match jobs.try_send(job) {
            Ok(()) => None,
            Err(TrySendError::Full(job)) => Some(job),
            Err(TrySendError::Disconnected(_)) => bail!("the {} worker threads ended early", E::THREAD),
        };
        if let Some(job) = job {
            let start = Instant::now();
            let sent = jobs.send(job);
            self.progress.waited += start.elapsed();
            if sent.is_err() {
                // Every worker stopped, which happens only after a failure: report it.
                self.collect(on_done, true)?;
                bail!("the {} worker threads ended early", E::THREAD);
            }
        }
        self.progress.submitted += 1;
        Ok(())
    }

    /// Takes the files finished so far, calling `on_done` for each; with `wait`, until every
    /// submitted file is done. The first failure is returned.
    pub fn collect(&mut self, on_done: &mut dyn FnMut(&Done, Progress), wait: bool) -> Result<()> {
        while self.progress.done < self.progress.submitted {
            let result = if wait {
                match self.done.recv() {
                    Ok(result) => result,
                    Err(_) => bail!("the {} worker threads ended early", E::THREAD),
                }
            } else {
                match self.done.try_recv() {
                    Ok(result) => result,
                    Err(_) => return Ok(()),
                }
            };
            let file = result?;
            self.progress.done += 1;
            self.progress.items += file.items;
            self.progress.build += file.build;
            self.progress.write += file.write;
            on_done(&file, self.progress());
        }
        Ok(())
    }

    /// Waits for every submitted file, then ends the workers.
    pub fn finish(mut self, on_done: &mut dyn FnMut(&Done, Progress)) -> Result<Progress> {
        self.jobs = None;
        self.collect(on_done, true)?;
        Ok(self.progress())
    }
}

impl<E: Export> Drop for Queue<E> {
    /// Without [`Queue::finish`] (the run failed): the workers drop what is queued, finish the
    /// file in hand, and end.
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        self.jobs = None;
        for worker in self.workers.drain(..) {
            let _ = worker.join();
        }
    }
}
