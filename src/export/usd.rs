//! `--export-usd FILE.usda`: the run as one USD stage, for Houdini, usdview, Omniverse and
//! Blender: the particles as a time-sampled `Points` prim, the water surface as a time-sampled
//! `Mesh`, the colliders and rigid bodies as meshes with their transforms, at the 60 Hz frame rate
//! (a time code a frame).
//!
//! The stage is USD's text format, in value clips (USD's "Sequencable, Re-timable Animated Value
//! Clips"): `FILE.usda`, the root layer, declares the prims and their attributes and holds what
//! does not change (the colliders' meshes, a static collider's pose, the particles' width);
//! `FILE_clips/` holds a layer a frame, `particles_NNNNNN.usda` (the particles and the moving
//! colliders' poses) and `surface_NNNNNN.usda` (the surface mesh), each the time samples of its one
//! frame, and a manifest a clip set naming the attributes its layers sample. USD opens a frame's
//! layers only when a value at that frame is asked for, so a long run opens as fast as a short
//! one; one text file of every frame would be parsed whole on opening (about 40 MB a frame of the
//! 451,200-particle dam break).
//!
//! Files are safe as the other exports' are: each layer is written under a temporary name and
//! renamed when whole, and the root layer, rewritten after each layer to name the layers written so
//! far, is renamed over the last one. An interrupted run leaves a stage that opens, holding the
//! frames finished. Everything is checked before the first step: an existing root or clip layers
//! are refused unless `--overwrite`.

use super::mesh_files::SurfaceMesh;
use super::queue::Workers;
use super::{check_output_file, deformation_measures, partial_path, write_atomically, FrameDir, FrameKind};
use crate::export::bodies::shape_mesh;
use crate::render::colliders::shape_triangles;
use crate::sim::colliders::Motion;
use crate::sim::material::NamedMaterial;
use crate::sim::params::FRAME_DT;
use crate::sim::{Particles, Scene, Simulation};
use anyhow::{bail, Result};
use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The particle layers (and the moving colliders' poses) of `--export-usd`, in `FILE_clips/`.
pub const PARTICLE_CLIPS: FrameKind = FrameKind {
    flag: "--export-usd",
    prefix: "particles_",
    extensions: &["usda"],
    companions: &[PARTICLE_MANIFEST],
    noun: ("USD particle layer", "USD particle layers"),
};

/// The surface layers of `--export-usd`, in `FILE_clips/`.
pub const SURFACE_CLIPS: FrameKind = FrameKind {
    flag: "--export-usd",
    prefix: "surface_",
    extensions: &["usda"],
    companions: &[SURFACE_MANIFEST],
    noun: ("USD surface layer", "USD surface layers"),
};

const PARTICLE_MANIFEST: &str = "particles.manifest.usda";
const SURFACE_MANIFEST: &str = "surface.manifest.usda";

/// The prim every other prim is under: the stage's default prim, where the clip sets are authored.
pub const ROOT_PRIM: &str = "/Sim";

/// The particles' attributes a frame samples, with their USD types, in the order they are written
/// (the primvars `J` and `von_mises` follow where the particles carry a deformation).
const PARTICLE_ATTRIBUTES: [(&str, &str); 5] = [
    ("point3f[]", "points"),
    ("vector3f[]", "velocities"),
    ("float3[]", "extent"),
    ("float[]", "primvars:density"),
    ("int[]", "primvars:material"),
];

/// The deformation's primvars, as in the PLY frames ([`super::PLY_SOLID_PROPERTIES`]).
const DEFORMATION_ATTRIBUTES: [(&str, &str); 2] =
    [("float[]", "primvars:J"), ("float[]", "primvars:von_mises")];

/// The surface mesh's attributes a frame samples.
const SURFACE_ATTRIBUTES: [(&str, &str); 5] = [
    ("point3f[]", "points"),
    ("normal3f[]", "normals"),
    ("int[]", "faceVertexCounts"),
    ("int[]", "faceVertexIndices"),
    ("float3[]", "extent"),
];

/// A moving collider's attributes a frame samples: its transform.
const POSE_ATTRIBUTES: [(&str, &str); 2] = [("double3", "xformOp:translate"), ("quatd", "xformOp:orient")];

/// A collider as the stage holds it: its mesh in its own frame, placed by a translate and an orient.
struct UsdCollider {
    /// Its index among the scene's colliders: the prim is `collider_K`, as in `--export-bodies`.
    index: usize,
    /// "box", "sphere", ... and what moves it.
    kind: String,
    mesh: SurfaceMesh,
    /// A static collider's pose, written once in the root layer; `None` for one that moves (a rigid
    /// body or a scripted motion), whose pose each particle layer samples.
    fixed: Option<Pose>,
}

/// A collider's transform: its centre (m) and its orientation, a unit quaternion (x, y, z, w).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub center: [f64; 3],
    pub orientation: [f64; 4],
}

/// The clip layers written so far: what the root layer names.
#[derive(Default)]
struct Written {
    particles: Vec<u64>,
    surface: Vec<u64>,
    /// The manifests are written with the first root layer: a run that fails before its first frame
    /// leaves nothing.
    manifests: bool,
}

/// One run's USD stage: the root layer and its clip layers. Shared by the thread that writes the
/// particle layers and the surface workers, which write the surface layers.
pub struct UsdCache {
    path: PathBuf,
    /// `FILE_clips`, the folder's name beside the root layer, as the root's asset paths name it.
    clips_name: String,
    particles: FrameDir,
    surface: FrameDir,
    every: u64,
    /// Whether the surface is reconstructed into the stage.
    has_surface: bool,
    /// Whether the particles carry a deformation (the primvars `J` and `von_mises`).
    deformation: bool,
    colliders: Vec<UsdCollider>,
    /// The particles' diameter, m: the spawn lattice's spacing.
    width: f32,
    materials: Vec<NamedMaterial>,
    /// The scene, for the root layer's doc string.
    about: String,
    written: Mutex<Written>,
    /// An earlier run's root layer that `--overwrite` removed.
    replaced: bool,
}

impl UsdCache {
    /// Claims `path` (a `.usda` or `.usd` file) and its clip folder `FILE_clips/` for a run of
    /// `scene`, before the first step: a bad name, a folder that is missing or cannot be written,
    /// an earlier run's root layer or clip layers (unless `overwrite`, which removes them) fail now,
    /// naming the fix. `has_surface`: the surface is reconstructed into the stage; `every`: `--every`.
    pub fn create(
        path: &Path,
        scene: &Scene,
        every: u64,
        has_surface: bool,
        overwrite: bool,
    ) -> Result<UsdCache> {
        super::check_every(every)?;
        let shown = path.display();
        let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !matches!(extension, "usda" | "usd") {
            bail!(
                "--export-usd {shown}: name a .usda file (USD's text format, which mpm writes; .usd \
                 works too); for binary .usdc, convert the stage afterwards (docs/export.md, \"USD\")"
            );
        }
        let Some(stem) = path.file_stem().and_then(|s| s.to_str()) else {
            bail!("--export-usd {shown}: the file name is not valid UTF-8; rename it")
        };
        // The clip folder's name goes into the root layer as an asset path, `@./NAME/...@`.
        if stem.chars().any(|c| c == '@' || c.is_control()) {
            bail!("--export-usd {shown}: a USD asset path cannot hold '@' or control characters; rename it");
        }
        check_output_file(path, "--export-usd", overwrite)?;
        let clips_name = format!("{stem}_clips");
        let clips = path.with_file_name(&clips_name);
        if clips.exists() && !clips.is_dir() {
            bail!(
                "--export-usd {shown}: {} is a file, and the stage's frames go into a folder of that \
                 name; move it, or choose another --export-usd name",
                clips.display()
            );
        }
        let unfinished = partial_path(path);
        if unfinished.exists() {
            std::fs::remove_file(&unfinished)?;
        }
        let particles = FrameDir::open(&clips, PARTICLE_CLIPS, "usda", overwrite)?;
        let surface = FrameDir::open(&clips, SURFACE_CLIPS, "usda", overwrite)?;
        let replaced = path.exists();
        if replaced {
            std::fs::remove_file(path).map_err(|e| {
                anyhow::anyhow!(
                    "--overwrite: cannot remove {shown}: {}",
                    crate::text::io_reason(&e)
                )
            })?;
        }
        let mut bodies = 0;
        let colliders = scene
            .colliders
            .list
            .iter()
            .enumerate()
            .map(|(index, c)| {
                let moves = if c.body.is_some() {
                    bodies += 1;
                    "rigid body"
                } else if matches!(c.motion, Motion::Static) {
                    "static"
                } else {
                    "moving"
                };
                let pose = c.pose(0.0);
                UsdCollider {
                    index,
                    kind: format!("{} ({moves})", c.shape.kind_name()),
                    mesh: shape_mesh(&shape_triangles(&c.shape)),
                    fixed: (moves == "static").then_some(Pose {
                        center: pose.center.to_array(),
                        orientation: pose.rotation.to_array(),
                    }),
                }
            })
            .collect();
        Ok(UsdCache {
            path: path.to_path_buf(),
            clips_name,
            particles,
            surface,
            every,
            has_surface,
            deformation: scene.has_deformation(),
            colliders,
            width: scene.dx / scene.particles_per_axis as f32,
            materials: scene.materials.clone(),
            about: format!(
                "scene {} ({}), dx = {} m, grid {}x{}x{}",
                scene.name, scene.source, scene.dx, scene.grid_res[0], scene.grid_res[1], scene.grid_res[2]
            ),
            written: Mutex::new(Written::default()),
            replaced,
        })
    }

    /// The root layer.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The clip layers' folder.
    pub fn clips_dir(&self) -> &Path {
        self.particles.dir()
    }

    /// `--every`.
    pub fn every(&self) -> u64 {
        self.every
    }

    pub fn wants(&self, frame: u64) -> bool {
        frame % self.every == 0
    }

    /// Whether the surface goes into the stage.
    pub fn has_surface(&self) -> bool {
        self.has_surface
    }

    /// What opening removed, for the user: a killed run's unfinished layers, and with `--overwrite`
    /// an earlier run's root layer and clip layers; `None` when nothing was removed.
    pub fn removed_note(&self) -> Option<String> {
        let root = self
            .replaced
            .then(|| format!("--overwrite: removed the earlier {}", self.path.display()));
        let notes: Vec<String> = [root, self.particles.removed_note(), self.surface.removed_note()]
            .into_iter()
            .flatten()
            .collect();
        (!notes.is_empty()).then(|| notes.join("\n"))
    }

    /// The particle layer of frame `frame`.
    pub fn particles_path(&self, frame: u64) -> PathBuf {
        self.particles.path_of(frame)
    }

    /// The surface layer of frame `frame`.
    pub fn surface_path(&self, frame: u64) -> PathBuf {
        self.surface.path_of(frame)
    }

    /// The moving colliders' poses now (the rigid bodies' as of the last frame's end), in the order
    /// of the colliders that move: what [`UsdFrame::poses`] holds.
    pub fn poses(&self, sim: &Simulation) -> Vec<Pose> {
        let mut bodies = sim.bodies().iter();
        sim.scene()
            .colliders
            .list
            .iter()
            .filter_map(|c| match (&c.body, &c.motion) {
                (Some(_), _) => bodies.next().map(|b| Pose {
                    center: b.center,
                    orientation: b.orientation,
                }),
                (None, Motion::Static) => None,
                (None, _) => {
                    let pose = c.pose(sim.time());
                    Some(Pose {
                        center: pose.center.to_array(),
                        orientation: pose.rotation.to_array(),
                    })
                }
            })
            .collect()
    }

    /// Writes frame `frame`'s particle layer (the particles and the moving colliders' poses), then
    /// the root layer naming it.
    pub fn write_particles(&self, job: &UsdFrame) -> Result<PathBuf> {
        let moving: Vec<&UsdCollider> = self.colliders.iter().filter(|c| c.fixed.is_none()).collect();
        if moving.len() != job.poses.len() {
            bail!(
                "--export-usd: {} poses for {} moving colliders",
                job.poses.len(),
                moving.len()
            );
        }
        let path = self.particles.write(job.frame, |out| {
            let frame = job.frame;
            let p = &job.particles;
            write_header(out, &job.comment)?;
            writeln!(out, "def Xform \"Sim\"\n{{\n    def Points \"Particles\"\n    {{")?;
            sampled(out, frame, "point3f[] points", |out| {
                write_array(out, &p.x, |b, x| vec3(b, x.to_array()))
            })?;
            sampled(out, frame, "vector3f[] velocities", |out| {
                write_array(out, &p.v, |b, v| vec3(b, v.to_array()))
            })?;
            let extent = points_extent(&p.x, self.width / 2.0);
            sampled(out, frame, "float3[] extent", |out| {
                write_array(out, &extent, |b, x| vec3(b, *x))
            })?;
            sampled(out, frame, "float[] primvars:density", |out| {
                write_array(out, &p.rho, |b, &r| float(b, r))
            })?;
            sampled(out, frame, "int[] primvars:material", |out| {
                write_array(out, &p.material, |b, &m| integer(b, u32::from(m)))
            })?;
            if self.deformation && !p.deformation.is_empty() {
                let measures: Vec<(f32, f32)> = (0..p.len())
                    .into_par_iter()
                    .map(|i| deformation_measures(p, i, &self.materials))
                    .collect();
                sampled(out, frame, "float[] primvars:J", |out| {
                    write_array(out, &measures, |b, m| float(b, m.0))
                })?;
                sampled(out, frame, "float[] primvars:von_mises", |out| {
                    write_array(out, &measures, |b, m| float(b, m.1))
                })?;
            }
            writeln!(out, "    }}")?;
            if !moving.is_empty() {
                writeln!(out, "\n    def Scope \"Colliders\"\n    {{")?;
                for (collider, pose) in moving.iter().zip(&job.poses) {
                    writeln!(out, "        def Mesh \"collider_{}\"\n        {{", collider.index)?;
                    let [x, y, z] = pose.center;
                    let [qx, qy, qz, qw] = pose.orientation;
                    writeln!(
                        out,
                        "            double3 xformOp:translate.timeSamples = {{ {frame}: ({x:?}, {y:?}, {z:?}) }}\n            \
                         quatd xformOp:orient.timeSamples = {{ {frame}: ({qw:?}, {qx:?}, {qy:?}, {qz:?}) }}\n        }}"
                    )?;
                }
                writeln!(out, "    }}")?;
            }
            writeln!(out, "}}")?;
            Ok(())
        })?;
        self.publish(|w| w.particles.push(job.frame))?;
        Ok(path)
    }

    /// Writes frame `frame`'s surface layer, then the root layer naming it.
    pub fn write_surface(&self, frame: u64, comment: &str, mesh: &SurfaceMesh) -> Result<PathBuf> {
        let path = self.surface.write(frame, |out| {
            write_header(out, comment)?;
            writeln!(out, "def Xform \"Sim\"\n{{\n    def Mesh \"Surface\"\n    {{")?;
            write_mesh_samples(out, frame, mesh)?;
            writeln!(out, "    }}\n}}")?;
            Ok(())
        })?;
        self.publish(|w| w.surface.push(frame))?;
        Ok(path)
    }

    /// Records a layer written (`add`), then rewrites the root layer to name every layer written,
    /// under the lock: the particle thread and the surface workers take turns.
    fn publish(&self, add: impl FnOnce(&mut Written)) -> Result<()> {
        let mut written = self
            .written
            .lock()
            .map_err(|_| anyhow::anyhow!("--export-usd: a thread writing the stage failed"))?;
        add(&mut written);
        if !written.manifests {
            self.write_manifests()?;
            written.manifests = true;
        }
        // Workers finish out of order; the root lists the frames in order.
        written.particles.sort_unstable();
        written.surface.sort_unstable();
        let text = self.root_layer(&written);
        write_atomically(&self.path, |out| Ok(out.write_all(text.as_bytes())?))
    }

    /// The manifests: which attributes each clip set's layers sample.
    fn write_manifests(&self) -> Result<()> {
        let mut particles =
            String::from("#usda 1.0\n\ndef Xform \"Sim\"\n{\n    def Points \"Particles\"\n    {\n");
        for (kind, name) in self.particle_attributes() {
            particles += &format!("        {kind} {name}\n");
        }
        particles += "    }\n";
        let moving: Vec<&UsdCollider> = self.colliders.iter().filter(|c| c.fixed.is_none()).collect();
        if !moving.is_empty() {
            particles += "\n    def Scope \"Colliders\"\n    {\n";
            for c in moving {
                particles += &format!("        def Mesh \"collider_{}\"\n        {{\n", c.index);
                for (kind, name) in POSE_ATTRIBUTES {
                    particles += &format!("            {kind} {name}\n");
                }
                particles += "        }\n";
            }
            particles += "    }\n";
        }
        particles += "}\n";
        let clips = self.clips_dir();
        write_atomically(&clips.join(PARTICLE_MANIFEST), |out| {
            Ok(out.write_all(particles.as_bytes())?)
        })?;
        if self.has_surface {
            let mut surface =
                String::from("#usda 1.0\n\ndef Xform \"Sim\"\n{\n    def Mesh \"Surface\"\n    {\n");
            for (kind, name) in SURFACE_ATTRIBUTES {
                surface += &format!("        {kind} {name}\n");
            }
            surface += "    }\n}\n";
            write_atomically(&clips.join(SURFACE_MANIFEST), |out| {
                Ok(out.write_all(surface.as_bytes())?)
            })?;
        }
        Ok(())
    }

    fn particle_attributes(&self) -> Vec<(&'static str, &'static str)> {
        let mut attributes = PARTICLE_ATTRIBUTES.to_vec();
        if self.deformation {
            attributes.extend(DEFORMATION_ATTRIBUTES);
        }
        attributes
    }

    /// The root layer's text: the stage's metadata, the clip sets naming the layers in `written`,
    /// and the prims with their attributes (values only for what never changes).
    fn root_layer(&self, written: &Written) -> String {
        let first = written.particles.first().copied().unwrap_or(0);
        let last = written.particles.last().copied().unwrap_or(0);
        let fps = (1.0 / f64::from(FRAME_DT)).round();
        let mut s = format!(
            "#usda 1.0\n(\n    doc = \"\"\"Written by mpm --export-usd: {}; {} to {last} (every {}). \
             The frames are value clips in ./{}/: a layer a frame.\"\"\"\n    defaultPrim = \"Sim\"\n    \
             metersPerUnit = 1\n    upAxis = \"Y\"\n    timeCodesPerSecond = {fps}\n    framesPerSecond = {fps}\n    \
             startTimeCode = {first}\n    endTimeCode = {last}\n)\n\n",
            self.about,
            crate::text::count(written.particles.len() as u64, "frame", "frames"),
            self.every,
            self.clips_name
        );
        s += "def Xform \"Sim\" (\n    clips = {\n";
        s += &self.clip_set("particles", "particles_", PARTICLE_MANIFEST, &written.particles);
        if self.has_surface && !written.surface.is_empty() {
            s += &self.clip_set("surface", "surface_", SURFACE_MANIFEST, &written.surface);
        }
        s += "    }\n)\n{\n";
        // The particles.
        s += "    def Points \"Particles\"\n    {\n";
        for (kind, name) in self.particle_attributes() {
            let interpolation = if name.starts_with("primvars:") {
                " (\n            interpolation = \"vertex\"\n        )"
            } else {
                ""
            };
            s += &format!("        {kind} {name}{interpolation}\n");
        }
        s += &format!(
            "        float[] widths = [{}] (\n            interpolation = \"constant\"\n        )\n",
            self.width
        );
        let names: Vec<String> = self.materials.iter().map(|m| format!("{:?}", m.name)).collect();
        let colours: Vec<String> = self.materials.iter().map(|m| tuple(m.colour)).collect();
        s += &format!(
            "        color3f[] primvars:displayColor = [{}] (\n            interpolation = \"constant\"\n        )\n",
            colours[0]
        );
        s += &format!(
            "        custom string[] mpm:materialNames = [{}]\n        custom color3f[] mpm:materialColors = [{}]\n    }}\n",
            names.join(", "),
            colours.join(", ")
        );
        // The surface.
        if self.has_surface {
            s += "\n    def Mesh \"Surface\"\n    {\n";
            for (kind, name) in SURFACE_ATTRIBUTES {
                let interpolation = if name == "normals" {
                    " (\n            interpolation = \"vertex\"\n        )"
                } else {
                    ""
                };
                s += &format!("        {kind} {name}{interpolation}\n");
            }
            s += &format!(
                "        uniform token subdivisionScheme = \"none\"\n        color3f[] primvars:displayColor = [{}] (\n            \
                 interpolation = \"constant\"\n        )\n    }}\n",
                colours[0]
            );
        }
        // The colliders.
        if !self.colliders.is_empty() {
            s += "\n    def Scope \"Colliders\"\n    {\n";
            for c in &self.colliders {
                s += &self.collider_prim(c);
            }
            s += "    }\n";
        }
        s += "}\n";
        s
    }

    /// A clip set of the root layer: `frames`' layers, each active from its frame on, stage time
    /// the layer's own.
    fn clip_set(&self, name: &str, prefix: &str, manifest: &str, frames: &[u64]) -> String {
        let dir = &self.clips_name;
        let assets: Vec<String> = frames
            .iter()
            .map(|f| format!("@./{dir}/{prefix}{f:06}.usda@"))
            .collect();
        let active: Vec<String> = frames
            .iter()
            .enumerate()
            .map(|(i, f)| format!("({f}, {i})"))
            .collect();
        let times: Vec<String> = frames.iter().map(|f| format!("({f}, {f})")).collect();
        format!(
            "        dictionary {name} = {{\n            double2[] active = [{}]\n            asset[] assetPaths = [{}]\n            \
             asset manifestAssetPath = @./{dir}/{manifest}@\n            string primPath = \"{ROOT_PRIM}\"\n            \
             double2[] times = [{}]\n        }}\n",
            active.join(", "),
            assets.join(", "),
            times.join(", ")
        )
    }

    /// A collider's prim: its mesh in its own frame, its transform's ops, and a static one's values.
    fn collider_prim(&self, c: &UsdCollider) -> String {
        let mesh = &c.mesh;
        let mut s = format!(
            "        def Mesh \"collider_{}\" (\n            doc = \"collider {} of the scene: {}\"\n        )\n        {{\n",
            c.index, c.index, c.kind
        );
        match c.fixed {
            Some(Pose { center, orientation }) => {
                let [x, y, z] = center;
                let [qx, qy, qz, qw] = orientation;
                s += &format!(
                    "            double3 xformOp:translate = ({x:?}, {y:?}, {z:?})\n            \
                     quatd xformOp:orient = ({qw:?}, {qx:?}, {qy:?}, {qz:?})\n"
                );
            }
            None => {
                for (kind, name) in POSE_ATTRIBUTES {
                    s += &format!("            {kind} {name}\n");
                }
            }
        }
        s += "            uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:orient\"]\n";
        let mut text = Vec::new();
        let _ = write_mesh_values(&mut text, mesh);
        s += &String::from_utf8_lossy(&text);
        s += "            uniform token subdivisionScheme = \"none\"\n            \
              color3f[] primvars:displayColor = [(0.6, 0.6, 0.6)] (\n                interpolation = \"constant\"\n            )\n        }\n";
        s
    }
}

/// One exported frame, on its way to the particle layers' thread.
pub struct UsdFrame {
    pub frame: u64,
    /// The layer's doc string (frame, time, scene).
    pub comment: String,
    /// The live particles (shared with the frame's PLY file).
    pub particles: Arc<Particles>,
    /// The moving colliders' poses ([`UsdCache::poses`]).
    pub poses: Vec<Pose>,
}

/// One particle layer written.
#[derive(Debug, Clone)]
pub struct LayerDone {
    pub frame: u64,
    pub path: PathBuf,
    pub particles: usize,
    /// Wall time of writing the layer and the root layer.
    pub write: Duration,
}

/// The particle layers' thread and the bounded queue that feeds it.
pub struct UsdQueue {
    cache: Arc<UsdCache>,
    workers: Workers<UsdFrame, LayerDone>,
    /// Layers written, and their summed wall time.
    written: u64,
    write: Duration,
}

impl UsdQueue {
    /// Starts the thread that writes the particle layers (each formats its arrays on rayon's pool).
    /// At most `waiting` frames wait for it.
    pub fn start(cache: Arc<UsdCache>, waiting: usize) -> Result<UsdQueue> {
        let writer = cache.clone();
        let workers = Workers::start("usd", 1, waiting, move |job: UsdFrame| {
            let start = Instant::now();
            let path = writer.write_particles(&job)?;
            Ok(LayerDone {
                frame: job.frame,
                path,
                particles: job.particles.len(),
                write: start.elapsed(),
            })
        })?;
        Ok(UsdQueue {
            cache,
            workers,
            written: 0,
            write: Duration::ZERO,
        })
    }

    pub fn cache(&self) -> &UsdCache {
        &self.cache
    }

    /// Hands a frame to the thread; waits only while the queue is full. An earlier layer's failure
    /// is returned here.
    pub fn submit(&mut self, job: UsdFrame) -> Result<()> {
        let (written, write) = (&mut self.written, &mut self.write);
        self.workers.submit(job, &mut |done| {
            *written += 1;
            *write += done.write;
        })
    }

    /// Takes the layers finished so far (without waiting); the first failure is returned.
    pub fn collect(&mut self) -> Result<()> {
        let (written, write) = (&mut self.written, &mut self.write);
        self.workers.collect(
            &mut |done| {
                *written += 1;
                *write += done.write;
            },
            false,
        )
    }

    /// Frames handed over and not yet written.
    pub fn queued(&self) -> u64 {
        self.workers.queued()
    }

    /// Waits for every frame handed over; then the closing line: layers written, seconds a layer,
    /// what the export thread waited. `after_last_frame` starts when the simulation ended.
    pub fn finish(self) -> Result<String> {
        let UsdQueue {
            cache,
            workers,
            mut written,
            mut write,
        } = self;
        let waited = workers.waited();
        let last_frame = Instant::now();
        workers.finish(&mut |done| {
            written += 1;
            write += done.write;
        })?;
        Ok(format!(
            "usd: {} in {} (a layer a frame in {}{}), {:.3} s a particle layer on its own thread; the \
             export thread waited {:.2} s for the queue, then {:.2} s for the last layers",
            crate::text::count(written, "frame", "frames"),
            cache.path().display(),
            cache.clips_dir().display(),
            if cache.has_surface() {
                ", the surface's too"
            } else {
                ""
            },
            write.as_secs_f64() / written.max(1) as f64,
            waited.as_secs_f64(),
            last_frame.elapsed().as_secs_f64()
        ))
    }
}

/// A clip layer's first lines: the header and `comment` as its doc string.
fn write_header(out: &mut dyn Write, comment: &str) -> Result<()> {
    let doc = comment.replace('"', "'");
    writeln!(out, "#usda 1.0\n(\n    doc = \"\"\"{doc}\"\"\"\n)\n")?;
    Ok(())
}

/// `DECLARATION.timeSamples = { FRAME: VALUE }`, the value written by `value`.
fn sampled(
    out: &mut dyn Write,
    frame: u64,
    declaration: &str,
    value: impl FnOnce(&mut dyn Write) -> Result<()>,
) -> Result<()> {
    write!(
        out,
        "        {declaration}.timeSamples = {{\n            {frame}: "
    )?;
    value(out)?;
    writeln!(out, ",\n        }}")?;
    Ok(())
}

/// A mesh's attributes as time samples of `frame`.
fn write_mesh_samples(out: &mut dyn Write, frame: u64, mesh: &SurfaceMesh) -> Result<()> {
    sampled(out, frame, "point3f[] points", |out| {
        write_array(out, &mesh.vertices, |b, v| vec3(b, *v))
    })?;
    sampled(out, frame, "normal3f[] normals", |out| {
        write_array(out, &mesh.normals, |b, n| vec3(b, *n))
    })?;
    sampled(out, frame, "int[] faceVertexCounts", |out| {
        write_array(out, &mesh.triangles, |b, _| b.extend_from_slice(b"3"))
    })?;
    sampled(out, frame, "int[] faceVertexIndices", |out| {
        write_array(out, &mesh.triangles, triangle)
    })?;
    let extent = points_extent(&mesh.vertices, 0.0);
    sampled(out, frame, "float3[] extent", |out| {
        write_array(out, &extent, |b, x| vec3(b, *x))
    })
}

/// A mesh's attributes with their values (not time-sampled): a collider's.
fn write_mesh_values(out: &mut dyn Write, mesh: &SurfaceMesh) -> Result<()> {
    let pad = "            ";
    write!(out, "{pad}point3f[] points = ")?;
    write_array(out, &mesh.vertices, |b, v| vec3(b, *v))?;
    write!(out, "\n{pad}normal3f[] normals = ")?;
    write_array(out, &mesh.normals, |b, n| vec3(b, *n))?;
    writeln!(out, " (\n{pad}    interpolation = \"vertex\"\n{pad})")?;
    write!(out, "{pad}int[] faceVertexCounts = ")?;
    write_array(out, &mesh.triangles, |b, _| b.extend_from_slice(b"3"))?;
    write!(out, "\n{pad}int[] faceVertexIndices = ")?;
    write_array(out, &mesh.triangles, triangle)?;
    write!(out, "\n{pad}float3[] extent = ")?;
    write_array(out, &points_extent(&mesh.vertices, 0.0), |b, x| vec3(b, *x))?;
    writeln!(out)?;
    Ok(())
}

/// Items an array's formatting hands to one rayon task.
const CHUNK: usize = 16384;

/// `[a, b, c]`, each item written by `item`: the text of each chunk of items is made on rayon's
/// pool, then written in order (a float's text takes far longer to make than to write).
fn write_array<T: Sync>(
    out: &mut dyn Write,
    items: &[T],
    item: impl Fn(&mut Vec<u8>, &T) + Sync,
) -> Result<()> {
    out.write_all(b"[")?;
    // A few chunks at a time, so the text of a whole array of millions is never held at once.
    for (g, group) in items.chunks(CHUNK * 16).enumerate() {
        let texts: Vec<Vec<u8>> = group
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut text = Vec::with_capacity(chunk.len() * 40);
                for (i, x) in chunk.iter().enumerate() {
                    if i > 0 {
                        text.extend_from_slice(b", ");
                    }
                    item(&mut text, x);
                }
                text
            })
            .collect();
        for (c, text) in texts.iter().enumerate() {
            if g > 0 || c > 0 {
                out.write_all(b", ")?;
            }
            out.write_all(text)?;
        }
    }
    out.write_all(b"]")?;
    Ok(())
}

/// The shortest decimal that reads back to `x` (zmij, Schubfach's algorithm; far quicker than
/// `core::fmt`'s): the stage's floats are the simulation's to the bit.
fn float(b: &mut Vec<u8>, x: f32) {
    if x.is_finite() {
        b.extend_from_slice(zmij::Buffer::new().format_finite(x).as_bytes());
    } else if x.is_nan() {
        b.extend_from_slice(b"nan");
    } else if x > 0.0 {
        b.extend_from_slice(b"inf");
    } else {
        b.extend_from_slice(b"-inf");
    }
}

fn vec3(b: &mut Vec<u8>, [x, y, z]: [f32; 3]) {
    b.push(b'(');
    float(b, x);
    b.extend_from_slice(b", ");
    float(b, y);
    b.extend_from_slice(b", ");
    float(b, z);
    b.push(b')');
}

fn integer(b: &mut Vec<u8>, n: u32) {
    b.extend_from_slice(itoa::Buffer::new().format(n).as_bytes());
}

fn triangle(b: &mut Vec<u8>, [i, j, k]: &[u32; 3]) {
    integer(b, *i);
    b.extend_from_slice(b", ");
    integer(b, *j);
    b.extend_from_slice(b", ");
    integer(b, *k);
}

/// `(r, g, b)`.
fn tuple([r, g, b]: [f32; 3]) -> String {
    format!("({r}, {g}, {b})")
}

/// The bounding box `[min, max]` of `points` grown by `pad` on every side (UsdGeom's extent; a
/// `Points` prim's includes half its width); all zeros for no points.
fn points_extent<P: Copy + Into<[f32; 3]> + Sync>(points: &[P], pad: f32) -> [[f32; 3]; 2] {
    if points.is_empty() {
        return [[0.0; 3]; 2];
    }
    let (lo, hi) = points
        .par_iter()
        .fold(
            || ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
            |(mut lo, mut hi), &p| {
                let p: [f32; 3] = p.into();
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
                (lo, hi)
            },
        )
        .reduce(
            || ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
            |(a, b), (c, d)| {
                (
                    std::array::from_fn(|i| a[i].min(c[i])),
                    std::array::from_fn(|i| b[i].max(d[i])),
                )
            },
        );
    [lo.map(|x| x - pad), hi.map(|x| x + pad)]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The floats' text reads back to the same bits (the test of the whole stage, through USD's own
    /// reader, is tests/usd_readers.rs).
    #[test]
    fn floats_are_written_to_read_back_exactly() {
        for x in [
            0.1f32,
            1.0 / 3.0,
            1e-7,
            123456.79,
            -0.0,
            2.5e-3,
            f32::MIN_POSITIVE,
        ] {
            let mut b = Vec::new();
            float(&mut b, x);
            let text = String::from_utf8(b).unwrap();
            assert_eq!(text.parse::<f32>().unwrap().to_bits(), x.to_bits(), "{text}");
            // USD's text reader reads a double and narrows it.
            assert_eq!(
                (text.parse::<f64>().unwrap() as f32).to_bits(),
                x.to_bits(),
                "{text}"
            );
        }
    }

    #[test]
    fn arrays_are_bracketed_and_comma_separated() {
        let mut out = Vec::new();
        write_array(&mut out, &[1u32, 2, 3], |b, &n| integer(b, n)).unwrap();
        assert_eq!(String::from_utf8(out).unwrap(), "[1, 2, 3]");
        let many: Vec<u32> = (0..(CHUNK * 20) as u32).collect();
        let mut out = Vec::new();
        write_array(&mut out, &many, |b, &n| integer(b, n)).unwrap();
        let text = String::from_utf8(out).unwrap();
        let read: Vec<u32> = text[1..text.len() - 1]
            .split(", ")
            .map(|n| n.parse().unwrap())
            .collect();
        assert_eq!(read, many);
        let mut out = Vec::new();
        write_array(&mut out, &[] as &[u32], |b, &n| integer(b, n)).unwrap();
        assert_eq!(String::from_utf8(out).unwrap(), "[]");
    }
}
