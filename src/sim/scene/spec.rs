//! The scene file's format: what the user wrote, every key optional where a default makes sense.
//! `validate.rs` turns it into a [`Scene`](super::Scene), checking every value.

use crate::sim::colliders::ColliderSpec;
use crate::sim::params::{Method, Pipeline, ScatterMode};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    pub name: Option<String>,
    pub description: Option<String>,
    pub domain: DomainSpec,
    /// `[material]`, the one liquid of the scene, or `[[material]]`, a table of named ones that the
    /// bodies and emitters name.
    pub material: MaterialsSpec,
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
    /// m: a pipe past the nozzle, in which the liquid moves at `speed` (a pump's push, which holds
    /// the weight of a viscous rope hanging from it). Default 0: particles leave the nozzle free.
    pub pipe_length: Option<f64>,
    #[serde(default = "default_ppc")]
    pub particles_per_cell: u32,
    /// The `[[material]]` it emits, by name (the scene's only material where omitted).
    pub material: Option<String>,
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

/// `[material]` (one table) or `[[material]]` (an array of them): told apart by the TOML's shape.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum MaterialsSpec {
    One(MaterialSpec),
    Table(Vec<MaterialSpec>),
}

impl<'de> Deserialize<'de> for MaterialsSpec {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        match toml::Value::deserialize(deserializer)? {
            array @ toml::Value::Array(_) => array
                .try_into()
                .map(MaterialsSpec::Table)
                .map_err(D::Error::custom),
            table => table.try_into().map(MaterialsSpec::One).map_err(D::Error::custom),
        }
    }
}

impl MaterialsSpec {
    /// The entries, each with its TOML key (`material` or `material[i]`).
    pub fn entries(&self) -> Vec<(String, &MaterialSpec)> {
        match self {
            MaterialsSpec::One(m) => vec![("material".to_string(), m)],
            MaterialsSpec::Table(ms) => ms
                .iter()
                .enumerate()
                .map(|(i, m)| (format!("material[{i}]"), m))
                .collect(),
        }
    }
}

/// How a liquid's viscosity follows its shear rate (docs/physics.md, "Materials").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LawSpec {
    /// A constant viscosity: water, oil, glycerine, honey.
    #[default]
    Newtonian,
    /// mu = K gammadot^(n - 1): shear-thinning below n = 1, thickening above.
    PowerLaw,
    /// mu = mu_inf + (mu_0 - mu_inf) (1 + (lambda gammadot)^a)^((n - 1) / a): blood, polymer solutions.
    CarreauYasuda,
    /// A yield stress tau_y, then K gammadot^n: mud, ketchup, lava; Bingham where n = 1.
    /// Regularised bi-viscous (mu = K gammadot^(n - 1) + tau_y / gammadot up to `max_viscosity`)
    /// or elastic (a `shear_modulus`: the yield stress borne by an elastic part, which lets the
    /// liquid come to rest).
    HerschelBulkley,
    /// An elastic solid, fixed-corotated (Stomakhin et al. 2012): a jelly.
    FixedCorotated,
    /// An elastic solid, Neo-Hookean.
    NeoHookean,
    /// Snow (Stomakhin et al. 2013): fixed-corotated with clamped stretch and hardening.
    Snow,
    /// Sand (Klar et al. 2016): Drucker-Prager plasticity in Hencky strain.
    Sand,
}

impl LawSpec {
    /// The name a scene gives it.
    pub fn name(self) -> &'static str {
        match self {
            LawSpec::Newtonian => "newtonian",
            LawSpec::PowerLaw => "power-law",
            LawSpec::CarreauYasuda => "carreau-yasuda",
            LawSpec::HerschelBulkley => "herschel-bulkley",
            LawSpec::FixedCorotated => "fixed-corotated",
            LawSpec::NeoHookean => "neo-hookean",
            LawSpec::Snow => "snow",
            LawSpec::Sand => "sand",
        }
    }

    pub const ALL: [LawSpec; 8] = [
        LawSpec::Newtonian,
        LawSpec::PowerLaw,
        LawSpec::CarreauYasuda,
        LawSpec::HerschelBulkley,
        LawSpec::FixedCorotated,
        LawSpec::NeoHookean,
        LawSpec::Snow,
        LawSpec::Sand,
    ];

    /// A solid's law: its particles carry a deformation gradient, and it has no equation of state.
    pub fn is_solid(self) -> bool {
        matches!(
            self,
            LawSpec::FixedCorotated | LawSpec::NeoHookean | LawSpec::Snow | LawSpec::Sand
        )
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// What bodies and emitters call it (`[[material]]` only).
    pub name: Option<String>,
    #[serde(default)]
    pub law: LawSpec,
    /// Linear RGB in [0, 1], for the viewer, the renders and the PLY files' colour.
    pub colour: Option<[f32; 3]>,
    /// How quickly the liquid hides what is behind it in the rendered surface: a multiple of the
    /// absorption its colour gives (1; 0 is clear; at `a` the liquid's own colour has replaced 95 %
    /// of what is behind after 1.2 / `a` metres of it, 4 cm at 30).
    pub absorption: Option<f32>,
    pub rest_density: f32,
    /// Give either the sound speed (m/s) or the EOS stiffness (Pa); the other follows.
    pub sound_speed: Option<f32>,
    pub eos_stiffness: Option<f32>,
    #[serde(default = "default_eos_power")]
    pub eos_power: f32,
    /// Newtonian: mu, Pa s. Carreau-Yasuda: the zero-shear viscosity mu_0.
    pub viscosity: Option<f32>,
    /// Power law and Herschel-Bulkley: K, Pa s^n.
    pub consistency: Option<f32>,
    /// n: power law, Carreau-Yasuda, Herschel-Bulkley (default 1 there: Bingham).
    pub flow_index: Option<f32>,
    /// Herschel-Bulkley: tau_y, Pa.
    pub yield_stress: Option<f32>,
    /// The ceiling of the effective viscosity, Pa s (power law, Herschel-Bulkley, Carreau-Yasuda
    /// where n > 1): the bi-viscous regularisation, and what the viscous limit on the substep follows.
    pub max_viscosity: Option<f32>,
    /// Herschel-Bulkley: the shear modulus G, Pa, of the elastic regularisation in place of the
    /// bi-viscous one: the particles carry an elastic strain whose stress bears the yield stress.
    pub shear_modulus: Option<f32>,
    /// The floor, Pa s: the power law's at high rates; Carreau-Yasuda's mu_inf.
    pub min_viscosity: Option<f32>,
    /// Carreau-Yasuda: lambda, s.
    pub relaxation_time: Option<f32>,
    /// Carreau-Yasuda: a (2: the Carreau law).
    pub transition_exponent: Option<f32>,
    /// Solids: Young's modulus E, Pa.
    pub youngs_modulus: Option<f32>,
    /// Solids: Poisson's ratio nu, in [0, 0.5).
    pub poisson_ratio: Option<f32>,
    /// Snow: theta_c, the compression past which it yields (2.5e-2 by default).
    pub critical_compression: Option<f32>,
    /// Snow: theta_s, the stretch past which it yields (7.5e-3 by default).
    pub critical_stretch: Option<f32>,
    /// Snow: xi, how much it hardens as it compacts (10 by default).
    pub hardening: Option<f32>,
    /// Sand: the friction angle phi, degrees (its angle of repose).
    pub friction_angle: Option<f32>,
    /// Sand: the Hencky strain of isotropic tension it bears before it yields (0: cohesionless).
    pub cohesion: Option<f32>,
    #[serde(default)]
    pub pressure_floor: f32,
}

fn default_eos_power() -> f32 {
    7.0
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
    /// The scheme: "explicit" (default: explicit MLS-MPM under the CFL policy) or "pbmpm"
    /// (position-based MPM, the CPU reference; docs/physics.md, "Position-based MPM").
    #[serde(default)]
    pub method: Method,
    /// pbmpm: constraint iterations a substep (default 4, 1 to 64).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iterations: Option<u32>,
    /// pbmpm: the tank walls' Coulomb friction coefficient (default 0: free slip, as the explicit
    /// method's walls).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall_friction: Option<f32>,
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
            method: Method::default(),
            iterations: None,
            wall_friction: None,
        }
    }
}

/// `time_step.max_substeps` when a scene gives none: past this many substeps per frame the CFL
/// policy calls the fluid diverged.
pub const DEFAULT_MAX_SUBSTEPS: u32 = 2000;

/// `time_step.cfl` when a scene gives neither it nor a fixed `dt`.
pub const DEFAULT_CFL: f32 = 0.4;

#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TimeStepSpec {
    /// Choose substeps so that (c + |v|max) dt / dx stays at this number.
    pub cfl: Option<f32>,
    /// Or use this fixed substep, s.
    pub dt: Option<f32>,
    /// The CFL policy gives up (the fluid is blowing up) past this many substeps per frame.
    pub max_substeps: Option<u32>,
    /// pbmpm: substeps a 60 Hz frame (default 2), each of 1 / (60 substeps) s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub substeps: Option<u32>,
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
    /// The `[[material]]` it is made of, by name (the scene's only material where omitted).
    pub material: Option<String>,
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
    /// The `[[material]]` it is made of, by name (the scene's only material where omitted).
    pub material: Option<String>,
}

fn default_ppc() -> u32 {
    8
}
