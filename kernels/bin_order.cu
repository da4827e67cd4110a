// bin_order: the fused pipeline and the position-based solver keep their particles stored in bin
// order. After each binning the particle state (x, v, C's three columns, density, each particle's
// slot, where the scene has solids their deformation, and the position-based solver's volume bias)
// is gathered from its place in memory into the place `order` gives it, in a second set of buffers that the host then
// swaps in (src/cuda/bin_order.rs), and `order` becomes the identity. one_pass then reads and
// writes each warp's particles as whole consecutive runs of memory instead of 32 scattered places
// reached through `order`: measured on the H100 (BENCHMARKS.md 0r), 6 to 10 % off the mean substep
// at every preset, these copies included.
//
// A particle's slot (its index as users see it: export, checkpoints, the CPU reference) travels with
// it, so readers put the particles back in slot order (DeviceParticles::download). Where the scene has
// emitters or sinks, `position` (slot -> place in memory) follows too: the lifecycle names particles
// by slot (kernels/lifecycle.cu). On one GPU every place holds its own slot, parked or live; a rank
// of several (src/cuda/cuda_ranks.rs) may hold parked copies of slots that live elsewhere (a migrant's,
// a drained particle's, a spare place's), so it follows only its live particles (`live_only`), which
// is all its lifecycle asks. Which place a particle takes inside its cell varies from run to
// run (bin_count's ranks); no result depends on it: every per-particle result is the same wherever
// the particle is stored, and the fixed-point scatter sums integers.
#include "common.cuh"

extern "C" __global__ void gather_into_bin_order(const u32 n,
                                                u32* __restrict__ order,  // read, then left as the identity
                                                const float4* __restrict__ x, const float4* __restrict__ v,
                                                const float4* __restrict__ c, const float* __restrict__ rho,
                                                const u32* __restrict__ slot,
                                                const float4* __restrict__ deformation,  // null without solids
                                                float4* __restrict__ x_out, float4* __restrict__ v_out,
                                                float4* __restrict__ c_out, float* __restrict__ rho_out,
                                                u32* __restrict__ slot_out, float4* __restrict__ deformation_out,
                                                u32* __restrict__ position,  // null without a flow
                                                const u32 live_only,  // a rank's: only its live slots
                                                const float* __restrict__ bias,  // null but under pbmpm
                                                float* __restrict__ bias_out) {
    FOR_EACH_INDEX(i, n) {
        const u32 p = order[i];
        const float4 xp = x[p];
        x_out[i] = xp;
        v_out[i] = v[p];
        for (u32 col = 0; col < 3u; ++col) c_out[(size_t)col * n + i] = c[(size_t)col * n + p];
        if (deformation) {
            for (u32 col = 0; col < 3u; ++col) deformation_out[(size_t)col * n + i] = deformation[(size_t)col * n + p];
        }
        rho_out[i] = rho[p];
        if (bias) bias_out[i] = bias[p];
        const u32 s = slot[p];
        slot_out[i] = s;
        if (position && !(live_only && is_parked(xp))) position[s] = i;
        order[i] = i;
    }
}
