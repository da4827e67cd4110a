// What the viewer needs from the particle state, written straight into an OpenGL vertex buffer that
// CUDA has mapped (CUDA-OpenGL interop: no host round trip), and the mouse push.
#include "common.cuh"

#define COLOUR_BY_SPEED 0u
#define COLOUR_BY_DENSITY 1u

// One float4 per particle: position xyz, and w = the colour quantity (|v| in m/s, or rho / rho0).
extern "C" __global__ void render_attributes(const float4* __restrict__ x, const float4* __restrict__ v,
                                             const float* __restrict__ rho, u32 num_particles, u32 colour_by,
                                             float inv_rest_density, float4* __restrict__ out) {
    FOR_EACH_INDEX(i, num_particles) {
        const float4 p = x[i];
        if (is_parked(p)) {  // the particle shader clips a NaN position (src/render/renderer.rs)
            const float nan = __int_as_float(0x7fffffff);
            out[i] = make_float4(nan, nan, nan, nan);
            continue;
        }
        float value;
        if (colour_by == COLOUR_BY_DENSITY) {
            value = rho[i] * inv_rest_density;
        } else {
            const float4 u = v[i];
            value = sqrtf(u.x * u.x + u.y * u.y + u.z * u.z);
        }
        out[i] = make_float4(p.x, p.y, p.z, value);
    }
}

// Mirror of `Push` in src/sim/push.rs.
struct Push {
    float origin[3];
    float radius;
    float direction[3];
    float _pad0;
    float delta_v[3];
    float _pad1;
};
static_assert(sizeof(Push) == 48, "Push must match src/sim/push.rs");

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
