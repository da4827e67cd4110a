// Colliders on the device (src/sim/colliders.rs, docs/physics.md "Colliders"): `ColliderState`
// (contract.cuh), the signed distance of each shape, the grid update's boundary condition and the
// particle backstop. The host evaluates every collider's motion once per substep into a small array of
// states (pose, rigid velocity, shape), uploaded only when it changed; mesh colliders add their
// distance samples in one buffer. Each function follows its Rust twin operation for operation, so the
// CPU reference and the kernels agree to rounding.


// What the grid update and the backstop read: the states, their count, the mesh samples.
// `impulses`: the rigid bodies' fixed-point impulse sums (6 per body), or null where nothing adds.
struct Colliders {
    const ColliderState* states;
    u32 count;
    const float* sdf;
    u64* impulses;
};

struct Vec3f {
    float x, y, z;
};

__device__ __forceinline__ Vec3f v3(float x, float y, float z) { return Vec3f{x, y, z}; }
__device__ __forceinline__ float collider_norm(Vec3f v) { return sqrtf(v.x * v.x + v.y * v.y + v.z * v.z); }
__device__ __forceinline__ float collider_sign(float x) { return x < 0.0f ? -1.0f : 1.0f; }

// Trilinear distance samples of a mesh and their gradient; far (+inf) outside the sampled box.
__device__ __forceinline__ float mesh_distance(const ColliderState& s, const float* __restrict__ sdf, Vec3f p,
                                               Vec3f& normal) {
    const float inv = 1.0f / s.sdf_spacing;
    const float g[3] = {(p.x - s.sdf_origin[0]) * inv, (p.y - s.sdf_origin[1]) * inv, (p.z - s.sdf_origin[2]) * inv};
    const float b[3] = {floorf(g[0]), floorf(g[1]), floorf(g[2])};
    normal = v3(0.0f, 1.0f, 0.0f);
    if (b[0] < 0.0f || b[1] < 0.0f || b[2] < 0.0f) return __int_as_float(0x7f800000);
    const u32 i = (u32)b[0], j = (u32)b[1], k = (u32)b[2];
    const u32 nx = s.sdf_dims[0], ny = s.sdf_dims[1], nz = s.sdf_dims[2];
    if (i + 1 >= nx || j + 1 >= ny || k + 1 >= nz) return __int_as_float(0x7f800000);
    const float f[3] = {g[0] - b[0], g[1] - b[1], g[2] - b[2]};
    const float* at = sdf + s.sdf_offset;
#define SDF_AT(a, bb, c) __ldg(&at[(a) + nx * ((bb) + ny * (c))])
    const float c000 = SDF_AT(i, j, k), c100 = SDF_AT(i + 1, j, k);
    const float c010 = SDF_AT(i, j + 1, k), c110 = SDF_AT(i + 1, j + 1, k);
    const float c001 = SDF_AT(i, j, k + 1), c101 = SDF_AT(i + 1, j, k + 1);
    const float c011 = SDF_AT(i, j + 1, k + 1), c111 = SDF_AT(i + 1, j + 1, k + 1);
#undef SDF_AT
    const float x00 = c000 + (c100 - c000) * f[0];
    const float x10 = c010 + (c110 - c010) * f[0];
    const float x01 = c001 + (c101 - c001) * f[0];
    const float x11 = c011 + (c111 - c011) * f[0];
    const float y0 = x00 + (x10 - x00) * f[1];
    const float y1 = x01 + (x11 - x01) * f[1];
    const float phi = y0 + (y1 - y0) * f[2];
    const float ga = (c100 - c000) + ((c110 - c010) - (c100 - c000)) * f[1];
    const float gb = (c101 - c001) + ((c111 - c011) - (c101 - c001)) * f[1];
    const Vec3f grad = v3(ga + (gb - ga) * f[2], (x10 - x00) + ((x11 - x01) - (x10 - x00)) * f[2], y1 - y0);
    const float len = collider_norm(grad);
    if (len > 0.0f) normal = v3(grad.x / len, grad.y / len, grad.z / len);
    return phi;
}

// Whether x lies farther than `margin` outside the collider's bounding ball (ColliderFrame's `beyond`):
// the cheap test that spares most nodes and particles the shape.
__device__ __forceinline__ bool collider_beyond(const ColliderState& s, Vec3f x, float margin) {
    const Vec3f r = v3(x.x - s.center[0], x.y - s.center[1], x.z - s.center[2]);
    const float limit = s.reach + margin;
    return r.x * r.x + r.y * r.y + r.z * r.z > limit * limit;
}

// Signed distance (negative inside) and outward unit normal of a shape at local point p.
__device__ __forceinline__ float collider_local_distance(const ColliderState& s, const float* __restrict__ sdf,
                                                         Vec3f p, Vec3f& normal) {
    if (s.kind == COLLIDER_BOX) {
        const Vec3f q = v3(fabsf(p.x) - s.size[0], fabsf(p.y) - s.size[1], fabsf(p.z) - s.size[2]);
        const Vec3f outside = v3(fmaxf(q.x, 0.0f), fmaxf(q.y, 0.0f), fmaxf(q.z, 0.0f));
        const float out_len = collider_norm(outside);
        const float inside = fminf(fmaxf(q.x, fmaxf(q.y, q.z)), 0.0f);
        if (out_len > 0.0f) {
            normal = v3(outside.x * collider_sign(p.x) / out_len, outside.y * collider_sign(p.y) / out_len,
                        outside.z * collider_sign(p.z) / out_len);
        } else if (q.x >= q.y && q.x >= q.z) {
            normal = v3(collider_sign(p.x), 0.0f, 0.0f);
        } else if (q.y >= q.z) {
            normal = v3(0.0f, collider_sign(p.y), 0.0f);
        } else {
            normal = v3(0.0f, 0.0f, collider_sign(p.z));
        }
        return out_len + inside;
    }
    if (s.kind == COLLIDER_SPHERE) {
        const float len = collider_norm(p);
        normal = len > 0.0f ? v3(p.x / len, p.y / len, p.z / len) : v3(0.0f, 1.0f, 0.0f);
        return len - s.size[0];
    }
    if (s.kind == COLLIDER_CAPSULE) {
        const float a = fminf(fmaxf(p.y, -s.size[1]), s.size[1]);
        const Vec3f d = v3(p.x, p.y - a, p.z);
        const float len = collider_norm(d);
        normal = len > 0.0f ? v3(d.x / len, d.y / len, d.z / len) : v3(1.0f, 0.0f, 0.0f);
        return len - s.size[0];
    }
    if (s.kind == COLLIDER_CYLINDER) {
        const float radial = sqrtf(p.x * p.x + p.z * p.z);
        const float dr = radial - s.size[0];
        const float dy = fabsf(p.y) - s.size[1];
        const float ox = fmaxf(dr, 0.0f), oy = fmaxf(dy, 0.0f);
        const float out_len = sqrtf(ox * ox + oy * oy);
        const Vec3f u = radial > 0.0f ? v3(p.x / radial, 0.0f, p.z / radial) : v3(1.0f, 0.0f, 0.0f);
        const float axial = collider_sign(p.y);
        if (out_len > 0.0f) {
            normal = v3(u.x * ox / out_len, oy * axial / out_len, u.z * ox / out_len);
        } else if (dr > dy) {
            normal = u;
        } else {
            normal = v3(0.0f, axial, 0.0f);
        }
        return out_len + fminf(fmaxf(dr, dy), 0.0f);
    }
    return mesh_distance(s, sdf, p, normal);
}

// Signed distance and outward unit normal (world frame) at world point x.
__device__ __forceinline__ float collider_distance(const ColliderState& s, const float* __restrict__ sdf, Vec3f x,
                                                   Vec3f& normal) {
    const float* m = s.rotation;
    const Vec3f r = v3(x.x - s.center[0], x.y - s.center[1], x.z - s.center[2]);
    const Vec3f p = v3(m[0] * r.x + m[3] * r.y + m[6] * r.z, m[1] * r.x + m[4] * r.y + m[7] * r.z,
                       m[2] * r.x + m[5] * r.y + m[8] * r.z);
    Vec3f n;
    const float phi = collider_local_distance(s, sdf, p, n);
    normal = v3(m[0] * n.x + m[1] * n.y + m[2] * n.z, m[3] * n.x + m[4] * n.y + m[5] * n.z,
                m[6] * n.x + m[7] * n.y + m[8] * n.z);
    return phi;
}

// The collider's own velocity at world point x: v + w x (x - c).
__device__ __forceinline__ Vec3f collider_velocity_at(const ColliderState& s, Vec3f x) {
    const Vec3f r = v3(x.x - s.center[0], x.y - s.center[1], x.z - s.center[2]);
    const float* w = s.angular_velocity;
    return v3(s.velocity[0] + (w[1] * r.z - w[2] * r.y), s.velocity[1] + (w[2] * r.x - w[0] * r.z),
              s.velocity[2] + (w[0] * r.y - w[1] * r.x));
}

// The grid update's boundary condition (ColliderFrame::project_node): for each collider in turn whose
// surface is within the band, the velocity relative to it loses its part into the collider (slip), all
// of it (stick), or that and a Coulomb share of its tangential part (friction).
// What collider s's boundary took from the liquid at x, `given` (N s), and its moment about the
// collider's centre, added to the sums of the rigid body s is (give_to_body in
// src/sim/colliders/geometry.rs); nothing for a collider that is no body, or without sums.
__device__ __forceinline__ void collider_give_to_body(const ColliderState& s, u64* impulses, Vec3f x, Vec3f given) {
    if (s.body == 0u || !impulses) return;
    const Vec3f r = v3(x.x - s.center[0], x.y - s.center[1], x.z - s.center[2]);
    const float sums[6] = {given.x, given.y, given.z, r.y * given.z - given.y * r.z, r.z * given.x - given.z * r.x,
                           r.x * given.y - given.x * r.y};
    u64* to = impulses + 6 * (s.body - 1u);
#pragma unroll
    for (int c = 0; c < 6; ++c) {
        const float scaled = sums[c] * BODY_IMPULSE_UNITS;
        // Out of range (beyond 2^52 units, or NaN) adds nothing, as fixed_point_units.
        const i64 units = fabsf(scaled) < 4503599627370496.0f ? __float2ll_rn(scaled) : 0;
        if (units != 0) atomicAdd((unsigned long long*)&to[c], (unsigned long long)units);
    }
}

// A rigid body's collider (s.body != 0) also adds what it took from the node, -m dv, and its moment
// about the collider's centre to the body's sums (ColliderFrame::project_node_exchanging). m is the
// particles' own mass at the node: the walls' mirror images carry no momentum the particles get back,
// and counting them would hand the body the image's share too. `image_push`: the velocity the walls'
// images gave the node (NodeSums::push); a Coulomb collider counts its push off the surface as normal
// velocity removed, so that its friction grips under the walls' mirror as where the mirror is off.
__device__ __forceinline__ void collider_project_node(const Colliders& colliders, Vec3f x, float m,
                                                      const float (&image_push)[3], float (&vel)[3]) {
    for (u32 k = 0; k < colliders.count; ++k) {
        const ColliderState& s = colliders.states[k];
        if (collider_beyond(s, x, s.band)) continue;
        Vec3f n;
        const float phi = collider_distance(s, colliders.sdf, x, n);
        if (!(phi < s.band)) continue;
        const Vec3f vc = collider_velocity_at(s, x);
        Vec3f rel = v3(vel[0] - vc.x, vel[1] - vc.y, vel[2] - vc.z);
        if (s.boundary == BOUNDARY_STICK || s.boundary == BOUNDARY_PIPE) {
            rel = v3(0.0f, 0.0f, 0.0f);
        } else {
            const float vn = rel.x * n.x + rel.y * n.y + rel.z * n.z;
            // The velocity into the surface before the walls' images pushed the node off it.
            const float into = vn - fmaxf(image_push[0] * n.x + image_push[1] * n.y + image_push[2] * n.z, 0.0f);
            const bool friction = s.boundary == BOUNDARY_FRICTION;
            if (vn < 0.0f || (friction && into < 0.0f)) {
                const Vec3f t = v3(rel.x - n.x * vn, rel.y - n.y * vn, rel.z - n.z * vn);
                Vec3f kept = t;
                if (friction) {
                    const float vt = collider_norm(t);
                    if (vt <= -s.friction * into) {
                        kept = v3(0.0f, 0.0f, 0.0f);
                    } else {
                        const float keep = 1.0f + s.friction * into / vt;
                        kept = v3(t.x * keep, t.y * keep, t.z * keep);
                    }
                }
                // Motion off the surface is left alone, so fluid can separate from it.
                rel = vn < 0.0f ? kept : v3(kept.x + n.x * vn, kept.y + n.y * vn, kept.z + n.z * vn);
            }
        }
        const Vec3f before = v3(vel[0], vel[1], vel[2]);
        vel[0] = vc.x + rel.x;
        vel[1] = vc.y + rel.y;
        vel[2] = vc.z + rel.z;
        collider_give_to_body(s, colliders.impulses, x,
                              v3((before.x - vel[0]) * m, (before.y - vel[1]) * m, (before.z - vel[2]) * m));
    }
}

// The position-based grid's boundary condition (ColliderFrame::hold_displacement): for each collider in
// turn, a node at x whose displacement over the substep of dt is d may not end nearer the surface than
// it started (than the band, where it started farther), measured where it ends, the frame holding the
// collider at the substep's end (so the node's start is read at x plus the collider's displacement
// there). A node that would is moved back out along the normal; a Coulomb collider then shortens the
// tangential displacement relative to it by its coefficient times that push; a sticking one makes the
// nodes within its band move with it.
__device__ __forceinline__ void collider_hold_displacement(const Colliders& colliders, Vec3f x, float dt,
                                                           float (&d)[3]) {
    for (u32 k = 0; k < colliders.count; ++k) {
        const ColliderState& s = colliders.states[k];
        const Vec3f vc = collider_velocity_at(s, x);
        const Vec3f moved = v3(vc.x * dt, vc.y * dt, vc.z * dt);
        const Vec3f start = v3(x.x + moved.x, x.y + moved.y, x.z + moved.z);
        Vec3f n;
        if (s.boundary == BOUNDARY_STICK || s.boundary == BOUNDARY_PIPE) {
            if (!collider_beyond(s, start, s.band) && collider_distance(s, colliders.sdf, start, n) < s.band) {
                d[0] = moved.x;
                d[1] = moved.y;
                d[2] = moved.z;
            }
            continue;
        }
        const Vec3f end = v3(x.x + d[0], x.y + d[1], x.z + d[2]);
        if (collider_beyond(s, end, s.band)) continue;
        const float phi = collider_distance(s, colliders.sdf, end, n);
        Vec3f start_normal;
        const float floor = collider_beyond(s, start, s.band)
                                ? s.band
                                : fminf(collider_distance(s, colliders.sdf, start, start_normal), s.band);
        if (!(phi < floor)) continue;  // a NaN distance holds nothing
        const float taken = floor - phi;
        d[0] += n.x * taken;
        d[1] += n.y * taken;
        d[2] += n.z * taken;
        if (s.boundary == BOUNDARY_FRICTION) {
            const Vec3f rel = v3(d[0] - moved.x, d[1] - moved.y, d[2] - moved.z);
            const float rn = rel.x * n.x + rel.y * n.y + rel.z * n.z;
            const Vec3f normal = v3(n.x * rn, n.y * rn, n.z * rn);
            const Vec3f t = v3(rel.x - normal.x, rel.y - normal.y, rel.z - normal.z);
            const float length = collider_norm(t);
            const float kept = length > 0.0f ? fmaxf(length - s.friction * taken, 0.0f) / length : 0.0f;
            d[0] = moved.x + normal.x + t.x * kept;
            d[1] = moved.y + normal.y + t.y * kept;
            d[2] = moved.z + normal.z + t.z * kept;
        }
    }
}

// The particle backstop after advection (ColliderFrame::backstop): a particle that ended inside a
// collider goes back to its surface along the normal and loses its velocity into it. True where it did.
// A nozzle's pipe holds its liquid rather than keeping it out.
// A push out of a rigid body is taken from the body (`m`: the particle's mass), as the grid update's
// exchange, for the body's next step (ColliderFrame::backstop_exchanging).
__device__ __forceinline__ bool collider_backstop(const Colliders& colliders, float m, float (&x)[3], float (&vel)[3]) {
    bool pushed = false;
    for (u32 k = 0; k < colliders.count; ++k) {
        const ColliderState& s = colliders.states[k];
        if (s.boundary == BOUNDARY_PIPE || collider_beyond(s, v3(x[0], x[1], x[2]), 0.0f)) continue;
        Vec3f n;
        const float phi = collider_distance(s, colliders.sdf, v3(x[0], x[1], x[2]), n);
        if (phi < 0.0f) {
            x[0] -= n.x * phi;
            x[1] -= n.y * phi;
            x[2] -= n.z * phi;
            const Vec3f vc = collider_velocity_at(s, v3(x[0], x[1], x[2]));
            const float vn = (vel[0] - vc.x) * n.x + (vel[1] - vc.y) * n.y + (vel[2] - vc.z) * n.z;
            if (vn < 0.0f) {
                vel[0] -= n.x * vn;
                vel[1] -= n.y * vn;
                vel[2] -= n.z * vn;
                collider_give_to_body(s, colliders.impulses, v3(x[0], x[1], x[2]), v3(n.x * vn * m, n.y * vn * m, n.z * vn * m));
            }
            pushed = true;
        }
    }
    return pushed;
}
