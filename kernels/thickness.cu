// The surface's thickness splats (src/render/surface.rs, pass 3), computed here instead of by
// OpenGL's additive blending where the particles come from a CUDA solver. Each particle adds the chord
// profile of its sphere to the texels its point sprite would cover, exactly as
// src/render/shaders/surface_particle.vert and surface_thickness.frag do, but as 64-bit integer
// atomics: the GL pass costs about 2.5 ns a sprite on an H100 whatever the sprite's size (its
// blending queues on the few raster units the chip has), these cost an atomic per texel covered.
// Integer sums also do not depend on the order particles arrive in, so a frame is the same run to run.
#include "common.cuh"

// A prime above any particle count that fits in memory, so coprime to every count.
#define VISIT_STRIDE 2654435761ull

// The splat of one particle: where it lands, how large, and what one texel at its centre gets.
struct Splat {
    float x, y;     // the centre, in texels from the texture's lower left corner
    float radius;   // in texels
    float scale;    // thickness units at the centre per unit of chord (sqrt(1 - r^2) = 1)
};

// gl_Position, gl_PointSize and v_splat of surface_particle.vert, and the clip test GL applies to a
// point (the whole sprite is dropped where its centre lies outside the clip volume, NaN included).
__device__ __forceinline__ bool project(const SplatCamera& cam, float4 p, Splat& s) {
    const float* v = cam.view;
    const float vx = v[0] * p.x + v[1] * p.y + v[2] * p.z + v[3];
    const float vy = v[4] * p.x + v[5] * p.y + v[6] * p.z + v[7];
    const float vz = v[8] * p.x + v[9] * p.y + v[10] * p.z + v[11];
    const float* m = cam.projection;
    const float cx = m[0] * vx + m[1] * vy + m[2] * vz + m[3];
    const float cy = m[4] * vx + m[5] * vy + m[6] * vz + m[7];
    const float cz = m[8] * vx + m[9] * vy + m[10] * vz + m[11];
    const float cw = m[12] * vx + m[13] * vy + m[14] * vz + m[15];
    if (!(fabsf(cx) <= cw && fabsf(cy) <= cw && fabsf(cz) <= cw)) return false;
    const float depth = fmaxf(-vz, 1e-4f);
    // GL clamps a point's size to its range: the largest splat is capped likewise, so a particle at
    // the camera does not loop over the whole texture.
    const float radius = fminf(fmaxf(cam.radius * cam.pixels_per_metre / depth, cam.min_splat_px),
                               THICKNESS_MAX_SPLAT_PX);
    const float splat_m = radius * depth / cam.pixels_per_metre;
    s.x = (cx / cw * 0.5f + 0.5f) * (float)cam.width;
    s.y = (cy / cw * 0.5f + 0.5f) * (float)cam.height;
    s.radius = radius;
    // chord * volume / sphere volume, with chord = 2 splat_m sqrt(1 - r^2): the splat adds exactly the
    // particle's volume, whatever its size on screen.
    s.scale = 2.0f * splat_m * cam.particle_volume / (4.18879f * splat_m * splat_m * splat_m) *
              THICKNESS_UNITS_PER_METRE;
    return true;
}

// One texel's two sums share a 64-bit word, so a splat costs one atomic a texel: the thickness in
// the low half, the thickness times the colour quantity (a speed or a density ratio, never negative)
// in the high half, each in THICKNESS_UNITS_PER_METRE. A half holds 2^32 units: 1,024 m of water, or
// of water times the quantity. A contribution is capped at 2^28 units, so a NaN or an absurd quantity
// cannot carry into the other half in one add.
__device__ __forceinline__ unsigned long long thickness_units(float value) {
    return (unsigned long long)fminf(fmaxf(rintf(value), 0.0f), 268435456.0f);
}

// `particles`: the renderer's vertex data, xyz and the colour quantity (kernels/render.cu), NaN for a
// parked slot. `sums`: one word a texel (see thickness_units); zero before the first splat
// (resolve_thickness leaves them so).
extern "C" __global__ void splat_thickness(const float4* __restrict__ particles, u32 count,
                                           SplatCamera cam, unsigned long long* __restrict__ sums) {
    FOR_EACH_INDEX(i, count) {
        // Neighbouring slots are neighbouring particles, whose splats cover the same texels: visited in
        // slot order, a warp's atomics would queue on a few addresses. A stride coprime to the count
        // visits every particle once, the lanes of a warp far apart.
        const float4 p = particles[(u32)((unsigned long long)i * VISIT_STRIDE % count)];
        Splat s;
        if (!project(cam, p, s)) continue;
        // The texels whose centres (x + 0.5, y + 0.5) lie within the sprite's square.
        const int x0 = max(0, (int)ceilf(s.x - s.radius - 0.5f));
        const int x1 = min((int)cam.width - 1, (int)floorf(s.x + s.radius - 0.5f));
        const int y0 = max(0, (int)ceilf(s.y - s.radius - 0.5f));
        const int y1 = min((int)cam.height - 1, (int)floorf(s.y + s.radius - 0.5f));
        const float inv_radius = 1.0f / s.radius;
        for (int y = y0; y <= y1; ++y) {
            const float dy = ((float)y + 0.5f - s.y) * inv_radius;
            for (int x = x0; x <= x1; ++x) {
                const float dx = ((float)x + 0.5f - s.x) * inv_radius;
                const float r2 = dx * dx + dy * dy;
                if (r2 > 1.0f) continue;
                const float t = s.scale * sqrtf(1.0f - r2);
                atomicAdd(sums + (size_t)y * cam.width + x,
                          thickness_units(t) | thickness_units(t * p.w) << 32);
            }
        }
    }
}

// Two floats as the half floats of one RG16F texel, red in the low half: the texture's own format,
// so GL fills it with a copy rather than a conversion.
__device__ __forceinline__ u32 half2_bits(float red, float green) {
    unsigned short r, g;
    asm("cvt.rn.f16.f32 %0, %1;" : "=h"(r) : "f"(red));
    asm("cvt.rn.f16.f32 %0, %1;" : "=h"(g) : "f"(green));
    return (u32)r | (u32)g << 16;
}

// The sums as the thickness texture's texels (RG: metres, and metres times the quantity), into the
// GL pixel buffer the texture is filled from; the sums are zeroed for the next frame's splats.
extern "C" __global__ void resolve_thickness(unsigned long long* __restrict__ sums, u32 texels,
                                             u32* __restrict__ out) {
    const float inv_scale = 1.0f / THICKNESS_UNITS_PER_METRE;
    FOR_EACH_INDEX(i, texels) {
        const unsigned long long sum = sums[i];
        out[i] = half2_bits((float)(u32)sum * inv_scale, (float)(u32)(sum >> 32) * inv_scale);
        sums[i] = 0;
    }
}
