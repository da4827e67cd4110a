//! The viewer's export of its run (`mpm view --export DIR ...`, the flags of `mpm run`): every K-th
//! simulated frame from the start, frame 0 the initial state, through the same [`FrameExports`]
//! (the export thread) and [`BodyExporter`] as `mpm run`. The stepping thread hands each frame
//! over as it completes, at the frame's boundary: on the GPU the particles' copy is then enqueued
//! behind that frame's substeps and ahead of the next frame's. The session holds one run of one
//! scene: a restart, another scene or a loaded snapshot ends it (its files would otherwise mix two
//! runs), as do the E key, an export error and the window's closing; nothing is exported after it.

use super::ViewerApp;
use crate::export::bodies::BodyExporter;
use crate::export::frames::{ExportProgress, Exports, FrameExports};
use crate::sim::{Scene, Simulation};
use anyhow::{bail, Error, Result};
use std::thread::JoinHandle;
use std::time::Instant;

/// An export under way. It travels with the simulation to the stepping thread and back.
pub(super) struct ExportSession {
    frames: Option<FrameExports>,
    bodies: Option<BodyExporter>,
    /// The last frame handed over: a frame goes once, and frame numbers only grow while the session
    /// lasts (what resets them ends it).
    last_frame: Option<u64>,
    /// Frames handed over (to any of the exports) and, of those, the ones the bodies' export wrote.
    exported: u64,
    bodies_written: u64,
    started: Instant,
    /// What is exported, for the panel: "ply, usd".
    kinds: String,
    /// Whether the exports hold the scene's colliders as the export started (the USD stage declares
    /// each one, static or moving; the bodies' files each rigid body).
    usd: bool,
    /// The first failure, which ends the session at the next draw; nothing is handed over after it.
    error: Option<Error>,
}

/// Why an export ended, in the words of its closing note.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum ExportEnd {
    /// R: the scene restarted.
    Restart,
    /// A preset or a scene file was loaded.
    NewScene,
    /// F9: a snapshot was loaded.
    Snapshot,
    /// E, or the panel's button.
    Stopped,
    /// The window closed (or the viewer quit).
    Closed,
    /// An export failed (a full disk); the viewer goes on.
    Failed,
}

impl ExportEnd {
    fn words(self) -> &'static str {
        match self {
            ExportEnd::Restart => "at the restart (R)",
            ExportEnd::NewScene => "at the new scene's start",
            ExportEnd::Snapshot => "at the snapshot's load (F9)",
            ExportEnd::Stopped => "when stopped (E)",
            ExportEnd::Closed => "as the viewer closed",
            ExportEnd::Failed => "by an error",
        }
    }
}

/// A change to the scene's colliders while the export runs.
#[derive(Clone, Copy)]
pub(super) enum ColliderChange {
    /// A body dropped into the scene (B, O).
    Drop,
    /// A static collider taken with the mouse: it moves from then on.
    MoveStatic,
}

impl ExportSession {
    /// Starts the export thread for `exports` (none where nothing is exported) of a run of `scene`.
    pub(super) fn start(exports: Exports, scene: &Scene) -> Result<Option<ExportSession>> {
        if exports.is_empty() {
            return Ok(None);
        }
        let kinds = exports.kinds().join(", ");
        let usd = exports.frames.usd.is_some();
        let Exports { frames, bodies } = exports;
        // A line per file on stderr: the window is the viewer's progress display.
        let frames = FrameExports::start(frames, scene, ExportProgress::Lines)?;
        Ok(Some(ExportSession {
            frames,
            bodies,
            last_frame: None,
            exported: 0,
            bodies_written: 0,
            started: Instant::now(),
            kinds,
            usd,
            error: None,
        }))
    }

    /// Hands the simulation's current frame over, where it has not been yet and an export wants it,
    /// on the thread that steps `sim` (with its CUDA context), between two frames. A failure is kept
    /// for the main thread, which ends the session with it ([`ViewerApp::poll_export`]).
    pub(super) fn export_frame(&mut self, sim: &mut Simulation) {
        let frame = sim.frame();
        if self.error.is_some() || self.last_frame == Some(frame) {
            return;
        }
        self.last_frame = Some(frame);
        let handed = match self.frames.as_mut() {
            Some(frames) => frames.submit(sim),
            None => Ok(false),
        };
        let written = crate::runner::export_bodies(sim, self.bodies.as_mut());
        match (handed, written) {
            (Ok(handed), Ok(written)) => {
                self.exported += u64::from(handed || written);
                self.bodies_written += u64::from(written);
            }
            (Err(e), _) | (_, Err(e)) => self.error = Some(e),
        }
    }

    /// Whether the export failed (here, or on the export thread since the last frame).
    pub(super) fn has_failed(&self) -> bool {
        self.error.is_some() || self.frames.as_ref().is_some_and(FrameExports::has_failed)
    }

    /// The panel's line: "42 frames (ply, usd)".
    pub(super) fn status(&self) -> String {
        format!(
            "{} ({})",
            crate::text::count(self.exported, "frame", "frames"),
            self.kinds
        )
    }

    /// Refuses `change` where an export under way could not follow it: the USD stage declared the
    /// scene's colliders, each static or moving, and the bodies' files its rigid bodies, when the
    /// export started.
    pub(super) fn check_collider_change(&self, change: ColliderChange) -> Result<()> {
        let listed_in = match (self.usd, self.bodies.is_some()) {
            (true, true) => "the USD stage and the body files list",
            (true, false) => "the USD stage lists",
            (false, true) => "the body files list",
            (false, false) => return Ok(()),
        };
        match change {
            ColliderChange::Drop => bail!(
                "cannot drop a body while the run is exported: {listed_in} the scene's colliders as \
                 the export started; press E to end the export first"
            ),
            ColliderChange::MoveStatic if self.usd => bail!(
                "cannot move a static collider while the run is exported: the USD stage holds it \
                 where it stands; press E to end the export first"
            ),
            ColliderChange::MoveStatic => Ok(()),
        }
    }

    /// Waits for every frame handed over to be written. Returns the closing lines (what each
    /// export wrote and what it cost, as `mpm run` ends with them) and the failure that ended the
    /// export, if one did.
    fn finish(mut self) -> (Vec<String>, Option<Error>) {
        let mut error = self.error.take();
        let mut lines = Vec::new();
        if let Some(frames) = self.frames.take() {
            match frames.finish() {
                Ok(closing) => lines = closing,
                // After a failure handed back by `submit` the thread is gone ("ended early"): the
                // first failure is the one to report.
                Err(e) => {
                    error.get_or_insert(e);
                }
            }
        }
        if let Some(bodies) = &self.bodies {
            lines.push(crate::runner::bodies_closing_line(bodies, self.bodies_written));
        }
        (lines, error)
    }

    /// The frames handed over and the time since the start, for a closing note.
    fn summary(&self) -> String {
        format!(
            "{} in {:.1} s ({})",
            crate::text::count(self.exported, "frame", "frames"),
            self.started.elapsed().as_secs_f64(),
            self.kinds
        )
    }
}

/// An ended export whose queued frames are still being written, on a thread of its own, so that
/// the window keeps answering meanwhile (a surface mesh or a volume may take seconds on a CPU).
pub(super) struct FinishingExport {
    thread: JoinHandle<(Vec<String>, Option<Error>)>,
    why: ExportEnd,
    /// [`ExportSession::summary`] as it ended.
    summary: String,
}

impl ViewerApp {
    /// Starts the export asked for on the command line, with the first scene; frame 0, the initial
    /// state, goes at once, from this thread, which made the simulation and has stepped none of it.
    pub(super) fn start_export(&mut self) -> Result<()> {
        let Some(exports) = self.pending_export.take() else {
            return Ok(());
        };
        let Some(sim) = self.sim.as_mut() else {
            return Ok(());
        };
        self.export = ExportSession::start(exports, sim.scene())?;
        if let Some(export) = self.export.as_mut() {
            export.export_frame(sim);
        }
        Ok(())
    }

    /// Ends the export, if one runs, for `why`: its queued frames are written on a thread of its own
    /// (waited for at once where the window closes), its closing lines go to stderr and a note to
    /// the panel. Nothing is exported after it in this viewer's life.
    pub(super) fn end_export(&mut self, why: ExportEnd) {
        let Some(export) = self.export.take() else {
            return;
        };
        let summary = export.summary();
        if why == ExportEnd::Closed {
            eprintln!("export: the viewer is closing; writing the frames still queued first");
            let (lines, error) = export.finish();
            self.report_export_end(why, &summary, lines, error);
            return;
        }
        self.message = Some(format!(
            "export ended {}: {summary}; writing the frames still queued",
            why.words()
        ));
        let thread = std::thread::Builder::new()
            .name("export-finish".into())
            .spawn(move || export.finish());
        match thread {
            Ok(thread) => self.finishing_export = Some(FinishingExport { thread, why, summary }),
            // The session was moved into the failed spawn's closure and dropped there, which waits
            // for its frames as well (FrameExports' Drop).
            Err(e) => self.message = Some(format!("export: cannot start a thread to finish it: {e}")),
        }
    }

    /// Once a draw: ends a failed export (the viewer goes on), and reports an ended export whose
    /// last frames are now written.
    pub(super) fn poll_export(&mut self) {
        if self.export.as_ref().is_some_and(ExportSession::has_failed) {
            self.end_export(ExportEnd::Failed);
        }
        if self
            .finishing_export
            .as_ref()
            .is_some_and(|f| f.thread.is_finished())
        {
            self.join_finishing_export();
        }
    }

    /// Waits for an ended export's last frames to be written, and reports it.
    pub(super) fn join_finishing_export(&mut self) {
        let Some(finishing) = self.finishing_export.take() else {
            return;
        };
        if !finishing.thread.is_finished() {
            eprintln!("export: writing the frames still queued before exiting");
        }
        let (lines, error) = finishing.thread.join().unwrap_or_else(|_| {
            let panicked = anyhow::anyhow!("the thread writing the export's last frames panicked");
            (Vec::new(), Some(panicked))
        });
        self.report_export_end(finishing.why, &finishing.summary, lines, error);
    }

    /// The closing lines and the closing note on stderr, the note (or the failure) on the panel's
    /// message line.
    fn report_export_end(&mut self, why: ExportEnd, summary: &str, lines: Vec<String>, error: Option<Error>) {
        for line in &lines {
            eprintln!("{line}");
        }
        let note = match error {
            Some(e) => format!("export stopped by an error after {summary}: {e:#}"),
            None => format!("export finished {}: {summary}", why.words()),
        };
        eprintln!("{note}");
        self.message = Some(note);
    }

    /// The panel's export line while an export runs: what it exported so far. (An ended one's
    /// last frames are the message line's.)
    pub(super) fn export_status(&self) -> Option<String> {
        self.export.as_ref().map(ExportSession::status)
    }
}

#[cfg(test)]
mod tests {
    use super::super::stepping::step_frames;
    use super::super::{ViewerApp, ViewerOptions};
    use super::*;
    use crate::backend::BackendKind;
    use crate::export::usd::UsdCache;
    use crate::export::PlyExporter;
    use crate::render::{DrawMode, Transfer};
    use crate::sim::Scene;
    use std::path::Path;

    /// A small tank the single-thread CPU steps in milliseconds a frame.
    const TANK: &str = r#"
name = "tank"
[domain]
size = [0.2, 0.2, 0.2]
resolution = [10, 10, 10]
[material]
rest_density = 1000.0
sound_speed = 10.0
[[block]]
min = [0.03, 0.03, 0.03]
max = [0.11, 0.13, 0.11]
"#;

    /// The viewer (no window: what the window's events call is called directly) on the CPU, its
    /// first scene started with `exports` as `mpm view` starts it.
    fn viewer(dir: &Path, exports: impl FnOnce(&Scene) -> Result<Exports>) -> ViewerApp {
        let scene = Scene::from_toml(TANK, "test tank").unwrap();
        let options = ViewerOptions {
            scene,
            backend: BackendKind::Cpu,
            vsync: false,
            max_fps: None,
            size: [64, 64],
            mode: DrawMode::Points,
            colouring: None,
            particle_radius: None,
            full_res_smoothing: false,
            transfer: Transfer::HostCopy,
            fixed_frames: Some(1),
            capture_dir: dir.to_path_buf(),
            quit_after: None,
            final_screenshot: None,
        };
        let exports = exports(&options.scene).unwrap();
        let mut app = ViewerApp::new(options, exports).unwrap();
        app.start_scene(app.scene.clone(), false).unwrap();
        app.start_export().unwrap();
        app
    }

    /// Steps to frame `last` as the viewer's stepping thread does (a draw's worth at a time), with
    /// the export along.
    fn step_to(app: &mut ViewerApp, last: u64) {
        let mut sim = app.sim.take().unwrap();
        let mut export = app.export.take();
        while sim.frame() < last {
            let frames = (last - sim.frame()) as u32;
            step_frames(&mut sim, &mut export, frames);
        }
        app.sim = Some(sim);
        app.export = export;
        app.poll_export();
    }

    fn ply_frames(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    /// Frame 0 and every frame stepped are exported; a restart ends the export (its last frames
    /// written, the note on the message line), and the new run writes nothing into its folder.
    #[test]
    fn a_restart_ends_the_export_and_the_new_run_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let frames = dir.path().join("frames");
        let mut app = viewer(dir.path(), |_| {
            Ok(Exports {
                frames: crate::export::frames::FrameExportSet {
                    ply: Some(PlyExporter::new(&frames, 1, false)?),
                    ..Default::default()
                },
                bodies: None,
            })
        });
        step_to(&mut app, 3);
        assert_eq!(app.export_status().as_deref(), Some("4 frames (ply)"));
        // R.
        app.start_scene(app.scene.clone(), false).unwrap();
        assert!(app.export.is_none(), "the restart ended the export");
        app.join_finishing_export();
        let message = app.message.clone().unwrap_or_default();
        assert!(
            message.starts_with("export finished at the restart (R): 4 frames in "),
            "{message}"
        );
        step_to(&mut app, 5);
        assert_eq!(
            ply_frames(&frames),
            [0, 1, 2, 3].map(|f| format!("frame_{f:06}.ply")),
            "the old run's frames, and none of the new run's"
        );
        assert_eq!(app.export_status(), None);
    }

    /// An export that fails (its folder gone: a write error, as a full disk's) ends with the error
    /// on the message line; the viewer steps on.
    #[test]
    fn a_failed_export_ends_with_its_error_and_the_viewer_goes_on() {
        let dir = tempfile::tempdir().unwrap();
        let frames = dir.path().join("frames");
        let mut app = viewer(dir.path(), |_| {
            Ok(Exports {
                frames: crate::export::frames::FrameExportSet {
                    ply: Some(PlyExporter::new(&frames, 2, false)?),
                    ..Default::default()
                },
                bodies: None,
            })
        });
        step_to(&mut app, 1);
        std::fs::remove_dir_all(&frames).unwrap();
        // Frame 2 fails on a PLY writer thread; the export thread learns it at its next look at
        // the queue (within its poll of a tenth of a second) and ends, which a later hand-over or
        // draw finds.
        step_to(&mut app, 4);
        let waited = std::time::Instant::now();
        while app.export.is_some() && waited.elapsed() < std::time::Duration::from_secs(10) {
            std::thread::sleep(std::time::Duration::from_millis(20));
            app.poll_export();
        }
        app.join_finishing_export();
        assert!(
            app.export.is_none(),
            "the failure did not end the export within 10 s"
        );
        let message = app.message.clone().unwrap_or_default();
        assert!(
            message.starts_with("export stopped by an error after ") && message.contains("cannot write"),
            "{message}"
        );
        step_to(&mut app, 6);
        assert_eq!(app.sim.as_ref().unwrap().frame(), 6);
    }

    /// While a USD stage is exported, a dropped body and a static collider moved are refused (the
    /// stage lists the colliders as they were at its start); with PLY frames alone both are fine.
    #[test]
    fn collider_changes_the_stage_cannot_follow_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let stage = dir.path().join("run.usda");
        let app = viewer(dir.path(), |scene| {
            Ok(Exports {
                frames: crate::export::frames::FrameExportSet {
                    usd: Some(std::sync::Arc::new(UsdCache::create(
                        &stage, scene, 1, false, false,
                    )?)),
                    ..Default::default()
                },
                bodies: None,
            })
        });
        let export = app.export.as_ref().unwrap();
        let drop = export.check_collider_change(ColliderChange::Drop).unwrap_err();
        assert!(format!("{drop}").contains("press E"), "{drop}");
        assert!(export.check_collider_change(ColliderChange::MoveStatic).is_err());

        let frames = dir.path().join("frames");
        let app = viewer(dir.path(), |_| {
            Ok(Exports {
                frames: crate::export::frames::FrameExportSet {
                    ply: Some(PlyExporter::new(&frames, 1, false)?),
                    ..Default::default()
                },
                bodies: None,
            })
        });
        let export = app.export.as_ref().unwrap();
        assert!(export.check_collider_change(ColliderChange::Drop).is_ok());
        assert!(export.check_collider_change(ColliderChange::MoveStatic).is_ok());
    }
}
