//! A checkpoint's particles where they lie in its file: read whole for a run of one process, or a
//! share at a time for a process of one rank (`dist::Start`), which then never holds the run's
//! particles, only its own.

use crate::dist::migrate::{layer, RankParticles};
use crate::dist::{Slabs, Start};
use crate::sim::{Deformation, Particles};
use anyhow::{anyhow, bail, Result};
use glam::{Mat3, Vec3};
use std::fs::File;
use std::ops::Range;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

// Every array is read into place as the file's little-endian words are laid out; a big-endian host
// would need them turned (mpm runs on x86_64 and aarch64, both little-endian).
const _: () = assert!(cfg!(target_endian = "little"));

/// Particles a question reads at a time: a few tens of megabytes of their arrays.
const CHUNK: usize = 1 << 20;

/// Where each particle array begins in the file (the format: the module doc of checkpoint.rs).
#[derive(Debug, Clone, Copy)]
pub(super) struct ParticleLayout {
    pub count: usize,
    pub x: u64,
    pub v: u64,
    pub c: u64,
    pub rho: u64,
    pub live: u64,
    /// None in version 1, whose particles are all of row 0.
    pub material: Option<u64>,
    pub deformation: Option<u64>,
    pub volume_bias: Option<u64>,
}

/// A checkpoint's particles, left in its file (`Checkpoint::open`).
#[derive(Debug)]
pub struct ParticlesInFile {
    file: File,
    /// For messages.
    path: PathBuf,
    layout: ParticleLayout,
    live: u64,
    /// Particles a question reads at a time (CHUNK; fewer in the tests, to cross pieces).
    chunk: usize,
}

impl ParticlesInFile {
    /// The particles of `file` as `layout` places them, their live flags counted and their
    /// material rows checked against a table of `materials` rows (both read a piece at a time).
    pub(super) fn new(
        file: File,
        path: &Path,
        layout: ParticleLayout,
        materials: u32,
    ) -> Result<ParticlesInFile> {
        let mut particles = ParticlesInFile {
            file,
            path: path.to_path_buf(),
            layout,
            live: 0,
            chunk: CHUNK,
        };
        for range in particles.pieces() {
            let live = particles.array::<u8>(layout.live, range.clone(), "live flags")?;
            particles.live += live.iter().filter(|&&l| l != 0).count() as u64;
            if let Some(material) = layout.material {
                let rows = particles.array::<u8>(material, range.clone(), "material rows")?;
                if let Some(i) = rows.iter().position(|&m| u32::from(m) >= materials) {
                    bail!(
                        "slot {} is made of material row {}, but the table has {materials}",
                        range.start + i,
                        rows[i]
                    );
                }
            }
        }
        Ok(particles)
    }

    /// Every particle.
    pub fn read_all(&self) -> Result<Particles> {
        self.read(0..self.layout.count)
    }

    /// The particles of `range`, every array.
    fn read(&self, range: Range<usize>) -> Result<Particles> {
        let l = &self.layout;
        Ok(Particles {
            x: self.array::<Vec3>(l.x, range.clone(), "positions")?,
            v: self.array::<Vec3>(l.v, range.clone(), "velocities")?,
            c: self.array::<Mat3>(l.c, range.clone(), "affine matrices")?,
            rho: self.array::<f32>(l.rho, range.clone(), "densities")?,
            live: self
                .array::<u8>(l.live, range.clone(), "live flags")?
                .into_iter()
                .map(|b| b != 0)
                .collect(),
            material: match l.material {
                Some(at) => self.array::<u8>(at, range.clone(), "material rows")?,
                None => vec![0; range.len()],
            },
            deformation: match l.deformation {
                Some(at) => self.array::<Deformation>(at, range.clone(), "deformations")?,
                None => Vec::new(),
            },
            volume_bias: match l.volume_bias {
                Some(at) => self.array::<f32>(at, range, "volume biases")?,
                None => Vec::new(),
            },
        })
    }

    /// Items `range` of the array of `T` at `at`, read in place.
    fn array<T: bytemuck::Pod>(&self, at: u64, range: Range<usize>, what: &str) -> Result<Vec<T>> {
        let size = std::mem::size_of::<T>();
        let mut items = vec![T::zeroed(); range.len()];
        self.file
            .read_exact_at(
                bytemuck::cast_slice_mut(&mut items),
                at + (range.start * size) as u64,
            )
            .map_err(|e| {
                anyhow!(
                    "cannot read the {what} of checkpoint {}: {}",
                    self.path.display(),
                    crate::text::io_reason(&e)
                )
            })?;
        Ok(items)
    }

    /// The particles in pieces of `chunk`.
    fn pieces(&self) -> impl Iterator<Item = Range<usize>> {
        let (count, chunk) = (self.layout.count, self.chunk);
        (0..count)
            .step_by(chunk)
            .map(move |start| start..(start + chunk).min(count))
    }

    /// Per particle of `range`, whether it is live, and its position.
    fn live_positions(&self, range: Range<usize>) -> Result<(Vec<u8>, Vec<Vec3>)> {
        let live = self.array::<u8>(self.layout.live, range.clone(), "live flags")?;
        Ok((live, self.array::<Vec3>(self.layout.x, range, "positions")?))
    }
}

impl Start for ParticlesInFile {
    fn slots(&self) -> usize {
        self.layout.count
    }

    fn live(&self) -> u64 {
        self.live
    }

    fn layer_counts(&self, slabs: &Slabs, inv_dx: f32) -> Result<Vec<u64>> {
        let mut counts = vec![0u64; slabs.blocks() as usize];
        for range in self.pieces() {
            let (live, x) = self.live_positions(range)?;
            for (_, &x) in live.iter().zip(&x).filter(|(&l, _)| l != 0) {
                counts[layer(x, slabs.axis, inv_dx).min(slabs.blocks() - 1) as usize] += 1;
            }
        }
        Ok(counts)
    }

    /// A piece at a time: the pieces' live particles of `rank`'s slab, every array of them.
    fn share(&self, slabs: &Slabs, rank: usize, inv_dx: f32) -> Result<RankParticles> {
        let mut mine = RankParticles {
            deformed: self.layout.deformation.is_some(),
            ..RankParticles::default()
        };
        for range in self.pieces() {
            let (live, x) = self.live_positions(range.clone())?;
            let owned: Vec<usize> = (0..range.len())
                .filter(|&i| live[i] != 0 && slabs.owner(layer(x[i], slabs.axis, inv_dx)) == rank)
                .collect();
            if owned.is_empty() {
                continue;
            }
            mine.particles.append(&mut self.read(range.clone())?.pick(&owned));
            mine.id.extend(owned.iter().map(|&i| (range.start + i) as u32));
        }
        Ok(mine)
    }
}

#[cfg(test)]
mod tests {
    use crate::backend::{self, BackendKind};
    use crate::checkpoint::Checkpoint;
    use crate::dist::share::assert_answers_as_whole;
    use crate::sim::{Scene, Simulation};

    /// `fountain`'s start (a third of its slots live, the rest parked) saved, then read back a
    /// piece at a time in pieces that cross its arrays' ends: every question answered as the
    /// particles read whole answer it.
    #[test]
    fn a_share_read_from_the_file_is_the_share_of_the_particles_read_whole() {
        let scene = Scene::load("fountain").unwrap();
        let solver = backend::create(BackendKind::Cpu, &scene).unwrap();
        let mut sim = Simulation::new(scene.clone(), solver);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("start.mpmck");
        Checkpoint::capture(&mut sim).unwrap().write_new(&path).unwrap();
        let whole = Checkpoint::read(&path).unwrap().particles;
        let (opened, mut in_file) = Checkpoint::open(&path).unwrap();
        assert!(opened.particles.is_empty() && opened.slots == whole.len());
        in_file.chunk = 7_001;
        assert!(whole.num_live() < whole.len(), "the start has parked slots");
        assert!(in_file.read_all().unwrap() == whole);
        assert_answers_as_whole(&scene, &in_file, &whole, 3);
    }
}
