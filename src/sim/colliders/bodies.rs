//! Rigid bodies: colliders that the liquid moves (docs/physics.md, "Rigid bodies").
//!
//! A body is a collider with a mass. Every substep the grid update treats it as any moving collider
//! (its boundary condition on the nodes in its band, relative to its rigid velocity) and adds, in
//! fixed point, what that condition took from each node: the impulse `-m_i dv_i` and its moment about
//! the body's centre. [`step_bodies`] then gives the body that impulse, gravity and its contacts (with
//! the walls, the other colliders and the other bodies), and moves it; the next substep's boundary
//! is the body where this one left it. The particle backstop's pushes out of the body go to the same
//! sums, for its next step. Exchanging
//! exactly the momentum the liquid lost keeps body and liquid together conserving momentum; the sums
//! are integers, so they do not depend on the order they are added in.
//!
//! The coupling is explicit: a node in the band takes the body's velocity, and the body takes the
//! node's momentum change. A body much lighter than the liquid in its band overshoots (the
//! added-mass instability), so validation refuses such bodies ([`Dynamics::band_mass_ratio`],
//! [`MAX_BAND_MASS_RATIO`]).
//!
//! [`step_bodies`] is the CPU twin of kernels/bodies.cu, operation for operation in double precision.

use super::{Shape, BAND_CELLS, BOUNDARY_PIPE};
use crate::contract::ColliderState;
pub use crate::contract::{BodyWalls, ContactFeature, RigidBody, BODY_IMPULSE_UNITS};
use crate::contract::{
    BODY_CONTACT_MARGIN, BODY_CONTACT_SWEEPS, BODY_FEATURE_INSET, BODY_PUSH_RATE, MAX_BODY_CONTACTS,
};
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

/// A mesh's contact features: the vertices farthest along this many directions.
const MESH_FEATURE_DIRECTIONS: usize = 64;

/// A shape's contact features: first its corners, the points that can touch a wall (the deepest
/// point of a convex shape against a plane is one of them), then points along its edges, which
/// with the corners meet other colliders and bodies (a box lying turned on another touches it where
/// their edges cross, away from any corner).
pub struct ContactFeatures {
    pub points: Vec<ContactFeature>,
    pub corners: usize,
}

/// Points along each edge of a box, between its corners, where it meets other colliders.
const EDGE_SAMPLES: usize = 3;

impl Shape {
    /// The points of the shape that can touch something, each swept by a ball ([`ContactFeatures`]).
    pub fn contact_features(&self) -> ContactFeatures {
        let corners = self.corners();
        let mut points = corners.clone();
        if let Shape::Box { .. } = self {
            // The twelve edges join corners that differ in one coordinate.
            for (a, from) in corners.iter().enumerate() {
                for axis in 0..3 {
                    if a & (1 << axis) == 0 {
                        let to = vec(&corners[a | (1 << axis)].point);
                        for k in 1..=EDGE_SAMPLES {
                            let t = k as f64 / (EDGE_SAMPLES + 1) as f64;
                            let p = vec(&from.point).lerp(to, t);
                            points.push(ContactFeature {
                                point: p.to_array(),
                                radius: 0.0,
                            });
                        }
                    }
                }
            }
        }
        ContactFeatures {
            corners: corners.len(),
            points,
        }
    }

    fn corners(&self) -> Vec<ContactFeature> {
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
    /// its `features` from `first_feature` on.
    pub fn initial_state(
        &self,
        center: DVec3,
        rotation: DQuat,
        slot: u32,
        first_feature: u32,
        features: &ContactFeatures,
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
            num_features: features.points.len() as u32,
            slot,
            num_corners: features.corners as u32,
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

    /// Refuses a body too light for the explicit coupling: one whose [`Self::band_mass_ratio`] is
    /// above [`MAX_BAND_MASS_RATIO`]. The error is what is wrong and what to do, which a scene file's
    /// refusal and a dropped body's each put in their own words.
    pub fn check_band_mass(
        &self,
        shape: &Shape,
        liquid_density: f64,
        dx: f64,
    ) -> Result<(), (String, &'static str)> {
        let ratio = self.band_mass_ratio(shape, liquid_density, dx);
        if ratio > MAX_BAND_MASS_RATIO {
            return Err((
                format!(
                    "gives a body of {:.4} kg, lighter than the liquid its boundary band would hold \
                     submerged ({ratio:.2} times its mass, at most {MAX_BAND_MASS_RATIO} is stable): the \
                     body and the liquid exchange momentum explicitly, and so light a body overshoots",
                    self.mass
                ),
                "make the body denser or larger, or the cells finer (the band is a cell thick)",
            ));
        }
        Ok(())
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

/// The bodies' substep (module docs), in four phases, the kernel's as well: each body takes the
/// grid's impulse and gravity (or, hinged, their moment about its axis); each free body finds its
/// contacts, with the walls, the other colliders and the other bodies; sequential impulses resolve
/// all of them together, so a box resting on a box resting on the floor holds both; then each
/// body moves. `frame` holds every collider where this substep put it (the bodies at their start).
#[allow(clippy::too_many_arguments)]
pub fn step_bodies(
    bodies: &mut [RigidBody],
    features: &[ContactFeature],
    impulses: &[[i64; 6]],
    dt: f64,
    gravity: DVec3,
    walls: &BodyWalls,
    frame: &super::ColliderFrame,
) {
    let mut motions: Vec<Motion> = bodies
        .iter()
        .zip(impulses)
        .map(|(body, impulse)| take_impulse(body, impulse, dt, gravity))
        .collect();
    let mut contacts = Vec::new();
    for (k, body) in bodies.iter().enumerate() {
        if !is_hinged(body) {
            contacts.extend(find_contacts(k, bodies, &motions, features, walls, frame));
        }
    }
    resolve_contacts(&mut motions, &mut contacts, dt);
    for (body, motion) in bodies.iter_mut().zip(&motions) {
        let corners = &features[body.first_feature as usize..][..body.num_corners as usize];
        move_body(body, motion, corners, dt, walls);
    }
}

/// A body over its substep: its centre of mass at the start, its new velocities, what contacts see of
/// its mass (none for a hinged body, which contacts cannot move: it is a moving obstacle to the
/// others) and the pseudo-velocities that push it out of overlaps.
struct Motion {
    com: DVec3,
    velocity: DVec3,
    angular_velocity: DVec3,
    inv_mass: f64,
    inv_inertia: DMat3,
    push_velocity: DVec3,
    push_angular_velocity: DVec3,
}

fn is_hinged(body: &RigidBody) -> bool {
    vec(&body.hinge_axis) != DVec3::ZERO
}

/// The body's velocities after the grid's impulse and gravity.
fn take_impulse(body: &RigidBody, impulse: &[i64; 6], dt: f64, gravity: DVec3) -> Motion {
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
    let hinged = is_hinged(body);
    if hinged {
        // About the fixed axis: the impulses' moment about it over the moment of inertia about it
        // (the hinge's reaction has no moment there).
        let axis = vec(&body.hinge_axis);
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
    }
    Motion {
        com,
        velocity: v,
        angular_velocity: w,
        inv_mass: if hinged { 0.0 } else { body.inv_mass },
        inv_inertia: if hinged { DMat3::ZERO } else { inv_inertia },
        push_velocity: DVec3::ZERO,
        push_angular_velocity: DVec3::ZERO,
    }
}

/// The body's motion over `dt` at its new velocities (plus its contacts' pushes): the rotation
/// exactly, about the centre of mass, which moves at v; or, hinged, about the axis, which carries the
/// centre of mass round with it. A free body is then put back inside the walls (by its `corners`).
fn move_body(body: &mut RigidBody, motion: &Motion, corners: &[ContactFeature], dt: f64, walls: &BodyWalls) {
    let v = motion.velocity + motion.push_velocity;
    let w = motion.angular_velocity + motion.push_angular_velocity;
    let turn = DQuat::from_scaled_axis(w * dt);
    let orientation = (turn * DQuat::from_array(body.orientation)).normalize();
    let hinged = is_hinged(body);
    let com = if hinged {
        let hinge = vec(&body.hinge_point);
        hinge + DMat3::from_quat(turn) * (motion.com - hinge)
    } else {
        motion.com + v * dt
    };
    let mut center = com - DMat3::from_quat(orientation) * vec(&body.centroid);
    if !hinged {
        center += wall_overlap(corners, DMat3::from_quat(orientation), center, walls);
    }
    body.center = center.to_array();
    body.orientation = orientation.to_array();
    body.velocity = motion.velocity.to_array();
    body.angular_velocity = motion.angular_velocity.to_array();
}

/// What a contact touches besides its body.
#[derive(Clone, Copy)]
enum Partner {
    /// A wall, or a collider that is no body, here moving at this velocity.
    Fixed(DVec3),
    /// Another body, by index.
    Body(usize),
}

/// A contact of body `body`'s feature: the touching point relative to the body's centre of mass and
/// to the partner's, the normal out of the partner, how deep the feature's ball is in it (negative:
/// the gap between them), the
/// Coulomb coefficient, and the impulses given so far this substep (velocity and push).
struct Contact {
    body: usize,
    partner: Partner,
    arm: DVec3,
    partner_arm: DVec3,
    normal: DVec3,
    depth: f64,
    friction: f64,
    normal_impulse: f64,
    friction_impulse: DVec3,
    push_impulse: f64,
}

/// Body `k`'s contacts (at most [`MAX_BODY_CONTACTS`]): its features touching or past a wall, then those
/// touching or inside another collider (in the frame's order; a nozzle's pipe is no obstacle). The
/// depth into a wall is undone by [`wall_overlap`]; into a collider, by the contact's push.
fn find_contacts(
    k: usize,
    bodies: &[RigidBody],
    motions: &[Motion],
    features: &[ContactFeature],
    walls: &BodyWalls,
    frame: &super::ColliderFrame,
) -> Vec<Contact> {
    let body = &bodies[k];
    let (r, center, com) = (rotation_of(body), vec(&body.center), motions[k].com);
    let own = &features[body.first_feature as usize..][..body.num_features as usize];
    let mut contacts = Vec::new();
    let mut add = |contact: Contact| {
        if contacts.len() < MAX_BODY_CONTACTS as usize {
            contacts.push(contact);
        }
    };
    let contact =
        |at: DVec3, normal: DVec3, depth: f64, partner: Partner, partner_com: DVec3, friction: f64| Contact {
            body: k,
            partner,
            arm: at - com,
            partner_arm: at - partner_com,
            normal,
            depth,
            friction,
            normal_impulse: 0.0,
            friction_impulse: DVec3::ZERO,
            push_impulse: 0.0,
        };
    // Wall by wall, then feature by feature (the kernel's lanes take the features).
    for a in 0..3 {
        for (side, sign) in [(walls.lo[a], 1.0), (walls.hi[a], -1.0)] {
            for f in &own[..body.num_corners as usize] {
                let p = center + r * vec(&f.point);
                // A feature's depth past the wall, its ball's radius included.
                let depth = sign * (side - p[a]) + f.radius;
                if depth >= -BODY_CONTACT_MARGIN {
                    let normal = DVec3::AXES[a] * sign;
                    let fixed = Partner::Fixed(DVec3::ZERO);
                    // Past the wall, [`wall_overlap`] undoes the depth: the contact keeps the gap.
                    let gap_only = depth.min(0.0);
                    add(contact(
                        p - normal * f.radius,
                        normal,
                        gap_only,
                        fixed,
                        com,
                        body.contact_friction,
                    ));
                }
            }
        }
    }
    let Some(own_state) = frame.states.get(body.slot as usize) else {
        return contacts;
    };
    for (slot, s) in frame.states.iter().enumerate() {
        if slot == body.slot as usize || s.boundary == BOUNDARY_PIPE || out_of_reach(s, own_state) {
            continue;
        }
        for f in own {
            let p = center + r * inset(vec(&f.point));
            let (phi, n) = frame.distance(s, p.as_vec3());
            let depth = f.radius - f64::from(phi);
            if depth < -BODY_CONTACT_MARGIN {
                continue;
            }
            let normal = n.as_dvec3();
            let at = p - normal * f.radius;
            add(if s.body == 0 {
                let moving = super::ColliderFrame::velocity_at(s, at.as_vec3()).as_dvec3();
                contact(
                    at,
                    normal,
                    depth,
                    Partner::Fixed(moving),
                    com,
                    body.contact_friction,
                )
            } else {
                let other = s.body as usize - 1;
                let friction = (body.contact_friction * bodies[other].contact_friction).sqrt();
                contact(
                    at,
                    normal,
                    depth,
                    Partner::Body(other),
                    motions[other].com,
                    friction,
                )
            });
        }
    }
    contacts
}

/// A feature's point a hair ([`BODY_FEATURE_INSET`]) towards the body's centre, where it meets other
/// colliders: boxes of one depth side by side (a quasi-2D tank's) have their corners exactly in each
/// other's face planes, where the distance is zero whether they overlap or not; inset, a corner that
/// overlaps is inside.
fn inset(point: DVec3) -> DVec3 {
    let length = point.length();
    if length > BODY_FEATURE_INSET {
        point * (1.0 - BODY_FEATURE_INSET / length)
    } else {
        point
    }
}

/// Whether two colliders' bounding balls are apart: no contact between them is possible.
fn out_of_reach(a: &ColliderState, b: &ColliderState) -> bool {
    let gap = glam::Vec3::from(a.center).distance(glam::Vec3::from(b.center));
    gap > a.reach + b.reach
}

/// Sequential impulses over every contact: each removes the velocity of its body into its partner
/// (an inelastic contact), opposes the sliding by Coulomb friction up to mu times the normal impulse,
/// and pushes the two apart by [`BODY_PUSH_RATE`] of their overlap a substep: a pseudo-velocity that moves
/// the bodies this substep only, so undoing an overlap adds no energy.
fn resolve_contacts(motions: &mut [Motion], contacts: &mut [Contact], dt: f64) {
    for _ in 0..BODY_CONTACT_SWEEPS {
        for c in contacts.iter_mut() {
            let relative = relative_velocity(motions, c, |m| (m.velocity, m.angular_velocity));
            let into = relative.dot(c.normal);
            let stiffness = response(motions, c, c.normal);
            // Apart by a gap, the body may close it this substep, no more.
            let closing = (-c.depth).max(0.0) / dt;
            let total = (c.normal_impulse - (into + closing) / stiffness).max(0.0);
            let mut change = c.normal * (total - c.normal_impulse);
            c.normal_impulse = total;
            let slide = relative - c.normal * into;
            let speed = slide.length();
            if speed > 0.0 {
                let along = slide / speed;
                let wanted = c.friction_impulse - along * (speed / response(motions, c, along));
                let limit = c.friction * c.normal_impulse;
                let friction = if wanted.length() > limit {
                    wanted * (limit / wanted.length())
                } else {
                    wanted
                };
                change += friction - c.friction_impulse;
                c.friction_impulse = friction;
            }
            apply_impulse(motions, c, change, |m| (&mut m.velocity, &mut m.angular_velocity));

            let apart = relative_velocity(motions, c, |m| (m.push_velocity, m.push_angular_velocity));
            let wanted = BODY_PUSH_RATE * c.depth.max(0.0) / dt;
            let total = (c.push_impulse + (wanted - apart.dot(c.normal)) / stiffness).max(0.0);
            let push = c.normal * (total - c.push_impulse);
            c.push_impulse = total;
            apply_impulse(motions, c, push, |m| {
                (&mut m.push_velocity, &mut m.push_angular_velocity)
            });
        }
    }
}

/// The velocity (as `pick` chooses: the real one or the push) of the contact's body at the contact,
/// less its partner's there.
fn relative_velocity(motions: &[Motion], c: &Contact, pick: impl Fn(&Motion) -> (DVec3, DVec3)) -> DVec3 {
    let (v, w) = pick(&motions[c.body]);
    let at = v + w.cross(c.arm);
    match c.partner {
        Partner::Fixed(moving) => at - moving,
        Partner::Body(b) => {
            let (v, w) = pick(&motions[b]);
            at - (v + w.cross(c.partner_arm))
        }
    }
}

/// The change of the relative velocity at the contact along `d` per unit impulse along `d`.
fn response(motions: &[Motion], c: &Contact, d: DVec3) -> f64 {
    let one = |m: &Motion, arm: DVec3| m.inv_mass + d.dot((m.inv_inertia * arm.cross(d)).cross(arm));
    match c.partner {
        Partner::Fixed(_) => one(&motions[c.body], c.arm),
        Partner::Body(b) => one(&motions[c.body], c.arm) + one(&motions[b], c.partner_arm),
    }
}

/// Gives the contact's body `impulse` at the contact, and its partner body the opposite, in the
/// velocities `pick` chooses.
fn apply_impulse(
    motions: &mut [Motion],
    c: &Contact,
    impulse: DVec3,
    pick: impl Fn(&mut Motion) -> (&mut DVec3, &mut DVec3),
) {
    let give = |m: &mut Motion, arm: DVec3, impulse: DVec3| {
        let (inv_mass, inv_inertia) = (m.inv_mass, m.inv_inertia);
        let (v, w) = pick(m);
        *v += impulse * inv_mass;
        *w += inv_inertia * arm.cross(impulse);
    };
    give(&mut motions[c.body], c.arm, impulse);
    if let Partner::Body(b) = c.partner {
        give(&mut motions[b], c.partner_arm, -impulse);
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
}

impl HostBodies {
    pub fn new(bodies: &BodiesState, features: &[ContactFeature], walls: BodyWalls) -> HostBodies {
        HostBodies {
            states: bodies.states.clone(),
            features: features.to_vec(),
            walls: Some(walls),
            impulses: bodies.impulses.clone(),
        }
    }

    /// The bodies' substep after the grid update ([`step_bodies`]), with the impulses summed in it;
    /// `frame` then holds the bodies where they ended.
    pub fn step(&mut self, dt: f32, gravity: [f32; 3], frame: &mut super::ColliderFrame) {
        let Some(walls) = self.walls else { return };
        let gravity = glam::Vec3::from(gravity).as_dvec3();
        step_bodies(
            &mut self.states,
            &self.features,
            &self.impulses,
            f64::from(dt),
            gravity,
            &walls,
            frame,
        );
        self.impulses.fill([0; 6]);
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
            dynamics.initial_state(center, rotation, 0, 0, &features),
            features.points,
        )
    }

    /// One substep of a body alone in the tank.
    fn step_one(body: &mut RigidBody, features: &[ContactFeature], impulse: &[i64; 6], dt: f64, g: DVec3) {
        let frame = super::super::ColliderFrame::default();
        step_bodies(
            std::slice::from_mut(body),
            features,
            &[*impulse],
            dt,
            g,
            &WALLS,
            &frame,
        );
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
            step_one(&mut body, &features, &[0; 6], dt, g);
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
        step_one(&mut body, &features, &impulse, 1e-4, DVec3::ZERO);
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
            step_one(&mut body, &features, &[0; 6], 1e-3, g);
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
            step_one(&mut body, &features, &[0; 6], 1e-3, g);
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

    /// Cubes of 10 cm and 500 kg/m^3 as bodies (centre, rotation, velocity), and static boxes
    /// (centre, half extents), in one frame.
    fn cubes(bodies: &[(DVec3, DQuat, DVec3)], fixed: &[(DVec3, DVec3)]) -> (HostBodies, ColliderFrame) {
        use super::super::{BOUNDARY_SLIP, COLLIDER_BOX};
        let half = DVec3::splat(0.05);
        let shape = Shape::Box { half_extents: half };
        let (p, features) = (shape.mass_properties(), shape.contact_features());
        let a_box = |center: DVec3, half: DVec3, body: u32| ColliderState {
            kind: COLLIDER_BOX,
            boundary: BOUNDARY_SLIP,
            rotation: glam::Mat3::IDENTITY.to_cols_array(),
            center: center.as_vec3().to_array(),
            size: half.as_vec3().to_array(),
            reach: half.length() as f32 * 1.01,
            body,
            ..ColliderState::default()
        };
        let mut states = Vec::new();
        let mut frame = ColliderFrame::default();
        for (k, &(center, rotation, velocity)) in bodies.iter().enumerate() {
            let dynamics = Dynamics {
                mass: 500.0 * p.volume,
                centroid: p.centroid,
                inertia: p.inertia * 500.0,
                velocity,
                angular_velocity: DVec3::ZERO,
                hinge: None,
                contact_friction: 0.5,
            };
            let first = (k * features.points.len()) as u32;
            states.push(dynamics.initial_state(center, rotation, k as u32, first, &features));
            frame.states.push(a_box(center, half, k as u32 + 1));
        }
        for &(center, half) in fixed {
            frame.states.push(a_box(center, half, 0));
        }
        frame.place_bodies(&states);
        let all_features = features.points.repeat(bodies.len());
        (
            HostBodies::new(&BodiesState::at_start(states), &all_features, WALLS),
            frame,
        )
    }

    /// The deepest any cube's corner lies inside another cube, m.
    fn deepest_overlap(bodies: &HostBodies, frame: &ColliderFrame) -> f64 {
        let mut deepest: f64 = 0.0;
        for body in &bodies.states {
            let r = rotation_of(body);
            for f in &bodies.features[..body.num_features as usize] {
                let p = vec(&body.center) + r * vec(&f.point);
                for (slot, s) in frame.states.iter().enumerate() {
                    if slot != body.slot as usize {
                        deepest = deepest.max(-f64::from(frame.distance(s, p.as_vec3()).0));
                    }
                }
            }
        }
        deepest
    }

    use super::super::ColliderFrame;

    /// Three cubes dropped in a slightly crooked stack settle into a stack: each on the one below,
    /// at rest, no corner inside another cube.
    #[test]
    fn a_stack_of_boxes_comes_to_rest() {
        let tilt = DQuat::from_rotation_y(0.1);
        let (mut bodies, mut frame) = cubes(
            &[
                (DVec3::new(0.5, 0.07, 0.5), DQuat::IDENTITY, DVec3::ZERO),
                (DVec3::new(0.51, 0.19, 0.5), tilt, DVec3::ZERO),
                (DVec3::new(0.49, 0.31, 0.51), DQuat::IDENTITY, DVec3::ZERO),
            ],
            &[],
        );
        let mut overlap: f64 = 0.0;
        let mut settled = Vec::new();
        for step in 0..3000 {
            bodies.step(1e-3, [0.0, -9.81, 0.0], &mut frame);
            overlap = overlap.max(deepest_overlap(&bodies, &frame));
            if step == 2499 {
                settled = bodies.states.clone();
            }
        }
        for (k, (body, before)) in bodies.states.iter().zip(&settled).enumerate() {
            let height = 0.05 + 0.1 * k as f64;
            assert!(
                (body.center[1] - height).abs() < 2e-3,
                "cube {k} at {} m, not {height}",
                body.center[1]
            );
            // At rest: a resting body's step is a gravity step undone by its contacts, so the
            // velocity it carries out of a step is up to g dt; where it is is what shows rest.
            let moved = vec(&body.center).distance(vec(&before.center));
            assert!(moved < 2e-4, "cube {k} moved {moved} m in its last half second");
        }
        assert!(overlap < 3e-3, "a corner went {overlap} m into a cube");
        assert!(deepest_overlap(&bodies, &frame) < 1e-3);
    }

    /// A cube dropped on a static box (a ledge) rests on its top.
    #[test]
    fn a_box_rests_on_a_static_collider() {
        let ledge = (DVec3::new(0.5, 0.2, 0.5), DVec3::new(0.2, 0.02, 0.2));
        let falling = (
            DVec3::new(0.55, 0.4, 0.5),
            DQuat::from_rotation_z(0.3),
            DVec3::ZERO,
        );
        let (mut bodies, mut frame) = cubes(&[falling], &[ledge]);
        for _ in 0..2000 {
            bodies.step(1e-3, [0.0, -9.81, 0.0], &mut frame);
        }
        let body = &bodies.states[0];
        assert!((body.center[1] - 0.27).abs() < 2e-3, "at {} m", body.center[1]);
        assert!(vec(&body.velocity).length() < 1e-2, "{:?}", body.velocity);
    }

    /// Two cubes meeting head on, off centre, without gravity: the contact's impulses are equal and
    /// opposite, so the momentum stays; an inelastic contact only loses energy; and neither passes
    /// through the other.
    #[test]
    fn colliding_bodies_keep_their_momentum() {
        let (mut bodies, mut frame) = cubes(
            &[
                (
                    DVec3::new(0.3, 0.5, 0.5),
                    DQuat::IDENTITY,
                    DVec3::new(1.0, 0.0, 0.0),
                ),
                (
                    DVec3::new(0.7, 0.53, 0.5),
                    DQuat::from_rotation_z(0.2),
                    DVec3::new(-1.0, 0.0, 0.0),
                ),
            ],
            &[],
        );
        let momentum = |b: &HostBodies| {
            b.states
                .iter()
                .map(|s| vec(&s.velocity) / s.inv_mass)
                .sum::<DVec3>()
        };
        let energy = |b: &HostBodies| {
            b.states
                .iter()
                .map(|s| {
                    let r = rotation_of(s);
                    let w = vec(&s.angular_velocity);
                    0.5 * vec(&s.velocity).length_squared() / s.inv_mass
                        + 0.5 * w.dot(r * mat(&s.inertia) * r.transpose() * w)
                })
                .sum::<f64>()
        };
        let (p0, e0) = (momentum(&bodies), energy(&bodies));
        let mut touched = false;
        for _ in 0..2500 {
            bodies.step(1e-4, [0.0; 3], &mut frame);
            touched |= bodies.states[0].velocity[0] < 0.9;
            assert!(deepest_overlap(&bodies, &frame) < 2e-3);
        }
        assert!(touched, "they never met");
        let p1 = momentum(&bodies);
        assert!((p1 - p0).length() < 1e-9, "momentum {p0} became {p1}");
        assert!(
            energy(&bodies) < e0,
            "the energy grew from {e0} to {}",
            energy(&bodies)
        );
        assert!(bodies.states[0].center[0] < bodies.states[1].center[0]);
    }
}
