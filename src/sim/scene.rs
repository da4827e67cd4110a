//! Scenes: the TOML format, its validation, and the particle lattice a scene spawns.
//!
//! A scene file is parsed into the `*Spec` structs (what the user wrote, every key optional where a
//! default makes sense), then validated into a [`Scene`] (what the solver runs, every value checked).
//! Every refusal names the file, the key and the fix.

use super::colliders::{self, ColliderFrame, ColliderSpec, Colliders, MAX_COLLIDERS};
use super::flow::{self, Emitter, Flow, Nozzle, Sink, MAX_EMITTERS};
use super::params::{Material, Params, Pipeline, ScatterMode, FRAME_DT};
use super::{mesh, presets};
use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;

/// The largest CFL number the solver is stable at (docs/physics.md, "The time step").
pub const MAX_CFL: f32 = 0.5;

/// A scene that could not be loaded: where, which key, what is wrong, and how to fix it.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    /// The file path or `preset NAME`.
    pub source: String,
    /// The offending key, in TOML path form (`material.rest_density`, `block[1].max`); empty for the file.
    pub key: String,
    pub problem: String,
    pub fix: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.key.is_empty() {
            write!(f, "scene {}: {}", self.source, self.problem)?;
        } else {
            write!(f, "scene {}: `{}` {}", self.source, self.key, self.problem)?;
        }
        if !self.fix.is_empty() {
            write!(f, "\n  fix: {}", self.fix)?;
        }
        Ok(())
    }
}

impl std::error::Error for SceneError {}

// ---------------------------------------------------------------------------------------------
// The file format.

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    pub name: Option<String>,
    pub description: Option<String>,
    pub domain: DomainSpec,
    pub material: MaterialSpec,
    #[serde(default)]
    pub solver: SolverSpec,
    #[serde(default)]
    pub time_step: TimeStepSpec,
    #[serde(default, rename = "block")]
    pub blocks: Vec<BlockSpec>,
    #[serde(default, rename = "sphere")]
    pub spheres: Vec<SphereSpec>,
    #[serde(default, rename = "collider")]
    pub colliders: Vec<ColliderSpec>,
    #[serde(default)]
    pub particles: Option<ParticlesSpec>,
    #[serde(default, rename = "emitter")]
    pub emitters: Vec<EmitterSpec>,
    #[serde(default, rename = "sink")]
    pub sinks: Vec<SinkSpec>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ParticlesSpec {
    /// Particle slots allocated up front, live and parked: what emitters can fill.
    pub capacity: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum NozzleShape {
    Disc,
    Rectangle,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct EmitterSpec {
    pub shape: NozzleShape,
    /// Centre of the nozzle, m.
    pub center: [f64; 3],
    /// The direction the fluid leaves in (normalised on load).
    pub normal: [f32; 3],
    /// Disc radius, m.
    pub radius: Option<f64>,
    /// Rectangle side lengths across the normal, m.
    pub size: Option<[f64; 2]>,
    /// m/s along the normal.
    pub speed: f32,
    /// m^3/s; default: what the nozzle passes at `speed` (its area times the speed).
    pub rate: Option<f64>,
    #[serde(default = "default_ppc")]
    pub particles_per_cell: u32,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SinkSpec {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DomainSpec {
    /// Tank size per axis, m.
    pub size: [f64; 3],
    /// Grid nodes per axis.
    pub resolution: [u32; 3],
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    pub rest_density: f32,
    /// Give either the sound speed (m/s) or the EOS stiffness (Pa); the other follows.
    pub sound_speed: Option<f32>,
    pub eos_stiffness: Option<f32>,
    #[serde(default = "default_eos_power")]
    pub eos_power: f32,
    #[serde(default = "default_viscosity")]
    pub viscosity: f32,
    #[serde(default)]
    pub pressure_floor: f32,
}

fn default_eos_power() -> f32 {
    7.0
}
fn default_viscosity() -> f32 {
    1.0e-3
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SolverSpec {
    #[serde(default = "default_gravity")]
    pub gravity: [f32; 3],
    #[serde(default = "default_band")]
    pub boundary_band: u32,
    /// nialltl's soft wall: pushes particles back before they reach the band.
    #[serde(default)]
    pub soft_wall: bool,
    /// Add a mirror-image fluid beyond the walls to the grid (mass and reflected momentum), so fluid at
    /// a wall has the density and pressure support it has inside; off, wall particles read low and the
    /// fluid sinks along the walls and circulates (the report's scheme).
    #[serde(default = "default_true")]
    pub mirror_wall_mass: bool,
    #[serde(default)]
    pub scatter: ScatterMode,
    /// The GPU's kernel sequence: "binned" (default) or "report".
    #[serde(default)]
    pub pipeline: Pipeline,
}

fn default_true() -> bool {
    true
}

fn default_gravity() -> [f32; 3] {
    [0.0, -9.81, 0.0]
}
fn default_band() -> u32 {
    2
}

impl Default for SolverSpec {
    fn default() -> Self {
        SolverSpec {
            gravity: default_gravity(),
            boundary_band: default_band(),
            soft_wall: false,
            mirror_wall_mass: true,
            scatter: ScatterMode::default(),
            pipeline: Pipeline::default(),
        }
    }
}

/// `time_step.max_substeps` when a scene gives none: past this many substeps per frame the CFL
/// policy calls the fluid diverged.
pub const DEFAULT_MAX_SUBSTEPS: u32 = 2000;

#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TimeStepSpec {
    /// Choose substeps so that (c + |v|max) dt / dx stays at this number.
    pub cfl: Option<f32>,
    /// Or use this fixed substep, s.
    pub dt: Option<f32>,
    /// The CFL policy gives up (the fluid is blowing up) past this many substeps per frame.
    pub max_substeps: Option<u32>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BlockSpec {
    pub min: [f64; 3],
    pub max: [f64; 3],
    #[serde(default = "default_ppc")]
    pub particles_per_cell: u32,
    #[serde(default)]
    pub velocity: [f32; 3],
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    pub center: [f64; 3],
    pub radius: f64,
    #[serde(default = "default_ppc")]
    pub particles_per_cell: u32,
    #[serde(default)]
    pub velocity: [f32; 3],
}

fn default_ppc() -> u32 {
    8
}

// ---------------------------------------------------------------------------------------------
// The validated scene.

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStepPolicy {
    /// Substeps per frame from the acoustic and advective limits, at this CFL number.
    Cfl { cfl: f32, max_substeps: u32 },
    /// A fixed substep; a frame is the whole number of substeps nearest to 1/60 s.
    Fixed { dt: f32 },
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
}

#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub name: String,
    pub description: String,
    /// Where it came from (`preset dam-break` or a path), for messages.
    pub source: String,
    pub grid_res: [u32; 3],
    pub dx: f32,
    pub material: Material,
    pub gravity: Vec3,
    pub boundary_band: u32,
    pub soft_wall: bool,
    /// Mirror the fluid beyond the walls onto the grid (see `Params::wall_mirror_lo`).
    pub mirror_wall_mass: bool,
    pub scatter: ScatterMode,
    /// The GPU's kernel sequence (the CPU reference ignores it).
    pub pipeline: Pipeline,
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
    /// False for a parked slot (see `sim::flow`): no part of the fluid, kept for its index.
    pub live: Vec<bool>,
}

impl Particles {
    /// Slots, live and parked.
    pub fn len(&self) -> usize {
        self.x.len()
    }
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    pub fn num_live(&self) -> usize {
        self.live.iter().filter(|&&l| l).count()
    }

    /// The live particles alone, in slot order: what export and statistics see.
    pub fn live_only(&self) -> Particles {
        if self.live.iter().all(|&l| l) {
            return self.clone();
        }
        let keep = |i: &usize| self.live[*i];
        let pick = |n: usize| (0..n).filter(keep);
        let n = self.len();
        Particles {
            x: pick(n).map(|i| self.x[i]).collect(),
            v: pick(n).map(|i| self.v[i]).collect(),
            c: pick(n).map(|i| self.c[i]).collect(),
            rho: pick(n).map(|i| self.rho[i]).collect(),
            live: vec![true; pick(n).count()],
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
        let looks_like_file = path.extension().is_some() || name_or_path.contains('/');
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
            fix: "see the scene file reference in README.md; `mpm scenes --show dam-break` prints a complete example".into(),
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
        Params {
            material: self.material,
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
            _pad: 0,
        }
    }

    /// Fixed-point scales (units per kg, units per kg m/s): a grid node at rest holds one cell's mass,
    /// rho0 dx^3, so that maps to 2^40 units; momentum maps one cell's mass at the reference speed to
    /// 2^40 units. The speed is the largest of the sound speed, the free-fall speed over the domain
    /// height and the bodies' speeds: a bound the fluid does not pass while the CFL policy holds.
    /// Contributions then sit near 2^37, far under the 2^52 per-contribution limit, and the rounding
    /// step (2^-40 of a cell's mass) is far finer than f32 resolves. The GPU's fixed-point scatter and
    /// the binned pipeline's tiles (in either scatter mode) use them; the CPU ignores them.
    pub fn fixed_point_scales(&self) -> (f32, f32) {
        let dx = f64::from(self.dx);
        let cell_mass = f64::from(self.material.rest_density) * dx * dx * dx;
        let height = f64::from(self.grid_res.iter().copied().max().unwrap_or(1)) * dx;
        let free_fall = (2.0 * f64::from(self.gravity.length()) * height).sqrt();
        let body_speed = f64::from(self.fastest_start());
        let speed = f64::from(self.material.sound_speed())
            .max(free_fall)
            .max(body_speed)
            .max(1e-3);
        let units = (1u64 << 40) as f64;
        ((units / cell_mass) as f32, (units / (cell_mass * speed)) as f32)
    }

    pub fn lattice(&self) -> Lattice {
        Lattice {
            spacing: f64::from(self.dx) / f64::from(self.particles_per_axis),
        }
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

    /// Particle slots a solver allocates: the flow's capacity (the live particles where the scene has
    /// no flow).
    pub fn slots(&self) -> usize {
        self.flow.capacity
    }

    /// The particles, in body order, each body's lattice points in x-fastest order, skipping points
    /// that an earlier body already covers; then the parked slots up to the capacity (at the origin,
    /// at rest).
    pub fn spawn(&self) -> Particles {
        let lattice = self.lattice();
        let slots = self.slots();
        let mut particles = Particles {
            x: Vec::with_capacity(slots),
            v: Vec::with_capacity(slots),
            c: vec![glam::Mat3::ZERO; slots],
            rho: vec![self.material.rest_density; slots],
            live: vec![true; self.num_particles],
        };
        let colliders = self.colliders_at_start();
        for (k, body) in self.bodies.iter().enumerate() {
            for p in self.own_points(&lattice, k, &colliders) {
                particles.x.push(p.as_vec3());
                particles.v.push(body.velocity);
            }
        }
        debug_assert_eq!(particles.x.len(), self.num_particles);
        particles.x.resize(slots, Vec3::ZERO);
        particles.v.resize(slots, Vec3::ZERO);
        particles.live.resize(slots, false);
        particles
    }

    /// The lattice points of body `k` that no earlier body covers: where its particles go.
    /// Points inside a collider (at time 0) are left out too.
    fn own_points<'a>(
        &'a self,
        lattice: &'a Lattice,
        k: usize,
        colliders: &'a ColliderFrame,
    ) -> impl Iterator<Item = DVec3> + 'a {
        lattice.points(&self.bodies[k].shape).filter(move |&p| {
            !self.bodies[..k].iter().any(|b| lattice.contains(&b.shape, p))
                && !colliders.contains(p.as_vec3())
        })
    }

    /// The colliders at time 0.
    fn colliders_at_start(&self) -> ColliderFrame {
        self.colliders.frame(0.0)
    }

    /// Refuses colliders on the report pipeline (whose kernels do not apply them), naming the fix.
    pub fn check_pipeline(&self) -> Result<(), SceneError> {
        if !self.colliders.is_empty() && self.pipeline == Pipeline::Report {
            return Err(SceneError {
                source: self.source.clone(),
                key: "solver.pipeline".into(),
                problem: format!(
                    "= \"report\" cannot run this scene's {} collider(s): only the binned pipeline applies colliders",
                    self.colliders.len()
                ),
                fix: "use --pipeline binned (or solver.pipeline = \"binned\", the default)".into(),
            });
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

    /// Total particle mass, kg.
    pub fn total_mass(&self) -> f64 {
        self.num_particles as f64 * f64::from(self.material.particle_mass)
    }
}

/// Where particles can be, in nodes per axis: `[lo, hi[a]]`. Nodes below `band` (and from `res - band`
/// up) have no wall-normal velocity, so fluid settles against the wall between node `band - 1` and
/// `band`; for the usual band of 2 this is exactly the clamp range [1, R-2] dx of g2p. The soft wall
/// pushes particles back from (band + 1) dx and (R - band - 2) dx instead. Bodies spawned inside start
/// against the walls rather than slumping into a gap or being squeezed, and these are the planes the
/// wall mass is mirrored about.
fn fluid_region_nodes(res: [u32; 3], band: u32, soft_wall: bool) -> (u32, [u32; 3]) {
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

/// The particle lattice: points at (j + 1/2) h on every axis, h = dx / particles-per-axis, so a
/// whole cell holds exactly n^3 points and the initial packing is exactly at rest density.
#[derive(Debug, Clone, Copy)]
pub struct Lattice {
    pub spacing: f64,
}

impl Lattice {
    fn point(&self, j: [i64; 3]) -> DVec3 {
        DVec3::new(j[0] as f64 + 0.5, j[1] as f64 + 0.5, j[2] as f64 + 0.5) * self.spacing
    }

    /// Lattice index range `[lo, hi)` of the points with `min <= x < max` on each axis.
    /// Bounds and points never coincide (points sit at half-integers), so rounding cannot flip a point.
    fn index_range(&self, min: DVec3, max: DVec3) -> ([i64; 3], [i64; 3]) {
        let first = |v: f64| (v / self.spacing - 0.5).ceil() as i64;
        (
            [first(min.x), first(min.y), first(min.z)],
            [first(max.x), first(max.y), first(max.z)],
        )
    }

    fn bounds(shape: &Shape) -> (DVec3, DVec3) {
        match *shape {
            Shape::Block { min, max } => (min, max),
            Shape::Sphere { center, radius } => (center - radius, center + radius),
        }
    }

    pub fn contains(&self, shape: &Shape, p: DVec3) -> bool {
        match *shape {
            Shape::Block { min, max } => {
                let (lo, hi) = self.index_range(min, max);
                let j = |v: f64| (v / self.spacing - 0.5).round() as i64;
                let idx = [j(p.x), j(p.y), j(p.z)];
                (0..3).all(|a| lo[a] <= idx[a] && idx[a] < hi[a])
            }
            Shape::Sphere { center, radius } => (p - center).length_squared() <= radius * radius,
        }
    }

    /// The lattice points of a shape, x fastest.
    pub fn points(&self, shape: &Shape) -> impl Iterator<Item = DVec3> + '_ {
        let (min, max) = Self::bounds(shape);
        // A sphere's bounding box is closed; widen by half a spacing so boundary points are visited.
        let pad = if matches!(shape, Shape::Sphere { .. }) {
            self.spacing
        } else {
            0.0
        };
        let (lo, hi) = self.index_range(min - pad, max + pad);
        let shape = *shape;
        (lo[2]..hi[2]).flat_map(move |k| {
            (lo[1]..hi[1]).flat_map(move |j| {
                (lo[0]..hi[0])
                    .map(move |i| self.point([i, j, k]))
                    .filter(move |p| self.contains(&shape, *p))
            })
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Validation.

struct Validator<'a> {
    source: &'a str,
}

impl Validator<'_> {
    fn err(&self, key: impl Into<String>, problem: impl Into<String>, fix: impl Into<String>) -> SceneError {
        SceneError {
            source: self.source.to_string(),
            key: key.into(),
            problem: problem.into(),
            fix: fix.into(),
        }
    }

    fn positive(&self, key: &str, value: f32, fix: &str) -> Result<f32, SceneError> {
        if value.is_finite() && value > 0.0 {
            Ok(value)
        } else {
            Err(self.err(key, format!("must be a positive number, got {value}"), fix))
        }
    }

    fn finite3(&self, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        if v.iter().all(|c| c.is_finite()) {
            Ok(Vec3::from(v))
        } else {
            Err(self.err(
                key,
                format!("must be finite, got {v:?}"),
                "give three finite numbers",
            ))
        }
    }

    fn scene(&self, spec: &SceneSpec) -> Result<Scene, SceneError> {
        let (grid_res, dx) = self.domain(&spec.domain)?;
        let band = spec.solver.boundary_band;
        if band < 1 || 2 * band + 4 > grid_res.iter().copied().min().unwrap_or(0) {
            return Err(self.err(
                "solver.boundary_band",
                format!("= {band} leaves no room for fluid in a grid of {grid_res:?} nodes"),
                "use 2 (the default); it must be at least 1 and leave 4 free nodes on every axis",
            ));
        }
        let particles_per_axis = self.particles_per_axis(spec)?;
        let material = self.material(&spec.material, dx, particles_per_axis)?;
        let gravity = self.finite3("solver.gravity", spec.solver.gravity)?;
        let bodies = self.bodies(spec, grid_res, dx, band, spec.solver.soft_wall)?;
        let emitter_speeds = spec
            .emitters
            .iter()
            .map(|e| if e.speed.is_finite() { e.speed } else { 0.0 });
        let max_body_speed = bodies
            .iter()
            .map(|b| b.velocity.length())
            .chain(emitter_speeds)
            .fold(0.0, f32::max);
        let colliders = self.colliders(spec, grid_res, dx)?;
        let max_speed = max_body_speed.max(colliders.max_speed());
        let time_step = self.time_step(&spec.time_step, &material, dx, max_speed)?;

        let mut scene = Scene {
            name: spec.name.clone().unwrap_or_else(|| default_name(self.source)),
            description: spec.description.clone().unwrap_or_default(),
            source: self.source.to_string(),
            grid_res,
            dx: dx as f32,
            material,
            gravity,
            boundary_band: band,
            soft_wall: spec.solver.soft_wall,
            mirror_wall_mass: spec.solver.mirror_wall_mass,
            scatter: spec.solver.scatter,
            pipeline: spec.solver.pipeline,
            time_step,
            particles_per_axis,
            bodies,
            colliders,
            num_particles: 0,
            flow: Flow::default(),
            // A spec always serialises (plain numbers, strings and arrays).
            toml: toml::to_string(spec).unwrap_or_default(),
        };
        // The exact count walks every lattice point: refuse absurd sizes from the volume estimate first.
        self.fits_in_memory(&scene, self.estimate_particles(&scene))?;
        scene.num_particles = self.count_particles(&scene, !spec.emitters.is_empty())?;
        scene.flow = self.flow(spec, &scene)?;
        self.fits_in_memory(&scene, scene.slots())?;
        Ok(scene)
    }

    fn domain(&self, d: &DomainSpec) -> Result<([u32; 3], f64), SceneError> {
        for (a, axis) in ["x", "y", "z"].iter().enumerate() {
            if !(d.size[a].is_finite() && d.size[a] > 0.0) {
                return Err(self.err(
                    "domain.size",
                    format!("{axis} = {} must be a positive length in metres", d.size[a]),
                    "give the tank size per axis, e.g. size = [1.0, 0.5, 0.5]",
                ));
            }
            if d.resolution[a] < 8 {
                return Err(self.err(
                    "domain.resolution",
                    format!("{axis} = {} is under 8 grid nodes", d.resolution[a]),
                    "use at least 8 nodes per axis (the boundary band and stencil need room)",
                ));
            }
        }
        let dxs: Vec<f64> = (0..3).map(|a| d.size[a] / f64::from(d.resolution[a])).collect();
        let dx = dxs[0];
        if dxs.iter().any(|&h| ((h - dx) / dx).abs() > 1e-4) {
            return Err(self.err(
                "domain.resolution",
                format!(
                    "gives different cell sizes per axis (size / resolution = {:.6}, {:.6}, {:.6} m)",
                    dxs[0], dxs[1], dxs[2]
                ),
                format!(
                    "cells must be cubes: keep size / resolution equal, e.g. resolution = [{}, {}, {}]",
                    d.resolution[0],
                    (d.size[1] / dx).round(),
                    (d.size[2] / dx).round()
                ),
            ));
        }
        Ok((d.resolution, dx))
    }

    fn particles_per_axis(&self, spec: &SceneSpec) -> Result<u32, SceneError> {
        let ppcs = spec
            .blocks
            .iter()
            .enumerate()
            .map(|(i, b)| (format!("block[{i}].particles_per_cell"), b.particles_per_cell))
            .chain(
                spec.spheres
                    .iter()
                    .enumerate()
                    .map(|(i, s)| (format!("sphere[{i}].particles_per_cell"), s.particles_per_cell)),
            )
            .chain(
                spec.emitters
                    .iter()
                    .enumerate()
                    .map(|(i, e)| (format!("emitter[{i}].particles_per_cell"), e.particles_per_cell)),
            );
        let mut chosen: Option<(String, u32)> = None;
        for (key, ppc) in ppcs {
            let n = (1..=4).find(|n| n * n * n == ppc).ok_or_else(|| {
                self.err(
                    &key,
                    format!("= {ppc} is not a cube lattice"),
                    "use 1, 8, 27 or 64 particles per cell (1 to 4 per axis); 8 is the usual choice",
                )
            })?;
            match &chosen {
                Some((first, m)) if *m != n => {
                    return Err(self.err(
                        &key,
                        format!("= {ppc} differs from `{first}` = {}", m * m * m),
                        "give every body the same particles_per_cell: the particle mass \
                         m_p = rho0 dx^3 / ppc is one material constant",
                    ))
                }
                Some(_) => {}
                None => chosen = Some((key, n)),
            }
        }
        chosen.map(|(_, n)| n).ok_or_else(|| {
            self.err(
                "block",
                "the scene has no fluid bodies and no emitters, so it has zero particles",
                "add at least one [[block]] (min, max), [[sphere]] (center, radius) or [[emitter]]",
            )
        })
    }

    fn material(&self, m: &MaterialSpec, dx: f64, n: u32) -> Result<Material, SceneError> {
        let rho0 = self.positive(
            "material.rest_density",
            m.rest_density,
            "give the rest density in kg/m^3, e.g. 1000 for water",
        )?;
        let gamma = self.positive("material.eos_power", m.eos_power, "use 7 (Tait, water)")?;
        let stiffness = match (m.sound_speed, m.eos_stiffness) {
            (Some(c0), None) => {
                let c0 = self.positive(
                    "material.sound_speed",
                    c0,
                    "give the sound speed in m/s; 10-20 for real-time water",
                )?;
                rho0 * c0 * c0 / gamma
            }
            (None, Some(k)) => self.positive("material.eos_stiffness", k, "give k in Pa")?,
            (Some(_), Some(_)) => {
                return Err(self.err(
                    "material.sound_speed",
                    "and `material.eos_stiffness` are both given",
                    "give one: the sound speed fixes the stiffness (k = rho0 c0^2 / gamma) and back",
                ))
            }
            (None, None) => {
                return Err(self.err(
                    "material.sound_speed",
                    "is missing",
                    "give sound_speed (m/s) or eos_stiffness (Pa), e.g. sound_speed = 20.0",
                ))
            }
        };
        if !(m.viscosity.is_finite() && m.viscosity >= 0.0) {
            return Err(self.err(
                "material.viscosity",
                format!("= {} must be zero or positive", m.viscosity),
                "give the dynamic viscosity in Pa s, 1e-3 for water",
            ));
        }
        if !(m.pressure_floor.is_finite() && m.pressure_floor <= 0.0) {
            return Err(self.err(
                "material.pressure_floor",
                format!("= {} must be zero or negative", m.pressure_floor),
                "use 0 (no tension) or a small negative pressure in Pa for surface cohesion",
            ));
        }
        let ppc = f64::from(n * n * n);
        Ok(Material {
            rest_density: rho0,
            eos_stiffness: stiffness,
            eos_power: gamma,
            viscosity: m.viscosity,
            pressure_floor: m.pressure_floor,
            particle_mass: (f64::from(rho0) * dx * dx * dx / ppc) as f32,
            _pad: [0; 2],
        })
    }

    fn bodies(
        &self,
        spec: &SceneSpec,
        res: [u32; 3],
        dx: f64,
        band: u32,
        soft_wall: bool,
    ) -> Result<Vec<Body>, SceneError> {
        let (lo, hi) = fluid_region(res, dx, band, soft_wall);
        let region = format!(
            "[{:.4}, {:.4}] x [{:.4}, {:.4}] x [{:.4}, {:.4}] m",
            lo.x, hi.x, lo.y, hi.y, lo.z, hi.z
        );
        let fix = format!(
            "keep bodies inside the fluid region {region} (the domain less the {band}-node boundary band{})",
            if soft_wall { " and the soft wall" } else { "" }
        );
        let mut bodies = Vec::new();
        for (i, b) in spec.blocks.iter().enumerate() {
            let (min, max) = (DVec3::from(b.min), DVec3::from(b.max));
            if !(min.is_finite() && max.is_finite()) || min.cmpge(max).any() {
                return Err(self.err(
                    format!("block[{i}]"),
                    format!("has min {:?} not below max {:?} on every axis", b.min, b.max),
                    "give min < max on x, y and z",
                ));
            }
            let eps = 1e-9 * dx;
            if min.cmplt(lo - eps).any() || max.cmpgt(hi + eps).any() {
                let key = if min.cmplt(lo - eps).any() { "min" } else { "max" };
                return Err(self.err(
                    format!("block[{i}].{key}"),
                    "lies outside the domain's fluid region",
                    fix.clone(),
                ));
            }
            bodies.push(Body {
                shape: Shape::Block { min, max },
                velocity: self.finite3(&format!("block[{i}].velocity"), b.velocity)?,
            });
        }
        for (i, s) in spec.spheres.iter().enumerate() {
            let center = DVec3::from(s.center);
            if !(s.radius.is_finite() && s.radius > 0.0) {
                return Err(self.err(
                    format!("sphere[{i}].radius"),
                    format!("= {} must be positive", s.radius),
                    "give the radius in metres",
                ));
            }
            if !center.is_finite()
                || (center - s.radius).cmplt(lo).any()
                || (center + s.radius).cmpgt(hi).any()
            {
                return Err(self.err(
                    format!("sphere[{i}]"),
                    "reaches outside the domain's fluid region",
                    fix.clone(),
                ));
            }
            bodies.push(Body {
                shape: Shape::Sphere {
                    center,
                    radius: s.radius,
                },
                velocity: self.finite3(&format!("sphere[{i}].velocity"), s.velocity)?,
            });
        }
        Ok(bodies)
    }

    /// Emitters and sinks, validated against the domain, and the particle capacity.
    fn flow(&self, spec: &SceneSpec, scene: &Scene) -> Result<Flow, SceneError> {
        let (lo, hi) = scene.fluid_region();
        let spacing = scene.lattice().spacing;
        let region = format!(
            "[{:.4}, {:.4}] x [{:.4}, {:.4}] x [{:.4}, {:.4}] m",
            lo.x, hi.x, lo.y, hi.y, lo.z, hi.z
        );
        if spec.emitters.len() > MAX_EMITTERS {
            return Err(self.err(
                "emitter",
                format!(
                    "{} emitters are more than the {MAX_EMITTERS} a scene may have",
                    spec.emitters.len()
                ),
                "merge nozzles that share a speed and direction into one rectangle",
            ));
        }
        let mut emitters = Vec::new();
        for (i, e) in spec.emitters.iter().enumerate() {
            emitters.push(self.emitter(i, e, spacing, (lo, hi), &region)?);
        }
        let domain = DVec3::from(scene.grid_res.map(f64::from)) * f64::from(scene.dx);
        let mut sinks = Vec::new();
        for (i, k) in spec.sinks.iter().enumerate() {
            let (min, max) = (DVec3::from(k.min), DVec3::from(k.max));
            if !(min.is_finite() && max.is_finite()) || min.cmpge(max).any() {
                return Err(self.err(
                    format!("sink[{i}]"),
                    format!("has min {:?} not below max {:?} on every axis", k.min, k.max),
                    "give min < max on x, y and z",
                ));
            }
            if min.cmplt(DVec3::ZERO).any() || max.cmpgt(domain).any() {
                return Err(self.err(
                    format!("sink[{i}]"),
                    format!(
                        "reaches outside the domain [0, {:.4}] x [0, {:.4}] x [0, {:.4}] m",
                        domain.x, domain.y, domain.z
                    ),
                    "keep the sink box inside the domain; a drain at the floor reaches down to 0",
                ));
            }
            if min.cmpge(hi).any() || max.cmple(lo).any() {
                return Err(self.err(
                    format!("sink[{i}]"),
                    format!("lies wholly in the boundary band, where no particle goes (the fluid region is {region})"),
                    "let the box reach into the fluid region",
                ));
            }
            sinks.push(Sink {
                min: min.as_vec3(),
                max: max.as_vec3(),
            });
        }
        let initial = scene.num_particles;
        let capacity = match &spec.particles {
            Some(p) => {
                let capacity = p.capacity;
                if capacity == 0 || capacity < initial as u64 {
                    return Err(self.err(
                        "particles.capacity",
                        format!("= {capacity} is below the {initial} particles the bodies spawn"),
                        format!("give at least {initial}, plus room for what the emitters add"),
                    ));
                }
                if capacity > u64::from(u32::MAX) {
                    return Err(self.err(
                        "particles.capacity",
                        format!("= {capacity} is above the 2^32 limit of particle indices"),
                        "give a smaller capacity",
                    ));
                }
                capacity as usize
            }
            None if !emitters.is_empty() => {
                return Err(self.err(
                    "particles.capacity",
                    "is missing: a scene with emitters allocates its particles up front",
                    format!(
                        "add [particles] capacity = N, N at least {initial} (the bodies' particles) plus what the emitters may add"
                    ),
                ))
            }
            None => initial,
        };
        Ok(Flow {
            emitters,
            sinks,
            capacity,
        })
    }

    fn emitter(
        &self,
        i: usize,
        e: &EmitterSpec,
        spacing: f64,
        (lo, hi): (DVec3, DVec3),
        region: &str,
    ) -> Result<Emitter, SceneError> {
        let key = |k: &str| format!("emitter[{i}].{k}");
        let normal = Vec3::from(e.normal);
        if !(normal.is_finite() && normal.length() > 1e-6) {
            return Err(self.err(
                key("normal"),
                format!("= {:?} is not a direction", e.normal),
                "give the direction the fluid leaves in, e.g. [0.0, -1.0, 0.0] for a tap",
            ));
        }
        let normal = normal.normalize();
        let nozzle = match (e.shape, e.radius, e.size) {
            (NozzleShape::Disc, Some(radius), None) if radius.is_finite() && radius > 0.0 => {
                Nozzle::Disc { radius }
            }
            (NozzleShape::Rectangle, None, Some(size)) if size.iter().all(|s| s.is_finite() && *s > 0.0) => {
                Nozzle::Rectangle { size }
            }
            (NozzleShape::Disc, ..) => {
                return Err(self.err(
                    key("radius"),
                    "must be given, positive, for a disc nozzle (and `size` left out)",
                    "give radius = R in metres",
                ))
            }
            (NozzleShape::Rectangle, ..) => {
                return Err(self.err(
                    key("size"),
                    "must be given, two positive lengths, for a rectangle nozzle (and `radius` left out)",
                    "give size = [A, B] in metres, the sides across the normal",
                ))
            }
        };
        if !(e.speed.is_finite() && e.speed > 0.0) {
            return Err(self.err(
                key("speed"),
                format!("= {} must be a positive speed", e.speed),
                "give the speed the fluid leaves the nozzle at, m/s",
            ));
        }
        let center = DVec3::from(e.center);
        let points = flow::nozzle_points(nozzle, center, normal, spacing);
        if points.is_empty() {
            return Err(self.err(
                format!("emitter[{i}]"),
                format!("has a nozzle smaller than the particle spacing {spacing:.4} m"),
                "make the nozzle wider than one particle spacing",
            ));
        }
        let (lo32, hi32) = (lo.as_vec3(), hi.as_vec3());
        if !center.is_finite() || points.iter().any(|p| p.cmplt(lo32).any() || p.cmpgt(hi32).any()) {
            return Err(self.err(
                format!("emitter[{i}]"),
                format!("reaches outside the domain's fluid region {region}"),
                "move the nozzle inside the region, or make it smaller",
            ));
        }
        let full = points.len() as f64 * spacing * spacing * f64::from(e.speed);
        let rate = match e.rate {
            None => full,
            Some(rate) if rate.is_finite() && rate > 0.0 && rate <= full * (1.0 + 1e-9) => rate,
            Some(rate) if rate.is_finite() && rate > full => {
                return Err(self.err(
                    key("rate"),
                    format!(
                        "= {rate:.3e} m^3/s is more than the nozzle passes at {} m/s ({full:.3e} m^3/s: its {} particle columns times the speed); particles would land on each other",
                        e.speed,
                        points.len()
                    ),
                    "raise the speed, widen the nozzle, or lower the rate",
                ))
            }
            Some(rate) => {
                return Err(self.err(
                    key("rate"),
                    format!("= {rate} must be a positive flow in m^3/s"),
                    format!("give a rate up to {full:.3e} m^3/s, or leave it out for that full flow"),
                ))
            }
        };
        Ok(Emitter {
            nozzle,
            center,
            normal,
            speed: e.speed,
            rate,
            points,
        })
    }

    fn colliders(&self, spec: &SceneSpec, res: [u32; 3], dx: f64) -> Result<Colliders, SceneError> {
        if spec.colliders.len() > MAX_COLLIDERS {
            return Err(self.err(
                format!("collider[{MAX_COLLIDERS}]"),
                format!(
                    "is one of {} colliders, more than the {MAX_COLLIDERS} a scene may have",
                    spec.colliders.len()
                ),
                "merge obstacles into one mesh collider, or drop some",
            ));
        }
        // Mesh files are found beside the scene file; a preset's among the files embedded with it.
        let dir = Path::new(self.source)
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let preset = self
            .source
            .strip_prefix("preset ")
            .is_some_and(|name| presets::get(name).is_some());
        let read_mesh = |file: &str, scale: f64| match presets::mesh(file).filter(|_| preset) {
            Some(text) => mesh::parse_triangles(Path::new(file), text.as_bytes(), scale)
                .map_err(|e| format!("{file} (embedded with the presets): {e}")),
            None => {
                let path = dir.join(file);
                mesh::read_triangles(&path, scale).map_err(|e| format!("{}: {e}", path.display()))
            }
        };
        let domain = DVec3::from(res.map(f64::from)) * dx;
        let list = spec
            .colliders
            .iter()
            .enumerate()
            .map(|(i, c)| {
                colliders::validate(c, &read_mesh, domain, dx)
                    .map_err(|e| self.err(format!("collider[{i}].{}", e.key), e.problem, e.fix))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Colliders::new(list, dx as f32))
    }

    fn time_step(
        &self,
        t: &TimeStepSpec,
        material: &Material,
        dx: f64,
        max_body_speed: f32,
    ) -> Result<TimeStepPolicy, SceneError> {
        let signal = material.sound_speed() + max_body_speed;
        let dt_limit = MAX_CFL * dx as f32 / signal;
        match (t.cfl, t.dt) {
            (Some(_), Some(_)) => Err(self.err(
                "time_step.dt",
                "and `time_step.cfl` are both given",
                "give cfl (substeps chosen from the stability limits) or a fixed dt, not both",
            )),
            (_, Some(dt)) => {
                let dt = self.positive("time_step.dt", dt, "give the substep in seconds")?;
                if dt > dt_limit {
                    return Err(self.err(
                        "time_step.dt",
                        format!(
                            "= {dt:.3e} s is above the stability limit {dt_limit:.3e} s \
                             ({MAX_CFL} dx / (c0 + |v|max) with c0 = {:.2} m/s)",
                            material.sound_speed()
                        ),
                        format!(
                            "use dt <= {dt_limit:.3e}, or drop dt and set cfl = 0.4 to let the solver choose"
                        ),
                    ));
                }
                Ok(TimeStepPolicy::Fixed { dt })
            }
            (cfl, None) => {
                let cfl = cfl.unwrap_or(0.4);
                if !(cfl.is_finite() && cfl > 0.0 && cfl <= MAX_CFL) {
                    return Err(self.err(
                        "time_step.cfl",
                        format!("= {cfl} is outside (0, {MAX_CFL}]"),
                        "use 0.3 to 0.5; 0.4 is the default",
                    ));
                }
                let max_substeps = t.max_substeps.unwrap_or(DEFAULT_MAX_SUBSTEPS);
                if max_substeps == 0 {
                    return Err(self.err(
                        "time_step.max_substeps",
                        "must be at least 1",
                        format!("drop it (default {DEFAULT_MAX_SUBSTEPS})"),
                    ));
                }
                Ok(TimeStepPolicy::Cfl { cfl, max_substeps })
            }
        }
    }

    /// The live particles the bodies spawn; zero only where emitters will bring fluid.
    fn count_particles(&self, scene: &Scene, has_emitters: bool) -> Result<usize, SceneError> {
        let lattice = scene.lattice();
        let colliders = scene.colliders_at_start();
        let mut total = 0usize;
        for (k, body) in scene.bodies.iter().enumerate() {
            let own = scene.own_points(&lattice, k, &colliders).count();
            if own == 0 {
                let blocks = scene.bodies[..k]
                    .iter()
                    .filter(|b| matches!(b.shape, Shape::Block { .. }))
                    .count();
                let key = match body.shape {
                    Shape::Block { .. } => format!("block[{blocks}]"),
                    Shape::Sphere { .. } => format!("sphere[{}]", k - blocks),
                };
                return Err(self.err(
                    key,
                    format!(
                        "holds zero particles (smaller than the particle spacing {:.4} m, or inside an earlier body or a collider)",
                        lattice.spacing
                    ),
                    "make it larger than one cell, or move it out of the bodies listed before it and the colliders",
                ));
            }
            total += own;
        }
        if total == 0 && !has_emitters {
            return Err(self.err(
                "block",
                "the scene spawns zero particles",
                "add a [[block]] or [[sphere]] of fluid, or an [[emitter]]",
            ));
        }
        if total > u32::MAX as usize {
            return Err(self.err(
                "block",
                format!("the scene spawns {total} particles, above the 2^32 limit of particle indices"),
                "use fewer particles per cell or smaller bodies",
            ));
        }
        Ok(total)
    }

    /// Body volumes over the lattice cell volume, overlaps counted twice: cheap, and close enough to
    /// refuse a scene that could never fit before counting its points one by one.
    fn estimate_particles(&self, scene: &Scene) -> usize {
        let cell = scene.lattice().spacing.powi(3);
        let volume: f64 = scene
            .bodies
            .iter()
            .map(|b| match b.shape {
                Shape::Block { min, max } => (max - min).element_product(),
                Shape::Sphere { radius, .. } => 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3),
            })
            .sum();
        (volume / cell) as usize
    }

    fn fits_in_memory(&self, scene: &Scene, particles: usize) -> Result<(), SceneError> {
        let nodes: usize = scene.grid_res.iter().map(|&r| r as usize).product();
        let needed = particles.saturating_mul(CPU_BYTES_PER_PARTICLE) + nodes * CPU_BYTES_PER_NODE;
        if nodes > u32::MAX as usize {
            return Err(self.err(
                "domain.resolution",
                format!("gives {nodes} grid nodes, above the 2^32 limit of node indices"),
                "use a coarser grid",
            ));
        }
        if let Some(available) = available_host_memory() {
            if needed as u64 > available {
                return Err(self.err(
                    "",
                    format!(
                        "needs {:.1} GiB ({} particles, {} grid nodes) but this machine has {:.1} GiB available",
                        gib(needed as u64),
                        particles,
                        nodes,
                        gib(available)
                    ),
                    "use a coarser domain.resolution, fewer particles_per_cell or smaller bodies",
                ));
            }
        }
        Ok(())
    }
}

fn gib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 30) as f64
}

/// `MemAvailable` from /proc/meminfo; `None` where that is not there (the check is then skipped).
fn available_host_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
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
