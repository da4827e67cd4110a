// What the viewer needs from the particle state, written straight into an OpenGL vertex buffer that
// CUDA has mapped (CUDA-OpenGL interop: no host round trip).
#include "common.cuh"

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
