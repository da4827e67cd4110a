// The grid's volume of a scene whose rest densities differ (Params::volume_density), and the density
// each particle gathers from it (docs/physics.md, "Several liquids"; the CPU twins are
// `CpuSolver::scatter_volume` and `volume_density` in src/sim/cpu.rs).
//
// The volume: V_i = sum_p w_ip over every live particle whatever its liquid, each weight rounded to
// fixed-point units (VOLUME_UNITS_PER_WEIGHT) and summed as integers whatever the scatter mode, so it
// is the same in any order and on any number of ranks (the CPU's differs by a unit where a weight's
// last bit does: NVRTC contracts the stencil's weights into fused multiply-adds). At the positions
// the substep's density is gathered at; the caller zeroes it first. Two scatters, the same integers:
// - scatter_volume_tiled (binned and fused pipelines): a CUDA block per bin chunk sums its particles'
//   weights in a shared 32-bit tile (tiles.cuh) and flushes each tile node with one 64-bit atomic. At
//   bench-655k's size on an H100 it replaced the warp runs below at 0.062 ms a substep;
// - scatter_volume (the report's pipeline, which has no node-block bins): a thread per slot, warp runs
//   of one cell summed in as few shuffle steps as the warp's longest run needs, one 64-bit atomic per
//   run and node.
//
// gather_volume_density: rho_p = m_p sum_i w_ip V_i / dx^3 (gather_volume_density in common.cuh), the
// walls' images added, into rho: the density p2g takes (report, binned), or the one one_pass
// advects (fused) in place of the grid mass's, so those passes keep their code for one rest density.
#include "tiles.cuh"

extern "C" __global__ void scatter_volume(const KernelParams params, const float4* __restrict__ x,
                                          u64* __restrict__ volume) {
    FOR_EACH_INDEX_CONVERGED(i, in_range, first, params.num_particles) {
        const float4 xp = x[in_range ? i : first];
        const bool live = in_range && !is_parked(xp);
        const Stencil s = make_stencil(xp, params);
        // Lanes that add nothing form runs of their own, so no run's head is one of them.
        const WarpRun run = warp_run(live ? s.base_index : 0xffffffffu);
        const u32 longest = warp_longest_run(run);
        const u32 lanes = longest <= 8 ? 8u : longest <= 16 ? 16u : 32u;
        FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
            u32 units[1] = {live ? (u32)__float2uint_rn(w * VOLUME_UNITS_PER_WEIGHT) : 0u};
            warp_run_sum(run, units, lanes);
            if (run.head && live) atomicAdd(&volume[node], (u64)units[0]);
        })
    }
}

// A chunk whose particles' weights could take a tile node's 32-bit sum past 2^31 goes to the grid
// (no chunk of up to 1,200 particles does).
__device__ __forceinline__ bool volume_tile_takes(u32 n) {
    return (float)n * (TILE_MAX_WEIGHT * VOLUME_UNITS_PER_WEIGHT + 0.5f) < TILE_SUM_LIMIT;
}

extern "C" __global__ void __launch_bounds__(TILE_THREADS)
    scatter_volume_tiled(const KernelParams params, const BinEntry* __restrict__ bins, const u32* __restrict__ order,
                         const float4* __restrict__ x, u64* __restrict__ volume, u32* block_marks, u32* block_list,
                         u32* work_counts, StepCounters* __restrict__ counters) {
    __shared__ u32 tile_marks[TILE_SPAN_BLOCKS];
    const float tile_scale[1] = {VOLUME_UNITS_PER_WEIGHT};
    const NodeBlocks blocks = node_blocks(params);
    const BlockMarks marks{block_marks, block_list, work_counts};
    u32 misses = 0;
    bool far = false;

    const u32 listed = work_counts[WORK_BINS];
    int* tile = tile_clear<1>(tile_marks, listed);
    for (u32 entry = blockIdx.x; entry < listed; entry += gridDim.x) {
        const BinEntry bin = bins[entry];
        const Tile t = make_tile(blocks, bin.bin);
        const bool fits = volume_tile_takes(bin.count);  // the same for the block
        for (u32 j = threadIdx.x; j < bin.count; j += blockDim.x) {
            // Particles stored in bin order (the fused pipeline) come without `order`.
            const u32 p = order ? order[bin.start + j] : bin.start + j;
            const float4 xp = x[p];
            if (is_parked(xp)) continue;
            const Stencil s = make_stencil(xp, params);
            u32 first;
            const bool in_tile = tile_place(params, t, s, first, far, tile_marks, marks, blocks, misses);
            tile_scatter<1>(
                s, params, first, in_tile && fits, tile, tile_scale,
                [&](float w, float, float, float, float (&weight)[1]) { weight[0] = w; },
                [&](u32 node, int, float scaled, float) { atomicAdd(&volume[node], (u64)__float2uint_rn(scaled)); });
        }
        FOR_EACH_TILE_NODE_IN_GRID(1, tile, t, params, blocks, marks, tile_marks, k, node, sums, {
            if (sums[0] != 0) atomicAdd(&volume[node], (u64)(u32)sums[0]);
        })
    }
    if (misses) atomicAdd(&counters->tile_misses, misses);
    if (far) counters->rebin_needed = 1u;
}

extern "C" __global__ void gather_volume_density(const KernelParams params, const float4* __restrict__ x,
                                                 const float4* __restrict__ v, const u64* __restrict__ volume,
                                                 float* __restrict__ rho) {
    FOR_EACH_INDEX(p, params.num_particles) {
        const float4 xp = x[p];
        if (is_parked(xp)) continue;
        const float m_p = material_table[material_index(params, v[p])].particle_mass;
        rho[p] = gather_volume_density(make_stencil(xp, params), params, volume, m_p);
    }
}
