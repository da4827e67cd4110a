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
        (self.eos_stiffness * (power(ratio, self.eos_power) - 1.0)).max(self.pressure_floor)
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
        self.sound_speed() * power(ratio, 0.5 * (self.eos_power - 1.0))
    }

    /// The signal speed of the CFL bound, c(rho) + speed.
    pub fn signal_speed(&self, rho: f32, speed: f32) -> f32 {
        self.sound_speed_at(rho) + speed
    }
}

/// `x^e` as kernels/material.cuh's `material_power` takes it: by squaring where `2e` is a whole
/// number up to 32 (water's `gamma = 7` and `(gamma - 1) / 2 = 3`), with a square root for a half,
/// `powf` otherwise. The same operations in the same order (IEEE multiplies and a correctly rounded
/// square root), so the reference and the kernels get the same bits.
pub fn power(x: f32, e: f32) -> f32 {
    let twice = 2.0 * e;
    if !((0.0..=32.0).contains(&twice) && twice == twice.floor()) {
        return x.powf(e);
    }
    let mut n = twice as u32;
    let mut result = if n & 1 == 1 { x.sqrt() } else { 1.0 };
    let mut base = x;
    n >>= 1;
    while n != 0 {
        if n & 1 == 1 {
            result *= base;
        }
        base *= base;
        n >>= 1;
    }
    result
}

#[cfg(test)]
mod tests {
    use super::power;

    #[test]
    fn power_by_squaring_agrees_with_powf() {
        for e in [0.0f32, 0.5, 1.0, 2.5, 3.0, 7.0, 16.0] {
            for x in [0.0f32, 0.5, 0.97, 1.0, 1.03, 2.0, 10.0] {
                let (ours, reference) = (power(x, e), x.powf(e));
                let tolerance = 4.0 * f32::EPSILON * reference.abs().max(f32::MIN_POSITIVE);
                assert!(
                    (ours - reference).abs() <= tolerance,
                    "{x}^{e}: {ours} against powf's {reference}"
                );
            }
        }
        // Exponents that are not whole or half numbers, and beyond 16, take powf itself.
        for e in [0.3f32, 7.25, 16.5, -1.0] {
            assert_eq!(power(1.7, e), 1.7f32.powf(e));
        }
        assert!(power(f32::NAN, 7.0).is_nan());
    }
}
