//! The fluid's constitutive law on the CPU: the Tait equation of state with its pressure floor, the
//! viscous stress, and the sound speed the time step follows (docs/physics.md). The twins of
//! kernels/material.cuh, operation for operation, so the reference and the kernels round alike: a new
//! law (a non-Newtonian viscosity, say) changes these methods and those functions, nothing else.

use super::params::Material;
use glam::{Mat3, Vec3};

impl Material {
    /// Tait pressure, clamped to the floor: p(rho) = max(p_min, k ((rho / rho0)^gamma - 1)).
    pub fn pressure(&self, rho: f32) -> f32 {
        let ratio = rho / self.rest_density;
        (self.eos_stiffness * (ratio.powf(self.eos_power) - 1.0)).max(self.pressure_floor)
    }

    /// Cauchy stress sigma = -p I + mu (C + C^T) of a particle with affine velocity `c`.
    pub fn stress(&self, pressure: f32, c: Mat3) -> Mat3 {
        Mat3::from_diagonal(Vec3::splat(-pressure)) + (c + c.transpose()) * self.viscosity
    }

    /// Sound speed at rest, c0 = sqrt(k gamma / rho0).
    pub fn sound_speed(&self) -> f32 {
        (self.eos_stiffness * self.eos_power / self.rest_density).sqrt()
    }

    /// Sound speed at density `rho`: c0 (rho/rho0)^((gamma-1)/2), from dp/drho of the Tait law.
    pub fn sound_speed_at(&self, rho: f32) -> f32 {
        let ratio = (rho / self.rest_density).max(0.0);
        self.sound_speed() * ratio.powf(0.5 * (self.eos_power - 1.0))
    }

    /// The signal speed of the CFL bound, c(rho) + speed.
    pub fn signal_speed(&self, rho: f32, speed: f32) -> f32 {
        self.sound_speed_at(rho) + speed
    }
}
