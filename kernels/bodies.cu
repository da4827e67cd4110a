// step_bodies (docs/physics.md "Rigid bodies"): each rigid body takes the impulse the grid update's
// boundary gave its band's nodes (fixed-point sums, read and zeroed here) and gravity, or their moment
// about its hinge; the free bodies find their contacts with the walls, the other colliders and each
// other, which sequential impulses resolve together; then each body moves, and its collider state
// for the next substep (and for this one's particle backstop) is written into its slot. The CPU twin
// is step_bodies in src/sim/colliders/bodies.rs, phase for phase and operation for operation in
// double precision. One block, a warp per body (its lanes share the search for its contacts); the
// contacts are resolved by a warp's first lane for each chain of each island of touching bodies, in
// body order (resolve_chain), so a run steps its bodies in the same order of operations every time.
#include "common.cuh"
#include "colliders.cuh"

struct D3 {
    double x, y, z;
};

__device__ __forceinline__ D3 d3(double x, double y, double z) { return D3{x, y, z}; }
__device__ __forceinline__ D3 d3(const double (&a)[3]) { return D3{a[0], a[1], a[2]}; }
__device__ __forceinline__ D3 d3(Vec3f a) { return D3{(double)a.x, (double)a.y, (double)a.z}; }
__device__ __forceinline__ Vec3f f3(D3 a) { return v3((float)a.x, (float)a.y, (float)a.z); }
__device__ __forceinline__ D3 operator+(D3 a, D3 b) { return d3(a.x + b.x, a.y + b.y, a.z + b.z); }
__device__ __forceinline__ D3 operator-(D3 a, D3 b) { return d3(a.x - b.x, a.y - b.y, a.z - b.z); }
__device__ __forceinline__ D3 operator*(D3 a, double s) { return d3(a.x * s, a.y * s, a.z * s); }
__device__ __forceinline__ double dot(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
__device__ __forceinline__ D3 cross(D3 a, D3 b) {
    return d3(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}
__device__ __forceinline__ double length(D3 a) { return sqrt(dot(a, a)); }
__device__ __forceinline__ double get(D3 a, int k) { return k == 0 ? a.x : (k == 1 ? a.y : a.z); }
__device__ __forceinline__ void set(D3& a, int k, double v) {
    if (k == 0) a.x = v;
    else if (k == 1) a.y = v;
    else a.z = v;
}
__device__ __forceinline__ void store(double (&out)[3], D3 a) {
    out[0] = a.x;
    out[1] = a.y;
    out[2] = a.z;
}

// Row-major 3x3.
struct M3 {
    double m[9];
};
__device__ __forceinline__ M3 m3(const double (&a)[9]) {
    M3 r;
    for (int k = 0; k < 9; ++k) r.m[k] = a[k];
    return r;
}
__device__ __forceinline__ void store(double (&out)[9], const M3& a) {
    for (int k = 0; k < 9; ++k) out[k] = a.m[k];
}
__device__ __forceinline__ D3 operator*(const M3& a, D3 v) {
    return d3(a.m[0] * v.x + a.m[1] * v.y + a.m[2] * v.z, a.m[3] * v.x + a.m[4] * v.y + a.m[5] * v.z,
              a.m[6] * v.x + a.m[7] * v.y + a.m[8] * v.z);
}
__device__ __forceinline__ M3 mul(const M3& a, const M3& b) {
    M3 r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            r.m[3 * i + j] = a.m[3 * i] * b.m[j] + a.m[3 * i + 1] * b.m[3 + j] + a.m[3 * i + 2] * b.m[6 + j];
    return r;
}
__device__ __forceinline__ M3 transpose(const M3& a) {
    M3 r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r.m[3 * i + j] = a.m[3 * j + i];
    return r;
}

// Quaternion (x, y, z, w).
struct Q {
    double x, y, z, w;
};
__device__ __forceinline__ Q qmul(Q a, Q b) {
    return Q{a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y, a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
             a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w, a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z};
}
__device__ __forceinline__ Q qnormalize(Q q) {
    const double inv = 1.0 / sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
    return Q{q.x * inv, q.y * inv, q.z * inv, q.w * inv};
}
// A turn by |v| about v's direction (glam's DQuat::from_scaled_axis).
__device__ __forceinline__ Q from_scaled_axis(D3 v) {
    const double angle = sqrt(dot(v, v));
    if (angle == 0.0) return Q{0.0, 0.0, 0.0, 1.0};
    const D3 axis = v * (1.0 / angle);
    double s, c;
    sincos(angle * 0.5, &s, &c);
    return Q{axis.x * s, axis.y * s, axis.z * s, c};
}
// World-from-body rotation matrix, row-major (glam's DMat3::from_quat).
__device__ __forceinline__ M3 rotation_of(Q q) {
    const double x2 = q.x + q.x, y2 = q.y + q.y, z2 = q.z + q.z;
    const double xx = q.x * x2, xy = q.x * y2, xz = q.x * z2, yy = q.y * y2, yz = q.y * z2, zz = q.z * z2;
    const double wx = q.w * x2, wy = q.w * y2, wz = q.w * z2;
    M3 r;
    r.m[0] = 1.0 - (yy + zz), r.m[1] = xy - wz, r.m[2] = xz + wy;
    r.m[3] = xy + wz, r.m[4] = 1.0 - (xx + zz), r.m[5] = yz - wx;
    r.m[6] = xz - wy, r.m[7] = yz + wx, r.m[8] = 1.0 - (xx + yy);
    return r;
}


__device__ __forceinline__ bool is_hinged(const RigidBody& b) {
    return b.hinge_axis[0] != 0.0 || b.hinge_axis[1] != 0.0 || b.hinge_axis[2] != 0.0;
}

// take_impulse in bodies.rs: the body's velocities after the grid's impulse (read and zeroed) and
// gravity.
__device__ BodyMotion take_impulse(const RigidBody& b, u64* impulses, double dt, D3 gravity) {
    double sums[6];
    for (int c = 0; c < 6; ++c) {
        sums[c] = (double)(i64)impulses[c] / (double)BODY_IMPULSE_UNITS;
        impulses[c] = 0ull;
    }
    const D3 linear = d3(sums[0], sums[1], sums[2]);
    const D3 about_origin = d3(sums[3], sums[4], sums[5]);
    const M3 r = rotation_of(Q{b.orientation[0], b.orientation[1], b.orientation[2], b.orientation[3]});
    const D3 center = d3(b.center);
    const D3 com = center + r * d3(b.centroid);
    const D3 angular = about_origin + cross(center - com, linear);
    const M3 inertia = mul(mul(r, m3(b.inertia)), transpose(r));
    const M3 inv_inertia = mul(mul(r, m3(b.inv_inertia)), transpose(r));
    D3 v = d3(b.velocity);
    D3 w = d3(b.angular_velocity);
    const bool hinged = is_hinged(b);
    if (hinged) {
        const D3 axis = d3(b.hinge_axis);
        const D3 arm = com - d3(b.hinge_point);
        const D3 weight = gravity * (dt / b.inv_mass);
        const double moment = dot(axis, angular + cross(arm, linear + weight));
        const double along = dot(axis, arm);
        const double moment_of_inertia = dot(axis, inertia * axis) + (dot(arm, arm) - along * along) / b.inv_mass;
        const double rate = dot(axis, w) + moment / moment_of_inertia;
        w = axis * rate;
        v = cross(w, arm);
    } else {
        v = v + linear * b.inv_mass + gravity * dt;
        w = inv_inertia * (inertia * w + angular);
    }
    BodyMotion m;
    store(m.com, com);
    store(m.velocity, v);
    store(m.angular_velocity, w);
    m.inv_mass = hinged ? 0.0 : b.inv_mass;
    M3 none;
    for (int k = 0; k < 9; ++k) none.m[k] = 0.0;
    store(m.inv_inertia, hinged ? none : inv_inertia);
    store(m.push_velocity, d3(0.0, 0.0, 0.0));
    store(m.push_angular_velocity, d3(0.0, 0.0, 0.0));
    return m;
}

// inset in bodies.rs.
__device__ __forceinline__ D3 inset(D3 point) {
    const double len = length(point);
    return len > BODY_FEATURE_INSET ? point * (1.0 - BODY_FEATURE_INSET / len) : point;
}

__device__ __forceinline__ BodyContact make_contact(u32 body, u32 partner, D3 at, D3 com, D3 partner_com, D3 normal,
                                                    double depth, D3 partner_velocity, double friction) {
    BodyContact c;
    store(c.arm, at - com);
    store(c.partner_arm, at - partner_com);
    store(c.normal, normal);
    store(c.partner_velocity, partner_velocity);
    store(c.friction_impulse, d3(0.0, 0.0, 0.0));
    c.depth = depth;
    c.friction = friction;
    c.normal_impulse = 0.0;
    c.push_impulse = 0.0;
    c.body = body;
    c.partner = partner;
    return c;
}

// Where this lane's contact goes (after the `n` found before, then the warp's lanes in order), or
// MAX_BODY_CONTACTS where it found none or the body's contacts are full; `n` moves past the warp's.
__device__ __forceinline__ u32 claim_contact(bool hit, u32 lane, u32& n) {
    const u32 found = __ballot_sync(0xffffffffu, hit);
    const u32 at = n + __popc(found & ((1u << lane) - 1u));
    n = min(n + __popc(found), MAX_BODY_CONTACTS);
    return hit && at < MAX_BODY_CONTACTS ? at : MAX_BODY_CONTACTS;
}

// find_contacts in bodies.rs, by body k's warp: each lane takes every 32nd feature. The contacts go
// out in the order the CPU finds them (wall by wall, then collider by collider, each feature by
// feature), each lane's where claim_contact puts it. Returns how many (the same in every lane).
__device__ u32 find_contacts(u32 k, u32 lane, const RigidBody* bodies, const BodyMotion* motions,
                             const ContactFeature* features, const BodyWalls& walls, const ColliderState* states,
                             u32 num_states, const float* sdf, BodyContact* out) {
    const RigidBody& b = bodies[k];
    const M3 r = rotation_of(Q{b.orientation[0], b.orientation[1], b.orientation[2], b.orientation[3]});
    const D3 center = d3(b.center);
    const D3 com = d3(motions[k].com);
    const ContactFeature* own = features + b.first_feature;
    u32 n = 0;
    // The six walls' corners in one sweep, lane by lane over (wall, corner) pairs in the CPU's order
    // (by axis, low side then high, then corner): two ballots where a wall at a time took six.
    const u32 pairs = 6u * b.num_corners;
    for (u32 first = 0; first < pairs; first += 32) {
        const u32 pair = first + lane;
        const u32 wall = pair / max(b.num_corners, 1u), f = pair % max(b.num_corners, 1u);
        const int a = (int)(wall / 2u);
        const double sign = wall % 2u == 0u ? 1.0 : -1.0;
        D3 p = d3(0.0, 0.0, 0.0);
        double depth = -1.0 / 0.0;
        if (pair < pairs) {
            const double side = wall % 2u == 0u ? walls.lo[a] : walls.hi[a];
            p = center + r * d3(own[f].point);
            depth = sign * (side - get(p, a)) + own[f].radius;
        }
        const u32 at = claim_contact(depth >= -BODY_CONTACT_MARGIN, lane, n);
        if (at < MAX_BODY_CONTACTS) {
            D3 normal = d3(0.0, 0.0, 0.0);
            set(normal, a, sign);
            out[at] = make_contact(k, NO_BODY, p - normal * own[f].radius, com, com, normal, fmin(depth, 0.0),
                                   d3(0.0, 0.0, 0.0), b.contact_friction);
        }
    }
    if (b.slot >= num_states) return n;
    const ColliderState& mine = states[b.slot];
    // The colliders whose reach meets this body's, lane j testing slot j: the warp reads every slot's
    // centre at once, where a loop over the slots waited on each read in turn.
    static_assert(MAX_COLLIDERS <= 32, "a lane a collider slot");
    bool near = false;
    if (lane < num_states && lane != b.slot && states[lane].boundary != BOUNDARY_PIPE) {
        const ColliderState& s = states[lane];
        const float dx = s.center[0] - mine.center[0], dy = s.center[1] - mine.center[1];
        const float dz = s.center[2] - mine.center[2];
        near = !(sqrtf(dx * dx + dy * dy + dz * dz) > s.reach + mine.reach);
    }
    for (u32 candidates = __ballot_sync(0xffffffffu, near); candidates != 0u; candidates &= candidates - 1u) {
        const u32 slot = __ffs(candidates) - 1u;
        const ColliderState& s = states[slot];
        for (u32 first = 0; first < b.num_features; first += 32) {
            const u32 f = first + lane;
            D3 p = d3(0.0, 0.0, 0.0), normal = d3(0.0, 1.0, 0.0);
            double depth = -1.0 / 0.0;
            if (f < b.num_features) {
                p = center + r * inset(d3(own[f].point));
                Vec3f n_world;
                const float phi = collider_distance(s, sdf, f3(p), n_world);
                depth = own[f].radius - (double)phi;
                normal = d3(n_world);
            }
            const u32 at_index = claim_contact(depth >= -BODY_CONTACT_MARGIN, lane, n);
            if (at_index < MAX_BODY_CONTACTS) {
                const D3 at = p - normal * own[f].radius;
                if (s.body == 0u) {
                    const D3 moving = d3(collider_velocity_at(s, f3(at)));
                    out[at_index] = make_contact(k, NO_BODY, at, com, com, normal, depth, moving, b.contact_friction);
                } else {
                    const u32 other = s.body - 1u;
                    const double friction = sqrt(b.contact_friction * bodies[other].contact_friction);
                    out[at_index] = make_contact(k, other, at, com, d3(motions[other].com), normal, depth,
                                                 d3(0.0, 0.0, 0.0), friction);
                }
            }
        }
    }
    return n;
}

// relative_velocity in bodies.rs: the body's velocity at the contact (the real one, or the push),
// less its partner's.
__device__ __forceinline__ D3 relative_velocity(const BodyMotion* motions, const BodyContact& c, bool push) {
    const BodyMotion& a = motions[c.body];
    D3 at = push ? d3(a.push_velocity) + cross(d3(a.push_angular_velocity), d3(c.arm))
                 : d3(a.velocity) + cross(d3(a.angular_velocity), d3(c.arm));
    if (c.partner == NO_BODY) return at - d3(c.partner_velocity);
    const BodyMotion& o = motions[c.partner];
    const D3 there = push ? d3(o.push_velocity) + cross(d3(o.push_angular_velocity), d3(c.partner_arm))
                          : d3(o.velocity) + cross(d3(o.angular_velocity), d3(c.partner_arm));
    return at - there;
}

__device__ __forceinline__ double response_of(const BodyMotion& m, D3 arm, D3 d) {
    return m.inv_mass + dot(d, cross(m3(m.inv_inertia) * cross(arm, d), arm));
}

// response in bodies.rs.
__device__ __forceinline__ double response(const BodyMotion* motions, const BodyContact& c, D3 d) {
    const double own = response_of(motions[c.body], d3(c.arm), d);
    return c.partner == NO_BODY ? own : own + response_of(motions[c.partner], d3(c.partner_arm), d);
}

__device__ __forceinline__ void give(BodyMotion& m, D3 arm, D3 impulse, bool push) {
    const D3 dv = impulse * m.inv_mass;
    const D3 dw = m3(m.inv_inertia) * cross(arm, impulse);
    if (push) {
        store(m.push_velocity, d3(m.push_velocity) + dv);
        store(m.push_angular_velocity, d3(m.push_angular_velocity) + dw);
    } else {
        store(m.velocity, d3(m.velocity) + dv);
        store(m.angular_velocity, d3(m.angular_velocity) + dw);
    }
}

// apply_impulse in bodies.rs.
__device__ __forceinline__ void apply_impulse(BodyMotion* motions, const BodyContact& c, D3 impulse, bool push) {
    give(motions[c.body], d3(c.arm), impulse, push);
    if (c.partner != NO_BODY) give(motions[c.partner], d3(c.partner_arm), impulse * -1.0, push);
}

// resolve_contacts in bodies.rs: sequential impulses over every body's contacts, in body order,
// each contact giving its normal and friction impulse to the velocities, then its push out of the
// overlap to the push velocities. The two never read each other's values (a contact's stiffness
// takes only the masses), so each is a chain of its own here, and so is each island of bodies that
// contacts join (piles): no impulse of one reaches another's motions. One thread walks one chain
// of one island, in body order: each motion sees the operations one walk over every contact gives
// it, in its order (so the bits of that walk), twice the islands working at once (ten cubes in three
// piles took 6 ms a substep on one thread, BENCHMARKS.md M10). The motions it changes are in
// shared memory (`motions`, copied in and out by the caller): a chain of reads after writes stays
// out of the L2 cache's latency.

// A copy in registers of where a contact is and what it joins, which both chains read; each chain
// copies its own impulses beside it and writes them back at the end (through the reference, every
// store to a motion may alias the contact, and each field was read again), leaving the other's alone.
__device__ __forceinline__ BodyContact contact_geometry(const BodyContact& stored) {
    BodyContact c;
    for (int k = 0; k < 3; ++k) {
        c.arm[k] = stored.arm[k];
        c.partner_arm[k] = stored.partner_arm[k];
        c.normal[k] = stored.normal[k];
        c.partner_velocity[k] = stored.partner_velocity[k];
    }
    c.depth = stored.depth;
    c.friction = stored.friction;
    c.body = stored.body;
    c.partner = stored.partner;
    return c;
}

// The velocity chain's part of one contact: the normal impulse (closing any gap this substep, no
// more) and the Coulomb friction, kept in `stored`.
__device__ __forceinline__ void resolve_velocity(BodyMotion* motions, BodyContact& stored, double dt) {
    BodyContact c = contact_geometry(stored);
    for (int k = 0; k < 3; ++k) c.friction_impulse[k] = stored.friction_impulse[k];
    c.normal_impulse = stored.normal_impulse;
    const D3 normal = d3(c.normal);
    const D3 relative = relative_velocity(motions, c, false);
    const double into = dot(relative, normal);
    const double stiffness = response(motions, c, normal);
    const double closing = fmax(-c.depth, 0.0) / dt;
    const double total = fmax(c.normal_impulse - (into + closing) / stiffness, 0.0);
    D3 change = normal * (total - c.normal_impulse);
    c.normal_impulse = total;
    const D3 slide = relative - normal * into;
    const double speed = length(slide);
    if (speed > 0.0) {
        const D3 along = slide * (1.0 / speed);
        const D3 wanted = d3(c.friction_impulse) - along * (speed / response(motions, c, along));
        const double limit = c.friction * c.normal_impulse;
        const D3 friction = length(wanted) > limit ? wanted * (limit / length(wanted)) : wanted;
        change = change + (friction - d3(c.friction_impulse));
        store(c.friction_impulse, friction);
    }
    apply_impulse(motions, c, change, false);
    stored.normal_impulse = c.normal_impulse;
    store(stored.friction_impulse, d3(c.friction_impulse));
}

// The push chain's part of one contact: the push out of the overlap, kept in `stored`.
__device__ __forceinline__ void resolve_push(BodyMotion* motions, BodyContact& stored, double dt) {
    BodyContact c = contact_geometry(stored);
    c.push_impulse = stored.push_impulse;
    const D3 normal = d3(c.normal);
    const double stiffness = response(motions, c, normal);
    const D3 apart = relative_velocity(motions, c, true);
    const double wanted = BODY_PUSH_RATE * fmax(c.depth, 0.0) / dt;
    const double pushed = fmax(c.push_impulse + (wanted - dot(apart, normal)) / stiffness, 0.0);
    const D3 push = normal * (pushed - c.push_impulse);
    c.push_impulse = pushed;
    apply_impulse(motions, c, push, true);
    stored.push_impulse = c.push_impulse;
}

// `island[k]`: which island body k is in, numbered from 0 in the order of each island's first
// body; returns how many. `partners[k]`: a bit for each body that body k's contacts touch. Bodies a
// contact joins share an island (a hinged body among them: both sides' contacts give it their
// impulse), the others are one each. One thread.
__device__ u32 find_islands(const u32* partners, u32 num_bodies, u32* island) {
    u32 root[MAX_COLLIDERS];
    for (u32 k = 0; k < num_bodies; ++k) root[k] = k;
    const auto find = [&](u32 k) {
        while (root[k] != k) k = root[k];
        return k;
    };
    for (u32 k = 0; k < num_bodies; ++k) {
        for (u32 bits = partners[k]; bits != 0u; bits &= bits - 1u) {
            const u32 a = find(k), b = find((u32)__ffs(bits) - 1u);
            // The lower index is the root, so a body's root comes before it.
            if (a < b) root[b] = a;
            if (b < a) root[a] = b;
        }
    }
    u32 islands = 0;
    for (u32 k = 0; k < num_bodies; ++k) {
        const u32 r = find(k);
        island[k] = r == k ? islands++ : island[r];
    }
    return islands;
}

// A bit for each body among the partners of body k's `n` contacts, by its warp.
__device__ u32 partner_bits(const BodyContact* contacts, u32 n, u32 lane) {
    u32 bits = 0u;
    for (u32 i = lane; i < n; i += 32u) {
        const u32 partner = contacts[i].partner;
        if (partner != NO_BODY) bits |= 1u << partner;
    }
    for (u32 offset = 16u; offset > 0u; offset /= 2u) bits |= __shfl_xor_sync(0xffffffffu, bits, offset);
    return bits;
}

// One chain (`push` or the velocities) of island `which`, by one thread, over every sweep.
__device__ void resolve_chain(BodyMotion* motions, BodyContact* contacts, const u32* counts, const u32* island,
                              u32 which, bool push, u32 num_bodies, double dt) {
    for (u32 sweep = 0; sweep < BODY_CONTACT_SWEEPS; ++sweep) {
        for (u32 k = 0; k < num_bodies; ++k) {
            if (island[k] != which) continue;
            for (u32 i = 0; i < counts[k]; ++i) {
                BodyContact& stored = contacts[k * MAX_BODY_CONTACTS + i];
                if (push) {
                    resolve_push(motions, stored, dt);
                } else {
                    resolve_velocity(motions, stored, dt);
                }
            }
        }
    }
}

// wall_overlap in bodies.rs: how far a body at `center` must move to be clear of the walls (by its
// corners).
__device__ D3 wall_overlap(const RigidBody& b, const ContactFeature* features, const M3& r, D3 center,
                           const BodyWalls& walls) {
    D3 push = d3(0.0, 0.0, 0.0);
    for (u32 f = 0; f < b.num_corners; ++f) {
        const ContactFeature& feature = features[b.first_feature + f];
        const D3 p = center + r * d3(feature.point);
        for (int a = 0; a < 3; ++a) {
            double s = fmax(get(push, a), walls.lo[a] - (get(p, a) - feature.radius));
            s = fmin(s, walls.hi[a] - (get(p, a) + feature.radius));
            set(push, a, s);
        }
    }
    return push;
}

// body_collider_state in bodies.rs, rounding for rounding: the pose and the rigid velocity at the
// collider's centre, from the body's state alone (its shape stays). Every operation is one that is
// never fused into a multiply-add (__dmul_rn, __dadd_rn, __dsub_rn), in glam's order, so the host
// places a body in its slot with the very bits the device does: a run resumed from a checkpoint
// starts its first substep with the slots the uninterrupted run had (src/cuda/colliders.rs).
__device__ void place_body(const RigidBody& b, ColliderState& s) {
    const double x = b.orientation[0], y = b.orientation[1], z = b.orientation[2], w = b.orientation[3];
    // DMat3::from_quat, row-major.
    const double x2 = __dadd_rn(x, x), y2 = __dadd_rn(y, y), z2 = __dadd_rn(z, z);
    const double xx = __dmul_rn(x, x2), xy = __dmul_rn(x, y2), xz = __dmul_rn(x, z2);
    const double yy = __dmul_rn(y, y2), yz = __dmul_rn(y, z2), zz = __dmul_rn(z, z2);
    const double wx = __dmul_rn(w, x2), wy = __dmul_rn(w, y2), wz = __dmul_rn(w, z2);
    const double r[9] = {__dsub_rn(1.0, __dadd_rn(yy, zz)), __dsub_rn(xy, wz), __dadd_rn(xz, wy),
                         __dadd_rn(xy, wz), __dsub_rn(1.0, __dadd_rn(xx, zz)), __dsub_rn(yz, wx),
                         __dsub_rn(xz, wy), __dadd_rn(yz, wx), __dsub_rn(1.0, __dadd_rn(xx, yy))};
    // The centre of mass, centre + R centroid (a matrix times a vector: column by column), and the
    // centre's offset from it.
    double offset[3];
    for (int a = 0; a < 3; ++a) {
        const double turned =
            __dadd_rn(__dadd_rn(__dmul_rn(r[3 * a], b.centroid[0]), __dmul_rn(r[3 * a + 1], b.centroid[1])),
                      __dmul_rn(r[3 * a + 2], b.centroid[2]));
        offset[a] = __dsub_rn(b.center[a], __dadd_rn(b.center[a], turned));
    }
    // velocity + angular_velocity x offset.
    const double* const om = b.angular_velocity;
    const double spin[3] = {__dsub_rn(__dmul_rn(om[1], offset[2]), __dmul_rn(offset[1], om[2])),
                            __dsub_rn(__dmul_rn(om[2], offset[0]), __dmul_rn(offset[2], om[0])),
                            __dsub_rn(__dmul_rn(om[0], offset[1]), __dmul_rn(offset[0], om[1]))};
    for (int i = 0; i < 9; ++i) s.rotation[i] = (float)r[i];
    for (int a = 0; a < 3; ++a) {
        s.center[a] = (float)b.center[a];
        s.velocity[a] = (float)__dadd_rn(b.velocity[a], spin[a]);
        s.angular_velocity[a] = (float)om[a];
    }
}

// move_body in bodies.rs, then its collider state into its slot (place_body).
__device__ void move_body(RigidBody& b, const BodyMotion& m, const ContactFeature* features, double dt,
                          const BodyWalls& walls, ColliderState& s) {
    const D3 v = d3(m.velocity) + d3(m.push_velocity);
    const D3 w = d3(m.angular_velocity) + d3(m.push_angular_velocity);
    const Q q0 = Q{b.orientation[0], b.orientation[1], b.orientation[2], b.orientation[3]};
    const Q turn = from_scaled_axis(w * dt);
    const Q orientation = qnormalize(qmul(turn, q0));
    const M3 r1 = rotation_of(orientation);
    const bool hinged = is_hinged(b);
    const D3 hinge = d3(b.hinge_point);
    const D3 com = d3(m.com);
    const D3 com1 = hinged ? hinge + rotation_of(turn) * (com - hinge) : com + v * dt;
    D3 center1 = com1 - r1 * d3(b.centroid);
    if (!hinged) center1 = center1 + wall_overlap(b, features, r1, center1, walls);
    store(b.center, center1);
    b.orientation[0] = orientation.x, b.orientation[1] = orientation.y;
    b.orientation[2] = orientation.z, b.orientation[3] = orientation.w;
    store(b.velocity, d3(m.velocity));
    store(b.angular_velocity, d3(m.angular_velocity));

    place_body(b, s);
}

// The four phases, a barrier between each: a phase reads what the one before wrote for every body.
extern "C" __global__ void step_bodies(const KernelParams params, const BodyWalls walls, const u32 num_bodies,
                                       RigidBody* __restrict__ bodies, const ContactFeature* __restrict__ features,
                                       u64* __restrict__ impulses, ColliderState* __restrict__ states,
                                       const u32 num_states, const float* __restrict__ sdf,
                                       BodyMotion* __restrict__ motions, BodyContact* __restrict__ contacts,
                                       u32* __restrict__ contact_counts) {
    // A warp a body: its first lane steps it, all its lanes look for its contacts.
    const u32 k = threadIdx.x / 32u, lane = threadIdx.x % 32u;
    const bool mine = k < num_bodies;
    const double dt = (double)params.dt;
    const D3 gravity = d3((double)params.gravity[0], (double)params.gravity[1], (double)params.gravity[2]);
    if (mine && lane == 0) motions[k] = take_impulse(bodies[k], impulses + 6 * k, dt, gravity);
    __syncthreads();
    __shared__ u32 partners[MAX_COLLIDERS];
    if (mine) {
        const u32 n = is_hinged(bodies[k]) ? 0u
                                           : find_contacts(k, lane, bodies, motions, features, walls, states,
                                                           num_states, sdf, contacts + k * MAX_BODY_CONTACTS);
        __syncwarp();  // each lane reads contacts the others wrote
        const u32 bits = partner_bits(contacts + k * MAX_BODY_CONTACTS, n, lane);
        if (lane == 0) {
            contact_counts[k] = n;
            partners[k] = bits;
        }
    }
    // Most substeps of floating bodies touch nothing: then there is nothing to resolve.
    const bool touching = __syncthreads_or(mine && lane == 0 && contact_counts[k] > 0u);
    if (touching) {
        __shared__ BodyMotion resolving[MAX_COLLIDERS];
        __shared__ u32 island[MAX_COLLIDERS];
        __shared__ u32 islands;
        if (threadIdx.x < num_bodies) resolving[threadIdx.x] = motions[threadIdx.x];
        if (threadIdx.x == 0) islands = find_islands(partners, num_bodies, island);
        __syncthreads();
        // Chain 2i is island i's velocities, 2i + 1 its pushes, each walked by the first lane of a
        // warp of its own where the block has enough (two lanes of one warp would take turns).
        if (lane == 0) {
            for (u32 chain = k; chain < 2u * islands; chain += blockDim.x / 32u) {
                resolve_chain(resolving, contacts, contact_counts, island, chain / 2u, chain % 2u == 1u, num_bodies,
                              dt);
            }
        }
        __syncthreads();
        if (threadIdx.x < num_bodies) motions[threadIdx.x] = resolving[threadIdx.x];
        __syncthreads();
    }
    if (mine && lane == 0) move_body(bodies[k], motions[k], features, dt, walls, states[bodies[k].slot]);
}
