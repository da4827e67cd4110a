//! The viewer's mouse push: a velocity change given to the particles near a ray (the line under the
//! cursor). Both backends apply the same formula: [`Push::velocity_change`] here, and `push_particles`
//! in kernels/push.cu, field for field.

pub use crate::contract::Push;
use glam::Vec3;

impl Push {
    pub fn new(origin: Vec3, direction: Vec3, radius: f32, delta_v: Vec3) -> Push {
        Push {
            origin: origin.to_array(),
            radius,
            direction: direction.normalize_or_zero().to_array(),
            _pad0: 0.0,
            delta_v: delta_v.to_array(),
            _pad1: 0.0,
        }
    }

    /// The velocity change of a particle at `x`: `delta_v (1 - d^2/r^2)^2` within distance `r` of
    /// the ray (in front of its origin), zero elsewhere.
    pub fn velocity_change(&self, x: Vec3) -> Vec3 {
        let direction = Vec3::from(self.direction);
        let offset = x - Vec3::from(self.origin);
        let along = offset.dot(direction).max(0.0);
        let dist_sq = (offset - direction * along).length_squared();
        let radius_sq = self.radius * self.radius;
        if dist_sq >= radius_sq {
            return Vec3::ZERO;
        }
        let falloff = 1.0 - dist_sq / radius_sq;
        Vec3::from(self.delta_v) * (falloff * falloff)
    }

    /// Gives every particle of a host copy its velocity change (the CPU solvers' push).
    pub fn apply_to(&self, particles: &mut super::scene::Particles) {
        for (x, v) in particles.x.iter().zip(particles.v.iter_mut()) {
            *v += self.velocity_change(*x);
        }
    }

    /// The largest speed the push can add, m/s (it raises the next step's signal speed).
    pub fn max_speed_gain(&self) -> f32 {
        Vec3::from(self.delta_v).length()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_is_strongest_on_the_ray_and_zero_outside_its_radius() {
        let push = Push::new(Vec3::ZERO, Vec3::X, 0.1, Vec3::new(0.0, 2.0, 0.0));
        assert_eq!(
            push.velocity_change(Vec3::new(0.5, 0.0, 0.0)),
            Vec3::new(0.0, 2.0, 0.0)
        );
        let half = push.velocity_change(Vec3::new(0.5, 0.05, 0.0));
        assert!((half.y - 2.0 * 0.75 * 0.75).abs() < 1e-5, "{half}");
        assert_eq!(push.velocity_change(Vec3::new(0.5, 0.1, 0.0)), Vec3::ZERO);
        // Behind the eye: measured from the origin itself.
        assert_eq!(push.velocity_change(Vec3::new(-0.5, 0.0, 0.0)), Vec3::ZERO);
    }
}
