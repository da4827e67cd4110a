//! Frame export. `--export`: one binary little-endian PLY of the particles per frame (positions,
//! velocities, density, material row; the volume ratio and von Mises stress where a material
//! carries a deformation; the material table's names and colours in header comments), which
//! ParaView, Blender, Open3D and meshio open as they are ([`ply`]).
//! `--export-surface`: the water surface of each frame as a triangle mesh ([`surface`]).
//! `--export-bodies`: the rigid bodies' meshes and a pose table ([`bodies`]).
//! `--export-volume`: the liquid as OpenVDB volumes ([`volume`], written by [`vdb`]).
//! `--export-usd`: the whole run as one USD stage ([`usd`]). The frames reach them through the
//! export thread ([`frames`]), off the stepping thread, and each runs on writer threads of its own
//! ([`queue`]). All go through [`FrameDir`], which owns the rules for a directory of numbered frame
//! files: nothing a user saved is replaced silently, and a failed write never leaves a truncated
//! file behind.

pub mod bodies;
pub mod frames;
pub mod mesh_files;
pub mod ply;
pub mod queue;
pub mod surface;
pub mod usd;
pub mod vdb;
pub mod volume;

pub use ply::{
    write_ply, PlyExporter, PARTICLE_FRAMES, PLY_MATERIAL_PROPERTY, PLY_PROPERTIES, PLY_SOLID_PROPERTIES,
};

use crate::sim::material::NamedMaterial;
use crate::sim::solid;
use crate::sim::Particles;
use crate::text::{io_reason, plural};
use anyhow::{bail, Context, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// One kind of numbered frame file in one directory: `{prefix}NNNNNN.{extension}`, names that sort
/// in frame order. Opening it refuses a directory that already holds files of this kind (in any of
/// `kind.extensions`: a run never mixes with an earlier one's files), unless `overwrite`, which
/// removes them first.
pub struct FrameDir {
    dir: PathBuf,
    kind: FrameKind,
    /// The extension this run writes (one of `kind.extensions`).
    extension: &'static str,
    /// The files of an earlier run that `--overwrite` removed, in name order.
    removed: Vec<PathBuf>,
    /// The half-written files of a killed run, removed.
    unfinished: Vec<PathBuf>,
}

/// What a [`FrameDir`] holds, in the words its messages use.
#[derive(Debug, Clone, Copy)]
pub struct FrameKind {
    /// The command-line flag that names the directory, e.g. `--export`.
    pub flag: &'static str,
    /// The start of every file name, e.g. `frame_`.
    pub prefix: &'static str,
    /// Every extension a run of this kind may write: all of them count as an earlier run's files.
    pub extensions: &'static [&'static str],
    /// Files of these names that a run of this kind writes beside its frames (the bodies' pose
    /// table): an earlier run's count as its files too.
    pub companions: &'static [&'static str],
    /// The noun for one file and for several, e.g. `frame`, `frames`.
    pub noun: (&'static str, &'static str),
}

impl FrameDir {
    /// Creates `dir` if needed and checks, before the first step, that a file can be written there.
    /// Refuses a directory that already holds files of `kind`, unless `overwrite`: files a user
    /// saved from an earlier run are never replaced silently. With `overwrite` the earlier files are
    /// all removed (see [`Self::removed_note`]), so that the directory holds one run only, not the
    /// new files mixed with a longer run's tail.
    pub fn open(dir: &Path, kind: FrameKind, extension: &'static str, overwrite: bool) -> Result<FrameDir> {
        debug_assert!(kind.extensions.contains(&extension));
        let what = (
            format!("exported {}", kind.noun.0),
            format!("exported {}", kind.noun.1),
        );
        let unfinished = remove_unfinished(dir, |name| kind.unfinished(name))?;
        let removed = claim_output_dir(
            dir,
            kind.flag,
            "export",
            (&what.0, &what.1),
            |name| kind.owns(name),
            overwrite,
        )?;
        Ok(FrameDir {
            dir: dir.to_path_buf(),
            kind,
            extension,
            removed,
            unfinished,
        })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The files of an earlier run that `--overwrite` removed, in name order.
    pub fn removed(&self) -> &[PathBuf] {
        &self.removed
    }

    /// What opening the folder removed, for the user: the unfinished files of a killed run, and
    /// [`Self::removed`]; `None` when nothing was removed.
    pub fn removed_note(&self) -> Option<String> {
        let unfinished = (!self.unfinished.is_empty()).then(|| {
            format!(
                "removed {} that a killed run left unfinished in {}",
                crate::text::count(self.unfinished.len(), "file", "files"),
                self.dir.display()
            )
        });
        let overwritten = self.overwritten_note();
        match (unfinished, overwritten) {
            (Some(a), Some(b)) => Some(format!("{a}\n{b}")),
            (a, b) => a.or(b),
        }
    }

    fn overwritten_note(&self) -> Option<String> {
        let (first, last) = (self.removed.first()?, self.removed.last()?);
        let name = |p: &PathBuf| {
            p.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        };
        Some(if self.removed.len() == 1 {
            format!(
                "--overwrite: removed {} of an earlier run from {}",
                name(first),
                self.dir.display()
            )
        } else {
            format!(
                "--overwrite: removed {} {} of an earlier run from {} ({} .. {})",
                self.removed.len(),
                self.kind.noun.1,
                self.dir.display(),
                name(first),
                name(last)
            )
        })
    }

    pub fn path_of(&self, frame: u64) -> PathBuf {
        self.dir
            .join(format!("{}{frame:06}.{}", self.kind.prefix, self.extension))
    }

    /// Writes frame `frame` through `write` to a temporary name, then renames it, so a failed write
    /// never leaves a truncated file under a frame's name, and an interrupt removes it
    /// ([`remove_unfinished_on_interrupt`]). A failure names the path, the reason and the fix for that
    /// reason (a full disk, a refused permission, a read-only file system).
    pub fn write(
        &self,
        frame: u64,
        write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
    ) -> Result<PathBuf> {
        let path = self.path_of(frame);
        write_atomically(&path, write)?;
        Ok(path)
    }
}

/// Writes `path` through `write` to `path.partial`, then renames it, so a failed write never leaves
/// a truncated file under the name (an earlier file of that name stays whole until the rename
/// replaces it), and an interrupt removes the partial file ([`remove_unfinished_on_interrupt`]). A
/// failure names the path, the reason and the fix for that reason (a full disk, a refused
/// permission, a read-only file system).
pub fn write_atomically(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> Result<()>) -> Result<()> {
    let tmp = partial_path(path);
    let written = Unfinished::create(&tmp)
        .map_err(anyhow::Error::from)
        .and_then(|(unfinished, f)| {
            let mut out = BufWriter::new(f);
            write(&mut out)?;
            // Flushed here, not on drop: a drop swallows the error of a disk that filled up at the end.
            out.flush()?;
            drop(out);
            std::fs::rename(&tmp, path)?;
            // Listed until renamed: an interrupt before then removes the whole but unnamed file.
            drop(unfinished);
            Ok(())
        });
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        let reason = e
            .chain()
            .find_map(|cause| cause.downcast_ref::<std::io::Error>())
            .map_or_else(|| format!("{e:#}"), io_reason);
        bail!("cannot write {}: {reason}", path.display());
    }
    Ok(())
}

/// The name a file is written under until it is complete: `NAME.partial`.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(PARTIAL);
    PathBuf::from(name)
}

impl FrameKind {
    /// Whether a file of this name is a finished file of this kind.
    fn owns(&self, name: &str) -> bool {
        if self.companions.contains(&name) {
            return true;
        }
        let Some(rest) = name.strip_prefix(self.prefix) else {
            return false;
        };
        self.extensions
            .iter()
            .any(|ext| rest.strip_suffix(ext).is_some_and(|r| r.ends_with('.')))
    }

    /// Whether a file of this name is one of this kind that a run was still writing when it was
    /// killed: never a finished file, so never counted, and removed when the folder is opened again.
    fn unfinished(&self, name: &str) -> bool {
        name.strip_suffix(PARTIAL)
            .is_some_and(|finished| self.owns(finished))
    }
}

/// The suffix of a file still being written.
const PARTIAL: &str = ".partial";

/// The files being written now, for the Ctrl-C handler to remove.
static UNFINISHED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// A file being written, listed in [`UNFINISHED`] while it is.
struct Unfinished(PathBuf);

impl Unfinished {
    /// Creates the file and lists it, both under the list's lock: the Ctrl-C handler holds that
    /// lock from its removals to the program's exit, so a file is either listed and on the disk
    /// when it removes the listed ones, or never created (a writer thread that created the file
    /// after the removals left it behind).
    fn create(path: &Path) -> std::io::Result<(Unfinished, File)> {
        let mut list = UNFINISHED.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let file = File::create(path)?;
        list.push(path.to_path_buf());
        Ok((Unfinished(path.to_path_buf()), file))
    }
}

impl Drop for Unfinished {
    fn drop(&mut self) {
        if let Ok(mut list) = UNFINISHED.lock() {
            list.retain(|p| p != &self.0);
        }
    }
}

/// Makes Ctrl-C (SIGINT, SIGTERM) remove the export files still being written before the program
/// exits, saying so: an interrupted run leaves only finished files. For `mpm run`, whose exports write
/// from several threads.
pub fn remove_unfinished_on_interrupt() -> Result<()> {
    ctrlc::set_handler(|| {
        // Held until the exit below: no writer thread creates a file after the removals.
        let list = UNFINISHED.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let removed: Vec<&PathBuf> = list.iter().filter(|p| std::fs::remove_file(p).is_ok()).collect();
        eprintln!(
            "error: interrupted{}",
            match removed.len() {
                0 => String::new(),
                n => format!(
                    "; removed {} being written",
                    crate::text::count(n, "file", "files")
                ),
            }
        );
        std::process::exit(130);
    })
    .context("installing the Ctrl-C handler")
}

/// Claims `dir` for a run's output files, before the first step: creates it if needed, checks that a
/// file can be written there, and refuses it when it holds files the run would clash with (`clashes`
/// of a file name), unless `overwrite`, which removes them (returned, for the run's note) so that the
/// directory holds one run only, never the new files mixed with an earlier run's tail. `flag` names
/// the directory's option, `role` the directory in messages, `what` one and several of its files.
pub fn claim_output_dir(
    dir: &Path,
    flag: &str,
    role: &str,
    what: (&str, &str),
    clashes: impl Fn(&str) -> bool,
    overwrite: bool,
) -> Result<Vec<PathBuf>> {
    if dir.exists() && !dir.is_dir() {
        bail!(
            "{flag} {} is a file, not a directory; give a directory for the {}",
            dir.display(),
            what.1
        );
    }
    std::fs::create_dir_all(dir).map_err(|e| {
        anyhow::anyhow!(
            "cannot create the {role} directory {}: {}",
            dir.display(),
            io_reason(&e)
        )
    })?;
    let mut existing: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read the {role} directory {}", dir.display()))?
        .filter_map(|e| e.ok())
        .filter(|e| clashes(&e.file_name().to_string_lossy()))
        .map(|e| e.path())
        .collect();
    existing.sort();
    if !existing.is_empty() && !overwrite {
        bail!(
            "{} already holds {} {}; pick another {flag} directory, or pass --overwrite to replace them",
            dir.display(),
            existing.len(),
            plural(existing.len(), what.0, what.1)
        );
    }
    // Before the first step: a directory that cannot take a file fails now, not after a long run.
    let probe = dir.join(".mpm-write-check");
    File::create(&probe)
        .and_then(|_| std::fs::remove_file(&probe))
        .map_err(|e| anyhow::anyhow!("cannot write into {}: {}", dir.display(), io_reason(&e)))?;
    for path in &existing {
        std::fs::remove_file(path).map_err(|e| {
            anyhow::anyhow!("--overwrite: cannot remove {}: {}", path.display(), io_reason(&e))
        })?;
    }
    Ok(existing)
}

/// A file a command writes (`bench --json`, `run --export-usd`), checked before the work: a path through a
/// file, a missing or unwritable folder, or a file in the way fails now, with the fix, not after
/// minutes of measuring.
pub fn check_output_file(path: &Path, flag: &str, overwrite: bool) -> Result<()> {
    if path.is_dir() {
        bail!("{flag} {} is a directory; give a file name", path.display());
    }
    if path.exists() && !overwrite {
        bail!(
            "{} exists; pass --overwrite to replace it, or choose another {flag} file",
            path.display()
        );
    }
    let folder = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if let Some(file) = folder.ancestors().find(|a| a.is_file()) {
        bail!(
            "{flag} {}: {} is a file, not a folder; choose a path through folders",
            path.display(),
            file.display()
        );
    }
    if !folder.is_dir() {
        bail!(
            "{flag} {}: the folder {} does not exist; create it, or choose another path",
            path.display(),
            folder.display()
        );
    }
    // A probe file, not the file itself: a run that fails later must not leave an empty report.
    let probe = folder.join(".mpm-write-check");
    std::fs::File::create(&probe)
        .and_then(|_| std::fs::remove_file(&probe))
        .map_err(|e| {
            anyhow::anyhow!(
                "{flag} {}: cannot write into {}: {}",
                path.display(),
                folder.display(),
                io_reason(&e)
            )
        })?;
    if path.exists() {
        std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| anyhow::anyhow!("{flag}: cannot replace {}: {}", path.display(), io_reason(&e)))?;
    }
    Ok(())
}

/// Removes the files of `dir` that `unfinished` names (a killed run's half-written files), returning
/// them; nothing where `dir` does not exist yet.
fn remove_unfinished(dir: &Path, unfinished: impl Fn(&str) -> bool) -> Result<Vec<PathBuf>> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(Vec::new());
    };
    let mut removed: Vec<PathBuf> = entries
        .filter_map(|e| e.ok())
        .filter(|e| unfinished(&e.file_name().to_string_lossy()))
        .map(|e| e.path())
        .collect();
    removed.sort();
    for path in &removed {
        std::fs::remove_file(path).map_err(|e| {
            anyhow::anyhow!(
                "cannot remove the unfinished {}: {}",
                path.display(),
                io_reason(&e)
            )
        })?;
    }
    Ok(removed)
}

/// `--every K`: export every K-th frame, K at least 1.
pub fn check_every(every: u64) -> Result<()> {
    if every == 0 {
        bail!("--every must be at least 1 (export every K-th frame)");
    }
    Ok(())
}

/// The header comment naming row `row` of the material table: `material ROW NAME R G B`, the colour
/// linear RGB from 0 to 1 (the name may hold spaces: the colour is the last three words).
pub fn material_comment(row: usize, material: &NamedMaterial) -> String {
    let [r, g, b] = material.colour;
    format!("material {row} {} {r:.3} {g:.3} {b:.3}", material.name)
}

/// Particle `i`'s [`PLY_SOLID_PROPERTIES`], `(J, von_mises)`, where the particles carry a
/// deformation: a solid's volume ratio and von Mises stress, an elastoviscoplastic liquid's rest
/// density over its density and its elastic part's stress, another liquid's density ratio and 0.
pub fn deformation_measures(particles: &Particles, i: usize, materials: &[NamedMaterial]) -> (f32, f32) {
    let law = materials.get(usize::from(particles.material[i])).map(|m| &m.law);
    match law {
        Some(law) if law.is_solid() => {
            let d = &particles.deformation[i];
            (
                solid::volume_ratio(law, d.f, d.plastic),
                solid::von_mises(law, d.f, d.plastic),
            )
        }
        Some(law) if law.is_elastoviscoplastic() => {
            let d = &particles.deformation[i];
            (
                law.rest_density / particles.rho[i],
                solid::von_mises(law, d.f, d.plastic),
            )
        }
        Some(law) => (law.rest_density / particles.rho[i], 0.0),
        None => (1.0, 0.0),
    }
}
