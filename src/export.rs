//! Frame export: one binary little-endian PLY per frame (positions, velocities, density), which
//! ParaView, Blender, Open3D and meshio open as they are. Names sort in frame order.

use crate::sim::Particles;
use crate::text::{io_reason, plural};
use anyhow::{bail, Context, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes `frame_NNNNNN.ply` files into one directory.
pub struct PlyExporter {
    dir: PathBuf,
    every: u64,
    /// The frames of an earlier run that `--overwrite` removed, in name order.
    removed: Vec<PathBuf>,
}

impl PlyExporter {
    /// Creates `dir` if needed and checks that a file can be written there. Refuses a directory that
    /// already holds frames, unless `overwrite`: frames a user saved from an earlier run are never
    /// replaced silently. With `overwrite` the earlier frames are all removed (see [`Self::removed`]),
    /// so that the directory holds one run only, not the new frames mixed with a longer run's tail.
    pub fn new(dir: &Path, every: u64, overwrite: bool) -> Result<PlyExporter> {
        if every == 0 {
            bail!("--every must be at least 1 (export every K-th frame)");
        }
        let removed = claim_output_dir(
            dir,
            "--export",
            ("exported frame", "exported frames"),
            is_frame_file,
            overwrite,
        )?;
        Ok(PlyExporter {
            dir: dir.to_path_buf(),
            every,
            removed,
        })
    }

    /// The frames of an earlier run that `--overwrite` removed, in name order.
    pub fn removed(&self) -> &[PathBuf] {
        &self.removed
    }

    /// One line for the user about [`Self::removed`], or `None` when nothing was removed.
    pub fn removed_note(&self) -> Option<String> {
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
                "--overwrite: removed {} frames of an earlier run from {} ({} .. {})",
                self.removed.len(),
                self.dir.display(),
                name(first),
                name(last)
            )
        })
    }

    pub fn wants(&self, frame: u64) -> bool {
        frame % self.every == 0
    }

    pub fn path_of(&self, frame: u64) -> PathBuf {
        self.dir.join(format!("frame_{frame:06}.ply"))
    }

    /// Writes the frame to a temporary name and renames it, so a failed write never leaves a
    /// truncated file under a frame's name.
    pub fn write(&self, frame: u64, comment: &str, particles: &Particles) -> Result<PathBuf> {
        let path = self.path_of(frame);
        let tmp = path.with_extension("ply.partial");
        let result = File::create(&tmp)
            .map_err(anyhow::Error::from)
            .and_then(|f| write_ply(BufWriter::new(f), comment, particles));
        if let Err(e) = result.and_then(|_| std::fs::rename(&tmp, &path).map_err(Into::into)) {
            let _ = std::fs::remove_file(&tmp);
            let reason = e
                .chain()
                .find_map(|cause| cause.downcast_ref::<std::io::Error>())
                .map_or_else(|| format!("{e:#}"), io_reason);
            bail!("cannot write {}: {reason}", path.display());
        }
        Ok(path)
    }
}

/// Claims `dir` for one run's output files: creates it, refuses one that already holds files `clashes`
/// picks (named by `what`, singular and plural, and the `flag` that chose the directory) unless
/// `overwrite`, which removes them, so the directory never mixes two runs' files; and checks that a
/// file can be written there, so a bad directory fails before the first step. Returns the removed
/// files in name order.
pub fn claim_output_dir(
    dir: &Path,
    flag: &str,
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
    let role = flag.trim_start_matches('-');
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

fn is_frame_file(name: &str) -> bool {
    name.starts_with("frame_") && (name.ends_with(".ply") || name.ends_with(".ply.partial"))
}

/// The vertex properties, in file order.
pub const PLY_PROPERTIES: [&str; 7] = ["x", "y", "z", "vx", "vy", "vz", "density"];

pub fn write_ply(mut out: impl Write, comment: &str, particles: &Particles) -> Result<()> {
    writeln!(out, "ply\nformat binary_little_endian 1.0")?;
    for line in comment.lines() {
        writeln!(out, "comment {line}")?;
    }
    writeln!(out, "element vertex {}", particles.len())?;
    for p in PLY_PROPERTIES {
        writeln!(out, "property float {p}")?;
    }
    writeln!(out, "end_header")?;
    let mut record = [0f32; 7];
    for i in 0..particles.len() {
        record[..3].copy_from_slice(&particles.x[i].to_array());
        record[3..6].copy_from_slice(&particles.v[i].to_array());
        record[6] = particles.rho[i];
        for value in record {
            out.write_all(&value.to_le_bytes())?;
        }
    }
    out.flush()?;
    Ok(())
}
