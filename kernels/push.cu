// The viewer's mouse push (src/sim/push.rs, `Push` in contract.cuh): a velocity change given to the
// particles near the ray under the cursor, the formula of `Push::velocity_change` operation for
// operation.
#include "common.cuh"

// v += delta_v (1 - d^2/r^2)^2 for particles within r of the ray: Push::velocity_change.
extern "C" __global__ void push_particles(Push push, u32 num_particles, const float4* __restrict__ x,
                                          float4* __restrict__ v) {
    FOR_EACH_INDEX(i, num_particles) {
        const float4 p = x[i];
        if (is_parked(p)) continue;
        const float ox = p.x - push.origin[0], oy = p.y - push.origin[1], oz = p.z - push.origin[2];
        const float along =
            fmaxf(ox * push.direction[0] + oy * push.direction[1] + oz * push.direction[2], 0.0f);
        const float dx = ox - push.direction[0] * along, dy = oy - push.direction[1] * along,
                    dz = oz - push.direction[2] * along;
        const float dist_sq = dx * dx + dy * dy + dz * dz;
        const float radius_sq = push.radius * push.radius;
        if (dist_sq < radius_sq) {
            const float falloff = 1.0f - dist_sq / radius_sq;
            const float w = falloff * falloff;
            float4 u = v[i];
            u.x += push.delta_v[0] * w;
            u.y += push.delta_v[1] * w;
            u.z += push.delta_v[2] * w;
            v[i] = u;
        }
    }
}
