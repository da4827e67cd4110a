// ranks: what `CudaRanks` (src/cuda/cuda_ranks.rs) does to particles across ranks: find those about
// to leave their rank's reach, count them per block layer for the balance, pack them for their new
// owner, and take every rank's own particles to their slots in one set (the slots no rank holds
// parked first, where a run's sinks and emitters park and fill them).
#include "tiles.cuh"
#include "slabs.cuh"

// Counts the live particles of the first `places` whose stencil base along `axis` lies outside keep_lo..=keep_hi: those
// that one more substep could carry past the rank's ghost planes (`Slabs::keeps`), so the ranks
// migrate first (strays[0]); and of those, the ones whose stencil already left the grid's box
// (strays[1]): a particle that moved more than a cell in a substep, whose sums the box could not
// hold, which stops the run.
extern "C" __global__ void count_strays(const KernelParams params, const u32 places, const u32 axis, const int keep_lo,
                                        const int keep_hi, const float4* __restrict__ x, u32* __restrict__ strays) {
    const int box_lo = (int)params.box_lo[axis], box_hi = box_lo + (int)params.box_res[axis] - 3;
    FOR_EACH_INDEX(p, places) {
        const float4 xp = x[p];
        if (is_parked(xp)) continue;
        const int base = stencil_base_along(params, axis, xp);
        if (base < keep_lo || base > keep_hi) {
            atomicAdd(&strays[0], 1u);
            if (base < box_lo || base > box_hi) atomicAdd(&strays[1], 1u);
        }
    }
}

// Adds the live particles of one rank's first `places` per block layer along `axis` to `counts` (`layers` of them, as
// `dist::migrate::layer_counts` counts): a histogram in shared memory (`layers` u32), then one
// atomic per layer and CUDA block.
extern "C" __global__ void count_layers(const KernelParams params, const u32 places, const u32 axis, const u32 layers,
                                        const float4* __restrict__ x, u32* __restrict__ counts) {
    extern __shared__ u32 histogram[];
    for (u32 k = threadIdx.x; k < layers; k += blockDim.x) histogram[k] = 0u;
    __syncthreads();
    FOR_EACH_INDEX(p, places) {
        const float4 xp = x[p];
        if (!is_parked(xp)) atomicAdd(&histogram[block_layer(stencil_base_along(params, axis, xp), layers)], 1u);
    }
    __syncthreads();
    for (u32 k = threadIdx.x; k < layers; k += blockDim.x) {
        if (histogram[k]) atomicAdd(&counts[k], histogram[k]);
    }
}

// A particle's deformation (F_E's three float4 columns, the plastic scalar in the first's w) from
// place p of a set of `count` places to place q of one of `to_count`, where the run carries one
// (both pointers null where it does not).
__device__ __forceinline__ void copy_deformation(const float4* __restrict__ from, const u32 count, const u32 p,
                                                 float4* __restrict__ to, const u32 to_count, const u32 q) {
    if (from == nullptr || to == nullptr) return;
    for (u32 col = 0; col < 3u; ++col) to[(size_t)col * to_count + q] = from[(size_t)col * count + p];
}

// Migration: every particle live on the sending rank's first `from_end` places (its places in use)
// whose block layer lies in first_layer..end_layer (the receiving rank's slab) is packed into
// places to_first..to_end of `to_*` (the sender's buffer for that receiver, as many places as the
// layer counts say it holds of that slab; the carrier then takes them to the receiver) and parked
// on the sender; `moved` counts them. A particle the places cannot hold stays where it is: the host
// finds `moved` past its count and stops the run. The order within the packed places is the
// atomics'; the receiver's next binning sorts them.
extern "C" __global__ void move_owned(const KernelParams params, const u32 axis, const u32 layers, const u32 first_layer,
                                      const u32 end_layer, const u32 from_end, float4* __restrict__ from_x,
                                      const float4* __restrict__ from_v, const float4* __restrict__ from_c,
                                      const float* __restrict__ from_rho, const u32* __restrict__ from_slot,
                                      const float4* __restrict__ from_deformation, const u32 to_count,
                                      const u32 to_first, const u32 to_end, float4* __restrict__ to_x,
                                      float4* __restrict__ to_v, float4* __restrict__ to_c,
                                      float* __restrict__ to_rho, u32* __restrict__ to_slot,
                                      float4* __restrict__ to_deformation, u32* __restrict__ moved) {
    const u32 n = params.num_particles;
    FOR_EACH_INDEX(p, from_end) {
        const float4 xp = from_x[p];
        if (is_parked(xp)) continue;
        const u32 layer = block_layer(stencil_base_along(params, axis, xp), layers);
        if (layer < first_layer || layer >= end_layer) continue;
        const u32 q = to_first + atomicAdd(moved, 1u);
        if (q >= to_end) continue;
        to_x[q] = xp;
        to_v[q] = from_v[p];
        for (u32 col = 0; col < 3u; ++col) to_c[(size_t)col * to_count + q] = from_c[(size_t)col * n + p];
        to_rho[q] = from_rho[p];
        to_slot[q] = from_slot[p];
        copy_deformation(from_deformation, n, p, to_deformation, to_count, q);
        from_x[p] = make_float4(xp.x, xp.y, xp.z, PARKED_W);
    }
}

// Copies one rank's live particles (x, v, C's three columns, density, deformation) among the first `places` of
// its `count` to their slots in `out_*` (`out_count` slots), which every rank writes in turn: a
// slot is live on exactly one rank.
extern "C" __global__ void take_owned(const u32 places, const u32 count, const float4* __restrict__ x,
                                      const float4* __restrict__ v, const float4* __restrict__ c,
                                      const float* __restrict__ rho, const u32* __restrict__ slot,
                                      const float4* __restrict__ deformation, const u32 out_count,
                                      float4* __restrict__ out_x, float4* __restrict__ out_v,
                                      float4* __restrict__ out_c, float* __restrict__ out_rho,
                                      float4* __restrict__ out_deformation) {
    FOR_EACH_INDEX(p, places) {
        const float4 xp = x[p];
        const u32 s = slot[p];
        if (is_parked(xp) || s >= out_count) continue;
        out_x[s] = xp;
        out_v[s] = v[p];
        for (u32 col = 0; col < 3u; ++col) out_c[(size_t)col * out_count + s] = c[(size_t)col * count + p];
        out_rho[s] = rho[p];
        copy_deformation(deformation, count, p, out_deformation, out_count, s);
    }
}

// Parks every slot of `x`'s first `count` (its position kept): the readers' set before the ranks
// take their particles to it, where a run with emitters or sinks has slots that no rank holds.
extern "C" __global__ void park_slots(const u32 count, float4* __restrict__ x) {
    FOR_EACH_INDEX(s, count) {
        const float4 xs = x[s];
        x[s] = make_float4(xs.x, xs.y, xs.z, PARKED_W);
    }
}
