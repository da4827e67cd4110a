//! Worker threads fed by a bounded queue: how an export runs beside the simulation. The simulation
//! hands a frame's data over ([`Workers::submit`]) and steps on; it waits only while the queue is
//! full, which bounds the frames held in memory on a long run. Every export of frames runs on it:
//! the surface meshes (`--export-surface`) and the volumes (`--export-volume`) through
//! [`FileQueue`], which counts their files and reports them in one set of lines, the PLY frames
//! (`--export`) and the USD cache (`--export-usd`) with closing lines of their own.

use anyhow::{bail, Result};
use std::path::Path;
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

/// What a [`FileQueue`]'s files are called in its lines.
#[derive(Debug, Clone, Copy)]
pub struct FileWords {
    /// The export's short name: it heads the closing line and names the threads ("surface").
    pub what: &'static str,
    /// The files, one and several, in the progress ("surface mesh", "surface meshes").
    pub files: (&'static str, &'static str),
    /// The same, short, in the times per file and the closing line ("mesh", "meshes").
    pub short: (&'static str, &'static str),
    /// The measure of a file's size that the closing line averages ("triangles").
    pub size: &'static str,
    /// The two stages of each file: its build and its write ("reconstruction", "writing").
    pub stages: [&'static str; 2],
}

/// A file a [`FileQueue`]'s workers finished: what its progress counts.
pub trait FinishedFile {
    /// What this kind of file is called.
    const WORDS: FileWords;
    /// Where it was written.
    fn path(&self) -> &Path;
    /// Its size in the measure of [`FileWords::size`].
    fn size(&self) -> u64;
    /// The wall times of its two stages ([`FileWords::stages`]).
    fn stages(&self) -> [Duration; 2];
    /// What it holds, for the line that reports it: "3944 triangles".
    fn contents(&self) -> String;
}

/// An exporter's worker threads, the bounded queue that feeds them, and the files they finished:
/// `J` the jobs handed over, `D` the files made of them.
pub struct FileQueue<E, J, D> {
    exporter: Arc<E>,
    workers: Workers<J, D>,
    /// The files finished so far, summed.
    progress: FileProgress,
}

impl<E, J, D> FileQueue<E, J, D>
where
    E: Send + Sync + 'static,
    J: Send + 'static,
    D: FinishedFile + Send + 'static,
{
    /// Starts `workers` threads that run `export` on the jobs [`Self::submit`] hands them; at most
    /// `waiting` more jobs wait for a free worker before `submit` blocks.
    pub fn start(
        exporter: E,
        workers: usize,
        waiting: usize,
        export: impl Fn(&E, &J) -> Result<D> + Send + Sync + 'static,
    ) -> Result<FileQueue<E, J, D>> {
        let exporter = Arc::new(exporter);
        let worker = exporter.clone();
        Ok(FileQueue {
            exporter,
            workers: Workers::start(D::WORDS.what, workers, waiting, move |job: J| {
                export(&worker, &job)
            })?,
            progress: FileProgress::new(D::WORDS),
        })
    }

    pub fn exporter(&self) -> &E {
        &self.exporter
    }

    /// The files finished so far, with the queue's own counts (files handed over, the export
    /// thread's wait, threads).
    pub fn progress(&self) -> FileProgress {
        FileProgress {
            submitted: self.workers.submitted(),
            waited: self.workers.waited(),
            workers: self.workers.threads(),
            ..self.progress
        }
    }

    /// Hands a frame to the workers, calling `on_done` for each file finished meanwhile. Waits only
    /// while the queue is full. A failure of an earlier file (a full disk) is returned here, so the
    /// run stops at the next exported frame.
    pub fn submit(&mut self, job: J, on_done: &mut dyn FnMut(&D, FileProgress)) -> Result<()> {
        self.progress = self.progress();
        self.workers.submit(job, &mut self.progress.counting(on_done))
    }

    /// Takes the files finished so far, calling `on_done` for each; with `wait`, until every
    /// submitted file is done. The first failure is returned.
    pub fn collect(&mut self, on_done: &mut dyn FnMut(&D, FileProgress), wait: bool) -> Result<()> {
        self.progress = self.progress();
        self.workers.collect(&mut self.progress.counting(on_done), wait)
    }

    /// Waits for every submitted file, calling `on_done` for each, then ends the workers.
    pub fn finish(mut self, on_done: &mut dyn FnMut(&D, FileProgress)) -> Result<FileProgress> {
        self.progress = self.progress();
        self.workers.finish(&mut self.progress.counting(on_done))?;
        Ok(self.progress)
    }
}

/// Where a [`FileQueue`]'s files stand: counts and times so far.
#[derive(Debug, Clone, Copy)]
pub struct FileProgress {
    words: FileWords,
    /// Files handed to the workers.
    submitted: u64,
    /// Files written, their sizes and the wall times of their stages, summed.
    done: u64,
    size: u64,
    stages: [Duration; 2],
    /// How long the export thread waited for room in the queue.
    waited: Duration,
    /// How many worker threads there are.
    workers: usize,
}

impl FileProgress {
    fn new(words: FileWords) -> FileProgress {
        FileProgress {
            words,
            submitted: 0,
            done: 0,
            size: 0,
            stages: [Duration::ZERO; 2],
            waited: Duration::ZERO,
            workers: 0,
        }
    }

    /// Files handed over and not yet written (in a worker's hands or waiting for one).
    pub fn queued(&self) -> u64 {
        self.submitted - self.done
    }

    /// Mean wall time per file (both stages), s.
    fn seconds_per_file(&self) -> f64 {
        if self.done == 0 {
            return 0.0;
        }
        (self.stages[0] + self.stages[1]).as_secs_f64() / self.done as f64
    }

    /// "3/5 surface meshes written, 2 queued, 0.84 s per mesh".
    pub fn status(&self) -> String {
        format!(
            "{}/{} {} written, {} queued, {:.2} s per {}",
            self.done,
            self.submitted,
            self.words.files.1,
            self.queued(),
            self.seconds_per_file(),
            self.words.short.0
        )
    }

    /// The closing line of a run's files, `files` where they went, `after_last_frame` the wait for
    /// the last ones: "surface: 12 meshes (obj in out/), 51234 triangles on average, 0.84 s per mesh
    /// (reconstruction 0.80 s, writing 0.04 s) on 2 worker threads; the export thread waited 0.00 s
    /// for the queue, then 1.20 s for the last meshes".
    pub fn summary(&self, files: &str, after_last_frame: Duration) -> String {
        let FileWords {
            what,
            short: (one, several),
            size,
            stages: [first, second],
            ..
        } = self.words;
        let per = |d: Duration| d.as_secs_f64() / self.done.max(1) as f64;
        let [build, write] = self.stages;
        format!(
            "{what}: {} ({files}), {} {size} on average, {:.3} s per {one} ({first} {:.3} s, {second} \
             {:.3} s) on {} worker threads; the export thread waited {:.2} s for the queue, then {:.2} s \
             for the last {several}",
            crate::text::count(self.done, one, several),
            self.size / self.done.max(1),
            per(build + write),
            per(build),
            per(write),
            self.workers,
            self.waited.as_secs_f64(),
            after_last_frame.as_secs_f64(),
        )
    }

    /// What a [`Workers`] calls with each file finished: counts it, then hands it to `on_done` with
    /// the counts so far.
    fn counting<'a, D: FinishedFile>(
        &'a mut self,
        on_done: &'a mut dyn FnMut(&D, FileProgress),
    ) -> impl FnMut(D) + 'a {
        move |file| {
            self.done += 1;
            self.size += file.size();
            let [build, write] = file.stages();
            self.stages[0] += build;
            self.stages[1] += write;
            on_done(&file, *self);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::surface::MeshDone;
    use crate::export::volume::VolumeDone;

    /// The progress of a queue of 3 files on 2 threads, which waited 10 ms for room, once `files`
    /// are written.
    fn counted<D: FinishedFile>(files: impl IntoIterator<Item = D>) -> FileProgress {
        let mut progress = FileProgress {
            submitted: 3,
            waited: Duration::from_millis(10),
            workers: 2,
            ..FileProgress::new(D::WORDS)
        };
        let mut report = |_: &D, _| {};
        files.into_iter().for_each(progress.counting(&mut report));
        progress
    }

    /// Each kind's words and measures stand where the lines of its own queue had them (the tests
    /// of `mpm run` check only the closing lines' starts).
    #[test]
    fn meshes_and_volumes_are_reported_in_their_own_words() {
        let ms = Duration::from_millis;
        let mesh = |triangles| MeshDone {
            frame: 0,
            path: "out/surface_000000.obj".into(),
            triangles,
            reconstruct: ms(300),
            write: ms(100),
        };
        assert_eq!(mesh(3944).contents(), "3944 triangles");
        let meshes = counted([mesh(100), mesh(300)]);
        assert_eq!(
            meshes.status(),
            "2/3 surface meshes written, 1 queued, 0.40 s per mesh"
        );
        assert_eq!(
            meshes.summary("obj in out", ms(1200)),
            "surface: 2 meshes (obj in out), 200 triangles on average, 0.400 s per mesh \
             (reconstruction 0.300 s, writing 0.100 s) on 2 worker threads; the export thread waited \
             0.01 s for the queue, then 1.20 s for the last meshes"
        );

        let volume = VolumeDone {
            frame: 0,
            path: "out/volume_000000.vdb".into(),
            band: 8432,
            liquid: 9193,
            build: ms(4500),
            write: ms(140),
        };
        assert_eq!(volume.contents(), "8432 voxels in the band, 9193 in the liquid");
        let volumes = counted([volume]);
        assert_eq!(
            volumes.status(),
            "1/3 volumes written, 2 queued, 4.64 s per volume"
        );
        assert_eq!(
            volumes.summary("vdb in out", ms(2720)),
            "volume: 1 volume (vdb in out), 17625 active voxels on average, 4.640 s per volume \
             (grids 4.500 s, writing 0.140 s) on 2 worker threads; the export thread waited 0.01 s \
             for the queue, then 2.72 s for the last volumes"
        );
    }
}
