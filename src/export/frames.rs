//! The exports of a run's frames, off the stepping thread: what `mpm run` and the viewer hand each
//! exported frame to. The stepping thread only starts the particles' copy to the host
//! (`Solver::snapshot_particles`: on the GPU an asynchronous copy into pinned memory) and hands it,
//! with the frame's header and the moving colliders' poses, to the export thread; that thread waits
//! for the copy, puts the particles in slot order and feeds the PLY, surface, volume and USD queues,
//! each with writer threads of its own. The queues hold up to [`QUEUE_BUDGET`] of frames, so a slow
//! writer (a volume takes seconds) costs the simulation nothing until they fill; then the
//! simulation waits for room, which bounds the memory held, and the closing lines say how long.

use super::bodies::BodyExporter;
use super::ply::{PlyExporter, PlyJob, PlyQueue};
use super::queue::{FileProgress, FileQueue, FinishedFile};
use super::surface::{SurfaceExporter, SurfaceJob, SurfaceQueue};
use super::usd::{Pose, UsdCache, UsdFrame, UsdQueue};
use super::volume::{VolumeExporter, VolumeJob, VolumeQueue};
use crate::sim::{ParticleSnapshot, Scene, Simulation};
use anyhow::{anyhow, Result};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The surface meshes' worker threads (each also runs its reconstruction on rayon's pool: two keep
/// the pool busy while one of them writes its file).
pub const SURFACE_WORKERS: usize = 2;
/// The volumes' worker threads, as the surfaces'.
pub const VOLUME_WORKERS: usize = 2;
/// Host memory the frames waiting in the exports' queues may hold, each export's queue its share:
/// the simulation steps on while a slow writer (a volume takes seconds) works through them, and
/// waits only when they are full. A quarter of the available memory where that is less.
pub const QUEUE_BUDGET: u64 = 2 << 30;
/// The queues' bounds: at least two frames wait, whatever their size; at most this many.
const QUEUE_FRAMES: std::ops::RangeInclusive<usize> = 2..=240;
/// How often the export thread, waiting for a frame, reports the meshes, volumes and layers
/// finished meanwhile.
const POLL: Duration = Duration::from_millis(100);

/// What a run exports per frame (each `None` where not asked for).
#[derive(Default)]
pub struct FrameExportSet {
    pub ply: Option<PlyExporter>,
    pub surface: Option<SurfaceExporter>,
    pub volume: Option<VolumeExporter>,
    pub usd: Option<Arc<UsdCache>>,
}

impl FrameExportSet {
    pub fn is_empty(&self) -> bool {
        self.ply.is_none() && self.surface.is_none() && self.volume.is_none() && self.usd.is_none()
    }
}

/// Every export of a run's frames that a command was asked for, made and checked before the first
/// step (`mpm run` and `mpm view` build it from the same flags): the frames' exports, which go
/// through [`FrameExports`], and the rigid bodies', which the stepping thread writes itself (a few
/// small files a frame).
#[derive(Default)]
pub struct Exports {
    pub frames: FrameExportSet,
    pub bodies: Option<BodyExporter>,
}

impl Exports {
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty() && self.bodies.is_none()
    }

    /// What making the exports removed, a line each: an earlier run's files (`--overwrite`) and a
    /// killed run's unfinished ones.
    pub fn removed_notes(&self) -> Vec<String> {
        let f = &self.frames;
        [
            f.ply.as_ref().and_then(PlyExporter::removed_note),
            f.surface.as_ref().and_then(SurfaceExporter::removed_note),
            f.volume.as_ref().and_then(VolumeExporter::removed_note),
            self.bodies.as_ref().and_then(BodyExporter::removed_note),
            f.usd.as_deref().and_then(UsdCache::removed_note),
        ]
        .into_iter()
        .flatten()
        .collect()
    }

    /// The surface meshes' and volumes' settings, as the user is told them before the first frame.
    pub fn settings_lines(&self) -> Vec<String> {
        let surface = self.frames.surface.as_ref().map(|surface| {
            format!(
                "surface meshes: {}; {}",
                surface.destination(),
                surface.settings().describe()
            )
        });
        let volume = self.frames.volume.as_ref().map(|volume| {
            format!(
                "volumes: {} into {}; {}",
                volume.format().extension(),
                volume.dir().display(),
                volume.settings().describe()
            )
        });
        [surface, volume].into_iter().flatten().collect()
    }

    /// The short names of what is exported, for a status line: `ply`, `surface` (mesh files),
    /// `volume`, `usd`, `bodies`.
    pub fn kinds(&self) -> Vec<&'static str> {
        let f = &self.frames;
        [
            f.ply.as_ref().map(|_| "ply"),
            // Meshes reconstructed for the USD stage alone are the stage's.
            f.surface
                .as_ref()
                .and_then(SurfaceExporter::dir)
                .map(|_| "surface"),
            f.volume.as_ref().map(|_| "volume"),
            f.usd.as_ref().map(|_| "usd"),
            self.bodies.as_ref().map(|_| "bodies"),
        ]
        .into_iter()
        .flatten()
        .collect()
    }
}

/// Where the export thread reports meshes, volumes and layers as they finish: the progress bar's
/// message on a terminal, else a line each on stderr.
#[derive(Clone)]
pub enum ExportProgress {
    Bar(indicatif::ProgressBar),
    Lines,
}

/// A frame on its way to the export thread.
struct FrameToExport {
    frame: u64,
    comment: String,
    particles: ParticleSnapshot,
    /// The moving colliders' poses, where the USD stage wants this frame.
    poses: Option<Vec<Pose>>,
}

/// The export thread, from the stepping thread's side.
pub struct FrameExports {
    frames: Option<SyncSender<FrameToExport>>,
    thread: Option<JoinHandle<Result<Vec<String>>>>,
    /// `--every` of each export: a frame is handed over where one of them wants it.
    every: Vec<u64>,
    usd: Option<Arc<UsdCache>>,
    handed: u64,
    /// Whether the backend's snapshots were asynchronous (on their way when handed over).
    asynchronous: bool,
    /// Time the stepping thread spent starting the particles' copies (and the header, the poses).
    starting: Duration,
    /// Time it waited for the export thread to take a frame (the writers a frame behind).
    waited: Duration,
}

impl FrameExports {
    /// Starts the export thread and the queues' workers for a run of `scene` (its material table
    /// heads the PLY files; its particle slots size the queues' frames); `None` where nothing is
    /// exported.
    pub fn start(
        set: FrameExportSet,
        scene: &Scene,
        progress: ExportProgress,
    ) -> Result<Option<FrameExports>> {
        if set.is_empty() {
            return Ok(None);
        }
        let FrameExportSet {
            ply,
            surface,
            volume,
            usd,
        } = set;
        let every = [
            ply.as_ref().map(PlyExporter::every),
            surface.as_ref().map(SurfaceExporter::every),
            volume.as_ref().map(VolumeExporter::every),
            usd.as_ref().map(|u| u.every()),
        ]
        .into_iter()
        .flatten()
        .collect();
        let queues = [ply.is_some(), surface.is_some(), volume.is_some(), usd.is_some()];
        let share = queue_budget() / queues.iter().filter(|&&q| q).count().max(1) as u64;
        // A frame's bytes in each queue: the live particles without C (PLY, USD), the positions
        // (surface), and the velocities where asked (volume).
        let frame = |bytes_per_particle: usize| queue_frames(share, scene.slots() * bytes_per_particle);
        let whole = 12 + 12 + 4 + 2 + if scene.has_deformation() { 40 } else { 0 };
        let materials = Arc::new(scene.materials.clone());
        let writer = ExportThread {
            ply: ply
                .map(|exporter| PlyQueue::start(exporter, materials.clone(), frame(whole)))
                .transpose()?,
            surface: surface
                .map(|exporter| {
                    FileQueue::start(exporter, SURFACE_WORKERS, frame(12), SurfaceExporter::export)
                })
                .transpose()?,
            volume: volume
                .map(|exporter| {
                    let bytes = if exporter.settings().velocity { 24 } else { 12 };
                    FileQueue::start(exporter, VOLUME_WORKERS, frame(bytes), VolumeExporter::export)
                })
                .transpose()?,
            usd: usd
                .clone()
                .map(|cache| UsdQueue::start(cache, frame(whole)))
                .transpose()?,
            progress,
            frames: 0,
            particles: Duration::ZERO,
        };
        // One frame waits here while the thread writes another: both hold a staging copy
        // (`SNAPSHOTS_IN_FLIGHT`) until the thread has read them.
        let (frames, received) = sync_channel(1);
        let thread = std::thread::Builder::new()
            .name("export".into())
            .spawn(move || writer.run(received))
            .map_err(|e| anyhow!("cannot start the export thread: {e}"))?;
        Ok(Some(FrameExports {
            frames: Some(frames),
            thread: Some(thread),
            every,
            usd,
            handed: 0,
            asynchronous: false,
            starting: Duration::ZERO,
            waited: Duration::ZERO,
        }))
    }

    pub fn wants(&self, frame: u64) -> bool {
        self.every.iter().any(|&every| frame % every == 0)
    }

    /// Hands the simulation's current frame to the export thread where an export wants it. An
    /// earlier frame's failure (a full disk) is returned here, so the run stops at its next
    /// exported frame.
    pub fn submit(&mut self, sim: &mut Simulation) -> Result<bool> {
        let frame = sim.frame();
        if !self.wants(frame) {
            return Ok(false);
        }
        let start = Instant::now();
        let job = FrameToExport {
            frame,
            comment: frame_comment(sim),
            poses: self.usd.as_ref().filter(|u| u.wants(frame)).map(|u| u.poses(sim)),
            particles: sim.solver_mut().snapshot_particles()?,
        };
        // A snapshot that waited for a staging copy to come back waited for the export thread.
        let buffers = match &job.particles {
            ParticleSnapshot::Pending(pending) => pending.waited_for_buffers(),
            ParticleSnapshot::Ready(_) => Duration::ZERO,
        };
        self.asynchronous = matches!(job.particles, ParticleSnapshot::Pending(_));
        self.starting += start.elapsed() - buffers;
        self.waited += buffers;
        let frames = self.frames.as_ref().expect("submit after finish");
        let sent = match frames.try_send(job) {
            Ok(()) => Ok(()),
            Err(TrySendError::Full(job)) => {
                let waiting = Instant::now();
                let sent = frames.send(job).map_err(|_| ());
                self.waited += waiting.elapsed();
                sent
            }
            Err(TrySendError::Disconnected(_)) => Err(()),
        };
        if sent.is_err() {
            // The thread ended, which it does only on a failure: that is the error.
            return Err(self
                .join()
                .err()
                .unwrap_or_else(|| anyhow!("the export thread ended early")));
        }
        self.handed += 1;
        Ok(true)
    }

    /// Whether the export thread has ended before [`Self::finish`], which it does only on a failure
    /// (a full disk): the next [`Self::submit`] or [`Self::finish`] returns that failure. For a
    /// caller that may hand nothing over for a while (the viewer, paused) and would say so at once.
    pub fn has_failed(&self) -> bool {
        self.thread.as_ref().is_none_or(JoinHandle::is_finished)
    }

    /// Waits for every frame handed over to be written; then the closing lines: what each export
    /// wrote and what it cost the stepping thread.
    pub fn finish(mut self) -> Result<Vec<String>> {
        self.frames = None;
        let each = |d: Duration| 1e3 * d.as_secs_f64() / self.handed.max(1) as f64;
        let handed_over = format!(
            "export: {} handed to the export thread, {:.2} ms each on the stepping thread ({}), which \
             waited {:.2} s in all for the export thread to take them",
            crate::text::count(self.handed, "frame", "frames"),
            each(self.starting),
            match self.asynchronous {
                true => "the particles' copy to the host overlaps the next substeps",
                false => "this backend copies the particles on it",
            },
            self.waited.as_secs_f64()
        );
        Ok([vec![handed_over], self.join()?].concat())
    }

    fn join(&mut self) -> Result<Vec<String>> {
        let thread = self
            .thread
            .take()
            .ok_or_else(|| anyhow!("the export thread ended early"))?;
        thread.join().map_err(|_| anyhow!("the export thread panicked"))?
    }
}

impl Drop for FrameExports {
    /// Without `finish` (the run failed): the frames handed over are still written, each file whole,
    /// and the thread ends; its closing lines go unsaid.
    fn drop(&mut self) {
        self.frames = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// The header comment of an exported frame's files.
pub fn frame_comment(sim: &Simulation) -> String {
    let scene = sim.scene();
    format!(
        "mpm frame {} t={:.6} s scene={} backend={}\ndx={} m grid={}x{}x{} rest_density={} kg/m^3",
        sim.frame(),
        sim.time(),
        scene.name,
        sim.backend(),
        scene.dx,
        scene.grid_res[0],
        scene.grid_res[1],
        scene.grid_res[2],
        scene.material().rest_density
    )
}

/// [`QUEUE_BUDGET`], or a quarter of the memory available where that is less.
fn queue_budget() -> u64 {
    let available = super::volume::available_memory().unwrap_or(u64::MAX);
    QUEUE_BUDGET.min(available / 4)
}

/// Frames of `bytes` each that `budget` holds, within [`QUEUE_FRAMES`].
fn queue_frames(budget: u64, bytes: usize) -> usize {
    let frames = budget / bytes.max(1) as u64;
    (frames.min(*QUEUE_FRAMES.end() as u64) as usize).max(*QUEUE_FRAMES.start())
}

/// The export thread's side: the writers and queues it feeds.
struct ExportThread {
    ply: Option<PlyQueue>,
    surface: Option<SurfaceQueue>,
    volume: Option<VolumeQueue>,
    usd: Option<UsdQueue>,
    progress: ExportProgress,
    /// Frames taken, and the time spent waiting for their particles' copy and reordering them.
    frames: u64,
    particles: Duration,
}

impl ExportThread {
    /// Writes each frame as it comes, reporting what the queues finish meanwhile; when the stepping
    /// side closes the channel, waits for the queues and returns the closing lines.
    fn run(mut self, frames: Receiver<FrameToExport>) -> Result<Vec<String>> {
        loop {
            match frames.recv_timeout(POLL) {
                Ok(frame) => self.write(frame)?,
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            self.collect()?;
        }
        self.finish()
    }

    fn write(&mut self, job: FrameToExport) -> Result<()> {
        let FrameToExport {
            frame,
            comment,
            particles,
            poses,
        } = job;
        let start = Instant::now();
        let particles = particles.wait()?.into_live_only();
        self.frames += 1;
        self.particles += start.elapsed();
        let progress = self.progress.clone();
        if let Some(queue) = self.volume.as_mut().filter(|q| q.exporter().wants(frame)) {
            let job = VolumeJob {
                frame,
                comment: comment.clone(),
                positions: particles.x.clone(),
                velocities: queue.exporter().settings().velocity.then(|| particles.v.clone()),
            };
            queue.submit(job, &mut |done, p| progress.file(done, p))?;
        }
        if let Some(queue) = self.surface.as_mut().filter(|q| q.exporter().wants(frame)) {
            let job = SurfaceJob {
                frame,
                comment: comment.clone(),
                positions: particles.x.clone(),
            };
            queue.submit(job, &mut |done, p| progress.file(done, p))?;
        }
        // The PLY frame and the USD layer share the particles.
        let particles = Arc::new(particles);
        if let Some(queue) = self.ply.as_mut().filter(|q| q.exporter.wants(frame)) {
            queue.submit(PlyJob {
                frame,
                comment: comment.clone(),
                particles: particles.clone(),
            })?;
        }
        if let Some(queue) = self.usd.as_mut().filter(|q| q.cache().wants(frame)) {
            queue.submit(UsdFrame {
                frame,
                comment,
                particles,
                poses: poses.unwrap_or_default(),
            })?;
        }
        Ok(())
    }

    /// Reports the meshes, volumes and layers finished so far.
    fn collect(&mut self) -> Result<()> {
        let progress = &self.progress;
        if let Some(queue) = self.surface.as_mut() {
            queue.collect(&mut |done, p| progress.file(done, p), false)?;
        }
        if let Some(queue) = self.volume.as_mut() {
            queue.collect(&mut |done, p| progress.file(done, p), false)?;
        }
        if let Some(queue) = self.usd.as_mut() {
            queue.collect()?;
        }
        if let Some(queue) = self.ply.as_mut() {
            queue.collect()?;
        }
        Ok(())
    }

    /// Waits for every queue; the closing line of each export.
    fn finish(self) -> Result<Vec<String>> {
        let progress = self.progress;
        let mut lines = vec![format!(
            "export thread: {:.2} ms a frame waiting for the particles and putting them in slot order",
            1e3 * self.particles.as_secs_f64() / self.frames.max(1) as f64
        )];
        if let Some(ply) = self.ply {
            lines.push(ply.finish()?);
        }
        if let Some(queue) = self.surface {
            let files = queue.exporter().destination();
            lines.push(progress.finish_files(queue, &files)?);
        }
        if let Some(queue) = self.volume {
            let files = queue.exporter().destination();
            lines.push(progress.finish_files(queue, &files)?);
        }
        if let Some(queue) = self.usd {
            progress.waiting(queue.queued(), ("USD layer", "USD layers"));
            lines.push(queue.finish()?);
        }
        Ok(lines)
    }
}

impl ExportProgress {
    /// Reports a file as it finishes.
    fn file(&self, file: &impl FinishedFile, progress: FileProgress) {
        match self {
            ExportProgress::Bar(bar) => bar.set_message(progress.status()),
            ExportProgress::Lines => {
                let [build, write] = file.stages();
                eprintln!(
                    "{}: {} in {:.2} s ({})",
                    file.path().display(),
                    file.contents(),
                    (build + write).as_secs_f64(),
                    progress.status()
                );
            }
        }
    }

    /// Says that `left` files are still to come after the last frame, where each file gets a line
    /// (a progress bar shows it anyway).
    fn waiting(&self, left: u64, (one, several): (&str, &str)) {
        if left > 0 && matches!(self, ExportProgress::Lines) {
            eprintln!(
                "simulation done; waiting for {}",
                crate::text::count(left, one, several)
            );
        }
    }

    /// Waits for the files left in `queue`, reporting each; then its closing line, `files` saying
    /// where they went.
    fn finish_files<E, J, D>(&self, queue: FileQueue<E, J, D>, files: &str) -> Result<String>
    where
        E: Send + Sync + 'static,
        J: Send + 'static,
        D: FinishedFile + Send + 'static,
    {
        let last_frame = Instant::now();
        self.waiting(queue.progress().queued(), D::WORDS.files);
        let done = queue.finish(&mut |file, p| self.file(file, p))?;
        Ok(done.summary(files, last_frame.elapsed()))
    }
}
