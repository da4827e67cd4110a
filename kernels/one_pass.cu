// one_pass: the fused pipeline's particle pass, all of a substep's particle work in one kernel.
// g2p of substep n (g2p_particle in common.cuh: gather v, C and the grid mass, soft wall, colliders'
// backstop, advect, clamp, sinks), the particle's density for substep n + 1 (advected_density: the
// grid's density at its old position carried over the substep by the fluid's divergence,
// docs/physics.md), then the whole scatter of substep n + 1 at the new position: mass and momentum
// with the stress impulse (particle_impulse; a solid's, solid_impulse, from the deformation the
// gather advanced: advance_deformation). Each particle's state is read and written once per
// substep and its stencil gathered once, where the binned pipeline reads it twice and gathers twice
// (g2p2g.cu, then p2g.cu's density gather).
//
// One CUDA block per listed bin chunk, a thread per particle, every lane kept in the loop (its
// particle `live` or not) because the float scatter sums runs of lanes in registers:
// - float scatter: each node's mass and momentum summed over a warp's runs of particles in one cell
//   (warp_run, as p2g.cu), then one 16-byte vector atomic per run and node (sm_90); each warp lists
//   the node blocks its lanes covered (warp_list_marked_blocks), so the chunk needs no barrier. Two
//   entry points (`Scatter`): node by node for scenes too small to fill the device, by planes of 9
//   nodes for scenes that fill it, where the runs' shuffles bound the pass; both shuffle only as
//   many steps as the warp's longest run needs (three for runs of up to 8, not five);
// - fixed-point scatter: four channels of a shared fixed-point tile per bin (tiles.cuh), flushed once
//   per tile node, as p2g_tiled.cu, without a branch per contribution (integer warp runs before the
//   tile measured slower, BENCHMARKS.md 0h and 0u).
// Measured on the H200 (2026-11-24, ncu at bench-655k): the four-channel tile in both modes took
// 222 us, the float runs 124 us (g2p2g and p2g of the binned pipeline: 97 + 78 us). On the H100
// (2026-11-26, BENCHMARKS.md 0t), with the warps' marks: the runs' shuffles 40 % of one_pass's time at
// the dam break, by throughput alone; a node-by-node pass in 3, 4 or 5 steps ran the small scenes
// faster and the large ones slower (three copies of the stencil loop), the planes the large ones
// 6 to 20 % faster.
//
// The fused pipeline stores its particles in bin order (bin_order.cu), so a chunk's particles are
// consecutive in memory and `order` is null; where they stay in place, the pass reads them through it.
//
// With `gather` 0 the kernel is the scatter half alone, with the state and density the particles
// carry: the first substep after they were spawned or uploaded (nothing to gather yet). The same
// instructions scatter in both uses, so a run resumed from a checkpoint scatters the bits the
// uninterrupted run scattered; but for a plastic solid, whose gather's return mapping hands the
// scatter the stress of its own decomposition where the scatter alone computes it anew from the
// stored deformation (to other rounding): so a frame's last substep (`gather` 2,
// GATHER_ENDING_FRAME) scatters as the scatter alone does, and a checkpoint of the frame resumes
// to the same bits. Also flags `rebin_needed` where a particle moved about a cell since
// binning.
#include "tiles.cuh"

#define SCATTER_CHANNELS 4  // mass, then momentum x, y, z: channel-major in the fixed-point tile
#define GATHER_ENDING_FRAME 2u  // `gather` at a frame's last substep (src/cuda/one_pass.rs)

// The kernel's parameters, and their names, for its entry points below.
#define ONE_PASS_PARAMETERS                                                                                     \
    const KernelParams params, const u32 gather, const BinEntry *__restrict__ bins, const u32 *__restrict__ order,      \
        float4 *__restrict__ x, float4 *__restrict__ v, float4 *__restrict__ c, float *__restrict__ rho,         \
        const u32 *__restrict__ slot, float4 *__restrict__ deformation, const float4 *__restrict__ grid_vel,      \
        float4 *grid_acc, u64 *fixed_mass,                                                                        \
        u64 *fixed_momentum, u32 *block_marks, u32 *block_list, u32 *work_counts,                                \
        StepCounters *__restrict__ counters, const ColliderState *__restrict__ collider_states,                  \
        const u32 num_colliders, const float *__restrict__ collider_sdf, u64 *__restrict__ body_impulses,        \
        const float4 *__restrict__ sinks, u32 num_sinks, u32 *__restrict__ free_slots, FlowCounters *__restrict__ flow
#define ONE_PASS_ARGUMENTS                                                                                      \
    params, gather, bins, order, x, v, c, rho, slot, deformation, grid_vel, grid_acc, fixed_mass, fixed_momentum,    \
        block_marks,                                                                                             \
        block_list, work_counts, counters, collider_states, num_colliders, collider_sdf, body_impulses, sinks,   \
        num_sinks, free_slots, flow

// The scatter one_pass is compiled with (an entry point each; src/cuda/one_pass.rs chooses).
enum class Scatter {
    // Floats; each of the 27 nodes' sums (4 values) summed over the warp's runs as soon as it is
    // computed, in 3, 4 or 5 shuffle steps (a copy of the stencil loop each): the least a particle
    // keeps in flight (96 registers, 5 blocks per SM), for scenes too small to fill the device, where
    // a warp's latency is the pass's.
    FloatRuns,
    // Floats; a plane of 9 nodes at a time (36 values in registers, 128 registers, 4 blocks per SM),
    // in as many shuffle steps as the warp's longest run needs: three, not five, for runs of up to 8
    // particles, for scenes that fill the device, where the shuffles' throughput bounds the pass.
    FloatPlanes,
    // Fixed point: four channels of a shared fixed-point tile per bin (tiles.cuh).
    FixedTile,
};

// A lane that scatters nothing still takes part in its warp's shuffles, adding zeros: its weights,
// offsets and impulse are zeroed once here (all finite, so every product is 0), not each of the 108
// values it computes.
__device__ __forceinline__ void zero_unless_live(bool live, Stencil& s, ParticleImpulse& q) {
    if (live) return;
    for (int a = 0; a < 3; ++a) {
        s.fx[a] = 0.0f;
        q.mv[a] = 0.0f;
        for (int o = 0; o < 3; ++o) {
            s.w[o][a] = 0.0f;
            q.affine[o][a] = 0.0f;
        }
    }
}

// Scatter::FloatRuns for one particle a lane, in STEPS shuffle steps (runs of up to 2^STEPS lanes).
// Every lane of the warp calls it.
template <int STEPS>
__device__ __forceinline__ void scatter_runs_in(const KernelParams& params, Stencil s, ParticleImpulse q, bool live,
                                                WarpRun run, float4* grid_acc) {
    const float m_p = q.mass;
    zero_unless_live(live, s, q);
    FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
        float impulse[3];
        impulse_at(q, w, d0, d1, d2, impulse);
        float sums[4] = {impulse[0], impulse[1], impulse[2], w * m_p};
        warp_run_sum(run, sums, 1u << STEPS);
        if (run.head && live) atomic_add_mass_momentum(&grid_acc[node], sums[0], sums[1], sums[2], sums[3]);
    })
}

// Scatter::FloatRuns in the fewest steps among 3, 4 and 5 that the warp's longest run needs.
__device__ __forceinline__ void scatter_runs(const KernelParams& params, const Stencil& s, const ParticleImpulse& q,
                                             bool live, WarpRun run, float4* grid_acc) {
    const u32 longest = warp_longest_run(run);
    if (longest <= 8) scatter_runs_in<3>(params, s, q, live, run, grid_acc);
    else if (longest <= 16) scatter_runs_in<4>(params, s, q, live, run, grid_acc);
    else scatter_runs_in<5>(params, s, q, live, run, grid_acc);
}

// Scatter::FloatPlanes for one particle a lane: the plane's mass and momentum sums summed over the
// runs (warp_run_sum, in the steps the warp's longest run needs), then the run's head adds each
// node's sums with one vector atomic. The heads' sums are scatter_runs's, bit for bit. Every lane
// of the warp calls it.
__device__ __forceinline__ void scatter_runs_by_plane(const KernelParams& params, Stencil s, ParticleImpulse q,
                                                      bool live, WarpRun run, float4* grid_acc) {
    const float m_p = q.mass;
    zero_unless_live(live, s, q);
    const u32 longest = warp_longest_run(run);
    const u32 row = params.box_res[0], plane = params.box_res[0] * params.box_res[1];
#pragma unroll
    for (u32 oz = 0; oz < 3; ++oz) {
        // Selected, not indexed: a dynamic index would put the stencil in local memory. (The planes
        // are unrolled, so that a plane's weights and impulses are computed while the last plane's
        // sums are shuffled: 2.7 % off the dam break against a plane at a time, BENCHMARKS.md 0t.)
        const float wz = oz == 0 ? s.w[0][2] : oz == 1 ? s.w[1][2] : s.w[2][2];
        const float d2 = (float)oz - s.fx[2];
        float sums[9 * 4];
#pragma unroll
        for (int k = 0; k < 9; ++k) {
            const int ox = k % 3, oy = k / 3;
            const float w = s.w[ox][0] * (s.w[oy][1] * wz);
            float impulse[3];
            impulse_at(q, w, (float)ox - s.fx[0], (float)oy - s.fx[1], d2, impulse);
            sums[4 * k] = impulse[0];
            sums[4 * k + 1] = impulse[1];
            sums[4 * k + 2] = impulse[2];
            sums[4 * k + 3] = w * m_p;
        }
        warp_run_sum(run, sums, longest);
        if (run.head && live) {
            const u32 first = s.base_index + oz * plane;
#pragma unroll
            for (int k = 0; k < 9; ++k)
                atomic_add_mass_momentum(&grid_acc[first + (u32)(k % 3) + (u32)(k / 3) * row], sums[4 * k],
                                         sums[4 * k + 1], sums[4 * k + 2], sums[4 * k + 3]);
        }
    }
}

// MATERIALS false: the scene is one Newtonian liquid (water): no particle's material row is read,
// no law's viscosity computed, no density taken from the grid's volume, so the pass is compiled as it was before the
// material table (BENCHMARKS.md M1: the fixed-point substep 2.7 % over the build before the table
// without these entries, 1.3 % with them). SOLIDS: a row of the table carries a deformation (a solid,
// or an elastoviscoplastic liquid), which the gather advances and the scatter takes its stress from
// (`deformation`, null in the other entries, which neither read it nor pay for it).
template <Scatter SCATTER, bool MATERIALS, bool SOLIDS>
__device__ __forceinline__ void one_pass(ONE_PASS_PARAMETERS) {
    constexpr bool FIXED = SCATTER == Scatter::FixedTile;
    __shared__ u32 tile_marks[TILE_SPAN_BLOCKS];
    const Colliders colliders{collider_states, num_colliders, collider_sdf, body_impulses};
    const BlockMarks marks{block_marks, block_list, work_counts};
    const TileScales scales = tile_scales(params);
    const float tile_scale[SCATTER_CHANNELS] = {scales.mass, scales.momentum, scales.momentum, scales.momentum};
    // The heaviest particle's tile units bound a chunk's sums (tiles.cuh); each takes its own.
    const float unit_mass = (MATERIALS ? heaviest_particle_mass(params) : material_table[0].particle_mass) * scales.mass;
    const u32 n = params.num_particles;
    const NodeBlocks blocks = node_blocks(params);
    float max_speed = 0.0f, max_signal = 0.0f, max_rho = 0.0f;
    u32 misses = 0, pushes = 0, overflows = 0;
    i64 mass_balance = 0;  // fixed point: mass units added to the tiles less those flushed (tiles.cuh)
    bool balanced = false;  // whether any of this CUDA block's chunks kept the mass balance
    bool far = false;

    const u32 listed = work_counts[WORK_BINS];
    int* tile = FIXED ? tile_clear<SCATTER_CHANNELS>(tile_marks, listed) : tile_memory;
    for (u32 entry = blockIdx.x; entry < listed; entry += gridDim.x) {
        const BinEntry bin = bins[entry];
        const Tile t = make_tile(blocks, bin.bin);
        u32 covered = 0u;  // float scatter: the tile's node blocks this lane's particles covered
        const bool may_wrap = FIXED && tile_chunk_may_wrap(bin.count, unit_mass);  // the same for the block
        balanced |= may_wrap;

        // Converged: the bound is the chunk's, the same for every lane of the block. A warp wholly past
        // the chunk's end skips the iteration (warp-uniform, so the warp-wide sums stay whole); a lane
        // past the end of a partial warp computes a copy of the first particle and scatters nothing.
        for (u32 j0 = 0; j0 < bin.count; j0 += blockDim.x) {
            if (j0 + (threadIdx.x & ~31u) >= bin.count) continue;
            const u32 j = j0 + threadIdx.x;
            bool live = j < bin.count;
            // Past the end: a copy of the first. Particles stored in bin order (bin_order.cu) come
            // without `order`: their places are the order's (2 % off the substep against reading
            // the identity it leaves, BENCHMARKS.md 0r).
            const u32 at = bin.start + (live ? j : 0u);
            const u32 p = order ? order[at] : at;
            float4 xp = x[p];
            live &= !is_parked(xp);  // parked since the last binning: nothing to move or scatter
            float rho_p;
            float4 vp, c0, c1, c2;
            Deformation d;          // (SOLIDS) advanced by the gather, scattered from
            bool deformed = false;  // whether the particle's material carries a deformation
            float tau[3][3];        // the gather's return mapping's stress of d, where `returned`
            bool returned = false;
            if (gather) {
                GridDensity density;
                const float tag = MATERIALS ? particle_material_tag(params, v, p) : 0.0f;
                G2pResult r = g2p_particle_and_density(params, xp, tag, grid_vel, density);
                // Several rest densities: the density gathered from the grid's volume where the
                // gather was (volume.cu, this substep), not from the liquids' mixed mass.
                const float rho_grid =
                    MATERIALS && params.volume_density ? rho[p] : mass_density(params, density);
                rho_p = advected_density(params, rho_grid, density);
                r.signal = material_signal_speed(material_table[MATERIALS ? material_index(params, r.v) : 0u], rho_p,
                                                 r.speed);
                if (live && colliders.count) {
                    const Backstop b = collider_backstop_particle(params, colliders, rho_p, r);
                    r = b.r;
                    pushes += b.pushed;
                }
                if (SOLIDS) {
                    const Material& mat = material_table[material_index(params, r.v)];
                    deformed = material_carries_deformation(mat);
                    if (deformed) {
                        d = load_deformation(deformation, n, p);
                        returned = advance_deformation(params, mat, r.c, d, tau);
                        r.signal = deformed_signal_speed(mat, rho_p, r.speed, d);
                    }
                }
                xp = r.x;
                vp = r.v;
                c0 = r.c[0];
                c1 = r.c[1];
                c2 = r.c[2];
                if (live) {
                    for (int col = 0; col < 3; ++col) c[(size_t)col * n + p] = r.c[col];
                    v[p] = r.v;
                    x[p] = r.x;
                    rho[p] = rho_p;
                    if (SOLIDS && deformed) store_deformation(deformation, n, p, d);
                    max_speed = fmaxf(max_speed, r.speed);
                    max_signal = fmaxf(max_signal, r.signal);
                    max_rho = fmaxf(max_rho, MATERIALS ? reported_density(params, r.v, rho_p) : rho_p);
                    if (num_sinks && in_a_sink(xp, sinks, num_sinks)) {
                        // Drained: parked, its slot (not its place in memory: bin_order.cu) pushed on
                        // the free stack (settle_free orders them).
                        x[p] = make_float4(xp.x, xp.y, xp.z, PARKED_W);
                        free_slots[atomicAdd(&flow->free_count, 1ull)] = slot[p];
                        atomicAdd(&flow->drained, 1ull);
                        live = false;
                    }
                }
            } else {
                rho_p = rho[p];
                vp = v[p];
                c0 = c[p];
                c1 = c[n + p];
                c2 = c[2 * (size_t)n + p];
                if (SOLIDS) {
                    deformed = material_carries_deformation(material_table[material_index(params, vp)]);
                    if (deformed) d = load_deformation(deformation, n, p);
                }
            }
            const ParticleImpulse q =
                SOLIDS && deformed
                    ? deformed_impulse(params, material_table[material_index(params, vp)], rho_p, vp, c0, c1, c2, d,
                                       returned && gather != GATHER_ENDING_FRAME ? tau : nullptr)
                    : particle_impulse<MATERIALS>(params, rho_p, vp, c0, c1, c2);
            const Stencil s = make_stencil(xp, params);
            u32 first = 0;
            bool in_tile = false;
            if (live && FIXED) in_tile = tile_place(params, t, s, first, far, tile_marks, marks, blocks, misses);
            if (live && !FIXED) in_tile = tile_place_bits(params, t, s, first, far, covered, marks, blocks, misses);
            if (FIXED) {
                if (!live) continue;  // no warp-wide operations below
                const bool taken = in_tile && tile_takes(s, tile_reach(q, scales.momentum), q.mass * scales.mass);
                const u32 added = tile_scatter<SCATTER_CHANNELS>(
                    s, params, first, taken, tile, tile_scale,
                    [&](float w, float d0, float d1, float d2, float (&value)[SCATTER_CHANNELS]) {
                        float impulse[3];
                        impulse_at_pinned(q, w, d0, d1, d2, impulse);
                        value[0] = __fmul_rn(w, q.mass);
                        for (int a = 0; a < 3; ++a) value[1 + a] = impulse[a];
                    },
                    [&](u32 node, int ch, float scaled, float value) {
                        if (ch == 0) grid_add(&grid_acc[node].w, &fixed_mass[node], true, scaled, value, counters);
                        else grid_add(&grid_acc[node].x + (ch - 1), &fixed_momentum[3 * (size_t)node + (ch - 1)], true,
                                      scaled, value, counters);
                    });
                if (may_wrap) mass_balance += added;
            } else {
                // A lane that scatters nothing is a run of its own (a key no cell has): were it to
                // head its neighbours' run (a particle drained in this pass, between particles of
                // one cell), the run's sum would go unadded.
                const WarpRun run = warp_run(live ? s.base_index : ~(threadIdx.x & 31u));
                if (SCATTER == Scatter::FloatPlanes) scatter_runs_by_plane(params, s, q, live, run, grid_acc);
                else scatter_runs(params, s, q, live, run, grid_acc);
            }
        }

        // Lists the node blocks this chunk's particles covered: the float scatter warp by warp, without
        // a barrier; the fixed-point one after flushing its tile.
        if (!FIXED) {
            warp_list_marked_blocks(params, t, blocks, marks, covered);
            continue;
        }
        // A taken particle's stencil lies inside the grid (positions are clamped to [1, R - 2] dx), so
        // the tile nodes outside it hold nothing for the mass balance.
        const u32 mass_limit = tile_mass_limit(bin.count);
        FOR_EACH_TILE_NODE_IN_GRID(SCATTER_CHANNELS, tile, t, params, blocks, marks, tile_marks, k, node, sums, {
            const u32 mass = (u32)sums[0];
            if (may_wrap) {
                mass_balance -= mass;
                overflows += mass >= mass_limit;
            }
            const u64 units[SCATTER_CHANNELS] = {tile_global_units(mass), tile_global_units(sums[1]),
                                                 tile_global_units(sums[2]), tile_global_units(sums[3])};
            if (units[0] != 0) atomicAdd(&fixed_mass[node], units[0]);
            for (int a = 0; a < 3; ++a) {
                if (units[1 + a] != 0) atomicAdd(&fixed_momentum[3 * (size_t)node + a], units[1 + a]);
            }
        })
    }
    if (gather) {
        atomic_max_nonnegative(&counters->max_speed_bits, max_speed);
        atomic_max_nonnegative(&counters->max_signal_bits, max_signal);
        atomic_max_nonnegative(&counters->max_density_bits, max_rho);
    }
    if (balanced) tile_count_mass_wraps(mass_balance, counters);
    if (overflows) atomicAdd(&counters->fixed_overflows, overflows);
    if (misses) atomicAdd(&counters->tile_misses, misses);
    if (pushes) atomicAdd(&counters->backstop_pushes, pushes);
    if (far) counters->rebin_needed = 1u;
}

// One entry point per scatter (the host launches the one it chose, src/cuda/one_pass.rs), each
// compiled for the blocks per SM it runs fastest at (ONE_PASS_*_MIN_BLOCKS, tiles.cuh); each for
// water (one Newtonian liquid), for any table of liquids (_liquids) and for a table with solids
// (_solids).
#define ONE_PASS_ENTRY(NAME, MIN_BLOCKS, SCATTER, MATERIALS, SOLIDS)                            \
    extern "C" __global__ void __launch_bounds__(TILE_THREADS, MIN_BLOCKS) NAME(ONE_PASS_PARAMETERS) { \
        one_pass<SCATTER, MATERIALS, SOLIDS>(ONE_PASS_ARGUMENTS);                               \
    }
ONE_PASS_ENTRY(one_pass_float, ONE_PASS_FLOAT_MIN_BLOCKS, Scatter::FloatRuns, false, false)
ONE_PASS_ENTRY(one_pass_float_planes, ONE_PASS_FLOAT_PLANES_MIN_BLOCKS, Scatter::FloatPlanes, false, false)
ONE_PASS_ENTRY(one_pass_fixed, ONE_PASS_FIXED_MIN_BLOCKS, Scatter::FixedTile, false, false)
ONE_PASS_ENTRY(one_pass_float_liquids, ONE_PASS_FLOAT_MIN_BLOCKS, Scatter::FloatRuns, true, false)
ONE_PASS_ENTRY(one_pass_float_planes_liquids, ONE_PASS_FLOAT_PLANES_MIN_BLOCKS, Scatter::FloatPlanes, true, false)
ONE_PASS_ENTRY(one_pass_fixed_liquids, ONE_PASS_FIXED_MIN_BLOCKS, Scatter::FixedTile, true, false)
ONE_PASS_ENTRY(one_pass_float_solids, ONE_PASS_FLOAT_MIN_BLOCKS, Scatter::FloatRuns, true, true)
ONE_PASS_ENTRY(one_pass_float_planes_solids, ONE_PASS_FLOAT_PLANES_MIN_BLOCKS, Scatter::FloatPlanes, true, true)
ONE_PASS_ENTRY(one_pass_fixed_solids, ONE_PASS_FIXED_MIN_BLOCKS, Scatter::FixedTile, true, true)
