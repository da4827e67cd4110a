//! `--export-surface`: the water surface of exported frames as triangle meshes.
//!
//! The surface is reconstructed with `splashsurf_lib`: an SPH density field is built from the
//! particle positions alone (a cubic spline kernel), and marching cubes extracts the level set at a
//! fraction of the rest density. The reconstruction runs on worker threads fed by a bounded queue
//! ([`SurfaceQueue`], a [`FileQueue`]), so the simulation steps on while meshes are built; it waits
//! only when the queue is full, which keeps memory bounded on long runs. Each mesh goes to its file
//! (`surface_NNNNNN.obj|ply|vtk`), to the USD cache of `--export-usd` ([`UsdCache`]), or to both.
//!
//! Defaults from the scene: the spawn lattice gives each particle a cube of fluid of edge
//! `dx / n` (`n^3` particles per cell), and splashsurf's particle volume is `(2 r)^3`, so the
//! particle radius is `r = dx / (2 n)`: the kernel then reads rest density inside the water.

use super::mesh_files::{SurfaceFormat, SurfaceMesh};
use super::queue::{FileQueue, FileWords, FinishedFile};
use super::usd::UsdCache;
use super::{check_every, FrameDir, FrameKind};
use crate::sim::Scene;
use anyhow::{bail, Result};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The surface meshes of `--export-surface`: `surface_NNNNNN.obj|ply|vtk`.
pub const SURFACE_FRAMES: FrameKind = FrameKind {
    flag: "--export-surface",
    prefix: "surface_",
    extensions: &["obj", "ply", "vtk"],
    companions: &[],
    noun: ("surface mesh", "surface meshes"),
};

/// Default kernel smoothing length, in particle radii (splashsurf's convention: the kernel's
/// compact support is twice this). 2 radii reach the nearest lattice neighbours on every side.
pub const DEFAULT_SMOOTHING_LENGTH: f32 = 2.0;
/// Default iso-surface threshold, as a fraction of rest density (splashsurf's usual 0.6: the
/// surface sits just inside the outermost particles' half-spacing).
pub const DEFAULT_THRESHOLD: f32 = 0.6;
/// Default marching-cubes cell edge, in particle radii: half the particle spacing.
pub const DEFAULT_CUBE_SIZE: f32 = 1.0;
/// Marching-cubes cells along the domain's longest axis, at most: a finer grid is almost surely a
/// mistyped value, and its memory grows with the square of the cell count.
pub const MAX_CUBES_PER_AXIS: f32 = 8192.0;

/// The reconstruction's parameters, in the units of the command line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceSettings {
    /// Particle radius, m (`--surface-particle-radius`).
    pub particle_radius: f32,
    /// Kernel smoothing length, in particle radii (`--surface-smoothing-length`).
    pub smoothing_length: f32,
    /// Iso-surface threshold, a fraction of rest density (`--surface-threshold`).
    pub threshold: f32,
    /// Marching-cubes cell edge, in particle radii (`--surface-cube-size`).
    pub cube_size: f32,
    /// The fluid's rest density, kg/m^3.
    pub rest_density: f32,
}

/// The command line's overrides of [`SurfaceSettings::for_scene`]; `None` keeps the default.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SurfaceOverrides {
    pub particle_radius: Option<f32>,
    pub smoothing_length: Option<f32>,
    pub threshold: Option<f32>,
    pub cube_size: Option<f32>,
}

impl SurfaceSettings {
    /// The defaults for `scene` (see the module's comment), with `overrides` applied and every
    /// value checked.
    pub fn for_scene(scene: &Scene, overrides: SurfaceOverrides) -> Result<SurfaceSettings> {
        let settings = SurfaceSettings {
            particle_radius: overrides
                .particle_radius
                .unwrap_or(scene.dx / (2.0 * scene.particles_per_axis as f32)),
            smoothing_length: overrides.smoothing_length.unwrap_or(DEFAULT_SMOOTHING_LENGTH),
            threshold: overrides.threshold.unwrap_or(DEFAULT_THRESHOLD),
            cube_size: overrides.cube_size.unwrap_or(DEFAULT_CUBE_SIZE),
            rest_density: scene.material().rest_density,
        };
        for (flag, value) in [
            ("--surface-particle-radius", settings.particle_radius),
            ("--surface-smoothing-length", settings.smoothing_length),
            ("--surface-threshold", settings.threshold),
            ("--surface-cube-size", settings.cube_size),
        ] {
            if !(value.is_finite() && value > 0.0) {
                bail!("{flag} {value} must be a positive number");
            }
        }
        let longest = scene.grid_res.iter().copied().max().unwrap_or(0) as f32 * scene.dx;
        let cubes = longest / settings.cube_edge();
        if cubes > MAX_CUBES_PER_AXIS {
            bail!(
                "the surface's marching-cubes cell ({:.3e} m = --surface-cube-size {} x radius {:.3e} m) \
                 would cut the {longest} m domain into {cubes:.0} cells per axis, more than \
                 {MAX_CUBES_PER_AXIS}; give a larger --surface-cube-size or --surface-particle-radius",
                settings.cube_edge(),
                settings.cube_size,
                settings.particle_radius
            );
        }
        Ok(settings)
    }

    /// The marching-cubes cell edge, m.
    pub fn cube_edge(&self) -> f32 {
        self.cube_size * self.particle_radius
    }

    /// One line for the user: what the reconstruction uses.
    pub fn describe(&self) -> String {
        format!("{}, cells of {:.4e} m", self.describe_field(), self.cube_edge())
    }

    /// The field's part of [`Self::describe`] (the volumes sample the same field on voxels).
    pub fn describe_field(&self) -> String {
        format!(
            "particle radius {:.4e} m, smoothing length {} radii (kernel support {:.4e} m), \
             threshold {} x rest density",
            self.particle_radius,
            self.smoothing_length,
            self.support_radius(),
            self.threshold,
        )
    }

    /// The kernel's reach (its compact support radius), m.
    pub fn support_radius(&self) -> f32 {
        2.0 * self.smoothing_length * self.particle_radius
    }

    /// splashsurf's parameters of this field, sampled on cells of edge `cell` (marching cubes' cells,
    /// or a volume's voxels: [`super::volume`]).
    pub(crate) fn splashsurf_parameters(&self, cell: f32) -> splashsurf_lib::Parameters<f32> {
        let mut p = splashsurf_lib::Parameters::new(self.particle_radius, self.support_radius(), cell);
        p.rest_density = self.rest_density;
        p.iso_surface_threshold = self.threshold;
        p
    }
}

/// The water surface of the particles at `positions`: a closed mesh, wound counter-clockwise seen
/// from outside, with vertex normals pointing out of the water.
pub fn reconstruct(positions: &[Vec3], settings: &SurfaceSettings) -> Result<SurfaceMesh> {
    if positions.is_empty() {
        return Ok(SurfaceMesh::default());
    }
    let points: Vec<_> = positions
        .iter()
        .map(|p| splashsurf_lib::nalgebra::Vector3::new(p.x, p.y, p.z))
        .collect();
    let reconstruction = splashsurf_lib::reconstruct_surface::<i64, f32>(
        &points,
        &settings.splashsurf_parameters(settings.cube_edge()),
    )
    .map_err(|e| anyhow::anyhow!("the surface reconstruction failed: {:#}", anyhow::Error::new(e)))?;
    let mesh = reconstruction.mesh;
    if mesh.vertices.len() > i32::MAX as usize {
        bail!(
            "the surface has {} vertices, more than a mesh file can index; give a larger \
             --surface-cube-size",
            mesh.vertices.len()
        );
    }
    let vertices: Vec<[f32; 3]> = mesh.vertices.iter().map(|v| [v.x, v.y, v.z]).collect();
    // splashsurf's marching cubes wind counter-clockwise seen from outside, as the files' readers
    // expect (tests/surface_export.rs checks it through the signed volume).
    let triangles: Vec<[u32; 3]> = mesh.triangles.iter().map(|t| t.map(|i| i as u32)).collect();
    let normals = vertex_normals(&vertices, &triangles);
    Ok(SurfaceMesh {
        vertices,
        normals,
        triangles,
    })
}

/// Area-weighted vertex normals of a counter-clockwise mesh; a vertex whose triangles all have no
/// area gets `+y`, never NaN.
fn vertex_normals(vertices: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut sums = vec![Vec3::ZERO; vertices.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| Vec3::from(vertices[i as usize]));
        // Its length is twice the triangle's area: larger triangles weigh more.
        let n = (b - a).cross(c - a);
        for &i in t {
            sums[i as usize] += n;
        }
    }
    sums.iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3::Y).to_array())
        .collect()
}

/// Writes `surface_NNNNNN.<format>` meshes into one directory, the USD cache's surface layers, or
/// both.
pub struct SurfaceExporter {
    /// `None` where the meshes go to the USD cache alone (`--usd-surface` without
    /// `--export-surface`).
    frames: Option<FrameDir>,
    every: u64,
    format: SurfaceFormat,
    settings: SurfaceSettings,
    usd: Option<Arc<UsdCache>>,
}

/// One finished mesh.
#[derive(Debug, Clone)]
pub struct MeshDone {
    pub frame: u64,
    /// The mesh file, or the USD cache's layer where the mesh has no file of its own.
    pub path: PathBuf,
    pub triangles: usize,
    /// Wall time of the reconstruction (density, marching cubes, normals).
    pub reconstruct: Duration,
    /// Wall time of writing the file and the USD layer.
    pub write: Duration,
}

impl FinishedFile for MeshDone {
    const WORDS: FileWords = FileWords {
        what: "surface",
        files: SURFACE_FRAMES.noun,
        short: ("mesh", "meshes"),
        size: "triangles",
        stages: ["reconstruction", "writing"],
    };

    fn path(&self) -> &Path {
        &self.path
    }

    fn size(&self) -> u64 {
        self.triangles as u64
    }

    fn stages(&self) -> [Duration; 2] {
        [self.reconstruct, self.write]
    }

    fn contents(&self) -> String {
        format!("{} triangles", self.triangles)
    }
}

/// The meshes' worker threads ([`SurfaceExporter::export`] on each job) and the bounded queue that
/// feeds them.
pub type SurfaceQueue = FileQueue<SurfaceExporter, SurfaceJob, MeshDone>;

/// The particles of one exported frame, on their way to a worker.
pub struct SurfaceJob {
    pub frame: u64,
    /// The file's header comment (frame, time, scene).
    pub comment: String,
    pub positions: Vec<Vec3>,
}

impl SurfaceExporter {
    /// Opens `dir` as [`FrameDir::open`] says (refusing files of an earlier run unless
    /// `overwrite`); `every` is `--every`.
    pub fn new(
        dir: &Path,
        every: u64,
        format: SurfaceFormat,
        settings: SurfaceSettings,
        overwrite: bool,
    ) -> Result<SurfaceExporter> {
        check_every(every)?;
        Ok(SurfaceExporter {
            frames: Some(FrameDir::open(
                dir,
                SURFACE_FRAMES,
                format.extension(),
                overwrite,
            )?),
            every,
            format,
            settings,
            usd: None,
        })
    }

    /// Meshes for the USD cache alone, no files of their own: `--usd-surface` without
    /// `--export-surface`.
    pub fn for_usd(usd: Arc<UsdCache>, every: u64, settings: SurfaceSettings) -> Result<SurfaceExporter> {
        check_every(every)?;
        Ok(SurfaceExporter {
            frames: None,
            every,
            format: SurfaceFormat::Obj,
            settings,
            usd: Some(usd),
        })
    }

    /// Also writes each mesh into the USD cache's surface layers.
    pub fn with_usd(self, usd: Arc<UsdCache>) -> SurfaceExporter {
        SurfaceExporter {
            usd: Some(usd),
            ..self
        }
    }

    /// `--every`.
    pub fn every(&self) -> u64 {
        self.every
    }

    pub fn wants(&self, frame: u64) -> bool {
        frame % self.every == 0
    }

    /// The mesh file of `frame`, where the meshes have files (`--export-surface`).
    pub fn path_of(&self, frame: u64) -> Option<PathBuf> {
        self.frames.as_ref().map(|f| f.path_of(frame))
    }

    /// The mesh files' directory (`--export-surface`), if any.
    pub fn dir(&self) -> Option<&Path> {
        self.frames.as_ref().map(FrameDir::dir)
    }

    /// Where the meshes go, for the user: "obj in out/surface", "the USD cache out/dam.usda", or
    /// both.
    pub fn destination(&self) -> String {
        let files = self
            .frames
            .as_ref()
            .map(|f| format!("{} in {}", self.format.extension(), f.dir().display()));
        let usd = self
            .usd
            .as_ref()
            .map(|u| format!("the USD cache {}", u.path().display()));
        match (files, usd) {
            (Some(files), Some(usd)) => format!("{files} and {usd}"),
            (files, usd) => files.or(usd).unwrap_or_default(),
        }
    }

    pub fn format(&self) -> SurfaceFormat {
        self.format
    }

    pub fn settings(&self) -> &SurfaceSettings {
        &self.settings
    }

    /// One line for the user about the meshes `--overwrite` removed, or `None`.
    pub fn removed_note(&self) -> Option<String> {
        self.frames.as_ref().and_then(FrameDir::removed_note)
    }

    /// Reconstructs and writes one frame's mesh, here and now.
    pub fn export(&self, job: &SurfaceJob) -> Result<MeshDone> {
        let start = Instant::now();
        let mesh = reconstruct(&job.positions, &self.settings)?;
        let reconstructed = Instant::now();
        let comment = format!("{}\nsurface: {}", job.comment, self.settings.describe());
        let file = self
            .frames
            .as_ref()
            .map(|frames| frames.write(job.frame, |out| self.format.write(out, &comment, &mesh)))
            .transpose()?;
        let layer = self
            .usd
            .as_ref()
            .map(|usd| usd.write_surface(job.frame, &comment, &mesh))
            .transpose()?;
        let path = file
            .or(layer)
            .expect("a surface exporter writes a file or a USD layer");
        Ok(MeshDone {
            frame: job.frame,
            path,
            triangles: mesh.triangles.len(),
            reconstruct: reconstructed - start,
            write: reconstructed.elapsed(),
        })
    }
}
