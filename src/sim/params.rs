//! The structs every kernel receives by value. They are mirrored field for field by
//! `kernels/common.cuh`; the asserts below and the `static_assert`s there keep the two in step.

use bytemuck::{Pod, Zeroable};
use std::mem::{offset_of, size_of};

/// Simulated seconds per displayed frame: the runner and the viewer advance one 60 Hz frame at a time.
pub const FRAME_DT: f32 = 1.0 / 60.0;

/// The constitutive law of the fluid: the one owner of these values (docs/physics.md, "Parameters").
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Material {
    /// rho0, kg/m^3.
    pub rest_density: f32,
    /// Tait stiffness k, Pa.
    pub eos_stiffness: f32,
    /// Tait exponent gamma.
    pub eos_power: f32,
    /// Dynamic viscosity mu, Pa s.
    pub viscosity: f32,
    /// p_min, Pa: pressure is clamped from below so that the free surface does not pull itself together.
    pub pressure_floor: f32,
    /// m_p, kg: rho0 dx^3 / particles-per-cell, so the initial packing is at rest density.
    pub particle_mass: f32,
    pub _pad: [u32; 2],
}

impl Material {
    /// Sound speed at rest, c0 = sqrt(k gamma / rho0).
    pub fn sound_speed(&self) -> f32 {
        (self.eos_stiffness * self.eos_power / self.rest_density).sqrt()
    }

    /// Sound speed at density `rho`: c0 (rho/rho0)^((gamma-1)/2), from dp/drho of the Tait law.
    pub fn sound_speed_at(&self, rho: f32) -> f32 {
        let ratio = (rho / self.rest_density).max(0.0);
        self.sound_speed() * ratio.powf(0.5 * (self.eos_power - 1.0))
    }

    /// Tait pressure, clamped to the floor.
    pub fn pressure(&self, rho: f32) -> f32 {
        let ratio = rho / self.rest_density;
        (self.eos_stiffness * (ratio.powf(self.eos_power) - 1.0)).max(self.pressure_floor)
    }
}

/// How p2g accumulates into the grid on the GPU. The CPU reference is sequential and ignores it.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum ScatterMode {
    /// Float atomics, as in the report: fastest, but the summation order (and so the last bits) varies.
    #[default]
    Float,
    /// Fixed-point integer atomics: order-independent, so runs are byte-identical.
    FixedPoint,
}

impl ScatterMode {
    /// The value of `Params::scatter_mode` that the kernels switch on.
    pub fn code(self) -> u32 {
        match self {
            ScatterMode::Float => 0,
            ScatterMode::FixedPoint => 1,
        }
    }
}

/// Which sequence of GPU kernels takes a substep. The CPU reference always runs the report's phases.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum Pipeline {
    /// Particles binned by 4x4x4-node block, scatters through shared-memory tiles, g2p fused with the
    /// next substep's mass scatter, grid update over the touched blocks only (the default).
    #[default]
    Binned,
    /// The report's four kernels, p2g_init, p2g, grid_update (whole grid), g2p, with global atomics:
    /// the baseline the benchmark tables compare with.
    Report,
}

impl Pipeline {
    pub fn name(self) -> &'static str {
        match self {
            Pipeline::Binned => "binned",
            Pipeline::Report => "report",
        }
    }
}

/// Everything one substep needs: material, solver settings, grid shape and the step size.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Params {
    pub material: Material,
    /// m/s^2.
    pub gravity: [f32; 3],
    /// The substep, s. Set by the time-step policy before every frame.
    pub dt: f32,
    /// Grid nodes per axis; node (i, j, k) sits at (i, j, k) dx and is stored at i + rx (j + ry k).
    pub grid_res: [u32; 3],
    /// Node spacing, m.
    pub dx: f32,
    pub inv_dx: f32,
    /// Outer node layers in which the wall-normal velocity is zeroed (free slip).
    pub boundary_band: u32,
    /// Time constant of the soft wall, s; 0 turns it off.
    pub soft_wall_tau: f32,
    pub num_particles: u32,
    /// `ScatterMode::code()`.
    pub scatter_mode: u32,
    /// Fixed-point units per kg of grid mass (fixed-point scatter only).
    pub fixed_mass_scale: f32,
    /// Fixed-point units per kg m/s of grid momentum (fixed-point scatter only).
    pub fixed_momentum_scale: f32,
    /// Mirror planes of the walls, in nodes: where fluid rests against the low walls (the same on every
    /// axis) and the high walls. The grid gains the mass and momentum of a mirror-image fluid beyond
    /// each wall (`cpu::mirror_walls`, kernels/mirror_walls.cu), so particles at a wall are not read as
    /// a free surface. 0 turns the mirror off (never 0 when on: the fluid region starts at node 1).
    pub wall_mirror_lo: u32,
    pub wall_mirror_hi: [u32; 3],
    pub _pad: u32,
}

impl Params {
    pub fn num_nodes(&self) -> usize {
        self.grid_res.iter().map(|&r| r as usize).product()
    }
}

const _: () = {
    assert!(size_of::<Material>() == 32);
    assert!(size_of::<Params>() == 112);
    assert!(offset_of!(Params, material) == 0);
    assert!(offset_of!(Params, gravity) == 32);
    assert!(offset_of!(Params, dt) == 44);
    assert!(offset_of!(Params, grid_res) == 48);
    assert!(offset_of!(Params, dx) == 60);
    assert!(offset_of!(Params, inv_dx) == 64);
    assert!(offset_of!(Params, boundary_band) == 68);
    assert!(offset_of!(Params, soft_wall_tau) == 72);
    assert!(offset_of!(Params, num_particles) == 76);
    assert!(offset_of!(Params, scatter_mode) == 80);
    assert!(offset_of!(Params, fixed_mass_scale) == 84);
    assert!(offset_of!(Params, fixed_momentum_scale) == 88);
    assert!(offset_of!(Params, wall_mirror_lo) == 92);
    assert!(offset_of!(Params, wall_mirror_hi) == 96);
};
