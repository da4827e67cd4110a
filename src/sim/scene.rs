//! Scenes: what the solver runs ([`Scene`]), loaded from a preset or a TOML file.
//!
//! A scene file is parsed into the `*Spec` structs of `spec` (what the user wrote, every key
//! optional where a default makes sense), then checked into a [`Scene`] by `validate` (every value
//! checked; every refusal names the file, the key and the fix). `lattice` places the particles a
//! scene spawns.

mod lattice;
mod spec;
mod validate;

pub use lattice::{Lattice, SpawnedParticle};
pub use spec::*;
pub(crate) use validate::available_host_memory;
pub use validate::SceneError;
use validate::Validator;

use super::colliders::Colliders;
use super::flow::Flow;
use super::material::{MaterialTable, NamedMaterial};
use super::params::{KernelParams, Material, Method, Params, Pipeline, ScatterMode, FRAME_DT};
use super::presets;
use crate::contract::MAX_MATERIALS;
use glam::{DVec3, Vec3};
use std::path::Path;

/// The largest CFL number the solver is stable at (docs/physics.md, "The time step").
pub const MAX_CFL: f32 = 0.5;

/// How many times finer (as a power of two) than the scene's coarsest the fixed-point momentum units
/// may be made for a slow flow (`Scene::fixed_momentum_scale_for`): 2^12 leaves a contribution 8
/// times the coarsest reference speed (at least the sound speed) before its 2^52 limit.
pub const MAX_MOMENTUM_REFINEMENT: u32 = 12;

// ---------------------------------------------------------------------------------------------
// The validated scene.

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStepPolicy {
    /// Substeps per frame from the acoustic and advective limits, at this CFL number.
    Cfl { cfl: f32, max_substeps: u32 },
    /// A fixed substep; a frame is the whole number of substeps nearest to 1/60 s.
    Fixed { dt: f32 },
}

impl TimeStepPolicy {
    /// The policy a scene of `method` gets where its file gives no time step: the CFL policy at
    /// its defaults, or pbmpm's default substeps a frame.
    pub fn default_for(method: Method) -> TimeStepPolicy {
        match method {
            Method::Explicit => TimeStepPolicy::Cfl {
                cfl: DEFAULT_CFL,
                max_substeps: DEFAULT_MAX_SUBSTEPS,
            },
            Method::Pbmpm => TimeStepPolicy::pbmpm(super::pbmpm::DEFAULT_SUBSTEPS),
        }
    }

    /// pbmpm's fixed substep: `substeps` a 60 Hz frame.
    pub fn pbmpm(substeps: u32) -> TimeStepPolicy {
        TimeStepPolicy::Fixed {
            dt: FRAME_DT / substeps as f32,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// Lattice points with `min <= x < max`.
    Block { min: DVec3, max: DVec3 },
    /// Lattice points with `|x - center| <= radius`.
    Sphere { center: DVec3, radius: f64 },
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    pub shape: Shape,
    pub velocity: Vec3,
    /// Its row of the material table.
    pub material: u8,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub name: String,
    pub description: String,
    /// Where it came from (`preset dam-break` or a path), for messages.
    pub source: String,
    pub grid_res: [u32; 3],
    pub dx: f32,
    /// The material table: `[material]`'s one row, or the `[[material]]` entries in order.
    pub materials: Vec<NamedMaterial>,
    pub gravity: Vec3,
    pub boundary_band: u32,
    pub soft_wall: bool,
    /// Mirror the fluid beyond the walls onto the grid (see `Params::wall_mirror_lo`).
    pub mirror_wall_mass: bool,
    pub scatter: ScatterMode,
    /// The GPU's kernel sequence (the CPU reference ignores it).
    pub pipeline: Pipeline,
    /// The scheme (`solver.method`): explicit MLS-MPM, or position-based MPM.
    pub method: Method,
    /// The position-based solver's settings (`solver.iterations`, `solver.wall_friction`); the
    /// defaults under the explicit method, which reads none of them.
    pub pbmpm: super::pbmpm::Settings,
    /// Ranks the run is split into (`--ranks`, `--gpus`, `crate::dist`); 1: not split. A run
    /// option, not a scene file setting.
    pub ranks: usize,
    /// GPUs the ranks run on (`--gpus`): 1, every rank on the one device; or as many as ranks, one
    /// rank per GPU, exchanging over NCCL. A run option, like `ranks`.
    pub gpus: usize,
    /// Where the ranks run one per process (`--processes`): this process's place among them, each
    /// driving one GPU, or with the CPU backend one rank of the reference; `None`, every rank in
    /// this process. A run option, like `ranks`.
    pub process: Option<crate::dist::launch::Process>,
    pub time_step: TimeStepPolicy,
    /// Particles per cell along one axis (the lattice is `n^3` per cell).
    pub particles_per_axis: u32,
    pub bodies: Vec<Body>,
    /// Obstacles and kinematic bodies (none in most scenes). No fluid spawns inside them.
    pub colliders: Colliders,
    /// Exact number of live particles [`Scene::spawn`] makes.
    pub num_particles: usize,
    /// Emitters, sinks and the particle slots (`flow.capacity`, at least `num_particles`).
    pub flow: Flow,
    /// The scene file's text as it was loaded (or the spec serialised, for a scene built in code):
    /// what a checkpoint carries, so a run resumes in exactly the scene it was started in.
    pub toml: String,
}

/// Particle arrays on the host (SoA), as spawned or as read back from a backend.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Particles {
    pub x: Vec<Vec3>,
    pub v: Vec<Vec3>,
    /// The APIC affine matrix C, 1/s.
    pub c: Vec<glam::Mat3>,
    /// Density estimated in the last p2g, kg/m^3 (rest density before the first step).
    pub rho: Vec<f32>,
    /// The row of the scene's material table each particle is made of.
    pub material: Vec<u8>,
    /// False for a parked slot (see `sim::flow`): no part of the fluid, kept for its index.
    pub live: Vec<bool>,
    /// Each slot's deformation where a material carries one (`Params::has_deformation`: a solid, or
    /// an elastoviscoplastic liquid), else empty. The slots of other liquids hold the rest state and
    /// nothing reads it.
    pub deformation: Vec<Deformation>,
    /// Under `solver.method = "pbmpm"`, each slot's volume bias: a liquid particle's pressure memory,
    /// how far past its rest volume its volume constraint aims (dimensionless; docs/physics.md,
    /// "Position-based MPM"), 0 for the other slots. Empty where no pbmpm solver ran.
    pub volume_bias: Vec<f32>,
}

/// A solid particle's deformation (docs/physics.md, "Solids"), or an elastoviscoplastic liquid's
/// ("Yield stress"): the elastic part of its deformation gradient, and the one plastic scalar its
/// law keeps.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Deformation {
    /// F_E, the elastic part of the deformation gradient (all of it for an elastic solid).
    pub f: glam::Mat3,
    /// Snow: J_p, the plastic part's volume ratio (1 at rest). Sand: the log-volume the return
    /// mapping took out in expansion (0 at rest). Elastic solids and liquids: 0, unused.
    pub plastic: f32,
}

impl Deformation {
    /// The undeformed state of a particle of law `law`.
    pub fn at_rest(law: u32) -> Deformation {
        Deformation {
            f: glam::Mat3::IDENTITY,
            plastic: super::solid::rest_plastic(law),
        }
    }
}

impl Particles {
    /// Slots, live and parked.
    pub fn len(&self) -> usize {
        self.x.len()
    }
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// What the slots' fields take in memory, bytes.
    pub fn bytes(&self) -> usize {
        use std::mem::size_of_val;
        size_of_val(self.x.as_slice())
            + size_of_val(self.v.as_slice())
            + size_of_val(self.c.as_slice())
            + size_of_val(self.rho.as_slice())
            + size_of_val(self.material.as_slice())
            + size_of_val(self.live.as_slice())
            + size_of_val(self.deformation.as_slice())
            + size_of_val(self.volume_bias.as_slice())
    }

    pub fn num_live(&self) -> usize {
        self.live.iter().filter(|&&l| l).count()
    }

    /// The live particles alone, in slot order: what export and statistics see. Particles read for
    /// export may come without C or a deformation (empty), and keep that.
    pub fn live_only(&self) -> Particles {
        if self.live.iter().all(|&l| l) {
            return self.clone();
        }
        self.pick_live()
    }

    /// [`Self::live_only`], taking the particles: no copy where every slot is live.
    pub fn into_live_only(self) -> Particles {
        match self.live.iter().all(|&l| l) {
            true => self,
            false => self.pick_live(),
        }
    }

    fn pick_live(&self) -> Particles {
        let live: Vec<usize> = (0..self.len()).filter(|&i| self.live[i]).collect();
        self.pick(&live)
    }

    /// The particles of `slots`, in that order (a rank's share of a run: `CudaRanks`). Arrays that
    /// came empty (C or a deformation left behind) stay empty.
    pub fn pick(&self, slots: &[usize]) -> Particles {
        fn each<T: Copy>(all: &[T], slots: &[usize]) -> Vec<T> {
            match all.is_empty() {
                true => Vec::new(),
                false => slots.iter().map(|&i| all[i]).collect(),
            }
        }
        Particles {
            x: each(&self.x, slots),
            v: each(&self.v, slots),
            c: each(&self.c, slots),
            rho: each(&self.rho, slots),
            material: each(&self.material, slots),
            live: each(&self.live, slots),
            deformation: each(&self.deformation, slots),
            volume_bias: each(&self.volume_bias, slots),
        }
    }

    /// Moves `other`'s particles after these (a share read a piece at a time: checkpoint.rs), each
    /// array appended to its own; `other` is left empty.
    pub fn append(&mut self, other: &mut Particles) {
        self.x.append(&mut other.x);
        self.v.append(&mut other.v);
        self.c.append(&mut other.c);
        self.rho.append(&mut other.rho);
        self.material.append(&mut other.material);
        self.live.append(&mut other.live);
        self.deformation.append(&mut other.deformation);
        self.volume_bias.append(&mut other.volume_bias);
    }

    /// Appends `count` parked slots at rest at the origin: room a run can fill without growing.
    pub fn park_more(&mut self, count: usize) {
        let len = self.len() + count;
        self.x.resize(len, glam::Vec3::ZERO);
        self.v.resize(len, glam::Vec3::ZERO);
        if !self.c.is_empty() {
            self.c.resize(len, glam::Mat3::ZERO);
        }
        self.rho.resize(len, 0.0);
        self.material.resize(len, 0);
        self.live.resize(len, false);
        if !self.deformation.is_empty() {
            self.deformation.resize(len, Deformation::at_rest(0));
        }
        if !self.volume_bias.is_empty() {
            self.volume_bias.resize(len, 0.0);
        }
    }
}

/// Bytes the CPU backend holds per particle (x, v, C, rho) and per grid node (mass, momentum).
pub const CPU_BYTES_PER_PARTICLE: usize = 4 * (3 + 3 + 9 + 1);
pub const CPU_BYTES_PER_NODE: usize = 4 * (1 + 3);

impl Scene {
    /// A preset name (see [`presets::NAMES`]) or a path to a `.toml` file.
    pub fn load(name_or_path: &str) -> Result<Scene, SceneError> {
        if let Some(text) = presets::get(name_or_path) {
            return Scene::from_toml(text, &format!("preset {name_or_path}"));
        }
        let path = Path::new(name_or_path);
        let looks_like_file = path.is_file() || path.extension().is_some() || name_or_path.contains('/');
        if !looks_like_file {
            return Err(SceneError {
                source: name_or_path.to_string(),
                key: String::new(),
                problem: "is neither a preset nor a scene file".into(),
                fix: format!(
                    "use one of the presets ({}) or the path of a .toml scene file",
                    presets::NAMES.join(", ")
                ),
            });
        }
        let text = std::fs::read_to_string(path).map_err(|e| {
            use std::io::ErrorKind;
            let (problem, fix) = match e.kind() {
                // Not UTF-8: a binary or random file, not a mistyped path.
                ErrorKind::InvalidData => (
                    "is not a text file, so not a scene (a scene is a TOML text file)".to_string(),
                    "give a .toml scene file; `mpm scenes --show dam-break` prints one to start from",
                ),
                ErrorKind::NotFound => (
                    "does not exist".to_string(),
                    "check the path; `mpm scenes` lists the built-in presets",
                ),
                _ if path.is_dir() => (
                    "is a directory".to_string(),
                    "give the path of a .toml scene file inside it",
                ),
                ErrorKind::PermissionDenied => (
                    format!("cannot be read: {e}"),
                    "the file is not readable by you: check its permissions",
                ),
                _ => (
                    format!("cannot be read: {e}"),
                    "check the path; `mpm scenes` lists the built-in presets",
                ),
            };
            SceneError {
                source: name_or_path.to_string(),
                key: String::new(),
                problem,
                fix: fix.into(),
            }
        })?;
        Scene::from_toml(&text, name_or_path)
    }

    pub fn from_toml(text: &str, source: &str) -> Result<Scene, SceneError> {
        let spec: SceneSpec = toml::from_str(text).map_err(|e| SceneError {
            source: source.to_string(),
            key: String::new(),
            problem: format!("is not a valid scene file:\n{}", e.to_string().trim_end()),
            fix: "see the scene file reference in docs/scenes.md; `mpm scenes --show dam-break` prints a complete example".into(),
        })?;
        let mut scene = Scene::from_spec(&spec, source)?;
        scene.toml = text.to_string();
        Ok(scene)
    }

    pub fn from_spec(spec: &SceneSpec, source: &str) -> Result<Scene, SceneError> {
        Validator { source }.scene(spec)
    }

    /// The parameters a step needs, with `dt` still to be set by the time-step policy: their one
    /// author. Every backend and tool takes them from here.
    pub fn params(&self) -> Params {
        let (mirror_lo, mirror_hi) = fluid_region_nodes(self.grid_res, self.boundary_band, self.soft_wall);
        let (fixed_mass_scale, fixed_momentum_scale) = self.fixed_point_scales();
        let mut materials = [Material::default(); MAX_MATERIALS as usize];
        for (row, m) in materials.iter_mut().zip(&self.materials) {
            *row = m.law;
        }
        let kernel = KernelParams {
            material_count: self.materials.len() as u32,
            gravity: self.gravity.to_array(),
            dt: 0.0,
            grid_res: self.grid_res,
            dx: self.dx,
            inv_dx: 1.0 / self.dx,
            boundary_band: self.boundary_band,
            soft_wall_tau: if self.soft_wall { FRAME_DT } else { 0.0 },
            num_particles: self.slots() as u32,
            scatter_mode: self.scatter.code(),
            fixed_mass_scale,
            fixed_momentum_scale,
            wall_mirror_lo: if self.mirror_wall_mass { mirror_lo } else { 0 },
            wall_mirror_hi: if self.mirror_wall_mass { mirror_hi } else { [0; 3] },
            density_rule: self.pipeline.density_rule().code(),
            volume_density: u32::from(self.rest_densities_differ()),
            box_lo: [0; 3],
            box_res: self.grid_res,
        };
        Params { kernel, materials }
    }

    /// Whether the materials the bodies and emitters are made of differ in rest density: then every
    /// particle's density is gathered from the grid's volume rather than its mass
    /// (`KernelParams::volume_density`). A row no body uses changes nothing.
    pub fn rest_densities_differ(&self) -> bool {
        let rows = self
            .bodies
            .iter()
            .map(|b| b.material)
            .chain(self.flow.emitters.iter().map(|e| e.material));
        let used: Vec<Material> = rows.map(|row| self.materials[usize::from(row)].law).collect();
        !used.is_empty() && used.as_slice().several_densities()
    }

    /// Fixed-point scales (units per kg, units per kg m/s): a grid node at rest holds one cell's mass,
    /// rho0 dx^3, so that maps to 2^40 units; momentum maps one cell's mass at the reference speed
    /// ([`Self::fixed_point_reference_speed`]) to 2^40 units. Contributions then sit near 2^37, far
    /// under the 2^52 per-contribution limit, and the mass's rounding step (2^-40 of a cell's mass)
    /// is far finer than f32 resolves. These are the coarsest units a run uses: each stretch of
    /// substeps refines the momentum's to the flow's own speed ([`Self::fixed_momentum_scale_for`]).
    /// The fixed-point scatter (GPU and CPU) and the binned pipeline's tiles (in either scatter mode)
    /// use them.
    pub fn fixed_point_scales(&self) -> (f32, f32) {
        let dx = f64::from(self.dx);
        let densest = self
            .materials
            .iter()
            .map(|m| m.law.rest_density)
            .fold(0.0, f32::max);
        let cell_mass = f64::from(densest) * dx * dx * dx;
        let speed = self.fixed_point_reference_speed();
        let units = (1u64 << 40) as f64;
        ((units / cell_mass) as f32, (units / (cell_mass * speed)) as f32)
    }

    /// The speed the coarsest momentum units are made for, m/s: the largest of the sound speed, the
    /// free-fall speed over the domain height and the bodies' speeds, a bound the fluid does not
    /// pass while the CFL policy holds.
    pub fn fixed_point_reference_speed(&self) -> f64 {
        let height = f64::from(self.grid_res.iter().copied().max().unwrap_or(1)) * f64::from(self.dx);
        let free_fall = (2.0 * f64::from(self.gravity.length()) * height).sqrt();
        let rows: Vec<Material> = self.materials.iter().map(|m| m.law).collect();
        f64::from(rows.as_slice().fastest_sound_speed())
            .max(free_fall)
            .max(f64::from(self.fastest_start()))
            .max(1e-3)
    }

    /// The fixed-point momentum scale for a stretch of substeps whose particles' momentum
    /// contributions reach at most `reach` m/s per unit of mass and weight: the coarsest scale
    /// ([`Self::fixed_point_scales`]) refined by the largest power of two, up to
    /// 2^[`MAX_MOMENTUM_REFINEMENT`], that keeps `reach` within the refined reference speed.
    ///
    /// Why: the binned pipeline's tiles round every momentum contribution in units 2^13 coarser than
    /// the grid's (`TILE_UNIT_SHIFT`, kernels/tiles.cuh). At the sound speed's units a creeping flow
    /// (a viscous liquid, a sphere sinking at Stokes' velocity) moves a few units a contribution, and
    /// the rounding decayed a viscous vortex 7 to 29 % fast on the GPU (BENCHMARKS.md M14). The
    /// flow's own speed sets units as fine as a fast flow's. A particle that outruns the refined speed
    /// anyway scatters through the grid's 64-bit atomics instead of its tile (`tile_takes`), where it
    /// has 2^15 times the reference speed of headroom before a contribution is out of range; powers of
    /// two keep the scale (so the substep's CUDA graph) the same from stretch to stretch while the
    /// flow's speed stays within a factor of two.
    pub fn fixed_momentum_scale_for(&self, reach: f32) -> f32 {
        let coarsest = self.fixed_point_scales().1;
        let ratio = self.fixed_point_reference_speed() / f64::from(reach);
        let refinement = if ratio.is_finite() {
            ratio
                .log2()
                .floor()
                .clamp(0.0, f64::from(MAX_MOMENTUM_REFINEMENT))
        } else {
            f64::from(MAX_MOMENTUM_REFINEMENT)
        };
        coarsest * (refinement as f32).exp2()
    }

    /// The lowest and highest coordinate a fluid body may reach on each axis: inside the boundary band.
    pub fn fluid_region(&self) -> (DVec3, DVec3) {
        fluid_region(
            self.grid_res,
            f64::from(self.dx),
            self.boundary_band,
            self.soft_wall,
        )
    }

    /// The planes that hold the rigid bodies: the fluid region's faces.
    pub fn body_walls(&self) -> crate::sim::colliders::bodies::BodyWalls {
        let (lo, hi) = self.fluid_region();
        crate::sim::colliders::bodies::BodyWalls {
            lo: lo.to_array(),
            hi: hi.to_array(),
        }
    }

    /// Particle slots a solver allocates: the flow's capacity (the live particles where the scene has
    /// no flow).
    pub fn slots(&self) -> usize {
        self.flow.capacity
    }

    /// A refusal of this scene's `key`, naming the problem and the fix (the checks made after it
    /// loaded, as the loader's own errors read).
    fn refusal(&self, key: &str, problem: impl Into<String>, fix: impl Into<String>) -> SceneError {
        SceneError {
            source: self.source.clone(),
            key: key.into(),
            problem: problem.into(),
            fix: fix.into(),
        }
    }

    /// Refuses colliders and emitters' pipes on the report pipeline (whose kernels do not apply
    /// them), and Coulomb colliders under the walls' mirror on the binned one, naming the fix. Nothing
    /// under pbmpm, whose substep is its own in every pipeline (src/cuda/pbmpm_substep.rs).
    pub fn check_pipeline(&self) -> Result<(), SceneError> {
        if self.method == Method::Pbmpm {
            return Ok(());
        }
        if !self.colliders.is_empty() && self.pipeline == Pipeline::Report {
            return Err(self.refusal(
                "solver.pipeline",
                format!(
                    "= \"report\" cannot run this scene's {} collider(s) and {} emitter pipe(s): only the fused and binned pipelines apply them",
                    self.colliders.len(),
                    self.colliders.num_pipes()
                ),
                "use --pipeline fused (or solver.pipeline = \"fused\", the default)",
            ));
        }
        // The binned pipeline adds the walls' images in a launch of their own, before its grid
        // update, which then cannot tell what they pushed: its Coulomb colliders would not grip
        // under the mirror (docs/physics.md, "Colliders").
        let (lo, hi) = self.fluid_region();
        let reach = f64::from(self.params().kernel.wall_mirror_lo) * f64::from(self.dx);
        if self.mirror_wall_mass
            && self.pipeline == Pipeline::Binned
            && self.colliders.friction_near_faces(lo, hi, self.dx, reach)
        {
            return Err(self.refusal(
                "solver.pipeline",
                "= \"binned\" cannot grip with a Coulomb (friction) collider that may reach the walls' \
                 mirror (a moving one, or one within its band of a wall): only the fused pipeline's \
                 grid update sees what the mirror pushed",
                "use --pipeline fused (or solver.pipeline = \"fused\", the default), or \
                 solver.mirror_wall_mass = false",
            ));
        }
        Ok(())
    }

    /// Runs the scene under `method` (the command line's `--method`, a checkpoint's): a change of
    /// method takes that method's default time-step policy (the CFL policy, or pbmpm's default
    /// substeps a frame).
    pub fn set_method(&mut self, method: Method) {
        if method != self.method {
            self.time_step = TimeStepPolicy::default_for(method);
            self.method = method;
        }
    }

    /// Refuses what the position-based solver does not run yet, naming the fix: rigid bodies,
    /// emitters and sinks, the soft wall, and runs split into ranks. Nothing under the explicit
    /// method. Checked when the scene loads and again when a backend is made (the command line's
    /// `--method` may have changed it since).
    pub fn check_method(&self) -> Result<(), SceneError> {
        if self.method != Method::Pbmpm {
            return Ok(());
        }
        let explicit_fix = "drop it, or run the scene with solver.method = \"explicit\" (the default)";
        let bodies = self.colliders.num_bodies();
        if bodies > 0 {
            return Err(self.refusal(
                "collider.density",
                format!(
                    "(or mass) makes {bodies} collider(s) rigid bodies, which solver.method = \"pbmpm\" does \
                     not move yet (its colliders stand still or follow their motion)"
                ),
                "drop the density and mass (the collider then stands still or follows its motion), or run \
                 the scene with solver.method = \"explicit\" (the default)",
            ));
        }
        if !self.flow.emitters.is_empty() || !self.flow.sinks.is_empty() {
            return Err(self.refusal(
                "emitter",
                format!(
                    "and sinks ({} emitter(s), {} sink(s)) do not run under solver.method = \"pbmpm\" yet",
                    self.flow.emitters.len(),
                    self.flow.sinks.len()
                ),
                explicit_fix,
            ));
        }
        if self.soft_wall {
            return Err(self.refusal(
                "solver.soft_wall",
                "= true: solver.method = \"pbmpm\" holds the particles with its own displacement walls",
                "drop solver.soft_wall",
            ));
        }
        if self.ranks > 1 {
            return Err(self.refusal(
                "solver.method",
                format!("= \"pbmpm\" runs on one rank, not the {} asked for", self.ranks),
                "drop --ranks and --gpus",
            ));
        }
        Ok(())
    }

    /// The fastest speed at the start, m/s: of the bodies, of what the emitters emit and of the
    /// moving colliders.
    pub fn fastest_start(&self) -> f32 {
        let bodies = self.bodies.iter().map(|b| b.velocity.length());
        let emitters = self.flow.emitters.iter().map(|e| e.speed);
        bodies.chain(emitters).fold(self.colliders.max_speed(), f32::max)
    }

    /// The first row of the material table: the scene's only material where it has one.
    /// Whether any material of the table is a solid: the viewer draws its particles as spheres.
    pub fn has_solids(&self) -> bool {
        self.materials.iter().any(|m| m.law.is_solid())
    }

    /// Whether any material carries a deformation (a solid, or an elastoviscoplastic liquid): then
    /// every particle has one (`Particles::deformation`).
    pub fn has_deformation(&self) -> bool {
        self.materials.iter().any(|m| m.law.carries_deformation())
    }

    pub fn material(&self) -> &Material {
        &self.materials[0].law
    }
}

/// Where particles can be, in nodes per axis: `[lo, hi[a]]`. Nodes below `band` (and from `res - band`
/// up) have no wall-normal velocity, so fluid settles against the wall between node `band - 1` and
/// `band`; for the usual band of 2 this is exactly the clamp range [1, R-2] dx of g2p. The soft wall
/// pushes particles back from (band + 1) dx and (R - band - 2) dx instead. Bodies spawned inside start
/// against the walls rather than slumping into a gap or being squeezed, and these are the planes the
/// wall mass is mirrored about.
pub fn fluid_region_nodes(res: [u32; 3], band: u32, soft_wall: bool) -> (u32, [u32; 3]) {
    let (lo, hi_margin) = if soft_wall {
        (band + 1, band + 2)
    } else {
        ((band - 1).max(1), band.max(2))
    };
    (lo, res.map(|r| r - hi_margin))
}

fn fluid_region(res: [u32; 3], dx: f64, band: u32, soft_wall: bool) -> (DVec3, DVec3) {
    let (lo, hi) = fluid_region_nodes(res, band, soft_wall);
    (
        DVec3::splat(f64::from(lo) * dx),
        DVec3::from(hi.map(f64::from)) * dx,
    )
}

fn default_name(source: &str) -> String {
    let source = source.strip_prefix("preset ").unwrap_or(source);
    Path::new(source)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| source.to_string())
}

impl TimeStepPolicy {
    /// How many substeps run before the substep is chosen anew from their extremes; `None`: a whole
    /// frame's at once. An impact can raise the density (and the sound speed, as rho^3 for water) by
    /// tens of percent within ten substeps (seen at the dam break's far wall and the drop's splash on
    /// the H200, with choices an eighth of a frame apart), so the CFL policy looks every four. A fixed
    /// dt needs no second look.
    pub fn substeps_per_choice(&self) -> Option<u32> {
        match self {
            TimeStepPolicy::Fixed { .. } => None,
            TimeStepPolicy::Cfl { .. } => Some(4),
        }
    }

    /// The longest substep the policy allows for a fastest signal speed (c + |v|) in m/s, whatever
    /// the span to cover: a fixed policy's dt, the CFL policy's `cfl dx / signal_speed`.
    pub fn longest_substep(&self, signal_speed: f32, dx: f32) -> f32 {
        match *self {
            TimeStepPolicy::Fixed { dt } => dt,
            TimeStepPolicy::Cfl { cfl, .. } => cfl * dx / signal_speed,
        }
    }

    /// Substeps and the substep to cover `span` seconds, for a fastest signal speed (c + |v|) in m/s.
    pub fn substeps(&self, span: f32, signal_speed: f32, dx: f32) -> Result<(u32, f32), String> {
        match *self {
            TimeStepPolicy::Fixed { dt } => Ok(((span / dt).round().max(1.0) as u32, dt)),
            TimeStepPolicy::Cfl { cfl, max_substeps } => {
                if !signal_speed.is_finite() {
                    return Err("the fluid diverged: its speed is no longer finite".into());
                }
                let n = (span * signal_speed / (cfl * dx)).ceil().max(1.0);
                let per_frame = n * FRAME_DT / span;
                if per_frame > max_substeps as f32 {
                    // Past the default only a runaway speed gets here; below it, the cap may simply
                    // be lower than this scene needs.
                    return Err(if per_frame > DEFAULT_MAX_SUBSTEPS as f32 {
                        format!(
                            "the fluid is blowing up: a signal speed of {signal_speed:.1} m/s needs \
                             {per_frame:.0} substeps per frame, over time_step.max_substeps = {max_substeps}"
                        )
                    } else {
                        format!(
                            "a signal speed of {signal_speed:.1} m/s needs {per_frame:.0} substeps per frame, \
                             more than time_step.max_substeps = {max_substeps} allows; raise max_substeps \
                             (the default is {DEFAULT_MAX_SUBSTEPS}) or lower the scene's speeds"
                        )
                    });
                }
                Ok((n as u32, span / n))
            }
        }
    }
}
