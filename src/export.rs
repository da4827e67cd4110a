//! Frame export: one binary little-endian PLY per frame (positions, velocities, density), which
//! ParaView, Blender, Open3D and meshio open as they are. Names sort in frame order.

use crate::sim::Particles;
use anyhow::{bail, Context, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes `frame_NNNNNN.ply` files into one directory.
pub struct PlyExporter {
    dir: PathBuf,
    every: u64,
}

impl PlyExporter {
    /// Creates `dir` if needed. Refuses a directory that already holds frames, unless `overwrite`:
    /// frames a user saved from an earlier run are never replaced silently.
    pub fn new(dir: &Path, every: u64, overwrite: bool) -> Result<PlyExporter> {
        if every == 0 {
            bail!("--every must be at least 1 (export every K-th frame)");
        }
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the export directory {}", dir.display()))?;
        if !overwrite {
            let existing = std::fs::read_dir(dir)
                .with_context(|| format!("cannot read the export directory {}", dir.display()))?
                .filter_map(|e| e.ok())
                .filter(|e| is_frame_file(&e.file_name().to_string_lossy()))
                .count();
            if existing > 0 {
                bail!(
                    "{} already holds {existing} exported frame(s); pick another --export directory, \
                     or pass --overwrite to replace them",
                    dir.display()
                );
            }
        }
        Ok(PlyExporter {
            dir: dir.to_path_buf(),
            every,
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
            bail!(
                "cannot write {}: {e:#}; free some space or choose a writable --export directory",
                path.display()
            );
        }
        Ok(path)
    }
}

fn is_frame_file(name: &str) -> bool {
    name.starts_with("frame_") && name.ends_with(".ply")
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
