//! Rigid bodies: colliders that the liquid moves (docs/physics.md, "Rigid bodies").
//!
//! A body is a collider with a mass. Every substep the grid update treats it as any moving collider
//! (its boundary condition on the nodes in its band, relative to its rigid velocity) and adds, in
//! fixed point, what that condition took from each node: the impulse `-m_i dv_i` and its moment about
//! the body's centre. [`step_body`] then gives the body that impulse, gravity and its contacts with
//! the walls, and moves it; the next substep's boundary is the body where this one left it. The
//! particle backstop's pushes out of the body go to the same sums, for its next step. Exchanging
//! exactly the momentum the liquid lost keeps body and liquid together conserving momentum; the sums
//! are integers, so they do not depend on the order they are added in.
//!
//! The coupling is explicit: a node in the band takes the body's velocity, and the body takes the
//! node's momentum change. A body much lighter than the liquid in its band overshoots (the
//! added-mass instability), so validation refuses such bodies ([`Dynamics::band_mass_ratio`],
//! [`MAX_BAND_MASS_RATIO`]).
//!
//! [`step_body`] is the CPU twin of kernels/bodies.cu, operation for operation in double precision.

use super::{Shape, BAND_CELLS};
use crate::contract::ColliderState;
pub use crate::contract::{BodyWalls, ContactFeature, RigidBody, BODY_IMPULSE_UNITS};
use glam::{DMat3, DQuat, DVec3};

/// What makes a collider a rigid body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dynamics {
    /// kg.
    pub mass: f64,
    /// The centre of mass, body frame, m.
    pub centroid: DVec3,
    /// About the centre of mass, body frame, kg m^2.
    pub inertia: DMat3,
    /// At the start: of the centre of mass, m/s, and about it, rad/s (world frame).
    pub velocity: DVec3,
    pub angular_velocity: DVec3,
    pub hinge: Option<Hinge>,
    /// Coulomb coefficient of its contacts with the walls.
    pub contact_friction: f64,
}

/// A fixed axis the body turns about (a water wheel's axle, a flap gate's hinge).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hinge {
    /// A point of the axis, world frame, m.
    pub point: DVec3,
    /// Unit.
    pub axis: DVec3,
}

/// The largest [`Dynamics::band_mass_ratio`] a scene may give a body. Measured (CPU, 1 cm cells, a
/// quasi-2D square log 10 cm across let go 8 cm under water; docs/physics.md, "Light bodies"): at a
/// ratio of 81 (density 20 kg/m^3) the run blew up in its first frame; at 32 (50 kg/m^3) the log
/// rose ten times as far in its first 0.17 s as the liquid's added mass allows; logs floating at the
/// surface were calm down to 50 kg/m^3.
pub const MAX_BAND_MASS_RATIO: f64 = 20.0;

/// Contacts a body resolves at once with the walls: a box on the floor has four, in a corner six.
const MAX_CONTACTS: usize = 16;
/// Sequential-impulse sweeps over a substep's contacts.
const CONTACT_SWEEPS: usize = 8;
/// A mesh's contact features: the vertices farthest along this many directions.
const MESH_FEATURE_DIRECTIONS: usize = 64;

impl Shape {
    /// The points of the shape that can touch a wall, each swept by a ball: the deepest point of a
    /// convex shape against a plane is one of them.
    pub fn contact_features(&self) -> Vec<ContactFeature> {
        let point = |p: DVec3, radius: f64| ContactFeature {
            point: p.to_array(),
            radius,
        };
        match self {
            Shape::Box { half_extents: h } => (0..8)
                .map(|c| {
                    let s = |bit: u32| if c & (1 << bit) == 0 { -1.0 } else { 1.0 };
                    point(DVec3::new(s(0) * h.x, s(1) * h.y, s(2) * h.z), 0.0)
                })
                .collect(),
            Shape::Sphere { radius } => vec![point(DVec3::ZERO, *radius)],
            Shape::Capsule { radius, half_length } => vec![
                point(DVec3::new(0.0, -half_length, 0.0), *radius),
                point(DVec3::new(0.0, *half_length, 0.0), *radius),
            ],
            Shape::Cylinder { radius, half_length } => (0..24)
                .map(|k| {
                    let angle = std::f64::consts::TAU * f64::from(k % 12) / 12.0;
                    let y = if k < 12 { -half_length } else { *half_length };
                    point(DVec3::new(radius * angle.cos(), y, radius * angle.sin()), 0.0)
                })
                .collect(),
            Shape::Mesh(mesh) => {
                // The vertex farthest along each of a spread of directions (a Fibonacci sphere):
                // the convex hull's corners that matter, however finely the mesh is cut.
                let mut picked: Vec<usize> = (0..MESH_FEATURE_DIRECTIONS)
                    .filter_map(|k| {
                        let y = 1.0 - 2.0 * (k as f64 + 0.5) / MESH_FEATURE_DIRECTIONS as f64;
                        let phi = k as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
                        let r = (1.0 - y * y).sqrt();
                        let d = DVec3::new(r * phi.cos(), y, r * phi.sin());
                        (0..mesh.vertices.len()).max_by(|&a, &b| {
                            let da = mesh.vertices[a].as_dvec3().dot(d);
                            da.total_cmp(&mesh.vertices[b].as_dvec3().dot(d))
                        })
                    })
                    .collect();
                picked.sort_unstable();
                picked.dedup();
                picked
                    .into_iter()
                    .map(|i| point(mesh.vertices[i].as_dvec3(), 0.0))
                    .collect()
            }
        }
    }
}

impl Dynamics {
    /// The body's state at the start, its collider at `center`, `rotation`; in collider state `slot`,
    /// its features from `first_feature` on.
    pub fn initial_state(
        &self,
        center: DVec3,
        rotation: DQuat,
        slot: u32,
        first_feature: u32,
        num_features: u32,
    ) -> RigidBody {
        let (hinge_point, hinge_axis) = self
            .hinge
            .map_or((DVec3::ZERO, DVec3::ZERO), |h| (h.point, h.axis));
        RigidBody {
            center: center.to_array(),
            orientation: rotation.normalize().to_array(),
            velocity: self.velocity.to_array(),
            angular_velocity: self.angular_velocity.to_array(),
            centroid: self.centroid.to_array(),
            inv_mass: 1.0 / self.mass,
            inertia: self.inertia.transpose().to_cols_array(),
            inv_inertia: self.inertia.inverse().transpose().to_cols_array(),
            hinge_point: hinge_point.to_array(),
            hinge_axis: hinge_axis.to_array(),
            contact_friction: self.contact_friction,
            first_feature,
            num_features,
            slot,
            _pad: 0,
        }
    }

    /// The mass of the liquid (density `liquid_density`) in the body's band when it is wholly
    /// submerged, over the body's own. The coupling is explicit: the body feels the liquid its
    /// boundary holds a substep late, so a body much lighter than that liquid accelerates as if the
    /// liquid had no inertia, and overshoots (the added-mass instability). The band counts the layer
    /// of nodes outside the surface and the layer inside it that particles' stencils reach:
    /// `BAND_CELLS + 1` cells of the surface's area.
    pub fn band_mass_ratio(&self, shape: &Shape, liquid_density: f64, dx: f64) -> f64 {
        let band = liquid_density * shape.surface_area() * (f64::from(BAND_CELLS) + 1.0) * dx;
        band / self.mass
    }
}

/// The fixed-point units of one node's share of a body's impulse (`BODY_IMPULSE_UNITS` per N s):
/// [`super::super::cpu::fixed_point_units`]' rounding, as the kernels' `__float2ll_rn`.
pub fn impulse_units(value: f32) -> i64 {
    crate::sim::cpu::fixed_point_units(value * BODY_IMPULSE_UNITS)
}

fn mat(rows: &[f64; 9]) -> DMat3 {
    DMat3::from_cols_array(rows).transpose()
}

fn vec(a: &[f64; 3]) -> DVec3 {
    DVec3::from_array(*a)
}

/// World-from-body rotation of a body.
fn rotation_of(body: &RigidBody) -> DMat3 {
    DMat3::from_quat(DQuat::from_array(body.orientation))
}

/// The collider state of `template` (the body's shape and boundary) at the body's pose: the rigid
/// velocity the grid update holds its band to. kernels/bodies.cu's place_body computes it from the
/// same state in the same operations, none fused, so the device's slots and the host's agree bit for
/// bit (what a resumed GPU run's first substep starts from).
pub fn body_collider_state(template: &ColliderState, body: &RigidBody) -> ColliderState {
    let r = rotation_of(body);
    let center = vec(&body.center);
    let centre_of_mass = center + r * vec(&body.centroid);
    let w = vec(&body.angular_velocity);
    let velocity = vec(&body.velocity) + w.cross(center - centre_of_mass);
    ColliderState {
        rotation: r.transpose().as_mat3().to_cols_array(),
        center: center.as_vec3().to_array(),
        velocity: velocity.as_vec3().to_array(),
        angular_velocity: w.as_vec3().to_array(),
        ..*template
    }
}

/// A body's impulse from the grid (linear, then angular about the body's frame origin), N s.
pub fn impulse_value(units: &[i64; 6]) -> (DVec3, DVec3) {
    let v = units.map(|u| u as f64 / f64::from(BODY_IMPULSE_UNITS));
    (DVec3::new(v[0], v[1], v[2]), DVec3::new(v[3], v[4], v[5]))
}

/// One substep of a body (module docs): the grid's impulse and gravity, its hinge or its contacts
/// with the walls, then the motion over `dt`.
pub fn step_body(
    body: &mut RigidBody,
    features: &[ContactFeature],
    impulse: &[i64; 6],
    dt: f64,
    gravity: DVec3,
    walls: &BodyWalls,
) {
    let (linear, about_origin) = impulse_value(impulse);
    let r = rotation_of(body);
    let center = vec(&body.center);
    let com = center + r * vec(&body.centroid);
    // The grid's angular impulse about the centre of mass.
    let angular = about_origin + (center - com).cross(linear);
    let inertia = r * mat(&body.inertia) * r.transpose();
    let inv_inertia = r * mat(&body.inv_inertia) * r.transpose();
    let mut v = vec(&body.velocity);
    let mut w = vec(&body.angular_velocity);
    let axis = vec(&body.hinge_axis);
    if axis != DVec3::ZERO {
        // About the fixed axis: the impulses' moment about it over the moment of inertia about it
        // (the hinge's reaction has no moment there).
        let arm = com - vec(&body.hinge_point);
        let weight = gravity * (dt / body.inv_mass);
        let moment = axis.dot(angular + arm.cross(linear + weight));
        let moment_of_inertia =
            axis.dot(inertia * axis) + (arm.length_squared() - axis.dot(arm).powi(2)) / body.inv_mass;
        let rate = axis.dot(w) + moment / moment_of_inertia;
        w = axis * rate;
        v = w.cross(arm);
    } else {
        v += linear * body.inv_mass + gravity * dt;
        // Angular momentum about the centre of mass is what the impulse changes.
        w = inv_inertia * (inertia * w + angular);
        resolve_wall_contacts(body, features, r, com, walls, inv_inertia, &mut v, &mut w);
    }
    // The rotation over the substep at the new rate, exactly: about the centre of mass, which moves
    // at v; or, hinged, about the axis, which carries the centre of mass round with it.
    let turn = DQuat::from_scaled_axis(w * dt);
    let orientation = (turn * DQuat::from_array(body.orientation)).normalize();
    let com = if axis == DVec3::ZERO {
        com + v * dt
    } else {
        let hinge = vec(&body.hinge_point);
        hinge + DMat3::from_quat(turn) * (com - hinge)
    };
    let mut center = com - DMat3::from_quat(orientation) * vec(&body.centroid);
    if axis == DVec3::ZERO {
        center += wall_overlap(features, DMat3::from_quat(orientation), center, walls);
    }
    body.center = center.to_array();
    body.orientation = orientation.to_array();
    body.velocity = v.to_array();
    body.angular_velocity = w.to_array();
}

/// A contact of a body's feature with a wall: the touching point relative to the centre of mass, the
/// wall's normal into the tank, and the impulses given so far this substep.
struct Contact {
    arm: DVec3,
    normal: DVec3,
    normal_impulse: f64,
    friction_impulse: DVec3,
}

/// The features touching or past a wall (at most [`MAX_CONTACTS`]), as contacts.
fn wall_contacts(
    features: &[ContactFeature],
    r: DMat3,
    center: DVec3,
    com: DVec3,
    walls: &BodyWalls,
) -> Vec<Contact> {
    let mut contacts = Vec::new();
    for f in features {
        let p = center + r * vec(&f.point);
        for a in 0..3 {
            for (side, sign) in [(walls.lo[a], 1.0), (walls.hi[a], -1.0)] {
                // A feature's depth past the wall, its ball's radius included.
                let depth = sign * (side - p[a]) + f.radius;
                if depth >= 0.0 && contacts.len() < MAX_CONTACTS {
                    let normal = DVec3::AXES[a] * sign;
                    contacts.push(Contact {
                        arm: p - normal * f.radius - com,
                        normal,
                        normal_impulse: 0.0,
                        friction_impulse: DVec3::ZERO,
                    });
                }
            }
        }
    }
    contacts
}

/// Sequential impulses against the walls: each contact's velocity into the wall is removed (an
/// inelastic contact), its sliding opposed by Coulomb friction up to mu times the normal impulse.
#[allow(clippy::too_many_arguments)]
fn resolve_wall_contacts(
    body: &RigidBody,
    features: &[ContactFeature],
    r: DMat3,
    com: DVec3,
    walls: &BodyWalls,
    inv_inertia: DMat3,
    v: &mut DVec3,
    w: &mut DVec3,
) {
    let mut contacts = wall_contacts(features, r, vec(&body.center), com, walls);
    // The velocity change at the contact per unit impulse along `d`.
    let response = |arm: DVec3, d: DVec3| body.inv_mass + d.dot((inv_inertia * arm.cross(d)).cross(arm));
    for _ in 0..CONTACT_SWEEPS {
        for c in &mut contacts {
            let at = *v + w.cross(c.arm);
            let into = at.dot(c.normal);
            let total = (c.normal_impulse - into / response(c.arm, c.normal)).max(0.0);
            let mut change = c.normal * (total - c.normal_impulse);
            c.normal_impulse = total;
            let slide = at - c.normal * into;
            let speed = slide.length();
            if speed > 0.0 {
                let along = slide / speed;
                let wanted = c.friction_impulse - along * (speed / response(c.arm, along));
                let limit = body.contact_friction * c.normal_impulse;
                let friction = if wanted.length() > limit {
                    wanted * (limit / wanted.length())
                } else {
                    wanted
                };
                change += friction - c.friction_impulse;
                c.friction_impulse = friction;
            }
            *v += change * body.inv_mass;
            *w += inv_inertia * c.arm.cross(change);
        }
    }
}

/// How far a body at `center` must move to be clear of the walls: what its contacts' impulses left
/// of an overlap (the contact is inelastic, so the depth is undone by position, adding no energy).
fn wall_overlap(features: &[ContactFeature], r: DMat3, center: DVec3, walls: &BodyWalls) -> DVec3 {
    let mut push = DVec3::ZERO;
    for f in features {
        let p = center + r * vec(&f.point);
        for a in 0..3 {
            push[a] = push[a].max(walls.lo[a] - (p[a] - f.radius));
            push[a] = push[a].min(walls.hi[a] - (p[a] + f.radius));
        }
    }
    push
}

/// The rigid bodies between two substeps: all a run carries of them to the next, which a checkpoint
/// holds. In the order of the colliders that are bodies.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BodiesState {
    pub states: Vec<RigidBody>,
    /// What each body's next step adds to the grid's impulse, `BODY_IMPULSE_UNITS` per N s (and per
    /// N m s): the particle backstop's pushes out of it in the substep's g2p, after the body stepped.
    pub impulses: Vec<[i64; 6]>,
}

impl BodiesState {
    /// Bodies at the start of a run: nothing pushed out of them yet.
    pub fn at_start(states: Vec<RigidBody>) -> BodiesState {
        let impulses = vec![[0; 6]; states.len()];
        BodiesState { states, impulses }
    }

    /// Refuses a state whose impulse rows do not match its bodies one for one (a solver would step a
    /// body without its sums, or read past them).
    pub fn check(&self) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.impulses.len() == self.states.len(),
            "{} rigid bodies with {} rows of impulse sums",
            self.states.len(),
            self.impulses.len()
        );
        Ok(())
    }
}

/// The rigid bodies a CPU backend steps: their states, contact features and walls, and the impulse
/// sums its grid update adds to.
#[derive(Debug, Clone, Default)]
pub struct HostBodies {
    pub states: Vec<RigidBody>,
    pub features: Vec<ContactFeature>,
    pub walls: Option<BodyWalls>,
    /// `BODY_IMPULSE_UNITS` per N s; one row per body, zeroed by each step.
    pub impulses: Vec<[i64; 6]>,
    /// The grid's mass before the walls' mirror images joined it: what the exchange counts
    /// ([`super::ColliderFrame::project_node_exchanging`]).
    pub own_mass: Vec<f32>,
}

impl HostBodies {
    pub fn new(bodies: &BodiesState, features: &[ContactFeature], walls: BodyWalls) -> HostBodies {
        HostBodies {
            states: bodies.states.clone(),
            features: features.to_vec(),
            walls: Some(walls),
            impulses: bodies.impulses.clone(),
            own_mass: Vec::new(),
        }
    }

    /// Every body's substep after the grid update ([`step_body`]), with the impulses summed in it;
    /// `frame` then holds the bodies where they ended.
    pub fn step(&mut self, dt: f32, gravity: [f32; 3], frame: &mut super::ColliderFrame) {
        let Some(walls) = self.walls else { return };
        let gravity = glam::Vec3::from(gravity).as_dvec3();
        for (body, impulse) in self.states.iter_mut().zip(&mut self.impulses) {
            let first = body.first_feature as usize;
            let features = &self.features[first..first + body.num_features as usize];
            step_body(body, features, impulse, f64::from(dt), gravity, &walls);
            *impulse = [0; 6];
        }
        frame.place_bodies(&self.states);
    }
}

impl super::ColliderFrame {
    /// Puts each body's collider state, at its pose in `bodies`, into its slot.
    pub fn place_bodies(&mut self, bodies: &[RigidBody]) {
        for body in bodies {
            if let Some(slot) = self.states.get_mut(body.slot as usize) {
                *slot = body_collider_state(slot, body);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WALLS: BodyWalls = BodyWalls {
        lo: [0.0; 3],
        hi: [1.0; 3],
    };

    /// A 10 x 20 x 30 cm box of 500 kg/m^3 at `center`, turned `rotation`.
    fn a_box(center: DVec3, rotation: DQuat, hinge: Option<Hinge>) -> (RigidBody, Vec<ContactFeature>) {
        let shape = Shape::Box {
            half_extents: DVec3::new(0.05, 0.1, 0.15),
        };
        let p = shape.mass_properties();
        let dynamics = Dynamics {
            mass: 500.0 * p.volume,
            centroid: p.centroid,
            inertia: p.inertia * 500.0,
            velocity: DVec3::ZERO,
            angular_velocity: DVec3::ZERO,
            hinge,
            contact_friction: 0.5,
        };
        let features = shape.contact_features();
        (
            dynamics.initial_state(center, rotation, 0, 0, features.len() as u32),
            features,
        )
    }

    fn units(value: DVec3) -> [i64; 3] {
        (value * f64::from(BODY_IMPULSE_UNITS))
            .to_array()
            .map(|v| v.round() as i64)
    }

    /// Clear of the walls and given nothing, a body falls freely: v = g t, and the position of the
    /// symplectic Euler step, c = c0 + g dt^2 n (n + 1) / 2.
    #[test]
    fn a_free_body_falls_at_g() {
        let (mut body, features) = a_box(DVec3::splat(0.5), DQuat::from_rotation_x(0.3), None);
        let (dt, g) = (1e-3, DVec3::new(0.0, -9.81, 0.0));
        for _ in 0..100 {
            step_body(&mut body, &features, &[0; 6], dt, g, &WALLS);
        }
        assert!(
            (vec(&body.velocity) - g * 0.1).length() < 1e-12,
            "{:?}",
            body.velocity
        );
        let fallen = DVec3::splat(0.5) + g * (dt * dt * 100.0 * 101.0 / 2.0);
        assert!((vec(&body.center) - fallen).length() < 1e-12, "{:?}", body.center);
    }

    /// The grid's impulse changes the momentum by itself, and its moment about the centre of mass
    /// the angular momentum: here a push at a point off the centre.
    #[test]
    fn an_impulse_and_its_moment_move_and_turn_the_body() {
        let rotation = DQuat::from_rotation_z(0.4);
        let (mut body, features) = a_box(DVec3::splat(0.5), rotation, None);
        let push = DVec3::new(0.02, 0.0, 0.01);
        let at = DVec3::new(0.03, 0.05, -0.02); // from the collider's centre
        let moment = at.cross(push);
        let mut impulse = [0; 6];
        impulse[..3].copy_from_slice(&units(push));
        impulse[3..].copy_from_slice(&units(moment));
        step_body(&mut body, &features, &impulse, 1e-4, DVec3::ZERO, &WALLS);
        let mass = 1.0 / body.inv_mass;
        assert!((vec(&body.velocity) * mass - push).length() < 1e-9);
        let r = DMat3::from_quat(rotation);
        let inertia = r * mat(&body.inertia) * r.transpose();
        // The turn over the step moved the world inertia a little: compare with the one it had.
        assert!((inertia * vec(&body.angular_velocity) - moment).length() < 1e-6 * moment.length());
    }

    /// A body falling onto the floor stops on it: no velocity into the floor, none of it below the
    /// floor's plane, and a tilted box comes to rest flat.
    #[test]
    fn a_box_dropped_on_the_floor_comes_to_rest_on_it() {
        let (mut body, features) = a_box(DVec3::new(0.5, 0.3, 0.5), DQuat::from_rotation_z(0.2), None);
        let g = DVec3::new(0.0, -9.81, 0.0);
        for _ in 0..4000 {
            step_body(&mut body, &features, &[0; 6], 1e-3, g, &WALLS);
        }
        let r = rotation_of(&body);
        let lowest = features
            .iter()
            .map(|f| (vec(&body.center) + r * vec(&f.point)).y)
            .fold(f64::INFINITY, f64::min);
        assert!(lowest > -1e-9 && lowest < 1e-3, "the lowest corner at {lowest} m");
        assert!(vec(&body.velocity).length() < 1e-2, "{:?}", body.velocity);
        // Back from its tilt, flat on a 10 x 30 cm face: its centre its y half extent up.
        assert!(
            (body.center[1] - 0.1).abs() < 1e-3,
            "centre at {} m",
            body.center[1]
        );
    }

    /// A hinged body swings about its axis alone: its centre keeps its distance from the hinge, and
    /// it turns about the axis only.
    #[test]
    fn a_hinged_body_swings_about_its_axis() {
        let hinge = Hinge {
            point: DVec3::new(0.5, 0.8, 0.5),
            axis: DVec3::Z,
        };
        let (mut body, features) = a_box(DVec3::new(0.7, 0.8, 0.5), DQuat::IDENTITY, Some(hinge));
        let g = DVec3::new(0.0, -9.81, 0.0);
        for _ in 0..300 {
            step_body(&mut body, &features, &[0; 6], 1e-3, g, &WALLS);
            let arm = vec(&body.center) - hinge.point;
            assert!((arm.length() - 0.2).abs() < 1e-9, "the arm is {} m", arm.length());
            let w = vec(&body.angular_velocity);
            assert!(w.x == 0.0 && w.y == 0.0, "{w}");
        }
        assert!(body.angular_velocity[2] < -1.0, "it has not swung down");
    }

    /// A body's collider state moves at the body's rigid velocity at the collider's centre.
    #[test]
    fn the_collider_state_carries_the_body_s_velocity_at_its_centre() {
        let (mut body, _) = a_box(DVec3::splat(0.5), DQuat::from_rotation_y(0.5), None);
        body.centroid = [0.01, 0.0, -0.02];
        body.velocity = [0.1, 0.2, 0.3];
        body.angular_velocity = [1.0, -2.0, 0.5];
        let state = body_collider_state(&ColliderState::default(), &body);
        let com = vec(&body.center) + rotation_of(&body) * vec(&body.centroid);
        let want = vec(&body.velocity) + vec(&body.angular_velocity).cross(vec(&body.center) - com);
        assert!((DVec3::from_array(state.velocity.map(f64::from)) - want).length() < 1e-6);
    }
}
