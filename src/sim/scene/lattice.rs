//! The particle lattice a scene spawns: its points, which body owns each, and the particles in the
//! order every backend (and the device spawn, src/cuda/spawn.rs) lays them out.

use super::{Deformation, Particles, Scene, Shape};
use crate::sim::colliders::ColliderFrame;
use glam::{DVec3, Vec3};

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

/// A particle as spawned: where, how fast, its density and its row of the material table (at rest
/// otherwise: no affine velocity, no deformation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpawnedParticle {
    pub x: Vec3,
    pub v: Vec3,
    pub rho: f32,
    pub material: u8,
}

impl Particles {
    /// Appends `p`'s position, velocity, density and material (a spawn fills the rest whole).
    pub fn push_spawned(&mut self, p: SpawnedParticle) {
        self.x.push(p.x);
        self.v.push(p.v);
        self.rho.push(p.rho);
        self.material.push(p.material);
    }
}

impl Scene {
    pub fn lattice(&self) -> Lattice {
        Lattice {
            spacing: f64::from(self.dx) / f64::from(self.particles_per_axis),
        }
    }

    /// The particles, in body order, each body's lattice points in x-fastest order, skipping points
    /// that an earlier body already covers; then the parked slots up to the capacity (at the origin,
    /// at rest).
    pub fn spawn(&self) -> Particles {
        let slots = self.slots();
        let mut particles = Particles {
            x: Vec::with_capacity(slots),
            v: Vec::with_capacity(slots),
            c: vec![glam::Mat3::ZERO; slots],
            rho: Vec::with_capacity(slots),
            material: Vec::with_capacity(slots),
            live: vec![true; self.num_particles],
            deformation: Vec::new(),
            volume_bias: Vec::new(),
        };
        self.each_spawned(|_, p| particles.push_spawned(p));
        if self.has_deformation() {
            particles.deformation = particles.material.iter().map(|&row| self.at_rest(row)).collect();
            particles.deformation.resize(slots, self.at_rest(0));
        }
        debug_assert_eq!(particles.x.len(), self.num_particles);
        particles.x.resize(slots, Vec3::ZERO);
        particles.v.resize(slots, Vec3::ZERO);
        particles.rho.resize(slots, self.material().rest_density);
        particles.material.resize(slots, 0);
        particles.live.resize(slots, false);
        particles
    }

    /// Each live particle [`spawn`](Scene::spawn) makes, with its slot, in slot order, none of them
    /// kept: what a process of one rank takes its share from (`dist::share::Spawn`).
    pub fn each_spawned(&self, mut visit: impl FnMut(usize, SpawnedParticle)) {
        let lattice = self.lattice();
        let colliders = self.colliders_at_start();
        let mut slot = 0;
        for (k, body) in self.bodies.iter().enumerate() {
            let rho = self.materials[usize::from(body.material)].law.rest_density;
            for p in self.own_points(&lattice, k, &colliders) {
                let x = p.as_vec3();
                visit(
                    slot,
                    SpawnedParticle {
                        x,
                        v: body.velocity,
                        rho,
                        material: body.material,
                    },
                );
                slot += 1;
            }
        }
    }

    /// The rest state of material row `row`'s deformation.
    pub fn at_rest(&self, row: u8) -> Deformation {
        Deformation::at_rest(self.materials[usize::from(row)].law.law)
    }

    /// The lattice points of body `k` that no earlier body covers: where its particles go.
    /// Points inside a collider (at time 0) are left out too.
    pub(super) fn own_points<'a>(
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
    pub(super) fn colliders_at_start(&self) -> ColliderFrame {
        self.colliders.frame(0.0)
    }
}
