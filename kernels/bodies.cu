// step_bodies (docs/physics.md "Rigid bodies"): each rigid body takes the impulse the grid update's
// boundary gave its band's nodes (fixed-point sums, read and zeroed here), gravity, its hinge or its
// contacts with the walls, and moves; its collider state for the next substep (and for this one's
// particle backstop) is written into its slot. The CPU twin is step_body in
// src/sim/colliders/bodies.rs, operation for operation in double precision; one thread per body, so
// a run steps its bodies in the same order of operations every time.
#include "common.cuh"

struct D3 {
    double x, y, z;
};

__device__ __forceinline__ D3 d3(double x, double y, double z) { return D3{x, y, z}; }
__device__ __forceinline__ D3 d3(const double (&a)[3]) { return D3{a[0], a[1], a[2]}; }
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

#define MAX_CONTACTS 16
#define CONTACT_SWEEPS 8

struct Contact {
    D3 arm, normal, friction_impulse;
    double normal_impulse;
};

__device__ __forceinline__ double response(const RigidBody& b, const M3& inv_inertia, D3 arm, D3 d) {
    return b.inv_mass + dot(d, cross(inv_inertia * cross(arm, d), arm));
}

// resolve_wall_contacts in bodies.rs: sequential impulses, inelastic, Coulomb friction.
__device__ void resolve_wall_contacts(const RigidBody& b, const ContactFeature* features, const M3& r, D3 com,
                                      const BodyWalls& walls, const M3& inv_inertia, D3& v, D3& w) {
    Contact contacts[MAX_CONTACTS];
    int n = 0;
    const D3 center = d3(b.center);
    for (u32 f = 0; f < b.num_features; ++f) {
        const ContactFeature& feature = features[b.first_feature + f];
        const D3 p = center + r * d3(feature.point);
        for (int a = 0; a < 3; ++a) {
            for (int s = 0; s < 2; ++s) {
                const double side = s == 0 ? walls.lo[a] : walls.hi[a];
                const double sign = s == 0 ? 1.0 : -1.0;
                const double depth = sign * (side - get(p, a)) + feature.radius;
                if (depth >= 0.0 && n < MAX_CONTACTS) {
                    D3 normal = d3(0.0, 0.0, 0.0);
                    set(normal, a, sign);
                    contacts[n++] = Contact{p - normal * feature.radius - com, normal, d3(0.0, 0.0, 0.0), 0.0};
                }
            }
        }
    }
    for (int sweep = 0; sweep < CONTACT_SWEEPS; ++sweep) {
        for (int k = 0; k < n; ++k) {
            Contact& c = contacts[k];
            const D3 at = v + cross(w, c.arm);
            const double into = dot(at, c.normal);
            const double total = fmax(c.normal_impulse - into / response(b, inv_inertia, c.arm, c.normal), 0.0);
            D3 change = c.normal * (total - c.normal_impulse);
            c.normal_impulse = total;
            const D3 slide = at - c.normal * into;
            const double speed = length(slide);
            if (speed > 0.0) {
                const D3 along = slide * (1.0 / speed);
                const D3 wanted = c.friction_impulse - along * (speed / response(b, inv_inertia, c.arm, along));
                const double limit = b.contact_friction * c.normal_impulse;
                const D3 friction = length(wanted) > limit ? wanted * (limit / length(wanted)) : wanted;
                change = change + (friction - c.friction_impulse);
                c.friction_impulse = friction;
            }
            v = v + change * b.inv_mass;
            w = w + inv_inertia * cross(c.arm, change);
        }
    }
}

// wall_overlap in bodies.rs.
__device__ D3 wall_overlap(const RigidBody& b, const ContactFeature* features, const M3& r, D3 center,
                           const BodyWalls& walls) {
    D3 push = d3(0.0, 0.0, 0.0);
    for (u32 f = 0; f < b.num_features; ++f) {
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

extern "C" __global__ void step_bodies(const KernelParams params, const BodyWalls walls, const u32 num_bodies,
                                       RigidBody* __restrict__ bodies, const ContactFeature* __restrict__ features,
                                       u64* __restrict__ impulses, ColliderState* __restrict__ states) {
    const u32 k = threadIdx.x;
    if (k >= num_bodies) return;
    RigidBody& b = bodies[k];
    const double dt = (double)params.dt;
    const D3 gravity = d3((double)params.gravity[0], (double)params.gravity[1], (double)params.gravity[2]);
    double sums[6];
    for (int c = 0; c < 6; ++c) {
        sums[c] = (double)(i64)impulses[6 * k + c] / (double)BODY_IMPULSE_UNITS;
        impulses[6 * k + c] = 0ull;
    }
    const D3 linear = d3(sums[0], sums[1], sums[2]);
    const D3 about_origin = d3(sums[3], sums[4], sums[5]);
    const Q q0 = Q{b.orientation[0], b.orientation[1], b.orientation[2], b.orientation[3]};
    const M3 r = rotation_of(q0);
    const D3 center = d3(b.center);
    const D3 com = center + r * d3(b.centroid);
    const D3 angular = about_origin + cross(center - com, linear);
    const M3 inertia = mul(mul(r, m3(b.inertia)), transpose(r));
    const M3 inv_inertia = mul(mul(r, m3(b.inv_inertia)), transpose(r));
    D3 v = d3(b.velocity);
    D3 w = d3(b.angular_velocity);
    const D3 axis = d3(b.hinge_axis);
    const bool hinged = axis.x != 0.0 || axis.y != 0.0 || axis.z != 0.0;
    if (hinged) {
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
        resolve_wall_contacts(b, features, r, com, walls, inv_inertia, v, w);
    }
    // The rotation over the substep at the new rate, exactly: about the centre of mass, which moves
    // at v; or, hinged, about the axis, which carries the centre of mass round with it.
    const Q turn = from_scaled_axis(w * dt);
    const Q orientation = qnormalize(qmul(turn, q0));
    const M3 r1 = rotation_of(orientation);
    const D3 hinge = d3(b.hinge_point);
    const D3 com1 = hinged ? hinge + rotation_of(turn) * (com - hinge) : com + v * dt;
    D3 center1 = com1 - r1 * d3(b.centroid);
    if (!hinged) center1 = center1 + wall_overlap(b, features, r1, center1, walls);
    store(b.center, center1);
    b.orientation[0] = orientation.x, b.orientation[1] = orientation.y;
    b.orientation[2] = orientation.z, b.orientation[3] = orientation.w;
    store(b.velocity, v);
    store(b.angular_velocity, w);

    place_body(b, states[b.slot]);
}
