//! The scene file's format: what the user wrote, every key optional where a default makes sense.
//! `validate.rs` turns it into a [`Scene`](super::Scene), checking every value.

use crate::sim::colliders::ColliderSpec;
use crate::sim::params::{Pipeline, ScatterMode};
use serde::{Deserialize, Serialize};

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
    /// The GPU's kernel sequence and density rule: "fused" (default), "binned" or "report".
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
