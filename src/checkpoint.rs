//! Checkpoints: the whole state of a run between two frames in one file, from which a run goes on
//! exactly as if it had never stopped (`mpm run --checkpoint DIR`, `mpm run --resume FILE`, the
//! viewer's snapshots).
//!
//! A checkpoint holds the scene as it was loaded (its TOML text and where it came from), the solver
//! options (backend, GPU pipeline, scatter mode), the parameters as the run had them (live changes
//! included), the clock and the time-step policy's memory ([`RunClock`]), and every particle's x, v,
//! C and density, the rigid bodies' states with the impulse sums their next step takes, and the
//! bodies dropped into the run (`sim::dropped`: the scene file does not name them). Nothing
//! else carries from one frame to the next: the CPU backends rebuild their grid every substep, and
//! the CUDA solver's between-substep state (the particle bins, the grid mass (and under the fused
//! pipeline momentum) of the next substep, scattered from the particles' saved state and density) is
//! rebuilt from the particles on the first substep after a resume, which gives the same integers in
//! the fixed-point scatter; its bodies' collider slots are placed from their states as its
//! step_bodies places them (tests/gpu_lifecycle.rs checks a resumed run byte for byte against an
//! uninterrupted one).
//!
//! # File format (version 7), all numbers little-endian
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `MPMCKPT` and a zero byte |
//! | 4 | format version (u32) |
//! | 4 | reserved, 0 |
//! | 8 | body length B (u64) |
//! | B | body |
//! | 4 | CRC-32 (IEEE) of everything before it |
//!
//! The body: a u64 length and that many bytes of JSON ([`Meta`]: the scene text and source, the
//! solver options, the particle slot count N, the emitter count E, whether a flow state follows,
//! whether the particles' deformation follows, whether their volume bias follows, the rigid body
//! count K, the dropped body count D, the run's method and a position-based run's iterations and
//! substeps a frame as it ran them, which its resumed scene takes in place of the file's); the
//! 214 words of [`Params`]
//! (the kernel parameters, then the material table's 8 rows of 24 words); the clock (frame u64,
//! time f64, signal speed f32, signal rise f32, the last two stretches' flow speeds f32, late
//! emitter layers u64, E emitter phases f64); then
//! x (3N f32), v (3N), C (9N, column by column per slot), density (N), the live flags (N bytes, 1
//! live, 0 parked) and each slot's material row (N bytes); then, where the scene has solids, each
//! slot's deformation (F_E column by column and the plastic scalar: 10N f32); then, where a
//! position-based run wrote it, each slot's volume bias (N f32); then, with emitters or sinks,
//! the lifecycle ([`FlowState`]): the free-slot stack (u64 length, u32 slots), its sorted length
//! (u64), the nozzle points' last particles (u64 length, u32 slots) and the counts (live, emitted,
//! drained, exhausted, blocked: u64 each); then, for each of the K rigid bodies, its [`RigidBody`] row
//! (its 42 f64, then its 4 u32: 352 bytes) and its 6 pending impulse sums (i64); then, for each of
//! the D dropped bodies (the last D of the K), its shape (u32: 0 a box, 1 a ball), its size (3 f64:
//! a box's edges, or a ball's radius and two zeros), its density and the centre it was let go at
//! (f64, then 3 f64): 60 bytes. Floats are stored as their bits, so a resumed state is the saved
//! one exactly.
//!
//! Version 1, written before scenes had a material table, still loads: its parameters are 28 words
//! (one material of 8 words: rest density, EOS stiffness, EOS power, viscosity, pressure floor,
//! particle mass and two of padding; then gravity to the density rule, as in version 2) and no
//! material rows follow the live flags. It reads as a table of one Newtonian row and every particle
//! made of it ([`params_from_version_1`]). Version 2, written before the solids, had rows of 16
//! words (the liquids' 13, then padding: 150 words in all) and no deformation; its rows
//! read with the solids' parameters zero ([`params_from_version_2`]). Version 3, written before
//! checkpoints held rigid bodies, is version 4 without them (no scene of bodies could be saved);
//! version 4, written before bodies could be dropped into a run, is version 5 without dropped bodies.
//! Version 5, written before the fixed-point momentum units followed the flow's speed, is version 6
//! without the clock's flow speeds: they read as the signal speed, so the first stretches after the
//! resume take units made for that (coarser than the flow's; the run is as exact, its bytes those
//! of another run).
//! Version 6, written before the position-based solver kept a volume bias, is version 7 without it
//! (a pbmpm run resumed from one starts its liquids' pressure memory from zero).
//!
//! A file is written to a temporary name in its directory, flushed to the disk, and renamed, so a
//! crash never leaves a partial file under a checkpoint's name; an existing file is never replaced.
//! It is read with its checksum checked a piece at a time; [`Checkpoint::read`] then reads its
//! particles whole, and [`Checkpoint::open`] leaves them in the file ([`ParticlesInFile`]), from
//! which a process of one rank reads its share alone.

use crate::backend::{self, BackendKind, SavedParticles, SavedState};
use crate::contract::{LAW_NEWTONIAN, MAX_MATERIALS};
use crate::export::claim_output_dir;
use crate::sim::colliders::bodies::{BodiesState, RigidBody};
use crate::sim::dropped::{self, DropShape, DroppedBody};
use crate::sim::flow::{FlowCounts, FlowState};
use crate::sim::params::{KernelParams, Material};
use crate::sim::pbmpm::{MAX_ITERATIONS, MAX_SUBSTEPS};
use crate::sim::scene::TimeStepPolicy;
use crate::sim::{
    Deformation, Method, Params, Particles, Pipeline, RunClock, ScatterMode, Scene, Simulation, FRAME_DT,
};
use crate::text::io_reason;
use anyhow::{anyhow, bail, ensure, Context, Result};
use serde::{Deserialize, Serialize};
use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

mod in_file;
use in_file::ParticleLayout;
pub use in_file::ParticlesInFile;

/// The first bytes of every checkpoint.
pub const MAGIC: [u8; 8] = *b"MPMCKPT\0";
/// The format this build writes; it reads this one and every earlier one.
pub const FORMAT_VERSION: u32 = 7;
/// The oldest format this build reads: version 1, before the material table.
pub const OLDEST_FORMAT_VERSION: u32 = 1;
/// The file name extension of checkpoints.
pub const EXTENSION: &str = "mpmck";
/// Magic, version, reserved word and body length.
const HEADER_BYTES: usize = 8 + 4 + 4 + 8;
const CHECKSUM_BYTES: usize = 4;
/// The parameters' words in a file: every word of [`Params`] but the grid box's, which say where a
/// GPU holds its grid, not what the run is (`KernelParams::box_lo`, the kernel parameters' last six).
const PARAMS_WORDS: usize = std::mem::size_of::<Params>() / 4 - BOX_WORDS;
const BOX_WORDS: usize = 6;
const _: () = assert!(std::mem::offset_of!(KernelParams, box_lo) == 4 * (KERNEL_WORDS - BOX_WORDS));
const _: () = assert!(std::mem::size_of::<KernelParams>() == 4 * KERNEL_WORDS);
/// Version 1's parameters: one material (8 words), then gravity to the density rule (20 words).
const VERSION_1_PARAMS_WORDS: usize = 28;
/// Version 2's material rows: the liquids' 13 words and 3 of padding.
const VERSION_2_MATERIAL_WORDS: usize = 16;
/// Version 2's parameters: the kernel parameters as saved, then the table of 8 rows of 16 words.
const VERSION_2_PARAMS_WORDS: usize =
    PARAMS_WORDS - (MATERIAL_WORDS - VERSION_2_MATERIAL_WORDS) * MAX_MATERIALS as usize;
const MATERIAL_WORDS: usize = std::mem::size_of::<Material>() / 4;
/// The liquids' parameters at the head of a material row (rest density to transition exponent).
const LIQUID_MATERIAL_WORDS: usize = 13;
const KERNEL_WORDS: usize = std::mem::size_of::<KernelParams>() / 4;
const _: () = assert!(std::mem::offset_of!(Material, shear_modulus) == 4 * LIQUID_MATERIAL_WORDS);
const _: () = assert!(VERSION_2_PARAMS_WORDS == 150);
/// Frame, time, signal speed and rise, two flow speeds, late layers (the emitters' phases follow, 8 bytes
/// each).
const CLOCK_BYTES: usize = 8 + 8 + 4 + 4 + 2 * 4 + 8;
/// Bytes per particle slot: x, v, C, density as f32, the live flag and the material row.
const BYTES_PER_PARTICLE: usize = 4 * (3 + 3 + 9 + 1) + 1 + 1;
/// A [`RigidBody`] row: its f64 fields, then its u32 fields (the contract lays them out so, without
/// padding; the assertions fail the build where a change of the struct would need a new layout).
const BODY_F64S: usize = 42;
const BODY_U32S: usize = 4;
const _: () = assert!(std::mem::size_of::<RigidBody>() == 8 * BODY_F64S + 4 * BODY_U32S);
const _: () = assert!(std::mem::offset_of!(RigidBody, first_feature) == 8 * BODY_F64S);
/// Bytes per rigid body: its row and its six impulse sums.
const BYTES_PER_BODY: usize = 8 * BODY_F64S + 4 * BODY_U32S + 8 * 6;
/// Bytes per dropped body: its shape's code, its size (3 f64), density and centre (3 f64).
const BYTES_PER_DROPPED: usize = 4 + 8 * 7;
/// The dropped bodies' shape codes.
const DROPPED_BOX: u32 = 0;
const DROPPED_BALL: u32 = 1;

/// What the body's JSON holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Meta {
    /// The mpm version that wrote the file (for the user; not checked).
    written_by: String,
    scene_source: String,
    scene_toml: String,
    /// `Solver::name()` of the backend that ran.
    backend: String,
    pipeline: Pipeline,
    scatter: ScatterMode,
    particles: u64,
    /// Emitter phases in the clock.
    emitters: u64,
    /// Whether the lifecycle's state follows the particles.
    flow: bool,
    /// Whether the particles' deformation follows their material rows (version 3 on).
    #[serde(default)]
    deformation: bool,
    /// Rigid bodies after the lifecycle (version 4 on).
    #[serde(default)]
    bodies: u64,
    /// Bodies dropped into the run, after the rigid bodies (version 5 on).
    #[serde(default)]
    dropped: u64,
    /// Whether the particles' volume bias (the position-based solver's) follows their deformation
    /// (version 7 on).
    #[serde(default)]
    volume_bias: bool,
    /// The method the run had (the command line's `--method` may have changed the file's; absent
    /// before it was kept).
    #[serde(default)]
    method: Option<Method>,
    /// A position-based run's iterations and substeps as it ran them (absent before they were kept,
    /// and under the explicit method).
    #[serde(default)]
    pbmpm: Option<PbmpmControls>,
}

/// A position-based run's constraint iterations and substeps a frame as it had them when saved: the
/// scene file's, or what the viewer's sliders (`Simulation::set_iterations`, `set_substeps`) made
/// them since.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct PbmpmControls {
    pub iterations: u32,
    pub substeps: u32,
}

/// A run's state between two frames.
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    /// Where the scene came from (`preset NAME` or a path), as it was loaded.
    pub scene_source: String,
    /// The scene file's text as it was loaded.
    pub scene_toml: String,
    /// The backend that ran (`cpu`, `cpu-parallel`, `cuda`).
    pub backend: String,
    pub pipeline: Pipeline,
    pub scatter: ScatterMode,
    pub params: Params,
    pub clock: RunClock,
    /// The run's particle slots, live and parked: the particles' length, where they were read
    /// ([`Self::read`]; [`Self::open`] leaves them in the file, and them empty).
    pub slots: usize,
    pub particles: Particles,
    /// The emitters' and sinks' state (free slots, nozzle points' last particles, counts), where the
    /// scene has them.
    pub flow: Option<FlowState>,
    /// The rigid bodies (none where the scene has none): the scene's, then the dropped ones.
    pub bodies: BodiesState,
    /// The bodies dropped into the run ([`Simulation::drop_body`]), in order; the scene file does
    /// not name them, so [`Self::resume`] adds them to its scene.
    pub dropped: Vec<DroppedBody>,
    /// The method the run had, which [`Self::scene`] gives its scene (`--method` may have changed the
    /// file's); `None` in files written before it was kept (they resume with the file's).
    pub method: Option<Method>,
    /// A position-based run's iterations and substeps; [`Self::scene`] gives them to its scene in
    /// place of the file's. `None` under the explicit method and in files written before they were
    /// kept (their runs resume with the file's).
    pub pbmpm: Option<PbmpmControls>,
}

impl Checkpoint {
    /// The state of `sim`, which must be between two frames (not inside one that
    /// `Simulation::step_frame_until` paused). Copies the particles to the host.
    pub fn capture(sim: &mut Simulation) -> Result<Checkpoint> {
        let clock = sim
            .clock()
            .context("a frame is half done; finish it (Simulation::step_frame) before saving the state")?;
        let scene = sim.scene();
        let (scene_source, scene_toml) = (scene.source.clone(), scene.toml.clone());
        let (pipeline, scatter, method) = (scene.pipeline, scene.scatter, scene.method);
        let pbmpm = match (method, scene.time_step) {
            (Method::Pbmpm, TimeStepPolicy::Fixed { dt }) => Some(PbmpmControls {
                iterations: scene.pbmpm.iterations,
                substeps: (FRAME_DT / dt).round() as u32,
            }),
            _ => None,
        };
        let backend = sim.backend().to_string();
        let params = *sim.params();
        let particles = sim.solver_mut().read_particles()?;
        let flow = sim.solver_mut().flow_state()?;
        let bodies = BodiesState {
            states: sim.solver_mut().bodies()?,
            impulses: sim.solver_mut().body_impulses()?,
        };
        let dropped = sim.dropped().to_vec();
        Ok(Checkpoint {
            flow,
            bodies,
            dropped,
            method: Some(method),
            pbmpm,
            scene_source,
            scene_toml,
            backend,
            pipeline,
            scatter,
            params,
            clock,
            slots: particles.len(),
            particles,
        })
    }

    /// The scene the run had, with its solver options, as its file gives it: without the bodies
    /// dropped into the run, which [`Self::resume`] adds (so a restart of it has none of them).
    pub fn scene(&self) -> Result<Scene> {
        let mut scene = Scene::from_toml(&self.scene_toml, &self.scene_source)
            .context("the scene saved in the checkpoint no longer loads")?;
        scene.pipeline = self.pipeline;
        scene.scatter = self.scatter;
        if let Some(method) = self.method {
            scene.set_method(method);
        }
        if let Some(controls) = self.pbmpm {
            ensure!(
                scene.method == Method::Pbmpm
                    && (1..=MAX_ITERATIONS).contains(&controls.iterations)
                    && (1..=MAX_SUBSTEPS).contains(&controls.substeps),
                "the checkpoint holds {} iterations and {} substeps a frame of a position-based run, but its \
                 scene is not one, or they are out of range: the file is inconsistent",
                controls.iterations,
                controls.substeps
            );
            scene.pbmpm.iterations = controls.iterations;
            scene.time_step = TimeStepPolicy::pbmpm(controls.substeps);
        }
        ensure!(
            scene.slots() == self.slots
                && scene.grid_res == self.params.grid_res
                && scene.flow.is_active() == self.flow.is_some()
                && scene.flow.emitters.len() == self.clock.emitter_phases.len()
                && scene.materials.len() == self.params.material_count as usize,
            "the checkpoint holds {} particle slots on a {:?} grid and {} materials, but its scene has {} \
             on {:?} and {} materials: the file is inconsistent",
            self.slots,
            self.params.grid_res,
            self.params.material_count,
            scene.slots(),
            scene.grid_res,
            scene.materials.len()
        );
        self.check_bodies(&self.with_dropped(scene.clone())?)?;
        Ok(scene)
    }

    /// `scene` with the bodies dropped into the run added after its colliders, each checked as when
    /// it was dropped.
    fn with_dropped(&self, mut scene: Scene) -> Result<Scene> {
        dropped::add_to(&mut scene, &self.dropped).context(
            "a body dropped into the checkpoint's run does not fit its scene: the file is inconsistent",
        )?;
        Ok(scene)
    }

    /// Refuses a checkpoint whose rigid bodies are not `scene`'s (with the dropped ones added):
    /// another count, or a body that is another collider or has other contact features than the
    /// scene gives it (a solver would step it with features that are not its own).
    fn check_bodies(&self, scene: &Scene) -> Result<()> {
        let (start, _) = scene.colliders.rigid_bodies();
        let saved = &self.bodies.states;
        let counting_dropped = match self.dropped.len() {
            0 => String::new(),
            n => format!(", counting the {n} dropped into the run"),
        };
        ensure!(
            saved.len() == start.len(),
            "the checkpoint holds {} but its scene has {} (colliders with a density or mass{counting_dropped}): \
             the file is inconsistent; resume from a checkpoint this scene's run wrote",
            crate::text::count(saved.len(), "rigid body", "rigid bodies"),
            start.len()
        );
        let layout = |b: &RigidBody| (b.slot, b.first_feature, b.num_features);
        if let Some(k) = (0..saved.len()).find(|&k| layout(&saved[k]) != layout(&start[k])) {
            let (slot, first, n) = layout(&saved[k]);
            let (scene_slot, scene_first, scene_n) = layout(&start[k]);
            bail!(
                "the checkpoint's rigid body {k} is collider {slot} with contact features {first}..{}, \
                 but its scene makes it collider {scene_slot} with {scene_first}..{}: the file is \
                 inconsistent (or an mpm that laid bodies out otherwise wrote it); resume from a \
                 checkpoint this mpm wrote",
                first + n,
                scene_first + scene_n
            );
        }
        Ok(())
    }

    /// The backend the run had.
    pub fn backend_kind(&self) -> Result<BackendKind> {
        BackendKind::of_solver(&self.backend)
            .ok_or_else(|| anyhow!("the checkpoint names an unknown backend `{}`", self.backend))
    }

    /// A simulation that goes on from this state on `backend` (its own by default), with `scene`
    /// (from [`Self::scene`], solver options possibly overridden), the bodies dropped into the run
    /// added to it.
    pub fn resume(&self, scene: Scene, backend: BackendKind) -> Result<Simulation> {
        self.resume_with(scene, backend, SavedParticles::Read(&self.particles))
    }

    /// [`Self::resume`] from particles left in the checkpoint's file ([`Self::open`]): the backend
    /// reads what its solver holds, a process of one CUDA rank (`Scene::process`) its share alone,
    /// any other solver every particle.
    pub fn resume_from_file(
        &self,
        scene: Scene,
        backend: BackendKind,
        particles: &ParticlesInFile,
    ) -> Result<Simulation> {
        self.resume_with(scene, backend, SavedParticles::InFile(particles))
    }

    fn resume_with(
        &self,
        scene: Scene,
        backend: BackendKind,
        particles: SavedParticles,
    ) -> Result<Simulation> {
        let scene = self.with_dropped(scene)?;
        self.check_bodies(&scene)?;
        let saved = SavedState {
            particles,
            flow: self.flow.as_ref(),
            bodies: &self.bodies,
        };
        let solver = backend::restore(backend, &scene, saved)?;
        // The scatter's mode and scales and the density rule are the scene's (whose solver options
        // --scatter and --pipeline may override); checkpoints written before the scene authored the
        // scales hold zeros there. The momentum's units are the last stretch's where the file has
        // them: the fused pipeline's first scatter after the resume takes them, as the
        // uninterrupted run's last one did (`Solver::resume_after`).
        let authored = scene.params();
        let mut params = self.params;
        params.scatter_mode = authored.scatter_mode;
        params.fixed_mass_scale = authored.fixed_mass_scale;
        if !(params.fixed_momentum_scale > 0.0 && params.fixed_momentum_scale.is_finite()) {
            params.fixed_momentum_scale = authored.fixed_momentum_scale;
        }
        params.density_rule = authored.density_rule;
        Ok(Simulation::resume(
            scene,
            solver,
            params,
            self.clock.clone(),
            &self.bodies.states,
            &self.dropped,
        ))
    }

    /// Writes the checkpoint to `path`, which must not exist: to a temporary file beside it, synced
    /// to the disk, then renamed, so `path` is either absent or complete.
    pub fn write_new(&self, path: &Path) -> Result<()> {
        ensure!(
            !path.exists(),
            "{} exists already; not overwriting it (choose another name)",
            path.display()
        );
        let dir = path
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let name = path
            .file_name()
            .with_context(|| format!("{} is not a file name", path.display()))?;
        let tmp = dir.join(format!(".{}.partial", name.to_string_lossy()));
        let written = File::create(&tmp)
            .map_err(anyhow::Error::from)
            .and_then(|file| {
                let mut out = Crc32Writer::new(BufWriter::with_capacity(1 << 20, file));
                self.write_to(&mut out)?;
                let checksum = out.hasher.clone().finalize();
                out.inner.write_all(&checksum.to_le_bytes())?;
                let file = out.inner.into_inner().map_err(|e| e.into_error())?;
                file.sync_all()?;
                Ok(())
            })
            .and_then(|()| {
                ensure!(!path.exists(), "{} appeared while it was written", path.display());
                std::fs::rename(&tmp, path).map_err(Into::into)
            });
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            let reason = e
                .chain()
                .find_map(|cause| cause.downcast_ref::<std::io::Error>())
                .map_or_else(|| format!("{e:#}"), io_reason);
            bail!("cannot write the checkpoint {}: {reason}", path.display());
        }
        // The rename is durable once the directory is synced; where a directory cannot be opened for
        // that (some platforms), the file itself is already complete.
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
        Ok(())
    }

    /// Header and body, without the checksum.
    fn write_to(&self, out: &mut impl Write) -> Result<()> {
        self.bodies.check()?;
        let meta = serde_json::to_vec(&Meta {
            written_by: format!("mpm {}", env!("CARGO_PKG_VERSION")),
            scene_source: self.scene_source.clone(),
            scene_toml: self.scene_toml.clone(),
            backend: self.backend.clone(),
            pipeline: self.pipeline,
            scatter: self.scatter,
            particles: self.particles.len() as u64,
            emitters: self.clock.emitter_phases.len() as u64,
            flow: self.flow.is_some(),
            deformation: !self.particles.deformation.is_empty(),
            bodies: self.bodies.states.len() as u64,
            dropped: self.dropped.len() as u64,
            volume_bias: !self.particles.volume_bias.is_empty(),
            method: self.method,
            pbmpm: self.pbmpm,
        })?;
        let n = self.particles.len();
        ensure!(
            n == self.slots,
            "a checkpoint of {} slots holds {n} particles: one opened with its particles left in its \
             file is read, not written",
            self.slots
        );
        let flow = self.flow.as_ref().map(flow_bytes).unwrap_or_default();
        let body = 8
            + meta.len()
            + 4 * PARAMS_WORDS
            + CLOCK_BYTES
            + 8 * self.clock.emitter_phases.len()
            + BYTES_PER_PARTICLE * n
            + std::mem::size_of_val(self.particles.deformation.as_slice())
            + std::mem::size_of_val(self.particles.volume_bias.as_slice())
            + flow.len()
            + BYTES_PER_BODY * self.bodies.states.len()
            + BYTES_PER_DROPPED * self.dropped.len();
        out.write_all(&MAGIC)?;
        out.write_all(&FORMAT_VERSION.to_le_bytes())?;
        out.write_all(&0u32.to_le_bytes())?;
        out.write_all(&(body as u64).to_le_bytes())?;
        out.write_all(&(meta.len() as u64).to_le_bytes())?;
        out.write_all(&meta)?;
        write_words(out, &saved_params_words(&self.params))?;
        let clock = &self.clock;
        out.write_all(&clock.frame.to_le_bytes())?;
        out.write_all(&clock.time.to_bits().to_le_bytes())?;
        out.write_all(&clock.signal_speed.to_bits().to_le_bytes())?;
        out.write_all(&clock.signal_rise.to_bits().to_le_bytes())?;
        for speed in clock.flow_speeds {
            out.write_all(&speed.to_bits().to_le_bytes())?;
        }
        out.write_all(&clock.late_layers.to_le_bytes())?;
        for phase in &clock.emitter_phases {
            out.write_all(&phase.to_bits().to_le_bytes())?;
        }
        let p = &self.particles;
        write_words(out, bytemuck::cast_slice(&p.x))?;
        write_words(out, bytemuck::cast_slice(&p.v))?;
        write_words(out, bytemuck::cast_slice(&p.c))?;
        write_words(out, bytemuck::cast_slice(&p.rho))?;
        let live: Vec<u8> = p.live.iter().map(|&l| u8::from(l)).collect();
        out.write_all(&live)?;
        out.write_all(&p.material)?;
        write_words(out, bytemuck::cast_slice(&p.deformation))?;
        write_words(out, bytemuck::cast_slice(&p.volume_bias))?;
        out.write_all(&flow)?;
        for (body, impulses) in self.bodies.states.iter().zip(&self.bodies.impulses) {
            out.write_all(&body_row_bytes(body))?;
            for sum in impulses {
                out.write_all(&sum.to_le_bytes())?;
            }
        }
        for body in &self.dropped {
            out.write_all(&dropped_row_bytes(body))?;
        }
        Ok(())
    }

    /// Reads a checkpoint, refusing (with what is wrong and what to do) a file that is not one, one
    /// of another format version, a truncated one and one whose checksum does not match.
    pub fn read(path: &Path) -> Result<Checkpoint> {
        let (mut checkpoint, particles) = Checkpoint::open(path)?;
        checkpoint.particles = particles.read_all()?;
        Ok(checkpoint)
    }

    /// Reads and checks a checkpoint as [`Self::read`] does, but for its particles, which stay in
    /// the file (the checkpoint's `particles` are empty): a process that resumes its share of a run
    /// reads only that (`ParticlesInFile` gives the ranks their shares).
    pub fn open(path: &Path) -> Result<(Checkpoint, ParticlesInFile)> {
        let file = File::open(path).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => anyhow!(
                "there is no checkpoint {}: give the path of a checkpoint_NNNNNN.mpmck that \
                 `mpm run --checkpoint DIR` wrote, or a viewer snapshot",
                path.display()
            ),
            _ => anyhow!("cannot read the checkpoint {}: {}", path.display(), io_reason(&e)),
        })?;
        Checkpoint::open_file(file, path).map_err(|e| anyhow!("checkpoint {}: {e:#}", path.display()))
    }

    fn open_file(file: File, path: &Path) -> Result<(Checkpoint, ParticlesInFile)> {
        let actual = file.metadata().context("cannot read its length")?.len();
        let mut head = vec![0u8; HEADER_BYTES.min(actual as usize)];
        file.read_exact_at(&mut head, 0)
            .map_err(|e| anyhow!("cannot read it: {}", io_reason(&e)))?;
        let magic_len = head.len().min(MAGIC.len());
        if head[..magic_len] != MAGIC[..magic_len] || head.is_empty() {
            bail!(
                "is not an mpm checkpoint (it does not begin with the checkpoint header); give a file \
                 that `mpm run --checkpoint DIR` or the viewer's snapshot wrote (*.{EXTENSION})"
            );
        }
        if head.len() < HEADER_BYTES {
            bail!(
                "is truncated: {actual} bytes, less than the {HEADER_BYTES}-byte header (the write was \
                 cut off, or the file was copied in part); use an earlier checkpoint"
            );
        }
        let word = |at: usize| u32::from_le_bytes(head[at..at + 4].try_into().expect("4 bytes"));
        let version = word(8);
        if !(OLDEST_FORMAT_VERSION..=FORMAT_VERSION).contains(&version) {
            bail!(
                "is of checkpoint format version {version}, but this mpm reads versions \
                 {OLDEST_FORMAT_VERSION} to {FORMAT_VERSION}{}",
                if version > FORMAT_VERSION {
                    ": it was written by a newer mpm; resume it with that one"
                } else {
                    " (the file is damaged: no version below 1 exists)"
                }
            );
        }
        let body = u64::from_le_bytes(head[16..24].try_into().expect("8 bytes"));
        let expected = (HEADER_BYTES as u64)
            .checked_add(body)
            .and_then(|b| b.checked_add(CHECKSUM_BYTES as u64))
            .context("is damaged: its header gives an impossible length")?;
        if actual < expected {
            bail!(
                "is truncated: {actual} bytes of the {expected} its header announces (the write was cut \
                 off, or the file was copied in part); use an earlier checkpoint"
            );
        }
        if actual > expected {
            bail!(
                "has {} bytes after its end ({actual} bytes, {expected} announced): it was changed \
                 after it was written; use an earlier checkpoint",
                actual - expected
            );
        }
        let end = expected - CHECKSUM_BYTES as u64;
        // The checksum over the whole file, read a piece at a time: nothing of it is held.
        let mut crc = crc32fast::Hasher::new();
        let mut piece = vec![0u8; 8 << 20];
        let mut at = 0;
        while at < end {
            let len = piece.len().min((end - at) as usize);
            file.read_exact_at(&mut piece[..len], at)
                .map_err(|e| anyhow!("cannot read it: {}", io_reason(&e)))?;
            crc.update(&piece[..len]);
            at += len as u64;
        }
        let mut stored = [0u8; 4];
        file.read_exact_at(&mut stored, end)
            .map_err(|e| anyhow!("cannot read it: {}", io_reason(&e)))?;
        let (stored, computed) = (u32::from_le_bytes(stored), crc.finalize());
        if stored != computed {
            bail!(
                "is corrupt: its checksum does not match its contents (stored {stored:08x}, computed \
                 {computed:08x}); the file was damaged after it was written; use an earlier checkpoint"
            );
        }
        let mut reader = std::io::BufReader::new(&file);
        reader.seek(SeekFrom::Start(HEADER_BYTES as u64))?;
        let (checkpoint, layout) = Body {
            reader,
            at: HEADER_BYTES as u64,
            left: end - HEADER_BYTES as u64,
            version,
        }
        .checkpoint()
        .context("is damaged (its checksum matches, so it was written so: a bug of the writer)")?;
        let particles = ParticlesInFile::new(file, path, layout, checkpoint.params.material_count)
            .context("is damaged (its checksum matches, so it was written so: a bug of the writer)")?;
        Ok((checkpoint, particles))
    }
}

/// Reads the body's fields in order from the file; the particles' arrays it passes over, noting
/// where each lies ([`ParticleLayout`]).
struct Body<R> {
    reader: R,
    /// The file offset of the next byte.
    at: u64,
    /// Bytes of the body not yet passed.
    left: u64,
    /// The file's format version: what the parameters and particles look like.
    version: u32,
}

impl<R: Read + Seek> Body<R> {
    fn take(&mut self, n: usize, what: &str) -> Result<Vec<u8>> {
        ensure!(self.left >= n as u64, "the body ends inside {what}");
        let mut bytes = vec![0u8; n];
        self.reader
            .read_exact(&mut bytes)
            .map_err(|e| anyhow!("cannot read {what}: {}", io_reason(&e)))?;
        (self.at, self.left) = (self.at + n as u64, self.left - n as u64);
        Ok(bytes)
    }

    /// Passes over `count` items of `size` bytes: where they begin in the file.
    fn skip(&mut self, count: usize, size: usize, what: &str) -> Result<u64> {
        let n = count
            .checked_mul(size)
            .and_then(|n| u64::try_from(n).ok())
            .with_context(|| format!("{count} {what}"))?;
        ensure!(self.left >= n, "the body ends inside {what}");
        let at = self.at;
        self.reader.seek(SeekFrom::Current(n as i64))?;
        (self.at, self.left) = (at + n, self.left - n);
        Ok(at)
    }

    fn u64(&mut self, what: &str) -> Result<u64> {
        Ok(u64::from_le_bytes(self.take(8, what)?.as_slice().try_into()?))
    }

    fn u32(&mut self, what: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(4, what)?.as_slice().try_into()?))
    }

    fn words(&mut self, n: usize, what: &str) -> Result<Vec<u32>> {
        let bytes = self.take(n.checked_mul(4).context("too many words")?, what)?;
        Ok(bytes
            .chunks_exact(4)
            .map(|w| u32::from_le_bytes(w.try_into().expect("4 bytes")))
            .collect())
    }

    /// A row that [`body_row_bytes`] wrote.
    fn rigid_body(&mut self) -> Result<RigidBody> {
        let mut native = Vec::with_capacity(std::mem::size_of::<RigidBody>());
        for _ in 0..BODY_F64S {
            native.extend(self.u64("the rigid bodies")?.to_ne_bytes());
        }
        for _ in 0..BODY_U32S {
            native.extend(self.u32("the rigid bodies")?.to_ne_bytes());
        }
        Ok(bytemuck::pod_read_unaligned(&native))
    }

    /// A row that [`dropped_row_bytes`] wrote.
    fn dropped_body(&mut self) -> Result<DroppedBody> {
        let what = "the dropped bodies";
        let code = self.u32(what)?;
        let mut numbers = [0.0; 7];
        for n in &mut numbers {
            *n = f64::from_bits(self.u64(what)?);
        }
        let [a, b, c, density, x, y, z] = numbers;
        let shape = match code {
            DROPPED_BOX => DropShape::Box {
                size: glam::DVec3::new(a, b, c),
            },
            DROPPED_BALL => DropShape::Ball { radius: a },
            other => bail!("a dropped body of shape code {other} (0 is a box, 1 a ball)"),
        };
        Ok(DroppedBody {
            shape,
            density,
            center: glam::DVec3::new(x, y, z),
        })
    }

    fn checkpoint(mut self) -> Result<(Checkpoint, ParticleLayout)> {
        let meta_len = usize::try_from(self.u64("the scene's length")?)?;
        let meta: Meta = serde_json::from_slice(&self.take(meta_len, "the scene")?)?;
        let params: Params = if self.version == 1 {
            params_from_version_1(&self.words(VERSION_1_PARAMS_WORDS, "the parameters")?)
        } else if self.version == 2 {
            params_from_version_2(&self.words(VERSION_2_PARAMS_WORDS, "the parameters")?)
        } else {
            params_from_saved(&self.words(PARAMS_WORDS, "the parameters")?)
        };
        ensure!(
            (1..=MAX_MATERIALS).contains(&params.material_count),
            "a table of {} materials (1 to {MAX_MATERIALS} exist)",
            params.material_count
        );
        let frame = self.u64("the clock")?;
        let time = f64::from_bits(self.u64("the clock")?);
        let signal_speed = f32::from_bits(self.u32("the clock")?);
        let signal_rise = f32::from_bits(self.u32("the clock")?);
        let flow_speeds = if self.version >= 6 {
            [
                f32::from_bits(self.u32("the clock")?),
                f32::from_bits(self.u32("the clock")?),
            ]
        } else {
            [signal_speed; 2]
        };
        let mut clock = RunClock {
            frame,
            time,
            signal_speed,
            signal_rise,
            flow_speeds,
            late_layers: self.u64("the clock")?,
            emitter_phases: Vec::new(),
        };
        for _ in 0..meta.emitters {
            clock
                .emitter_phases
                .push(f64::from_bits(self.u64("the emitters' phases")?));
        }
        let n = usize::try_from(meta.particles)?;
        // Version 1 knew one material: it has no rows, every particle is made of row 0.
        let layout = ParticleLayout {
            count: n,
            x: self.skip(n, 12, "positions")?,
            v: self.skip(n, 12, "velocities")?,
            c: self.skip(n, 36, "affine matrices")?,
            rho: self.skip(n, 4, "densities")?,
            live: self.skip(n, 1, "live flags")?,
            material: match self.version {
                1 => None,
                _ => Some(self.skip(n, 1, "material rows")?),
            },
            deformation: match meta.deformation {
                true => Some(self.skip(n, std::mem::size_of::<Deformation>(), "deformations")?),
                false => None,
            },
            volume_bias: match meta.volume_bias {
                true => Some(self.skip(n, 4, "volume biases")?),
                false => None,
            },
        };
        let flow = if meta.flow {
            let free_len = usize::try_from(self.u64("the free slots")?)?;
            let free = self.words(free_len, "the free slots")?;
            let sorted = usize::try_from(self.u64("the free slots")?)?;
            let last_len = usize::try_from(self.u64("the nozzle points")?)?;
            let last = self.words(last_len, "the nozzle points")?;
            let mut counts = [0u64; 5];
            for count in &mut counts {
                *count = self.u64("the flow counts")?;
            }
            let [live, emitted, drained, exhausted, blocked] = counts;
            ensure!(
                sorted <= free.len(),
                "{sorted} sorted of {} free slots",
                free.len()
            );
            Some(FlowState {
                free,
                sorted,
                last,
                counts: FlowCounts {
                    live,
                    emitted,
                    drained,
                    exhausted,
                    blocked,
                },
            })
        } else {
            None
        };
        let mut bodies = BodiesState::default();
        for _ in 0..meta.bodies {
            bodies.states.push(self.rigid_body()?);
            let mut impulses = [0i64; 6];
            for sum in &mut impulses {
                *sum = self.u64("the rigid bodies' impulse sums")? as i64;
            }
            bodies.impulses.push(impulses);
        }
        ensure!(
            meta.dropped <= meta.bodies,
            "{} dropped bodies among {} rigid bodies",
            meta.dropped,
            meta.bodies
        );
        let dropped = (0..meta.dropped)
            .map(|_| self.dropped_body())
            .collect::<Result<Vec<_>>>()?;
        ensure!(self.left == 0, "{} bytes after the state", self.left);
        let checkpoint = Checkpoint {
            flow,
            bodies,
            dropped,
            method: meta.method,
            pbmpm: meta.pbmpm,
            scene_source: meta.scene_source,
            scene_toml: meta.scene_toml,
            backend: meta.backend,
            pipeline: meta.pipeline,
            scatter: meta.scatter,
            params,
            clock,
            slots: n,
            particles: Particles::default(),
        };
        Ok((checkpoint, layout))
    }
}

/// The words a checkpoint holds of `params`: all but the grid box's.
pub fn saved_params_words(params: &Params) -> Vec<u32> {
    let words: &[u32] = bytemuck::cast_slice(std::slice::from_ref(params));
    let (kernel, table) = words.split_at(KERNEL_WORDS);
    [&kernel[..KERNEL_WORDS - BOX_WORDS], table].concat()
}

/// [`saved_params_words`]'s words as [`Params`], the box the whole grid's (one GPU's; a solver that
/// holds a part of the grid sets its own).
fn params_from_saved(words: &[u32]) -> Params {
    let (kernel, table) = words.split_at(KERNEL_WORDS - BOX_WORDS);
    let whole = [kernel, &[0; BOX_WORDS], table].concat();
    let mut params: Params = bytemuck::pod_read_unaligned(bytemuck::cast_slice(&whole));
    params.kernel.box_res = params.kernel.grid_res;
    params
}

/// Version 2's 150 words of parameters as today's [`Params`]: the kernel parameters as they were,
/// then each material row's 13 words of the liquids' parameters (its 3 of padding dropped), the
/// solids' parameters zero.
pub fn params_from_version_2(words: &[u32]) -> Params {
    assert_eq!(
        words.len(),
        VERSION_2_PARAMS_WORDS,
        "version 2's parameters are 150 words"
    );
    let (kernel, table) = words.split_at(KERNEL_WORDS - BOX_WORDS);
    let mut today = kernel.to_vec();
    for row in table.chunks_exact(VERSION_2_MATERIAL_WORDS) {
        today.extend_from_slice(&row[..LIQUID_MATERIAL_WORDS]);
        today.resize(today.len() + MATERIAL_WORDS - LIQUID_MATERIAL_WORDS, 0);
    }
    params_from_saved(&today)
}

/// Version 1's 28 words of parameters as today's [`Params`]: its one material becomes row 0 of a
/// table of one, a Newtonian liquid with exactly the row loading its scene's `[material]` gives
/// (the flow index 1, the viscosity its own ceiling, the unused Carreau-Yasuda exponent 2), and the
/// density is gathered from the grid's mass (one rest density). The fields after the material keep their order.
pub fn params_from_version_1(words: &[u32]) -> Params {
    assert_eq!(
        words.len(),
        VERSION_1_PARAMS_WORDS,
        "version 1's parameters are 28 words"
    );
    let f = |i: usize| f32::from_bits(words[i]);
    let u3 = |i: usize| [words[i], words[i + 1], words[i + 2]];
    let f3 = |i: usize| u3(i).map(f32::from_bits);
    let mut materials = [Material::default(); MAX_MATERIALS as usize];
    materials[0] = Material {
        rest_density: f(0),
        eos_stiffness: f(1),
        eos_power: f(2),
        viscosity: f(3),
        pressure_floor: f(4),
        particle_mass: f(5),
        law: LAW_NEWTONIAN,
        flow_index: 1.0,
        max_viscosity: f(3),
        transition_exponent: 2.0,
        ..Material::default()
    };
    // words[6..8] were the material's padding.
    let kernel = KernelParams {
        material_count: 1,
        gravity: f3(8),
        dt: f(11),
        grid_res: u3(12),
        dx: f(15),
        inv_dx: f(16),
        boundary_band: words[17],
        soft_wall_tau: f(18),
        num_particles: words[19],
        scatter_mode: words[20],
        fixed_mass_scale: f(21),
        fixed_momentum_scale: f(22),
        wall_mirror_lo: words[23],
        wall_mirror_hi: u3(24),
        density_rule: words[27],
        volume_density: 0,
        box_lo: [0; 3],
        box_res: u3(12),
    };
    Params { kernel, materials }
}

/// A rigid body's row as the body stores it: each f64 field, then each u32 field, little-endian.
fn body_row_bytes(body: &RigidBody) -> Vec<u8> {
    let (floats, words) = bytemuck::bytes_of(body).split_at(8 * BODY_F64S);
    let floats = floats
        .chunks_exact(8)
        .flat_map(|f| u64::from_ne_bytes(f.try_into().expect("8 bytes")).to_le_bytes());
    let words = words
        .chunks_exact(4)
        .flat_map(|w| u32::from_ne_bytes(w.try_into().expect("4 bytes")).to_le_bytes());
    floats.chain(words).collect()
}

/// A dropped body's row as the body stores it: its shape's code, size, density and centre.
fn dropped_row_bytes(body: &DroppedBody) -> Vec<u8> {
    let (code, size) = match body.shape {
        DropShape::Box { size } => (DROPPED_BOX, size.to_array()),
        DropShape::Ball { radius } => (DROPPED_BALL, [radius, 0.0, 0.0]),
    };
    let numbers = size
        .into_iter()
        .chain([body.density])
        .chain(body.center.to_array());
    code.to_le_bytes()
        .into_iter()
        .chain(numbers.flat_map(|n| n.to_bits().to_le_bytes()))
        .collect()
}

/// The lifecycle's state as the body stores it.
fn flow_bytes(state: &FlowState) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend((state.free.len() as u64).to_le_bytes());
    out.extend(state.free.iter().flat_map(|w| w.to_le_bytes()));
    out.extend((state.sorted as u64).to_le_bytes());
    out.extend((state.last.len() as u64).to_le_bytes());
    out.extend(state.last.iter().flat_map(|w| w.to_le_bytes()));
    let c = &state.counts;
    for count in [c.live, c.emitted, c.drained, c.exhausted, c.blocked] {
        out.extend(count.to_le_bytes());
    }
    out
}

fn write_words(out: &mut impl Write, words: &[u32]) -> std::io::Result<()> {
    // Little-endian whatever the machine; in chunks, so a large state needs no second copy.
    let mut chunk = Vec::with_capacity(4 * 4096);
    for part in words.chunks(4096) {
        chunk.clear();
        chunk.extend(part.iter().flat_map(|w| w.to_le_bytes()));
        out.write_all(&chunk)?;
    }
    Ok(())
}

/// Passes bytes on and keeps their CRC-32.
struct Crc32Writer<W> {
    inner: W,
    hasher: crc32fast::Hasher,
}

impl<W: Write> Crc32Writer<W> {
    fn new(inner: W) -> Self {
        Crc32Writer {
            inner,
            hasher: crc32fast::Hasher::new(),
        }
    }
}

impl<W: Write> Write for Crc32Writer<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hasher.update(&buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// The checkpoints of one `mpm run`: `checkpoint_NNNNNN.mpmck` (the frame number) in one directory,
/// every K-th frame and at the run's last frame.
pub struct CheckpointSeries {
    dir: PathBuf,
    every: u64,
    /// Checkpoints of an earlier run that `--overwrite` removed.
    removed: usize,
}

impl CheckpointSeries {
    /// Claims `dir` (created if needed). A run from the start refuses a directory that already holds
    /// checkpoints; a run resumed from `resumed` (a checkpoint at frame F) keeps those up to F of the
    /// same scene (the run it continues) and refuses later ones, which it would replace, and any of
    /// another scene, which it would mix with its own. `overwrite` removes the ones refused instead.
    pub fn new(
        dir: &Path,
        every: u64,
        resumed: Option<&Checkpoint>,
        overwrite: bool,
    ) -> Result<CheckpointSeries> {
        ensure!(every >= 1, "--checkpoint-every must be at least 1");
        let same_scene = |name: &str| {
            Checkpoint::open(&dir.join(name)).is_ok_and(|(other, _)| {
                resumed
                    .is_some_and(|r| other.scene_source == r.scene_source && other.scene_toml == r.scene_toml)
            })
        };
        let clashes = |name: &str| match (checkpoint_frame(name), resumed) {
            (Some(frame), Some(start)) => frame > start.clock.frame || !same_scene(name),
            (Some(_), None) => true,
            (None, _) => false,
        };
        let what = match resumed {
            Some(start) => (
                format!("checkpoint after frame {} or of another scene", start.clock.frame),
                format!(
                    "checkpoints after frame {} or of another scene",
                    start.clock.frame
                ),
            ),
            None => ("checkpoint".to_string(), "checkpoints".to_string()),
        };
        let removed = claim_output_dir(
            dir,
            "--checkpoint",
            "checkpoint",
            (&what.0, &what.1),
            clashes,
            overwrite,
        )?;
        Ok(CheckpointSeries {
            dir: dir.to_path_buf(),
            every,
            removed: removed.len(),
        })
    }

    /// What `--overwrite` removed, for the user; `None` when nothing was.
    pub fn removed_note(&self) -> Option<String> {
        (self.removed > 0).then(|| {
            format!(
                "--overwrite: removed {} from {}",
                crate::text::count(self.removed, "checkpoint", "checkpoints"),
                self.dir.display()
            )
        })
    }

    /// Whether the run writes a checkpoint after `frame` (`last`: the run's final frame).
    pub fn wants(&self, frame: u64, last: bool) -> bool {
        last || frame % self.every == 0
    }

    pub fn path_of(&self, frame: u64) -> PathBuf {
        self.dir.join(format!("checkpoint_{frame:06}.{EXTENSION}"))
    }

    /// Writes the state of `sim` as its frame's checkpoint.
    pub fn write(&self, sim: &mut Simulation) -> Result<PathBuf> {
        let path = self.path_of(sim.frame());
        Checkpoint::capture(sim)?.write_new(&path)?;
        Ok(path)
    }
}

/// The checkpoint of the latest frame in a folder that `mpm run --checkpoint DIR` wrote, for
/// `--resume DIR`; an error naming what to give where the folder holds none.
pub fn newest_in(dir: &Path) -> Result<PathBuf> {
    let entries = std::fs::read_dir(dir)
        .map_err(|e| anyhow!("cannot read the folder {}: {}", dir.display(), io_reason(&e)))?;
    let newest = entries
        .filter_map(|e| e.ok())
        .filter_map(|e| checkpoint_frame(&e.file_name().to_string_lossy()).map(|f| (f, e.path())))
        .max_by_key(|(frame, _)| *frame);
    match newest {
        Some((_, path)) => Ok(path),
        None => bail!(
            "--resume {} is a folder without checkpoints (checkpoint_NNNNNN.{EXTENSION}, which `mpm \
             run --checkpoint DIR` writes); give a checkpoint file, or the folder a run wrote them to",
            dir.display()
        ),
    }
}

/// The frame of a series' checkpoint file name, `None` for other names.
fn checkpoint_frame(name: &str) -> Option<u64> {
    name.strip_prefix("checkpoint_")?
        .strip_suffix(&format!(".{EXTENSION}"))?
        .parse()
        .ok()
}
