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

use super::mesh::MeshSdf;
pub use crate::contract::{
    ColliderState, BOUNDARY_FRICTION, BOUNDARY_SLIP, BOUNDARY_STICK, COLLIDER_BOX, COLLIDER_CAPSULE,
    COLLIDER_CYLINDER, COLLIDER_MESH, COLLIDER_SPHERE,
};
use glam::{DMat3, DQuat, DVec3, Vec3};
use std::sync::Arc;

/// The most colliders a scene may have: the kernels walk them per node, so they stay few.
pub const MAX_COLLIDERS: usize = 16;

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
    pub motion: Motion,
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

    /// The largest speed any point of the collider reaches, m/s (for the first substep's choice).
    pub fn max_speed(&self) -> f64 {
        let r = self.shape.bounding_radius();
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
        }
    }

    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// Whether any collider moves.
    pub fn any_moving(&self) -> bool {
        self.list.iter().any(|c| c.motion != Motion::Static)
    }

    /// Every collider at time `t`, s.
    pub fn frame(&self, t: f64) -> ColliderFrame {
        ColliderFrame {
            states: self
                .list
                .iter()
                .zip(&self.sdf_offsets)
                .map(|(c, &offset)| ColliderState {
                    sdf_offset: offset,
                    ..c.state(t, self.dx)
                })
                .collect(),
            sdf: self.sdf.clone(),
        }
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

#[inline(always)]
fn row(m: &[f32; 9], r: usize) -> Vec3 {
    Vec3::new(m[3 * r], m[3 * r + 1], m[3 * r + 2])
}

/// rotation^T v: world to local.
#[inline(always)]
fn to_local(m: &[f32; 9], v: Vec3) -> Vec3 {
    Vec3::new(
        m[0] * v.x + m[3] * v.y + m[6] * v.z,
        m[1] * v.x + m[4] * v.y + m[7] * v.z,
        m[2] * v.x + m[5] * v.y + m[8] * v.z,
    )
}

/// rotation v: local to world.
#[inline(always)]
fn to_world(m: &[f32; 9], v: Vec3) -> Vec3 {
    Vec3::new(row(m, 0).dot(v), row(m, 1).dot(v), row(m, 2).dot(v))
}

#[inline(always)]
fn norm(v: Vec3) -> f32 {
    (v.x * v.x + v.y * v.y + v.z * v.z).sqrt()
}

#[inline(always)]
fn sign(x: f32) -> f32 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// Signed distance (negative inside) and outward unit normal of a shape at local point p. The
/// operations follow collider_local_distance in kernels/colliders.cuh one for one.
fn local_distance(s: &ColliderState, sdf: &[f32], p: Vec3) -> (f32, Vec3) {
    match s.kind {
        COLLIDER_BOX => {
            let q = p.abs() - Vec3::from(s.size);
            let outside = q.max(Vec3::ZERO);
            let out_len = norm(outside);
            let inside = q.x.max(q.y.max(q.z)).min(0.0);
            let normal = if out_len > 0.0 {
                Vec3::new(
                    outside.x * sign(p.x),
                    outside.y * sign(p.y),
                    outside.z * sign(p.z),
                ) / out_len
            } else if q.x >= q.y && q.x >= q.z {
                Vec3::new(sign(p.x), 0.0, 0.0)
            } else if q.y >= q.z {
                Vec3::new(0.0, sign(p.y), 0.0)
            } else {
                Vec3::new(0.0, 0.0, sign(p.z))
            };
            (out_len + inside, normal)
        }
        COLLIDER_SPHERE => {
            let len = norm(p);
            let normal = if len > 0.0 { p / len } else { Vec3::Y };
            (len - s.size[0], normal)
        }
        COLLIDER_CAPSULE => {
            let a = p.y.clamp(-s.size[1], s.size[1]);
            let d = Vec3::new(p.x, p.y - a, p.z);
            let len = norm(d);
            let normal = if len > 0.0 { d / len } else { Vec3::X };
            (len - s.size[0], normal)
        }
        COLLIDER_CYLINDER => {
            let radial = (p.x * p.x + p.z * p.z).sqrt();
            let dr = radial - s.size[0];
            let dy = p.y.abs() - s.size[1];
            let (ox, oy) = (dr.max(0.0), dy.max(0.0));
            let out_len = (ox * ox + oy * oy).sqrt();
            let u = if radial > 0.0 {
                Vec3::new(p.x / radial, 0.0, p.z / radial)
            } else {
                Vec3::X
            };
            let axial = Vec3::new(0.0, sign(p.y), 0.0);
            let normal = if out_len > 0.0 {
                (u * ox + axial * oy) / out_len
            } else if dr > dy {
                u
            } else {
                axial
            };
            (out_len + dr.max(dy).min(0.0), normal)
        }
        _ => mesh_distance(s, sdf, p),
    }
}

/// Trilinear samples of a mesh's distance field and their gradient; far (+infinity) outside the
/// sampled box, which reaches past the band on every side.
fn mesh_distance(s: &ColliderState, sdf: &[f32], p: Vec3) -> (f32, Vec3) {
    const FAR: (f32, Vec3) = (f32::INFINITY, Vec3::Y);
    let inv = 1.0 / s.sdf_spacing;
    let g = (p - Vec3::from(s.sdf_origin)) * inv;
    let base = g.floor();
    if base.x < 0.0 || base.y < 0.0 || base.z < 0.0 {
        return FAR;
    }
    let (i, j, k) = (base.x as u32, base.y as u32, base.z as u32);
    let [nx, ny, nz] = s.sdf_dims;
    if i + 1 >= nx || j + 1 >= ny || k + 1 >= nz {
        return FAR;
    }
    let f = g - base;
    let at = |a: u32, b: u32, c: u32| sdf[(s.sdf_offset + a + nx * (b + ny * c)) as usize];
    let c000 = at(i, j, k);
    let c100 = at(i + 1, j, k);
    let c010 = at(i, j + 1, k);
    let c110 = at(i + 1, j + 1, k);
    let c001 = at(i, j, k + 1);
    let c101 = at(i + 1, j, k + 1);
    let c011 = at(i, j + 1, k + 1);
    let c111 = at(i + 1, j + 1, k + 1);
    // Along x first, then y, then z.
    let x00 = c000 + (c100 - c000) * f.x;
    let x10 = c010 + (c110 - c010) * f.x;
    let x01 = c001 + (c101 - c001) * f.x;
    let x11 = c011 + (c111 - c011) * f.x;
    let y0 = x00 + (x10 - x00) * f.y;
    let y1 = x01 + (x11 - x01) * f.y;
    let phi = y0 + (y1 - y0) * f.z;
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let gx = lerp(
        lerp(c100 - c000, c110 - c010, f.y),
        lerp(c101 - c001, c111 - c011, f.y),
        f.z,
    );
    let gy = lerp(x10 - x00, x11 - x01, f.z);
    let gz = y1 - y0;
    let grad = Vec3::new(gx, gy, gz);
    let len = norm(grad);
    if len > 0.0 {
        (phi, grad / len)
    } else {
        (phi, Vec3::Y)
    }
}

/// Whether x lies farther than `margin` outside the collider's bounding ball (so farther than
/// `margin` from the collider): the cheap test that spares most nodes and particles the shape.
#[inline(always)]
fn beyond(s: &ColliderState, x: Vec3, margin: f32) -> bool {
    let r = x - Vec3::from(s.center);
    let limit = s.reach + margin;
    r.x * r.x + r.y * r.y + r.z * r.z > limit * limit
}

impl ColliderFrame {
    pub fn is_empty(&self) -> bool {
        self.states.is_empty()
    }

    /// Whether x lies inside a collider (where a scene spawns no fluid).
    pub fn contains(&self, x: Vec3) -> bool {
        self.states.iter().any(|s| self.distance(s, x).0 < 0.0)
    }

    /// Signed distance and outward unit normal (world frame) of collider `s` at world point x.
    pub fn distance(&self, s: &ColliderState, x: Vec3) -> (f32, Vec3) {
        let p = to_local(&s.rotation, x - Vec3::from(s.center));
        let (phi, n) = local_distance(s, &self.sdf, p);
        (phi, to_world(&s.rotation, n))
    }

    /// The collider's own velocity at world point x.
    fn velocity_at(s: &ColliderState, x: Vec3) -> Vec3 {
        Vec3::from(s.velocity) + Vec3::from(s.angular_velocity).cross(x - Vec3::from(s.center))
    }

    /// The grid update's boundary condition at a node at x with velocity v: for each collider in
    /// turn (scene order) whose surface is within the band, the velocity relative to the collider
    /// loses its part into the collider (slip), all of it (stick), or that and a Coulomb share of its
    /// tangential part (friction). A relative velocity leaving the collider is left alone, so fluid
    /// can separate from it.
    pub fn project_node(&self, x: Vec3, mut v: Vec3) -> Vec3 {
        for s in &self.states {
            if beyond(s, x, s.band) {
                continue;
            }
            let (phi, n) = self.distance(s, x);
            if phi.is_nan() || phi >= s.band {
                continue; // as the kernel's !(phi < band)
            }
            let vc = Self::velocity_at(s, x);
            let mut rel = v - vc;
            if s.boundary == BOUNDARY_STICK {
                rel = Vec3::ZERO;
            } else {
                let vn = rel.dot(n);
                if vn < 0.0 {
                    let tangential = rel - n * vn;
                    rel = if s.boundary == BOUNDARY_FRICTION {
                        let vt = norm(tangential);
                        if vt <= -s.friction * vn {
                            Vec3::ZERO
                        } else {
                            tangential * (1.0 + s.friction * vn / vt)
                        }
                    } else {
                        tangential
                    };
                }
            }
            v = vc + rel;
        }
        v
    }

    /// The particle backstop, after advection: a particle at x that ended inside a collider is put
    /// back on its surface along the normal, and its velocity into the collider (relative to it) is
    /// removed. Returns the new position and velocity where it did; `None` where no collider holds x.
    pub fn backstop(&self, mut x: Vec3, mut v: Vec3) -> Option<(Vec3, Vec3)> {
        let mut pushed = false;
        for s in &self.states {
            if beyond(s, x, 0.0) {
                continue;
            }
            let (phi, n) = self.distance(s, x);
            if phi < 0.0 {
                x -= n * phi;
                let vn = (v - Self::velocity_at(s, x)).dot(n);
                if vn < 0.0 {
                    v -= n * vn;
                }
                pushed = true;
            }
        }
        pushed.then_some((x, v))
    }
}

// ---------------------------------------------------------------------------------------------
// The scene file's `[[collider]]` tables.

/// One `[[collider]]` table as written.
#[derive(Debug, Clone, Default, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ColliderSpec {
    /// "box", "sphere", "capsule", "cylinder" or "mesh".
    pub shape: String,
    /// m. The shape's centre; for a mesh, where its file's origin goes (default 0).
    pub center: Option<[f64; 3]>,
    /// Box: full edge lengths, m.
    pub size: Option<[f64; 3]>,
    /// Sphere, capsule, cylinder, m.
    pub radius: Option<f64>,
    /// Capsule: length of its axis segment (end caps not counted); cylinder: its height. m, along
    /// the local y axis.
    pub length: Option<f64>,
    /// Orientation as Euler angles in degrees about the world x, then y, then z axes.
    pub rotation: Option<[f64; 3]>,
    /// Or as an axis and an angle in degrees: [ax, ay, az, degrees].
    pub axis_angle: Option<[f64; 4]>,
    /// Mesh: an .obj or .stl file, relative to the scene file.
    pub file: Option<String>,
    /// Mesh: factor applied to the file's coordinates (default 1).
    pub scale: Option<f64>,
    /// "slip" (default), "stick" or "friction" (then `friction` gives the coefficient).
    pub boundary: Option<String>,
    /// Coulomb coefficient; implies boundary = "friction".
    pub friction: Option<f64>,
    pub motion: Option<MotionSpec>,
}

/// `[collider.motion]`: give `velocity` and/or `angular_velocity`, or `piston`, or `flap`.
#[derive(Debug, Clone, Default, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    /// m/s.
    pub velocity: Option<[f64; 3]>,
    /// Degrees per second about the collider's centre, as a world-frame axis times rate.
    pub angular_velocity: Option<[f64; 3]>,
    pub piston: Option<PistonSpec>,
    pub flap: Option<FlapSpec>,
}

#[derive(Debug, Clone, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct PistonSpec {
    /// Direction of the stroke (normalised).
    pub direction: [f64; 3],
    /// m.
    pub amplitude: f64,
    /// s.
    pub period: f64,
    /// Degrees; the offset is amplitude sin(360 t / period + phase).
    #[serde(default)]
    pub phase: f64,
}

#[derive(Debug, Clone, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct FlapSpec {
    /// A point of the hinge line, m.
    pub hinge: [f64; 3],
    /// Direction of the hinge line.
    pub axis: [f64; 3],
    /// Degrees.
    pub amplitude: f64,
    /// s.
    pub period: f64,
    /// Degrees.
    #[serde(default)]
    pub phase: f64,
}

/// A refused collider: the key (below `collider[i]`), what is wrong, the fix.
#[derive(Debug)]
pub struct SpecError {
    pub key: String,
    pub problem: String,
    pub fix: String,
}

fn spec_err(key: impl Into<String>, problem: impl Into<String>, fix: impl Into<String>) -> SpecError {
    SpecError {
        key: key.into(),
        problem: problem.into(),
        fix: fix.into(),
    }
}

fn positive(key: &str, value: Option<f64>, what: &str) -> Result<f64, SpecError> {
    match value {
        None => Err(spec_err(key, "is missing", format!("give {what}"))),
        Some(v) if v.is_finite() && v > 0.0 => Ok(v),
        Some(v) => Err(spec_err(
            key,
            format!("= {v} must be a positive number"),
            format!("give {what}; a collider of zero size is nothing"),
        )),
    }
}

fn finite(key: &str, v: &[f64]) -> Result<(), SpecError> {
    if v.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        Err(spec_err(
            key,
            format!("must be finite, got {v:?}"),
            "give finite numbers",
        ))
    }
}

fn unit(key: &str, v: [f64; 3]) -> Result<DVec3, SpecError> {
    finite(key, &v)?;
    DVec3::from(v).try_normalize().ok_or_else(|| {
        spec_err(
            key,
            format!("= {v:?} has no direction"),
            "give a non-zero direction vector, e.g. [1.0, 0.0, 0.0]",
        )
    })
}

fn oscillation(key: &str, amplitude: f64, period: f64, phase_deg: f64) -> Result<Oscillation, SpecError> {
    finite(&format!("{key}.amplitude"), &[amplitude])?;
    finite(&format!("{key}.phase"), &[phase_deg])?;
    if !(period.is_finite() && period > 0.0) {
        return Err(spec_err(
            format!("{key}.period"),
            format!("= {period} must be a positive number of seconds"),
            "give the period of one stroke in seconds, e.g. 1.0",
        ));
    }
    Ok(Oscillation {
        amplitude,
        period,
        phase: phase_deg.to_radians(),
    })
}

/// A mesh file's welded vertices and triangles, or why they could not be read.
pub type ReadMesh<'a> = &'a dyn Fn(&str, f64) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), String>;

/// Validates one `[[collider]]` table. `read_mesh` reads a mesh file named in the scene (with its
/// scale), its errors naming where it looked; `domain` is the tank's size, m; `dx` the grid spacing.
pub fn validate(
    spec: &ColliderSpec,
    read_mesh: ReadMesh,
    domain: DVec3,
    dx: f64,
) -> Result<Collider, SpecError> {
    const SHAPES: &str = "box, sphere, capsule, cylinder or mesh";
    let center = DVec3::from(spec.center.unwrap_or([0.0; 3]));
    finite("center", &center.to_array())?;
    if spec.center.is_none() && spec.shape != "mesh" {
        return Err(spec_err(
            "center",
            "is missing",
            "give the collider's centre in metres, e.g. center = [0.5, 0.1, 0.25]",
        ));
    }
    let rotation = match (spec.rotation, spec.axis_angle) {
        (Some(_), Some(_)) => {
            return Err(spec_err(
                "rotation",
                "and `axis_angle` are both given",
                "give one orientation: Euler degrees (rotation = [x, y, z]) or axis_angle = [ax, ay, az, degrees]",
            ))
        }
        (Some(e), None) => {
            finite("rotation", &e)?;
            let [x, y, z] = e.map(f64::to_radians);
            DQuat::from_rotation_z(z) * DQuat::from_rotation_y(y) * DQuat::from_rotation_x(x)
        }
        (None, Some(a)) => {
            let axis = unit("axis_angle", [a[0], a[1], a[2]])?;
            finite("axis_angle", &a)?;
            DQuat::from_axis_angle(axis, a[3].to_radians())
        }
        (None, None) => DQuat::IDENTITY,
    };
    let mesh_keys_given = spec.file.is_some() || spec.scale.is_some();
    let shape = match spec.shape.as_str() {
        "box" => {
            let size = spec.size.ok_or_else(|| {
                spec_err(
                    "size",
                    "is missing",
                    "give the box's edge lengths in metres, e.g. size = [0.2, 0.1, 0.3]",
                )
            })?;
            for (a, s) in size.iter().enumerate() {
                positive(&format!("size[{a}]"), Some(*s), "every edge length in metres")?;
            }
            Shape::Box {
                half_extents: DVec3::from(size) * 0.5,
            }
        }
        "sphere" => Shape::Sphere {
            radius: positive("radius", spec.radius, "the radius in metres")?,
        },
        "capsule" | "cylinder" => {
            let radius = positive("radius", spec.radius, "the radius in metres")?;
            let half_length = 0.5 * positive("length", spec.length, "the length along its axis in metres")?;
            if spec.shape == "capsule" {
                Shape::Capsule { radius, half_length }
            } else {
                Shape::Cylinder { radius, half_length }
            }
        }
        "mesh" => {
            let file = spec.file.as_deref().ok_or_else(|| {
                spec_err(
                    "file",
                    "is missing",
                    "give the mesh file, e.g. file = \"obstacle.obj\" (.obj or .stl)",
                )
            })?;
            let scale = match spec.scale {
                None => 1.0,
                Some(s) => positive("scale", Some(s), "a positive scale factor")?,
            };
            let fail = |problem: String| {
                spec_err(
                    "file",
                    problem,
                    "give a closed (watertight) triangle mesh in an .obj or .stl file",
                )
            };
            let (vertices, triangles) = read_mesh(file, scale).map_err(fail)?;
            super::mesh::check_closed(&triangles).map_err(|e| fail(format!("{file}: {e}")))?;
            let band = f64::from(BAND_CELLS) * dx;
            Shape::Mesh(Arc::new(super::mesh::build_sdf(
                vertices,
                triangles,
                dx,
                band + 2.0 * dx,
            )))
        }
        other => {
            return Err(spec_err(
                "shape",
                format!("= {other:?} is not a collider shape"),
                format!("use one of {SHAPES}"),
            ))
        }
    };
    if mesh_keys_given && !matches!(shape, Shape::Mesh(_)) {
        return Err(spec_err(
            "file",
            "is only for shape = \"mesh\"",
            "drop `file` and `scale`, or set shape = \"mesh\"",
        ));
    }
    for (key, given, used) in [
        ("size", spec.size.is_some(), matches!(shape, Shape::Box { .. })),
        (
            "radius",
            spec.radius.is_some(),
            matches!(
                shape,
                Shape::Sphere { .. } | Shape::Capsule { .. } | Shape::Cylinder { .. }
            ),
        ),
        (
            "length",
            spec.length.is_some(),
            matches!(shape, Shape::Capsule { .. } | Shape::Cylinder { .. }),
        ),
    ] {
        if given && !used {
            return Err(spec_err(
                key,
                format!("is not a key of a {} collider", shape.kind_name()),
                "box: size; sphere: radius; capsule and cylinder: radius and length; mesh: file and scale",
            ));
        }
    }
    let boundary = match (spec.boundary.as_deref(), spec.friction) {
        (None | Some("slip"), None) => Boundary::Slip,
        (Some("stick"), None) => Boundary::Stick,
        (None | Some("friction"), Some(mu)) => {
            if !(mu.is_finite() && mu >= 0.0) {
                return Err(spec_err(
                    "friction",
                    format!("= {mu} must be zero or positive"),
                    "give the Coulomb coefficient, e.g. friction = 0.3 (0 is free slip)",
                ));
            }
            Boundary::Friction(mu as f32)
        }
        (Some("friction"), None) => {
            return Err(spec_err(
                "friction",
                "is missing",
                "give the Coulomb coefficient, e.g. friction = 0.3",
            ))
        }
        (Some(kind @ ("slip" | "stick")), Some(_)) => {
            return Err(spec_err(
                "friction",
                format!("is given with boundary = {kind:?}"),
                "drop `friction`, or set boundary = \"friction\"",
            ))
        }
        (Some(other), _) => return Err(spec_err(
            "boundary",
            format!("= {other:?} is not a boundary kind"),
            "use \"slip\" (free slip, the default), \"stick\" (no slip) or \"friction\" with friction = mu",
        )),
    };
    let motion = match &spec.motion {
        None => Motion::Static,
        Some(m) => match (m.velocity, m.angular_velocity, &m.piston, &m.flap) {
            (None, None, None, None) => Motion::Static,
            (v, w, None, None) => {
                let v = v.unwrap_or([0.0; 3]);
                let w = w.unwrap_or([0.0; 3]);
                finite("motion.velocity", &v)?;
                finite("motion.angular_velocity", &w)?;
                Motion::Steady {
                    velocity: DVec3::from(v),
                    angular_velocity: DVec3::from(w.map(f64::to_radians)),
                    since: 0.0,
                }
            }
            (None, None, Some(p), None) => Motion::Piston {
                direction: unit("motion.piston.direction", p.direction)?,
                oscillation: oscillation("motion.piston", p.amplitude, p.period, p.phase)?,
            },
            (None, None, None, Some(f)) => {
                finite("motion.flap.hinge", &f.hinge)?;
                Motion::Flap {
                    hinge: DVec3::from(f.hinge),
                    axis: unit("motion.flap.axis", f.axis)?,
                    oscillation: Oscillation {
                        amplitude: f.amplitude.to_radians(),
                        ..oscillation("motion.flap", f.amplitude, f.period, f.phase)?
                    },
                }
            }
            _ => {
                return Err(spec_err(
                    "motion",
                    "mixes kinds of motion",
                    "give velocity and/or angular_velocity, or piston, or flap: one kind per collider",
                ))
            }
        },
    };
    let collider = Collider {
        shape,
        boundary,
        center,
        rotation,
        motion,
    };
    // Some of the collider must be inside the domain (a paddle or a slope may well run through a
    // wall or the floor, its centre outside), or the fluid would never meet it.
    let (lo, hi) = collider_bounds(&collider);
    if hi.cmple(DVec3::ZERO).any() || lo.cmpge(domain).any() {
        return Err(spec_err(
            "center",
            format!(
                "puts the collider (centre {:?}, reaching [{:.3}, {:.3}, {:.3}] to [{:.3}, {:.3}, {:.3}] m) outside \
                 the domain [0, {:.4}] x [0, {:.4}] x [0, {:.4}] m",
                center.to_array(),
                lo.x, lo.y, lo.z, hi.x, hi.y, hi.z,
                domain.x, domain.y, domain.z
            ),
            "move the collider so that at least part of it is inside the tank",
        ));
    }
    Ok(collider)
}

/// A box that holds the collider at rest, world frame.
fn collider_bounds(c: &Collider) -> (DVec3, DVec3) {
    let m = DMat3::from_quat(c.rotation);
    let half = match &c.shape {
        Shape::Box { half_extents } => DVec3::new(
            m.row(0).abs().dot(*half_extents),
            m.row(1).abs().dot(*half_extents),
            m.row(2).abs().dot(*half_extents),
        ),
        Shape::Mesh(mesh) => {
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for v in &mesh.vertices {
                let w = m * v.as_dvec3();
                lo = lo.min(w);
                hi = hi.max(w);
            }
            return (c.center + lo, c.center + hi);
        }
        other => DVec3::splat(other.bounding_radius()),
    };
    (c.center - half, c.center + half)
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
}
