// What the viewer needs from the particle state, written straight into an OpenGL vertex buffer that
// CUDA has mapped (CUDA-OpenGL interop: no host round trip).
#include "common.cuh"

// One float4 per particle: position xyz, and w = the colour quantity (|v| in m/s, rho / rho0, or the
// particle's row of the material table as a float, whose colour the shaders look up).
// Written at the particle's slot, not at its place in memory: the fused pipeline stores particles in
// bin order (bin_order.cu), and drawn in that order the surface's additive thickness splats land
// on the same pixels back to back and queue there (its thickness pass took 2.21 ms a frame instead
// of 1.29 at the dam break, H100, BENCHMARKS.md 0r).
extern "C" __global__ void render_attributes(const float4* __restrict__ x, const float4* __restrict__ v,
                                             const float* __restrict__ rho, const u32* __restrict__ slot,
                                             u32 num_particles, u32 colour_by, float inv_rest_density,
                                             float4* __restrict__ out) {
    FOR_EACH_INDEX(i, num_particles) {
        const float4 p = x[i];
        const u32 s = slot[i];
        if (is_parked(p)) {  // the particle shader clips a NaN position (src/render/renderer.rs)
            const float nan = __int_as_float(0x7fffffff);
            out[s] = make_float4(nan, nan, nan, nan);
            continue;
        }
        float value;
        if (colour_by == COLOUR_BY_DENSITY) {
            value = rho[i] * inv_rest_density;
        } else if (colour_by == COLOUR_BY_MATERIAL) {
            // v.w holds the row's bits (material.cuh, material_row), 0 in a scene of one material.
            value = (float)min(__float_as_uint(v[i].w), MAX_MATERIALS - 1u);
        } else {
            const float4 u = v[i];
            value = sqrtf(u.x * u.x + u.y * u.y + u.z * u.z);
        }
        out[s] = make_float4(p.x, p.y, p.z, value);
    }
}
