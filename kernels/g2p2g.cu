// g2p2g: the binned pipeline's particle pass that ends one substep and begins the next (G2P2G):
// g2p of substep n (g2p_particle in common.cuh, the same math as g2p.cu: gather, soft wall, advect,
// clamp), then the mass scatter of substep n + 1 at the new position (docs/physics.md step 1), through a
// shared fixed-point tile per bin (tiles.cuh), a thread per particle. So each substep reads and writes the particle state twice (here
// and in p2g_tiled) instead of three times, and the stencil is built once for both halves.
// p2g_mass is the mass half alone: the first substep's, and after the particles were replaced.
// Also flags `rebin_needed` where a particle moved about a cell since binning.
#include "tiles.cuh"

template <bool ADVECT>
__device__ __forceinline__ void scatter_bins_mass(const KernelParams& params, const BinEntry* __restrict__ bins,
                                                  const u32* __restrict__ order, float4* __restrict__ x,
                                                  float4* __restrict__ v, float4* __restrict__ c,
                                                  const float4* __restrict__ grid_vel, float* __restrict__ rho,
                                                  float4* grid_acc, u64* fixed_mass, const BlockMarks& marks,
                                                  u32* work_counts, StepCounters* __restrict__ counters,
                                                  const Colliders& colliders, const float4* __restrict__ sinks,
                                                  u32 num_sinks, u32* __restrict__ free_slots,
                                                  FlowCounters* __restrict__ flow) {
    __shared__ u32 tile_marks[TILE_SPAN_BLOCKS];
    const bool fixed = params.scatter_mode == SCATTER_FIXED_POINT;
    const float tile_scale[1] = {tile_scales(params).mass};
    const float inv_scale = 1.0f / params.fixed_mass_scale;
    const u32 n = params.num_particles;
    const NodeBlocks blocks = node_blocks(params);
    float max_speed = 0.0f, max_signal = 0.0f;
    u32 misses = 0, pushes = 0;
    bool far = false;
    // The heaviest particle's tile units bound a chunk's sums (tiles.cuh); each takes its own.
    const float unit_mass = heaviest_particle_mass(params) * tile_scale[0];
    i64 mass_balance = 0;  // mass units added to the tiles less those flushed (tiles.cuh)
    bool balanced = false;  // whether any of this CUDA block's chunks kept the mass balance

    const u32 listed = work_counts[WORK_BINS];
    int* tile = tile_clear<1>(tile_marks, listed);
    for (u32 entry = blockIdx.x; entry < listed; entry += gridDim.x) {
        const BinEntry bin = bins[entry];
        const Tile t = make_tile(blocks, bin.bin);
        const bool may_wrap = tile_chunk_may_wrap(bin.count, unit_mass);  // the same for the block
        balanced |= may_wrap;

        for (u32 j = threadIdx.x; j < bin.count; j += blockDim.x) {
            const u32 p = order[bin.start + j];
            float4 xp = x[p];
            if (is_parked(xp)) continue;  // parked since the last binning: nothing to move or scatter
            if (ADVECT) {
                const float material_tag = particle_material_tag(params, v, p);
                G2pResult r = g2p_particle(params, xp, material_tag, rho[p], grid_vel);
                if (colliders.count) {
                    const Backstop b = collider_backstop_particle(params, colliders, rho[p], r);
                    r = b.r;
                    pushes += b.pushed;
                }
                for (int col = 0; col < 3; ++col) c[(size_t)col * n + p] = r.c[col];
                v[p] = r.v;
                x[p] = r.x;
                xp = r.x;
                max_speed = fmaxf(max_speed, r.speed);
                max_signal = fmaxf(max_signal, r.signal);
                if (num_sinks && in_a_sink(xp, sinks, num_sinks)) {
                    // Drained: parked, its slot pushed on the free stack (settle_free orders the pushes).
                    x[p] = make_float4(xp.x, xp.y, xp.z, PARKED_W);
                    free_slots[atomicAdd(&flow->free_count, 1ull)] = p;
                    atomicAdd(&flow->drained, 1ull);
                    continue;
                }
            }
            const Stencil s = make_stencil(xp, params);
            const float m_p = particle_mass_of(params, v, p);
            u32 first;
            const bool in_tile = tile_place(params, t, s, first, far, tile_marks, marks, blocks, misses);
            const u32 added = tile_scatter<1>(
                s, params, first, in_tile && tile_takes(s, 0.0f, m_p * tile_scale[0]), tile, tile_scale,
                [&](float w, float, float, float, float (&mass)[1]) { mass[0] = __fmul_rn(w, m_p); },
                [&](u32 node, int, float scaled, float mass) {
                    grid_add(&grid_acc[node].w, &fixed_mass[node], fixed, scaled, mass, counters);
                });
            if (may_wrap) mass_balance += added;
        }

        // A taken particle's stencil lies inside the grid (positions are clamped to [1, R - 2] dx), so
        // the tile nodes outside it hold nothing for the mass balance.
        FOR_EACH_TILE_NODE_IN_GRID(1, tile, t, params, blocks, marks, tile_marks, k, node, sums, {
            const u32 mass = (u32)sums[0];
            if (may_wrap) mass_balance -= mass;
            const u64 units = tile_global_units(mass);
            if (units != 0) {
                if (fixed) atomicAdd(&fixed_mass[node], units);
                else atomicAdd(&grid_acc[node].w, fixed_point_value(units, inv_scale));
            }
        })
    }
    if (ADVECT) {
        atomic_max_nonnegative(&counters->max_speed_bits, max_speed);
        atomic_max_nonnegative(&counters->max_signal_bits, max_signal);
    }
    if (balanced) tile_count_mass_wraps(mass_balance, counters);
    if (misses) atomicAdd(&counters->tile_misses, misses);
    if (pushes) atomicAdd(&counters->backstop_pushes, pushes);
    if (far) counters->rebin_needed = 1u;
}

extern "C" __global__ void __launch_bounds__(TILE_THREADS, G2P2G_MIN_BLOCKS) g2p2g(const KernelParams params, const BinEntry* __restrict__ bins,
                                 const u32* __restrict__ order, float4* __restrict__ x, float4* __restrict__ v,
                                 float4* __restrict__ c, const float4* __restrict__ grid_vel,
                                 float* __restrict__ rho, float4* grid_acc, u64* fixed_mass, u32* block_marks,
                                 u32* block_list, u32* work_counts, StepCounters* __restrict__ counters,
                                 const ColliderState* __restrict__ collider_states, const u32 num_colliders,
                                 const float* __restrict__ collider_sdf, u64* __restrict__ /*body_impulses*/,
                                 const float4* __restrict__ sinks, u32 num_sinks, u32* __restrict__ free_slots,
                                 FlowCounters* __restrict__ flow) {
    // The binned pipeline takes no rigid bodies (their exchange needs the fused grid update's own
    // mass): the bodies' sums, always null here, are not passed on.
    scatter_bins_mass<true>(params, bins, order, x, v, c, grid_vel, rho, grid_acc, fixed_mass,
                            BlockMarks{block_marks, block_list, work_counts}, work_counts, counters,
                            Colliders{collider_states, num_colliders, collider_sdf, nullptr}, sinks, num_sinks,
                            free_slots, flow);
}

extern "C" __global__ void __launch_bounds__(TILE_THREADS, G2P2G_MIN_BLOCKS) p2g_mass(const KernelParams params, const BinEntry* __restrict__ bins,
                                    const u32* __restrict__ order, float4* __restrict__ x, float4* __restrict__ v,
                                    float4* grid_acc, u64* fixed_mass, u32* block_marks, u32* block_list,
                                    u32* work_counts, StepCounters* __restrict__ counters) {
    scatter_bins_mass<false>(params, bins, order, x, v, nullptr, nullptr, nullptr, grid_acc, fixed_mass,
                             BlockMarks{block_marks, block_list, work_counts}, work_counts, counters,
                             Colliders{nullptr, 0u, nullptr, nullptr}, nullptr, 0u, nullptr, nullptr);
}
