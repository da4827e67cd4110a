//! Colliders: rigid obstacles and kinematic bodies that the fluid flows around (docs/physics.md,
//! "Colliders").
//!
//! A scene's `[[collider]]` tables are validated into [`Collider`]s (shape, pose, boundary condition,
//! motion). Every substep, [`Colliders::frame`] evaluates their motion at the end of the substep into
//! a [`ColliderFrame`]: one [`ColliderState`] per collider (the pose, the rigid velocity and the shape,
//! `#[repr(C)]`, mirrored by kernels/colliders.cuh), plus the signed distance fields of the mesh
//! colliders. Every backend reads the same frame, so the CPU reference and the kernels evaluate the
//! same numbers:
//!
//! - the grid update projects the velocity of every node inside a collider or within
//!   [`BAND_CELLS`] cells of its surface against the collider's normal, relative to the collider's
//!   own velocity ([`ColliderFrame::project_node`]);
//! - after advection, a particle that still ended inside a collider is put back on its surface along
//!   the distance field's gradient and loses its velocity into it: the backstop
//!   ([`ColliderFrame::backstop`]), counted and reported.
//!
//! A nozzle's pipe (`[[emitter]] pipe_length`) rides in the same frame, after the colliders: a
//! cylinder or box along the nozzle's normal whose inside nodes take the nozzle's velocity, as a
//! pump-fed pipe drives what it holds ([`BOUNDARY_PIPE`]: no band, no backstop, no fluid kept out).

use super::flow::{self, Emitter, Nozzle};
use super::mesh::MeshSdf;
pub use crate::contract::{
    ColliderState, BOUNDARY_FRICTION, BOUNDARY_PIPE, BOUNDARY_SLIP, BOUNDARY_STICK, COLLIDER_BOX,
    COLLIDER_CAPSULE, COLLIDER_CYLINDER, COLLIDER_MESH, COLLIDER_SPHERE,
};
use glam::{DMat3, DQuat, DVec3, Vec3};
use std::sync::Arc;

pub mod bodies;
mod geometry;
mod mass;
mod spec;

pub use bodies::{Dynamics, Hinge};
pub use mass::{triangles_mass_properties, MassProperties};
pub use spec::{validate, ColliderSpec, FlapSpec, HingeSpec, MotionSpec, PistonSpec, SpecError};

/// The most colliders a scene may have (the contract's `MAX_COLLIDERS`).
pub const MAX_COLLIDERS: usize = crate::contract::MAX_COLLIDERS as usize;

/// Nodes closer to a collider's surface than this many cells (or inside it) get its boundary
/// condition. One cell: the fluid rests within about a cell of the surface, and a particle's
/// stencil (1.5 cells) always reaches a constrained node before the particle reaches the surface.
pub const BAND_CELLS: f32 = 1.0;

/// The boundary condition of a collider.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Boundary {
    /// Free slip: the velocity into the collider is removed, the tangential velocity kept.
    Slip,
    /// No slip: the fluid in the band moves with the collider.
    Stick,
    /// Coulomb friction: as slip, and the tangential velocity shrinks by mu times the normal velocity
    /// removed, down to zero (sticking while |v_t| <= mu |v_n|).
    Friction(f32),
}

/// What a collider is, in its own frame (centred on its `center`).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    Box {
        half_extents: DVec3,
    },
    Sphere {
        radius: f64,
    },
    /// A segment along local y from -half_length to half_length, swept by a sphere of `radius`.
    Capsule {
        radius: f64,
        half_length: f64,
    },
    /// A solid cylinder along local y, flat caps at +-half_length.
    Cylinder {
        radius: f64,
        half_length: f64,
    },
    /// A closed triangle mesh, as a signed distance field sampled around it.
    Mesh(Arc<MeshSdf>),
}

impl Shape {
    /// The radius of a ball about the local origin that holds the shape.
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Shape::Box { half_extents } => half_extents.length(),
            Shape::Sphere { radius } => *radius,
            Shape::Capsule { radius, half_length } => radius + half_length,
            Shape::Cylinder { radius, half_length } => (radius * radius + half_length * half_length).sqrt(),
            // Its trilinear distance samples may read up to a fraction of a cell short of the truth.
            Shape::Mesh(mesh) => mesh.bounding_radius + f64::from(mesh.spacing),
        }
    }

    pub fn kind_name(&self) -> &'static str {
        match self {
            Shape::Box { .. } => "box",
            Shape::Sphere { .. } => "sphere",
            Shape::Capsule { .. } => "capsule",
            Shape::Cylinder { .. } => "cylinder",
            Shape::Mesh(_) => "mesh",
        }
    }
}

/// A sinusoidal oscillation: angle or offset A sin(2 pi t / T + phase).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Oscillation {
    pub amplitude: f64,
    /// s.
    pub period: f64,
    /// rad.
    pub phase: f64,
}

impl Oscillation {
    fn omega(&self) -> f64 {
        std::f64::consts::TAU / self.period
    }
    /// Value and rate at time t.
    fn at(&self, t: f64) -> (f64, f64) {
        let arg = self.omega() * t + self.phase;
        (
            self.amplitude * arg.sin(),
            self.amplitude * self.omega() * arg.cos(),
        )
    }
}

/// How a collider moves (the pose it is given is its pose at `since`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    Static,
    /// Constant velocity (m/s) and rotation rate about the centre (rad/s, world axis times rate),
    /// from the pose at time `since`.
    Steady {
        velocity: DVec3,
        angular_velocity: DVec3,
        since: f64,
    },
    /// A piston: the centre moves along the unit `direction` by the oscillation (m).
    Piston {
        direction: DVec3,
        oscillation: Oscillation,
    },
    /// A flap: the body turns about the line through `hinge` along the unit `axis` by the
    /// oscillation (rad).
    Flap {
        hinge: DVec3,
        axis: DVec3,
        oscillation: Oscillation,
    },
}

/// A validated collider.
#[derive(Debug, Clone, PartialEq)]
pub struct Collider {
    pub shape: Shape,
    pub boundary: Boundary,
    /// Pose at rest (or at `Motion::Steady::since`): world = rotation * local + center.
    pub center: DVec3,
    pub rotation: DQuat,
    /// `Motion::Static` for a rigid body: its pose at the start.
    pub motion: Motion,
    /// A rigid body's mass and inertia: the liquid moves it (`bodies`); `None` for a collider that
    /// moves as its motion says.
    pub body: Option<Dynamics>,
}

/// Pose and rigid velocity at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub center: DVec3,
    pub rotation: DQuat,
    pub velocity: DVec3,
    pub angular_velocity: DVec3,
}

impl Collider {
    pub fn pose(&self, t: f64) -> Pose {
        match self.motion {
            Motion::Static => Pose {
                center: self.center,
                rotation: self.rotation,
                velocity: DVec3::ZERO,
                angular_velocity: DVec3::ZERO,
            },
            Motion::Steady {
                velocity,
                angular_velocity,
                since,
            } => {
                let elapsed = t - since;
                let turn = DQuat::from_scaled_axis(angular_velocity * elapsed);
                Pose {
                    center: self.center + velocity * elapsed,
                    rotation: (turn * self.rotation).normalize(),
                    velocity,
                    angular_velocity,
                }
            }
            Motion::Piston {
                direction,
                oscillation,
            } => {
                let (offset, rate) = oscillation.at(t);
                Pose {
                    center: self.center + direction * offset,
                    rotation: self.rotation,
                    velocity: direction * rate,
                    angular_velocity: DVec3::ZERO,
                }
            }
            Motion::Flap {
                hinge,
                axis,
                oscillation,
            } => {
                let (angle, rate) = oscillation.at(t);
                let turn = DQuat::from_axis_angle(axis, angle);
                let center = hinge + turn * (self.center - hinge);
                let angular_velocity = axis * rate;
                Pose {
                    center,
                    rotation: (turn * self.rotation).normalize(),
                    // The rigid velocity field about the hinge, expressed about the centre.
                    velocity: angular_velocity.cross(center - hinge),
                    angular_velocity,
                }
            }
        }
    }

    /// The largest speed any point of the collider reaches, m/s (for the first substep's choice); a
    /// rigid body's at the start.
    pub fn max_speed(&self) -> f64 {
        let r = self.shape.bounding_radius();
        if let Some(body) = &self.body {
            return body.velocity.length() + body.angular_velocity.length() * 2.0 * r;
        }
        match self.motion {
            Motion::Static => 0.0,
            Motion::Steady {
                velocity,
                angular_velocity,
                ..
            } => velocity.length() + angular_velocity.length() * r,
            Motion::Piston { oscillation, .. } => oscillation.amplitude.abs() * oscillation.omega(),
            Motion::Flap {
                hinge, oscillation, ..
            } => oscillation.amplitude.abs() * oscillation.omega() * ((self.center - hinge).length() + r),
        }
    }

    fn state(&self, t: f64, dx: f32) -> ColliderState {
        let pose = self.pose(t);
        // Row-major: the columns of the transpose.
        let rotation = DMat3::from_quat(pose.rotation).transpose().as_mat3();
        let (kind, size) = match &self.shape {
            Shape::Box { half_extents } => (COLLIDER_BOX, half_extents.as_vec3().to_array()),
            Shape::Sphere { radius } => (COLLIDER_SPHERE, [*radius as f32, 0.0, 0.0]),
            Shape::Capsule { radius, half_length } => {
                (COLLIDER_CAPSULE, [*radius as f32, *half_length as f32, 0.0])
            }
            Shape::Cylinder { radius, half_length } => {
                (COLLIDER_CYLINDER, [*radius as f32, *half_length as f32, 0.0])
            }
            Shape::Mesh(_) => (COLLIDER_MESH, [0.0; 3]),
        };
        let (boundary, friction) = match self.boundary {
            Boundary::Slip => (BOUNDARY_SLIP, 0.0),
            Boundary::Stick => (BOUNDARY_STICK, 0.0),
            Boundary::Friction(mu) => (BOUNDARY_FRICTION, mu),
        };
        let mut state = ColliderState {
            kind,
            boundary,
            friction,
            band: BAND_CELLS * dx,
            rotation: rotation.to_cols_array(),
            center: pose.center.as_vec3().to_array(),
            velocity: pose.velocity.as_vec3().to_array(),
            angular_velocity: pose.angular_velocity.as_vec3().to_array(),
            size,
            reach: (self.shape.bounding_radius() * (1.0 + 1e-4)) as f32 + 1e-3 * dx,
            ..bytemuck::Zeroable::zeroed()
        };
        if let Shape::Mesh(mesh) = &self.shape {
            state.sdf_origin = mesh.origin.to_array();
            state.sdf_dims = mesh.dims;
            state.sdf_spacing = mesh.spacing;
        }
        state
    }
}

/// A scene's colliders, and the distance samples of its meshes laid end to end.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Colliders {
    pub list: Vec<Collider>,
    /// Grid spacing of the scene, m.
    pub dx: f32,
    sdf: Arc<[f32]>,
    sdf_offsets: Vec<u32>,
    /// The emitters' pipes ([`Colliders::set_pipes`]), static: after the colliders in every frame.
    pipes: Vec<ColliderState>,
}

impl Colliders {
    pub fn new(list: Vec<Collider>, dx: f32) -> Colliders {
        let mut sdf = Vec::new();
        let mut sdf_offsets = Vec::with_capacity(list.len());
        for c in &list {
            sdf_offsets.push(sdf.len() as u32);
            if let Shape::Mesh(mesh) = &c.shape {
                sdf.extend_from_slice(&mesh.values);
            }
        }
        Colliders {
            list,
            dx,
            sdf: sdf.into(),
            sdf_offsets,
            pipes: Vec::new(),
        }
    }

    /// The pipes of the emitters that have one (`pipe_length > 0`): from a cell behind the nozzle
    /// (so that a new particle's whole stencil is held) to `pipe_length` past it, as wide as the
    /// nozzle, moving nothing but giving the nodes inside the nozzle's velocity.
    pub fn set_pipes(&mut self, emitters: &[Emitter]) {
        let dx = f64::from(self.dx);
        self.pipes = emitters
            .iter()
            .filter(|e| e.pipe_length > 0.0)
            .map(|e| {
                let n = e.normal.as_dvec3();
                // Local y along the normal (a rectangle's second side along local z).
                let u = flow::frame(e.normal).0.as_dvec3();
                let rotation = DMat3::from_cols(u, n, u.cross(n));
                let half_length = 0.5 * (e.pipe_length + dx);
                let (kind, size) = match e.nozzle {
                    Nozzle::Disc { radius } => (COLLIDER_CYLINDER, DVec3::new(radius, half_length, 0.0)),
                    Nozzle::Rectangle { size } => (
                        COLLIDER_BOX,
                        DVec3::new(0.5 * size[0], half_length, 0.5 * size[1]),
                    ),
                };
                ColliderState {
                    kind,
                    boundary: BOUNDARY_PIPE,
                    band: 0.0,
                    rotation: rotation.transpose().as_mat3().to_cols_array(),
                    center: (e.center + n * (half_length - dx)).as_vec3().to_array(),
                    velocity: (e.normal * e.speed).to_array(),
                    size: size.as_vec3().to_array(),
                    reach: (size.length() * (1.0 + 1e-4)) as f32 + 1e-3 * self.dx,
                    ..bytemuck::Zeroable::zeroed()
                }
            })
            .collect();
    }

    /// Appends `collider` after the others (before the pipes, which ride after the colliders in
    /// every frame): a body dropped into a running scene (`sim::dropped`). Its mesh samples, if
    /// any, go after the others' in a new buffer, so a backend that holds the old one uploads it anew.
    pub fn add(&mut self, collider: Collider) {
        self.sdf_offsets.push(self.sdf.len() as u32);
        if let Shape::Mesh(mesh) = &collider.shape {
            self.sdf = self.sdf.iter().chain(&mesh.values).copied().collect();
        }
        self.list.push(collider);
    }

    /// Whether nothing bounds the flow but the walls: no collider and no pipe.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty() && self.pipes.is_empty()
    }

    /// The scene's colliders (not counting the pipes).
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// How many emitters have a pipe.
    pub fn num_pipes(&self) -> usize {
        self.pipes.len()
    }

    /// Whether a Coulomb collider's band may meet the slabs within `reach` of the box [lo, hi]'s
    /// faces (the walls' mirror planes): a moving one anywhere, a still one where its bounding ball,
    /// grown by its band and `reach`, reaches a face.
    pub fn friction_near_faces(&self, lo: DVec3, hi: DVec3, dx: f32, reach: f64) -> bool {
        self.list
            .iter()
            .filter(|c| matches!(c.boundary, Boundary::Friction(_)))
            .any(|c| {
                let r = c.shape.bounding_radius() + f64::from(BAND_CELLS * dx) + reach;
                c.motion != Motion::Static
                    || c.body.is_some()
                    || (0..3).any(|a| c.center[a] - r <= lo[a] || c.center[a] + r >= hi[a])
            })
    }

    /// Whether any collider moves (a rigid body counts).
    pub fn any_moving(&self) -> bool {
        self.list
            .iter()
            .any(|c| c.motion != Motion::Static || c.body.is_some())
    }

    /// How many of the colliders are rigid bodies.
    pub fn num_bodies(&self) -> usize {
        self.list.iter().filter(|c| c.body.is_some()).count()
    }

    /// Every collider at time `t`, s. A rigid body's state is its pose at the start, marked with its
    /// body (`ColliderState::body`): the solver that steps it puts its own pose in that slot.
    pub fn frame(&self, t: f64) -> ColliderFrame {
        let mut bodies = 0;
        ColliderFrame {
            states: self
                .list
                .iter()
                .zip(&self.sdf_offsets)
                .map(|(c, &offset)| {
                    let body = match c.body {
                        Some(_) => {
                            bodies += 1;
                            bodies
                        }
                        None => 0,
                    };
                    ColliderState {
                        sdf_offset: offset,
                        body,
                        ..c.state(t, self.dx)
                    }
                })
                .chain(self.pipes.iter().copied())
                .collect(),
            sdf: self.sdf.clone(),
        }
    }

    /// The rigid bodies at the start (in the order of the colliders that are bodies) and their
    /// contact features, laid end to end.
    pub fn rigid_bodies(&self) -> (Vec<bodies::RigidBody>, Vec<bodies::ContactFeature>) {
        let (mut list, mut features) = (Vec::new(), Vec::new());
        for (slot, c) in self.list.iter().enumerate() {
            if let Some(dynamics) = &c.body {
                let own = c.shape.contact_features();
                list.push(dynamics.initial_state(
                    c.center,
                    c.rotation,
                    slot as u32,
                    features.len() as u32,
                    &own,
                ));
                features.extend(own.points);
            }
        }
        (list, features)
    }

    /// The largest speed a collider reaches, m/s.
    pub fn max_speed(&self) -> f32 {
        self.list.iter().map(Collider::max_speed).fold(0.0, f64::max) as f32
    }
}

/// Every collider at one instant: what a backend's substep reads.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ColliderFrame {
    pub states: Vec<ColliderState>,
    /// The mesh colliders' distance samples (`ColliderState::sdf_offset` indexes it).
    pub sdf: Arc<[f32]>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn collider(motion: Motion) -> Collider {
        Collider {
            shape: Shape::Box {
                half_extents: DVec3::new(0.1, 0.2, 0.05),
            },
            boundary: Boundary::Slip,
            center: DVec3::new(0.5, 0.3, 0.2),
            rotation: DQuat::from_rotation_z(0.3),
            motion,
            body: None,
        }
    }

    /// Every motion's rigid velocity is the time derivative of its pose: a point fixed in the body
    /// moves at v + w x (x - c), by central differences of the pose.
    #[test]
    fn each_motion_moves_at_the_velocity_it_reports() {
        let oscillation = Oscillation {
            amplitude: 0.05,
            period: 0.8,
            phase: 0.4,
        };
        let motions = [
            Motion::Static,
            Motion::Steady {
                velocity: DVec3::new(0.3, -0.1, 0.2),
                angular_velocity: DVec3::new(0.5, 1.0, -0.7),
                since: 0.1,
            },
            Motion::Piston {
                direction: DVec3::X,
                oscillation,
            },
            Motion::Flap {
                hinge: DVec3::new(0.4, 0.0, 0.2),
                axis: DVec3::Z,
                oscillation: Oscillation {
                    amplitude: 0.3,
                    ..oscillation
                },
            },
        ];
        let local = DVec3::new(0.07, -0.15, 0.03);
        for motion in motions {
            let c = collider(motion);
            let point = |t: f64| {
                let pose = c.pose(t);
                pose.center + pose.rotation * local
            };
            for t in [0.0, 0.37, 1.2] {
                let h = 1e-5;
                let finite = (point(t + h) - point(t - h)) / (2.0 * h);
                let pose = c.pose(t);
                let rigid = pose.velocity + pose.angular_velocity.cross(point(t) - pose.center);
                assert!(
                    (finite - rigid).length() < 1e-6,
                    "{motion:?} at t = {t}: {finite} vs {rigid}"
                );
                assert!(
                    rigid.length() <= c.max_speed() + 1e-9,
                    "{motion:?}: faster than max_speed"
                );
            }
        }
    }

    /// The grid condition against a still floor: slip keeps the tangential velocity and removes the
    /// normal one into the floor; stick removes both; friction removes mu |v_n| of the tangential
    /// part; a velocity leaving the floor is kept; a node beyond the band is untouched.
    #[test]
    fn the_boundary_conditions_project_as_documented() {
        let floor = |boundary| Collider {
            shape: Shape::Box {
                half_extents: DVec3::new(1.0, 0.1, 1.0),
            },
            boundary,
            center: DVec3::new(0.5, 0.0, 0.5),
            rotation: DQuat::IDENTITY,
            motion: Motion::Static,
            body: None,
        };
        let at = Vec3::new(0.5, 0.105, 0.5); // half a cell above the top, within the band
        let into = Vec3::new(0.8, -0.5, 0.0);
        let project = |b, x, v| Colliders::new(vec![floor(b)], 0.01).frame(0.0).project_node(x, v);
        let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-6;
        assert!(close(project(Boundary::Slip, at, into), Vec3::new(0.8, 0.0, 0.0)));
        assert!(close(project(Boundary::Stick, at, into), Vec3::ZERO));
        assert!(close(
            project(Boundary::Friction(0.4), at, into),
            Vec3::new(0.6, 0.0, 0.0)
        ));
        assert!(close(project(Boundary::Friction(2.0), at, into), Vec3::ZERO));
        let leaving = Vec3::new(0.8, 0.5, 0.0);
        assert!(close(project(Boundary::Friction(0.4), at, leaving), leaving));
        let far = Vec3::new(0.5, 0.2, 0.5);
        assert!(close(project(Boundary::Stick, far, into), into));
        // Below the surface the backstop puts a particle back on it.
        let frame = Colliders::new(vec![floor(Boundary::Slip)], 0.01).frame(0.0);
        let (x, v) = frame.backstop(Vec3::new(0.5, 0.09, 0.5), into).expect("inside");
        assert!(
            close(x, Vec3::new(0.5, 0.1, 0.5)) && close(v, Vec3::new(0.8, 0.0, 0.0)),
            "{x} {v}"
        );
        assert!(frame.backstop(at, into).is_none());
    }

    /// A collider added after the others (a body dropped into a running scene) is where the same
    /// list given at once puts it: after the colliders before it and before the emitters' pipes,
    /// with the next body index, a mesh's samples after the others'; and the bodies' list and
    /// contact features are the same.
    #[test]
    fn an_added_collider_rides_where_the_list_given_at_once_puts_it() {
        let dx = 0.01f32;
        // A 10 cm cube with a corner at the origin.
        let (unit, triangles) = crate::sim::mesh::tests::cube();
        let cube: Vec<DVec3> = unit.into_iter().map(|v| (v + 0.5) * 0.1).collect();
        let sdf = crate::sim::mesh::build_sdf("cube", cube, triangles, 0.02, 0.03, None, u64::MAX).unwrap();
        let mesh = Collider {
            shape: Shape::Mesh(Arc::new(sdf)),
            center: DVec3::new(0.2, 0.1, 0.2),
            ..collider(Motion::Static)
        };
        let shape = Shape::Box {
            half_extents: DVec3::new(0.02, 0.03, 0.04),
        };
        let p = shape.mass_properties();
        let body = Collider {
            shape,
            body: Some(Dynamics {
                mass: 500.0 * p.volume,
                centroid: p.centroid,
                inertia: p.inertia * 500.0,
                velocity: DVec3::ZERO,
                angular_velocity: DVec3::ZERO,
                hinge: None,
                contact_friction: 0.4,
            }),
            ..collider(Motion::Static)
        };
        let center = DVec3::new(0.5, 0.6, 0.4);
        let nozzle = Nozzle::Disc { radius: 0.02 };
        let normal = Vec3::NEG_Y;
        let pipe = Emitter {
            nozzle,
            center,
            normal,
            speed: 0.3,
            rate: 1e-5,
            points: flow::nozzle_points(nozzle, center, normal, 0.005),
            material: 0,
            pipe_length: 0.05,
        };
        let mut whole = Colliders::new(vec![body.clone(), mesh.clone(), body.clone(), mesh.clone()], dx);
        whole.set_pipes(std::slice::from_ref(&pipe));
        let mut added = Colliders::new(vec![body.clone(), mesh.clone()], dx);
        added.set_pipes(&[pipe]);
        added.add(body);
        added.add(mesh);
        assert_eq!(added.len(), 4);
        assert_eq!(added.frame(0.3), whole.frame(0.3));
        assert_eq!(added.frame(0.3).states[2].body, 2);
        assert_eq!(added.rigid_bodies(), whole.rigid_bodies());
    }

    /// A pipe gives the nodes inside it (from a cell behind the nozzle to its length past it, as
    /// wide as the nozzle) the nozzle's velocity and leaves every other node alone; it keeps no
    /// particle out and no fluid from spawning, and it rides after the colliders in the frame.
    #[test]
    fn a_pipe_drives_the_nodes_inside_it_at_the_nozzle_s_velocity() {
        let dx = 0.01f32;
        let normal = Vec3::new(1.0, -2.0, 0.5).normalize();
        let center = DVec3::new(0.5, 0.6, 0.4);
        let emitter = |nozzle, pipe_length| Emitter {
            nozzle,
            center,
            normal,
            speed: 0.3,
            rate: 1e-5,
            points: flow::nozzle_points(nozzle, center, normal, 0.005),
            material: 0,
            pipe_length,
        };
        let disc = Nozzle::Disc { radius: 0.02 };
        let rectangle = Nozzle::Rectangle { size: [0.04, 0.01] };
        let mut colliders = Colliders::new(Vec::new(), dx);
        colliders.set_pipes(&[emitter(disc, 0.05), emitter(rectangle, 0.0)]);
        assert_eq!(colliders.num_pipes(), 1, "a nozzle without a pipe has none");
        assert!(!colliders.is_empty());
        let frame = colliders.frame(1.0);
        let (u, v) = flow::frame(normal);
        let at = |along: f32, across: f32| center.as_vec3() + normal * along + u * across;
        let still = Vec3::new(0.1, 0.2, -0.3);
        let driven = normal * 0.3;
        let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-5;
        for (x, inside) in [
            (at(0.0, 0.0), true),
            (at(0.049, 0.019), true),
            (at(-0.009, 0.0), true), // a cell behind the nozzle
            (at(-0.011, 0.0), false),
            (at(0.051, 0.0), false),
            (at(0.02, 0.021), false),
            (at(0.02, 0.0) + v * 0.021, false),
        ] {
            let want = if inside { driven } else { still };
            assert!(
                close(frame.project_node(x, still), want),
                "{x}: {}",
                frame.project_node(x, still)
            );
            assert!(!frame.contains(x), "a pipe keeps no fluid from spawning");
            assert!(
                frame.backstop(x, still).is_none(),
                "a pipe pushes no particle out"
            );
        }
        // Rectangles too, their sides across the normal as the nozzle's.
        let mut boxed = Colliders::new(Vec::new(), dx);
        boxed.set_pipes(&[emitter(rectangle, 0.03)]);
        let frame = boxed.frame(0.0);
        assert!(close(frame.project_node(at(0.02, 0.019), still), driven));
        assert!(close(frame.project_node(at(0.02, 0.021), still), still));
        assert!(close(
            frame.project_node(at(0.02, 0.0) + v * 0.004, still),
            driven
        ));
        assert!(close(frame.project_node(at(0.02, 0.0) + v * 0.006, still), still));
    }
}
