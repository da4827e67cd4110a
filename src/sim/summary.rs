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

    /// The statistics of the union of disjoint sets of particles from theirs (several ranks' own
    /// particles): counts and energies add, extremes take the extreme, means weigh by the counts.
    pub fn of_parts(parts: &[Summary]) -> Summary {
        let counted: Vec<&Summary> = parts.iter().filter(|part| part.particles > 0).collect();
        let n: usize = counted.iter().map(|part| part.particles).sum();
        let Some(first) = counted.first() else {
            return Summary::of(&Particles::default(), &Params::default());
        };
        let weighed = |value: &dyn Fn(&Summary) -> f64| {
            counted
                .iter()
                .map(|part| value(part) * part.particles as f64)
                .sum::<f64>()
                / n as f64
        };
        Summary {
            particles: n,
            max_speed: counted
                .iter()
                .fold(first.max_speed, |m, part| m.max(part.max_speed)),
            density_ratio_min: counted
                .iter()
                .fold(first.density_ratio_min, |m, part| m.min(part.density_ratio_min)),
            density_ratio_mean: weighed(&|part| f64::from(part.density_ratio_mean)) as f32,
            density_ratio_max: counted
                .iter()
                .fold(first.density_ratio_max, |m, part| m.max(part.density_ratio_max)),
            kinetic_energy: counted.iter().map(|part| part.kinetic_energy).sum(),
            centre_of_mass: [0, 1, 2].map(|axis| weighed(&|part| part.centre_of_mass[axis])),
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

#[cfg(test)]
mod tests {
    use super::Summary;
    use crate::sim::Scene;

    #[test]
    fn the_parts_of_a_set_sum_to_its_statistics() {
        let scene = Scene::load("bench-65k").unwrap();
        let table = scene.params();
        let mut particles = scene.spawn();
        for (i, (v, rho)) in particles.v.iter_mut().zip(&mut particles.rho).enumerate() {
            *v = glam::Vec3::new((i % 7) as f32, -((i % 5) as f32), 0.5);
            *rho *= 1.0 + (i % 11) as f32 * 0.01;
        }
        let n = particles.len();
        let (low, high): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| particles.x[i].x < 0.1);
        assert!(!low.is_empty() && !high.is_empty());
        let whole = Summary::of(&particles, &table);
        let empty = Summary::of(&particles.pick(&[]), &table);
        let parts = [
            Summary::of(&particles.pick(&low), &table),
            empty,
            Summary::of(&particles.pick(&high), &table),
        ];
        let joined = Summary::of_parts(&parts);
        assert_eq!(joined.particles, whole.particles);
        assert_eq!(joined.max_speed, whole.max_speed);
        assert_eq!(joined.density_ratio_min, whole.density_ratio_min);
        assert_eq!(joined.density_ratio_max, whole.density_ratio_max);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
        assert!(close(joined.kinetic_energy, whole.kinetic_energy));
        assert!((joined.density_ratio_mean - whole.density_ratio_mean).abs() <= 1e-6);
        for axis in 0..3 {
            assert!(close(joined.centre_of_mass[axis], whole.centre_of_mass[axis]));
        }
        assert_eq!(Summary::of_parts(&[empty]), empty);
    }
}
