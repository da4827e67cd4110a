// p2g_tiled: the binned pipeline's p2g (docs/physics.md step 2, the same per-particle math as p2g.cu:
// gather_density, particle_impulse), one CUDA block per listed bin and a thread per particle,
// momentum accumulated in a shared fixed-point tile and flushed once per tile node (tiles.cuh).
// The binned pipeline runs it for the fixed-point scatter, where it is 4x faster than p2g.cu's 64-bit
// global atomics; float momentum goes through p2g.cu's warp-aggregated float atomics, which beat the
// tile on the H200 (src/cuda/solver.rs, `CudaSolver::scatter_momentum`, has the figures). The density is gathered from the global grid mass,
// which the previous substep's g2p2g (or p2g_mass) scattered and mirror_walls completed.
#include "tiles.cuh"

extern "C" __global__ void __launch_bounds__(TILE_THREADS, P2G_TILED_MIN_BLOCKS) p2g_tiled(const KernelParams params,
                                     const BinEntry* __restrict__ bins,
                                     const u32* __restrict__ order,  // particles by bin
                                     const float4* __restrict__ x,
                                     const float4* __restrict__ v,
                                     const float4* __restrict__ c,  // 3 arrays of N: columns 0, 1, 2 of C
                                     float* __restrict__ rho_out,
                                     float4* grid_acc,       // .xyz momentum, .w mass (float scatter)
                                     const u64* fixed_mass,  // fixed-point scatter
                                     u64* fixed_momentum,    // 3 per node, interleaved
                                     u32* block_marks, u32* block_list, u32* work_counts,
                                     StepCounters* __restrict__ counters) {
    __shared__ u32 tile_marks[TILE_SPAN_BLOCKS];
    const bool fixed = params.scatter_mode == SCATTER_FIXED_POINT;
    const TileScales scales = tile_scales(params);
    const float tile_scale[3] = {scales.momentum, scales.momentum, scales.momentum};
    const float inv_scale = 1.0f / params.fixed_momentum_scale;
    const float unit_mass = heaviest_particle_mass(params) * scales.mass;
    const u32 n = params.num_particles;
    const NodeBlocks blocks = node_blocks(params);
    const BlockMarks marks{block_marks, block_list, work_counts};
    float max_rho = 0.0f;
    u32 misses = 0, overflows = 0;

    const u32 listed = work_counts[WORK_BINS];
    int* tile = tile_clear<3>(tile_marks, listed);
    for (u32 entry = blockIdx.x; entry < listed; entry += gridDim.x) {
        const BinEntry bin = bins[entry];
        const Tile t = make_tile(blocks, bin.bin);
        const bool may_wrap = tile_chunk_may_wrap(bin.count, unit_mass);  // the same for the block

        for (u32 j = threadIdx.x; j < bin.count; j += blockDim.x) {
            const u32 p = order[bin.start + j];
            if (is_parked(x[p])) continue;  // drained since the last binning
            const Stencil s = make_stencil(x[p], params);
            // volume_density: the density gathered from the grid's volume (several rest densities,
            // volume.cu), not from its mass.
            const float rho = params.volume_density ? rho_out[p] : gather_density(s, params, grid_acc, fixed_mass);
            const float4 vp = v[p];
            rho_out[p] = rho;
            max_rho = fmaxf(max_rho, reported_density(params, vp, rho));
            const ParticleImpulse q = particle_impulse(params, rho, vp, c[p], c[n + p], c[2 * (size_t)n + p]);
            u32 first;
            bool far = false;
            const bool in_tile = tile_place(params, t, s, first, far, tile_marks, marks, blocks, misses);
            const bool taken = in_tile && tile_takes(s, tile_reach(q, scales.momentum), q.mass * scales.mass);
            tile_scatter<3>(
                s, params, first, taken, tile, tile_scale,
                [&](float w, float d0, float d1, float d2, float (&impulse)[3]) {
                    impulse_at_pinned(q, w, d0, d1, d2, impulse);
                },
                [&](u32 node, int a, float scaled, float impulse) {
                    grid_add(&grid_acc[node].x + a, &fixed_momentum[3 * (size_t)node + a], fixed, scaled, impulse,
                             counters);
                });
        }

        const float mass_limit = (float)tile_mass_limit(bin.count);
        FOR_EACH_TILE_NODE_IN_GRID(3, tile, t, params, blocks, marks, tile_marks, k, node, sums, {
            if (may_wrap) {
                // The node's whole mass (this substep's mass scatter, the walls' images added) bounds
                // its mass over the chunk's particles: in tile units exactly in fixed point, with room
                // for a float sum's rounding otherwise.
                const float mass = fixed ? (float)(fixed_mass[node] >> TILE_UNIT_SHIFT)
                                         : grid_acc[node].w * scales.mass * 1.001f;
                overflows += mass >= mass_limit;
            }
            const u64 units[3] = {tile_global_units(sums[0]), tile_global_units(sums[1]),
                                  tile_global_units(sums[2])};
            if (fixed) {
                for (int a = 0; a < 3; ++a) {
                    if (units[a] != 0) atomicAdd(&fixed_momentum[3 * (size_t)node + a], units[a]);
                }
            } else if (units[0] != 0 || units[1] != 0 || units[2] != 0) {
                atomic_add_momentum(&grid_acc[node], fixed_point_value(units[0], inv_scale),
                                    fixed_point_value(units[1], inv_scale), fixed_point_value(units[2], inv_scale));
            }
        })
    }
    atomic_max_nonnegative(&counters->max_density_bits, max_rho);
    if (overflows) atomicAdd(&counters->fixed_overflows, overflows);
    if (misses) atomicAdd(&counters->tile_misses, misses);
}
