//! The statistics of a state: the runner's line, the viewer's panel, the tests' checks. The CPU
//! computes them from the particles; the CUDA backend reduces them on the device (src/cuda/stats.rs).

use super::params::{Material, Params};
use super::scene::Particles;
use glam::DVec3;
use serde::Serialize;

/// Particle statistics of one state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Summary {
    /// Live particles.
    pub particles: usize,
    /// m/s.
    pub max_speed: f32,
    /// rho / rho0 over the particles.
    pub density_ratio_min: f32,
    pub density_ratio_mean: f32,
    pub density_ratio_max: f32,
    /// J.
    pub kinetic_energy: f64,
    /// m.
    pub centre_of_mass: [f64; 3],
}

impl Summary {
    /// Of the live particles, each of its row of `table`'s materials; an empty state (a tank
    /// before its emitters start) has zeros.
    pub fn of(particles: &Particles, table: &Params) -> Summary {
        let n = particles.num_live();
        if n == 0 {
            return Summary {
                particles: 0,
                max_speed: 0.0,
                density_ratio_min: 0.0,
                density_ratio_mean: 0.0,
                density_ratio_max: 0.0,
                kinetic_energy: 0.0,
                centre_of_mass: [0.0; 3],
            };
        }
        let mut com = DVec3::ZERO;
        let mut ke = 0.0f64;
        let mut max_speed = 0.0f32;
        let (mut rmin, mut rmax, mut rsum) = (f32::INFINITY, f32::NEG_INFINITY, 0.0f64);
        for i in (0..particles.len()).filter(|&i| particles.live[i]) {
            com += particles.x[i].as_dvec3();
            let v2 = particles.v[i].length_squared();
            let material = Material::of(table, particles.material[i]);
            ke += 0.5 * f64::from(material.particle_mass) * f64::from(v2);
            max_speed = max_speed.max(v2.sqrt());
            let r = particles.rho[i] / material.rest_density;
            rmin = rmin.min(r);
            rmax = rmax.max(r);
            rsum += f64::from(r);
        }
        let inv_n = 1.0 / n.max(1) as f64;
        Summary {
            particles: n,
            max_speed,
            density_ratio_min: rmin,
            density_ratio_mean: (rsum * inv_n) as f32,
            density_ratio_max: rmax,
            kinetic_energy: ke,
            centre_of_mass: (com * inv_n).to_array(),
        }
    }

    /// False where a NaN or infinity has crept into the state.
    pub fn is_finite(&self) -> bool {
        self.max_speed.is_finite()
            && self.density_ratio_max.is_finite()
            && self.density_ratio_min.is_finite()
            && self.kinetic_energy.is_finite()
            && self.centre_of_mass.iter().all(|c| c.is_finite())
    }
}
