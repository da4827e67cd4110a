//! Collider geometry on the CPU, the twin of kernels/colliders.cuh function for function: each
//! shape's signed distance and normal, the grid update's boundary condition and the particle
//! backstop, evaluated from a frame's `ColliderState`s so both sides compute the same numbers.

use super::*;

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

    /// Whether x lies inside a collider (where a scene spawns no fluid; a nozzle's pipe is no
    /// obstacle).
    pub fn contains(&self, x: Vec3) -> bool {
        self.states
            .iter()
            .any(|s| s.boundary != BOUNDARY_PIPE && self.distance(s, x).0 < 0.0)
    }

    /// Signed distance and outward unit normal (world frame) of collider `s` at world point x.
    pub fn distance(&self, s: &ColliderState, x: Vec3) -> (f32, Vec3) {
        let p = to_local(&s.rotation, x - Vec3::from(s.center));
        let (phi, n) = local_distance(s, &self.sdf, p);
        (phi, to_world(&s.rotation, n))
    }

    /// The collider's own velocity at world point x.
    pub(super) fn velocity_at(s: &ColliderState, x: Vec3) -> Vec3 {
        Vec3::from(s.velocity) + Vec3::from(s.angular_velocity).cross(x - Vec3::from(s.center))
    }

    /// The grid update's boundary condition at a node at x with velocity v: for each collider in
    /// turn (scene order) whose surface is within the band, the velocity relative to the collider
    /// loses its part into the collider (slip), all of it (stick), or that and a Coulomb share of its
    /// tangential part (friction). A relative velocity leaving the collider is left alone, so fluid
    /// can separate from it. A nozzle's pipe (band 0) gives the nodes inside it its velocity.
    pub fn project_node(&self, x: Vec3, v: Vec3) -> Vec3 {
        self.project_node_exchanging(x, v, 0.0, Vec3::ZERO, &mut [])
    }

    /// [`Self::project_node`] for a node where the particles put mass `m`, adding to `impulses[k]`
    /// (fixed-point units of [`super::bodies::BODY_IMPULSE_UNITS`]: linear, then the moment about
    /// the collider's centre) what rigid body k's boundary took from the node: `-m dv` at x. `m` leaves
    /// out the walls' mirror images: the particles never get the image's momentum back, so counting it
    /// would hand the body more than the liquid lost. The kernels' twin is collider_project_node.
    ///
    /// `image_push`: the velocity the walls' mirror images gave the node ([`crate::sim::cpu::image_push`];
    /// zero away from the walls or where nothing keeps the node's own sums). Where a Coulomb
    /// collider's surface meets a wall's mirror, the image has already taken the node's motion into
    /// the wall before the collider projects: its push off the surface counts as normal velocity
    /// the boundary removed, so the friction grips as it does where the mirror is off.
    pub fn project_node_exchanging(
        &self,
        x: Vec3,
        mut v: Vec3,
        m: f32,
        image_push: Vec3,
        impulses: &mut [[i64; 6]],
    ) -> Vec3 {
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
            if s.boundary == BOUNDARY_STICK || s.boundary == BOUNDARY_PIPE {
                rel = Vec3::ZERO;
            } else {
                let vn = rel.dot(n);
                // The velocity into the surface before the walls' images pushed the node off it.
                let into = vn - image_push.dot(n).max(0.0);
                let friction = s.boundary == BOUNDARY_FRICTION;
                if vn < 0.0 || (friction && into < 0.0) {
                    let tangential = rel - n * vn;
                    let kept = if friction {
                        let vt = norm(tangential);
                        if vt <= -s.friction * into {
                            Vec3::ZERO
                        } else {
                            tangential * (1.0 + s.friction * into / vt)
                        }
                    } else {
                        tangential
                    };
                    // Motion off the surface is left alone, so fluid can separate from it.
                    rel = if vn < 0.0 { kept } else { kept + n * vn };
                }
            }
            let before = v;
            v = vc + rel;
            give_to_body(s, impulses, x, (before - v) * m);
        }
        v
    }

    /// The position-based grid's boundary condition (`solver.method = "pbmpm"`) at a node at x whose
    /// displacement over the substep of `dt` s is d: for each collider in turn (scene order), the node
    /// may not *end* the substep nearer its surface than it started, nor nearer than the collider's
    /// band where it started farther, measured where it ends, so a node cannot step through a surface
    /// whatever its displacement (the test of the tank's walls, `pbmpm::wall_displacement`, for any
    /// shape; the band keeps the fluid a cell clear, as the explicit boundary does). A node that
    /// would is moved back out along the normal there; a Coulomb collider then shortens the tangential displacement relative to it by
    /// its coefficient times that push, to zero at most; a sticking one makes every node within its
    /// band move with it. The frame holds each collider where the substep ends, so the node's start
    /// is read at x plus the collider's own displacement at x. The kernels' twin is
    /// collider_hold_displacement.
    pub fn hold_displacement(&self, x: Vec3, mut d: Vec3, dt: f32) -> Vec3 {
        for s in &self.states {
            let moved = Self::velocity_at(s, x) * dt;
            let start = x + moved;
            if s.boundary == BOUNDARY_STICK || s.boundary == BOUNDARY_PIPE {
                if !beyond(s, start, s.band) && self.distance(s, start).0 < s.band {
                    d = moved;
                }
                continue;
            }
            let end = x + d;
            if beyond(s, end, s.band) {
                continue;
            }
            let (phi, n) = self.distance(s, end);
            let floor = if beyond(s, start, s.band) {
                s.band
            } else {
                self.distance(s, start).0.min(s.band)
            };
            if phi.is_nan() || phi >= floor {
                continue; // as the kernel's !(phi < floor): a NaN distance holds nothing
            }
            let taken = floor - phi;
            d += n * taken;
            if s.boundary == BOUNDARY_FRICTION {
                let rel = d - moved;
                let normal = n * rel.dot(n);
                let tangential = rel - normal;
                let length = norm(tangential);
                let kept = if length > 0.0 {
                    (length - s.friction * taken).max(0.0) / length
                } else {
                    0.0
                };
                d = moved + normal + tangential * kept;
            }
        }
        d
    }

    /// Whether a collider has Coulomb friction: then the CPU backends keep the nodes' own sums
    /// beside the walls' images, for `project_node_exchanging`'s image push.
    pub fn has_friction(&self) -> bool {
        self.states.iter().any(|s| s.boundary == BOUNDARY_FRICTION)
    }

    /// The particle backstop, after advection: a particle at x that ended inside a collider is put
    /// back on its surface along the normal, and its velocity into the collider (relative to it) is
    /// removed. Returns the new position and velocity where it did; `None` where no collider holds x.
    /// A nozzle's pipe holds its liquid rather than keeping it out.
    pub fn backstop(&self, x: Vec3, v: Vec3) -> Option<(Vec3, Vec3)> {
        self.backstop_exchanging(x, v, 0.0, &mut [])
    }

    /// [`Self::backstop`] of a particle of mass `m`: what a rigid body's push gave it, `m dv`, is taken
    /// from the body (added to `impulses` as the grid update adds, for its next step), so a push
    /// out of a body conserves momentum too. The kernels' twin is collider_backstop.
    pub fn backstop_exchanging(
        &self,
        mut x: Vec3,
        mut v: Vec3,
        m: f32,
        impulses: &mut [[i64; 6]],
    ) -> Option<(Vec3, Vec3)> {
        let mut pushed = false;
        for s in &self.states {
            if s.boundary == BOUNDARY_PIPE || beyond(s, x, 0.0) {
                continue;
            }
            let (phi, n) = self.distance(s, x);
            if phi < 0.0 {
                x -= n * phi;
                let vn = (v - Self::velocity_at(s, x)).dot(n);
                if vn < 0.0 {
                    v -= n * vn;
                    give_to_body(s, impulses, x, n * (vn * m));
                }
                pushed = true;
            }
        }
        pushed.then_some((x, v))
    }
}

/// Adds `given` (N s, what collider `s`'s boundary took from the liquid at x) and its moment about the
/// collider's centre to the sums of the rigid body `s` is, in `impulses`; nothing for a collider that
/// is no body, or without sums.
fn give_to_body(s: &ColliderState, impulses: &mut [[i64; 6]], x: Vec3, given: Vec3) {
    let Some(sums) = (s.body as usize).checked_sub(1).and_then(|k| impulses.get_mut(k)) else {
        return;
    };
    let moment = (x - Vec3::from(s.center)).cross(given);
    for (sum, value) in sums
        .iter_mut()
        .zip(given.to_array().into_iter().chain(moment.to_array()))
    {
        *sum += super::bodies::impulse_units(value);
    }
}
