// Where a particle lies among the ranks' slabs (src/dist/slabs.rs): its stencil base node along the
// slab axis and the block layer that holds it. ranks.cu counts and moves particles by them, and
// lifecycle.cu gives a rank the emitted particles its slab holds.
#include "common.cuh"

// The stencil base node of `xp` along `axis`, rounded as `dist::migrate::base` (no fused
// multiply-add), so host and device agree on every particle's block layer.
__device__ __forceinline__ int stencil_base_along(const KernelParams& params, u32 axis, float4 xp) {
    const float along = axis == 0u ? xp.x : axis == 1u ? xp.y : xp.z;
    return (int)floorf(__fsub_rn(__fmul_rn(along, params.inv_dx), 0.5f));
}

// The block layer of a base node, clamped into the grid's `layers` as `Slabs::owner` clamps it.
__device__ __forceinline__ u32 block_layer(int base, u32 layers) {
    return min((u32)max(base, 0) / NODE_BLOCK_EDGE, layers - 1u);
}
