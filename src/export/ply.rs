//! The particle frames of `--export`: one binary little-endian PLY of the live particles per
//! exported frame ([`write_ply`]), written by [`PlyExporter`] into one directory, and the queue of
//! writer threads the export thread hands them to ([`PlyQueue`]).

use super::queue::Workers;
use super::{check_every, deformation_measures, material_comment, FrameDir, FrameKind};
use crate::sim::material::NamedMaterial;
use crate::sim::Particles;
use anyhow::Result;
use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The particle frames of `--export`.
pub const PARTICLE_FRAMES: FrameKind = FrameKind {
    flag: "--export",
    prefix: "frame_",
    extensions: &["ply"],
    companions: &[],
    noun: ("frame", "frames"),
};

/// Writes `frame_NNNNNN.ply` files of the particles into one directory.
pub struct PlyExporter {
    frames: FrameDir,
    every: u64,
}

impl PlyExporter {
    /// Opens the directory as [`FrameDir::open`] says; `every` is `--every` (at least 1).
    pub fn new(dir: &Path, every: u64, overwrite: bool) -> Result<PlyExporter> {
        check_every(every)?;
        Ok(PlyExporter {
            frames: FrameDir::open(dir, PARTICLE_FRAMES, "ply", overwrite)?,
            every,
        })
    }

    /// The frames of an earlier run that `--overwrite` removed, in name order.
    pub fn removed(&self) -> &[PathBuf] {
        self.frames.removed()
    }

    pub fn dir(&self) -> &Path {
        self.frames.dir()
    }

    /// One line for the user about [`Self::removed`], or `None` when nothing was removed.
    pub fn removed_note(&self) -> Option<String> {
        self.frames.removed_note()
    }

    /// `--every`.
    pub fn every(&self) -> u64 {
        self.every
    }

    pub fn wants(&self, frame: u64) -> bool {
        frame % self.every == 0
    }

    pub fn path_of(&self, frame: u64) -> PathBuf {
        self.frames.path_of(frame)
    }

    /// Writes the frame to a temporary name and renames it, so a failed write never leaves a
    /// truncated file under a frame's name. `materials` is the scene's table, which the particles'
    /// rows index.
    pub fn write(
        &self,
        frame: u64,
        comment: &str,
        particles: &Particles,
        materials: &[NamedMaterial],
    ) -> Result<PathBuf> {
        self.frames
            .write(frame, |out| write_ply(out, comment, particles, materials))
    }
}

/// The float vertex properties, in file order; [`PLY_MATERIAL_PROPERTY`] follows them.
pub const PLY_PROPERTIES: [&str; 7] = ["x", "y", "z", "vx", "vy", "vz", "density"];
/// The last vertex property, a `uchar`: the particle's row of the material table, which the
/// header's `comment material ROW NAME R G B` lines name and colour.
pub const PLY_MATERIAL_PROPERTY: &str = "material";

/// The float vertex properties that follow [`PLY_MATERIAL_PROPERTY`] where the particles carry a
/// deformation (a solid, or a liquid with the elastic regularisation of its yield stress): `J`, a
/// solid's volume ratio det F (the elastic part's times snow's plastic J_p; a liquid's rest density
/// over its density), and `von_mises`, the von Mises stress sqrt(3/2 s:s) in Pa of a solid, s the
/// deviatoric part of its Cauchy stress tau / J_E, or of an elastoviscoplastic liquid's elastic
/// part (sqrt(3) tau_y where it yields); 0 for other liquids.
pub const PLY_SOLID_PROPERTIES: [&str; 2] = ["J", "von_mises"];

/// A binary little-endian PLY of `particles`: `comment` (each line a `comment`), a `comment
/// material` line for each of `materials`, then per vertex the float [`PLY_PROPERTIES`], the
/// `uchar` material row and, where the particles carry a deformation, [`PLY_SOLID_PROPERTIES`].
pub fn write_ply(
    mut out: impl Write,
    comment: &str,
    particles: &Particles,
    materials: &[NamedMaterial],
) -> Result<()> {
    writeln!(out, "ply\nformat binary_little_endian 1.0")?;
    for line in comment.lines() {
        writeln!(out, "comment {line}")?;
    }
    for (row, material) in materials.iter().enumerate() {
        writeln!(out, "comment {}", material_comment(row, material))?;
    }
    writeln!(out, "element vertex {}", particles.len())?;
    for p in PLY_PROPERTIES {
        writeln!(out, "property float {p}")?;
    }
    writeln!(out, "property uchar {PLY_MATERIAL_PROPERTY}")?;
    let deformed = !particles.deformation.is_empty();
    if deformed {
        for p in PLY_SOLID_PROPERTIES {
            writeln!(out, "property float {p}")?;
        }
    }
    writeln!(out, "end_header")?;
    // The vertices as bytes, a chunk of particles a task on rayon's pool, then one write: a
    // write call per value cost the dam break's frame tens of milliseconds.
    let record = 7 * 4 + 1 + if deformed { 2 * 4 } else { 0 };
    const CHUNK: usize = 1 << 14;
    let chunks: Vec<Vec<u8>> = (0..particles.len().div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let range = chunk * CHUNK..((chunk + 1) * CHUNK).min(particles.len());
            let mut bytes = Vec::with_capacity(range.len() * record);
            for i in range {
                let values = particles.x[i]
                    .to_array()
                    .into_iter()
                    .chain(particles.v[i].to_array());
                for value in values.chain([particles.rho[i]]) {
                    bytes.extend_from_slice(&value.to_le_bytes());
                }
                bytes.push(particles.material[i]);
                if deformed {
                    let (j, von_mises) = deformation_measures(particles, i, materials);
                    bytes.extend_from_slice(&j.to_le_bytes());
                    bytes.extend_from_slice(&von_mises.to_le_bytes());
                }
            }
            bytes
        })
        .collect();
    for bytes in chunks {
        out.write_all(&bytes)?;
    }
    out.flush()?;
    Ok(())
}

/// The PLY frames' writer threads (each formats its vertices on rayon's pool).
pub const PLY_WORKERS: usize = 2;

/// The PLY frames' writer threads and their queue.
pub struct PlyQueue {
    pub exporter: Arc<PlyExporter>,
    workers: Workers<PlyJob, Duration>,
    /// Frames written, and their summed wall time.
    written: u64,
    writing: Duration,
}

/// One frame for the PLY writers: the live particles, shared with the frame's USD layer.
pub struct PlyJob {
    pub frame: u64,
    pub comment: String,
    pub particles: Arc<Particles>,
}

impl PlyQueue {
    pub fn start(
        exporter: PlyExporter,
        materials: Arc<Vec<NamedMaterial>>,
        waiting: usize,
    ) -> Result<PlyQueue> {
        let exporter = Arc::new(exporter);
        let writer = exporter.clone();
        let workers = Workers::start("ply", PLY_WORKERS, waiting, move |job: PlyJob| {
            let start = Instant::now();
            writer.write(job.frame, &job.comment, &job.particles, &materials)?;
            Ok(start.elapsed())
        })?;
        Ok(PlyQueue {
            exporter,
            workers,
            written: 0,
            writing: Duration::ZERO,
        })
    }

    pub fn submit(&mut self, job: PlyJob) -> Result<()> {
        let (written, writing) = (&mut self.written, &mut self.writing);
        self.workers.submit(job, &mut |took| {
            *written += 1;
            *writing += took;
        })
    }

    pub fn collect(&mut self) -> Result<()> {
        let (written, writing) = (&mut self.written, &mut self.writing);
        self.workers.collect(
            &mut |took| {
                *written += 1;
                *writing += took;
            },
            false,
        )
    }

    /// Waits for every frame handed over; the closing line.
    pub fn finish(self) -> Result<String> {
        let PlyQueue {
            exporter,
            workers,
            mut written,
            mut writing,
        } = self;
        let (threads, waited) = (workers.threads(), workers.waited());
        workers.finish(&mut |took| {
            written += 1;
            writing += took;
        })?;
        Ok(format!(
            "exported {} into {} ({:.2} ms a frame on {threads} writer threads; the export thread \
             waited {:.2} s for the queue)",
            crate::text::count(written, "particle frame", "particle frames"),
            exporter.dir().display(),
            1e3 * writing.as_secs_f64() / written.max(1) as f64,
            waited.as_secs_f64()
        ))
    }
}
