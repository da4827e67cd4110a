//! The viewer's snapshots: F5 (or the panel's button) saves the running state as a checkpoint in
//! `--capture-dir` (`snapshot-NNN.mpmck`, the first free number, never overwriting); F9 loads the
//! newest one there and goes on from it, in its own scene. The files are ordinary checkpoints, so
//! `mpm run --resume` continues them headless too.

use super::ViewerApp;
use crate::checkpoint::{Checkpoint, EXTENSION};
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

impl ViewerApp {
    pub(super) fn save_snapshot(&mut self) -> Result<()> {
        let Some(sim) = &mut self.sim else { return Ok(()) };
        // A snapshot is a state between frames: a frame split over draws is finished first, and the
        // last stretch of substeps, which the window leaves in flight at every frame's end
        // (`Simulation::overlap_frames`), accounted. (Finishing a frame leaves its last stretch in
        // flight again, so the state was never between frames, and F5 always failed with "a frame
        // is half done".)
        if sim.time_stepped() > sim.time() {
            sim.step_frame()?;
            // A frame completed here, on the main thread, is exported as the stepping thread's are.
            if let Some(export) = self.export.as_mut() {
                export.export_frame(sim);
            }
        }
        sim.settle()?;
        let path = next_free_snapshot(&self.options.capture_dir);
        Checkpoint::capture(sim)?.write_new(&path)?;
        self.message = Some(format!("saved {} (F9 loads it)", path.display()));
        Ok(())
    }

    pub(super) fn load_snapshot(&mut self) -> Result<()> {
        let dir = &self.options.capture_dir;
        let path = newest_snapshot(dir)?.with_context(|| {
            format!(
                "no snapshot-NNN.{EXTENSION} in {} to load; F5 saves one",
                dir.display()
            )
        })?;
        let checkpoint = Checkpoint::read(&path)?;
        let scene = checkpoint.scene()?;
        let reframe = scene.grid_res != self.scene.grid_res || scene.dx != self.scene.dx;
        self.start_scene_from(scene, reframe, Some(&checkpoint))?;
        self.message = Some(format!(
            "loaded {} (frame {}, t = {:.3} s)",
            path.display(),
            checkpoint.clock.frame,
            checkpoint.clock.time
        ));
        Ok(())
    }
}

fn snapshot_number(path: &Path) -> Option<u32> {
    let name = path.file_name()?.to_str()?;
    name.strip_prefix("snapshot-")?
        .strip_suffix(&format!(".{EXTENSION}"))?
        .parse()
        .ok()
}

fn next_free_snapshot(dir: &Path) -> PathBuf {
    (0..)
        .map(|i| dir.join(format!("snapshot-{i:03}.{EXTENSION}")))
        .find(|p| !p.exists())
        .unwrap_or_else(|| dir.join(format!("snapshot.{EXTENSION}")))
}

/// The highest-numbered snapshot in `dir`, `None` where there is none.
fn newest_snapshot(dir: &Path) -> Result<Option<PathBuf>> {
    let entries = std::fs::read_dir(dir).with_context(|| format!("cannot read {}", dir.display()))?;
    Ok(entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter_map(|p| snapshot_number(&p).map(|n| (n, p)))
        .max_by_key(|(n, _)| *n)
        .map(|(_, p)| p))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snapshots_are_numbered_and_the_newest_is_found() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(newest_snapshot(dir.path()).unwrap(), None);
        for _ in 0..3 {
            std::fs::write(next_free_snapshot(dir.path()), b"").unwrap();
        }
        std::fs::write(dir.path().join("snapshot-x.mpmck"), b"").unwrap();
        let newest = newest_snapshot(dir.path()).unwrap().unwrap();
        assert_eq!(newest.file_name().unwrap(), "snapshot-002.mpmck");
        assert_eq!(
            next_free_snapshot(dir.path()).file_name().unwrap(),
            "snapshot-003.mpmck"
        );
    }
}
