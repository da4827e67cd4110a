// The particle lifecycle of scenes with emitters and sinks (src/sim/flow.rs is the reference and says
// why it works this way). A slot's x.w is PARKED_W while it is parked: the binned pipeline's passes
// skip it, bins.cu sorts it past every bin, the statistics and the renderer ignore it. Sinks park
// particles inside g2p2g (tiles.cuh's `drain_into_sink`), pushing their slots on the free stack;
// `settle_free` sorts what a substep pushed, highest first, so which slot an emission takes never
// depends on the order threads pushed them; `emit_particles` fills nozzle points from the stack's top.
// The stack and each nozzle point's last particle hold slots (a particle's index as users see it);
// the fused pipeline stores particles in bin order (bin_order.cu), so a slot's place in the particle
// arrays is looked up in `position` (the identity in the binned pipeline, which never moves them).
// Both are one block: their work is a substep's drains and the nozzles' points, not the particles.
//
// On the ranks of a run (src/cuda/cuda_ranks.rs) every rank keeps the same stack and nozzle points:
// the host shares each substep's drains among them before `settle_free`, `nozzles_blocked` gives
// each rank's look at the last particles it holds, the host ORs the looks, and every rank then runs
// the same emission, writing only the particles its slab holds, after its places in use.
#include "tiles.cuh"
#include "slabs.cuh"

#define SETTLE_SHARED 4096u

// Sorts free[sorted, free_count) into descending order and marks it sorted. Up to SETTLE_SHARED
// slots by a bitonic sort in shared memory (a substep drains far fewer); beyond, by odd-even
// transposition in place (slow, but right, for a sink that swallows a whole body at once).
extern "C" __global__ void __launch_bounds__(1024) settle_free(u32* __restrict__ free_slots, FlowCounters* __restrict__ flow) {
    __shared__ u32 keys[SETTLE_SHARED];
    const u32 sorted = (u32)flow->sorted;
    const u32 count = (u32)flow->free_count;
    const u32 len = count - sorted;
    u32* tail = free_slots + sorted;
    if (len > 1 && len <= SETTLE_SHARED) {
        u32 size = 1;
        while (size < len) size <<= 1;
        for (u32 i = threadIdx.x; i < size; i += blockDim.x) keys[i] = i < len ? tail[i] : 0u;  // 0 sorts last
        __syncthreads();
        for (u32 k = 2; k <= size; k <<= 1) {
            for (u32 j = k >> 1; j > 0; j >>= 1) {
                for (u32 i = threadIdx.x; i < size; i += blockDim.x) {
                    const u32 partner = i ^ j;
                    if (partner > i) {
                        const u32 a = keys[i], b = keys[partner];
                        const bool larger_first = (i & k) == 0;
                        if (larger_first ? a < b : a > b) {
                            keys[i] = b;
                            keys[partner] = a;
                        }
                    }
                }
                __syncthreads();
            }
        }
        for (u32 i = threadIdx.x; i < len; i += blockDim.x) tail[i] = keys[i];
    } else if (len > SETTLE_SHARED) {
        for (u32 round = 0; round < len; ++round) {
            for (u32 i = 2 * threadIdx.x + (round & 1u); i + 1 < len; i += 2 * blockDim.x) {
                const u32 a = tail[i], b = tail[i + 1];
                if (a < b) {
                    tail[i] = b;
                    tail[i + 1] = a;
                }
            }
            __syncthreads();
        }
    }
    __syncthreads();
    if (threadIdx.x == 0) flow->sorted = count;
}

// One emission: each point of each emitter in `mask` takes the top free slot, in point order, unless
// its last particle is live and within the clearance of it (judged on the state before the emission,
// as the reference does). A point past the stack's end counts as exhausted. Where the grid already
// holds the next substep's mass (g2p2g or one_pass scattered it), the new particles' mass is added,
// rounded as the tiles round, and their node blocks listed; under the fused pipeline (whose one_pass
// scattered the momentum too) so is their momentum, m_p u: at rest density with C = 0 and its
// deformation at rest a particle's stress impulse is zero. Otherwise the next scatter covers them.
//
// On a rank: `blocked_by` holds every rank's look at each point's last particle (nozzles_blocked), OR'd;
// a new particle is written only where its block layer lies in own_first..own_end along `axis` (the
// rank's slab), at the next of the places counted from `append_at` by `appended`, its slot and
// `position` set. On one GPU `blocked` and `appended` are null and the layers one, own_first..own_end
// 0..1: every particle goes to its slot's place.
extern "C" __global__ void __launch_bounds__(1024) emit_particles(
    const KernelParams params, const u32 mask,
    const float4* __restrict__ points,      // xyz, w = the emitter's index as bits
    const u32 num_points,
    const float4* __restrict__ velocities,  // per emitter
    const float clearance_sq,
    u32* __restrict__ emits,                // scratch, one per point
    u32* __restrict__ last,                 // per point: its last slot, or NO_PARTICLE
    u32* __restrict__ position,             // per slot: its place in the particle arrays
    const u32* __restrict__ free_slots, FlowCounters* __restrict__ flow,
    const u32* __restrict__ blocked_by,     // per point, the ranks' looks; null on one GPU
    const u32 axis, const u32 layers, const u32 own_first, const u32 own_end,
    const u32 append_at, u32* __restrict__ appended,  // null on one GPU
    float4* __restrict__ x, float4* __restrict__ v, float4* __restrict__ c, float* __restrict__ rho,
    u32* __restrict__ slot,
    float4* __restrict__ deformation,  // null where no material carries one
    const u32 scatter_mass, float4* grid_acc, u64* fixed_mass, u64* fixed_momentum,
    u32* block_marks, u32* block_list, u32* work_counts, StepCounters* __restrict__ counters) {
    __shared__ u32 scan[1024];
    __shared__ u32 carried;
    const u32 n = params.num_particles;

    u32 blocked = 0;
    for (u32 g = threadIdx.x; g < num_points; g += blockDim.x) {
        const float4 at = points[g];
        u32 wants = 0u;
        if (mask & (1u << __float_as_uint(at.w))) {
            const u32 previous = last[g];
            bool clear = true;
            if (blocked_by) {
                clear = blocked_by[g] == 0u;
            } else if (previous != NO_PARTICLE) {
                const float4 xp = x[position[previous]];
                const float dx = xp.x - at.x, dy = xp.y - at.y, dz = xp.z - at.z;
                clear = xp.w != 0.0f || dx * dx + dy * dy + dz * dz >= clearance_sq;
            }
            if (clear) wants = 1u;
            else ++blocked;
        }
        emits[g] = wants;
    }
    if (blocked) atomicAdd(&flow->blocked, (u64)blocked);
    if (threadIdx.x == 0) carried = 0u;
    __syncthreads();

    const u32 available = (u32)flow->free_count;
    const bool fixed = params.scatter_mode == SCATTER_FIXED_POINT;
    const TileScales scales = tile_scales(params);
    const bool scatter_momentum = params.density_rule == DENSITY_ADVECTED;
    const NodeBlocks blocks = node_blocks(params);
    const BlockMarks marks{block_marks, block_list, work_counts};
    for (u32 base = 0; base < num_points; base += blockDim.x) {
        const u32 g = base + threadIdx.x;
        const u32 wants = g < num_points ? emits[g] : 0u;
        scan[threadIdx.x] = wants;
        __syncthreads();
        for (u32 offset = 1; offset < blockDim.x; offset <<= 1) {
            const u32 add = threadIdx.x >= offset ? scan[threadIdx.x - offset] : 0u;
            __syncthreads();
            scan[threadIdx.x] += add;
            __syncthreads();
        }
        const u32 rank = carried + scan[threadIdx.x] - wants;
        const float4 at = wants ? points[g] : make_float4(0.0f, 0.0f, 0.0f, 0.0f);
        const float4 xp = make_float4(at.x, at.y, at.z, 0.0f);
        const u32 layer = block_layer(stencil_base_along(params, axis, xp), layers);
        const u32 taken = wants && rank < available ? free_slots[available - 1u - rank] : NO_PARTICLE;
        if (taken != NO_PARTICLE) last[g] = taken;
        if (taken != NO_PARTICLE && layer >= own_first && layer < own_end) {
            u32 p = position[taken];
            if (appended) {
                p = append_at + atomicAdd(appended, 1u);
                position[taken] = p;
                slot[p] = taken;
            }
            const float4 u = velocities[__float_as_uint(at.w)];  // w: the emitter's material tag
            const Material& mat = material_table[material_index(params, u)];
            const float m_p = mat.particle_mass;
            x[p] = xp;
            v[p] = u;
            for (int col = 0; col < 3; ++col) c[(size_t)col * n + p] = make_float4(0.0f, 0.0f, 0.0f, 0.0f);
            rho[p] = mat.rest_density;
            if (deformation) {
                // At rest, whatever the slot held before it was drained.
                Deformation rest;
                for (int col = 0; col < 3; ++col)
                    for (int row = 0; row < 3; ++row) rest.f[col][row] = col == row ? 1.0f : 0.0f;
                rest.plastic = solid_rest_plastic(mat.law);
                store_deformation(deformation, n, p, rest);
            }
            if (scatter_mass) {
                const Stencil s = make_stencil(xp, params);
                mark_stencil_blocks(params, marks, blocks, s);
                FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
                    const float mass = w * m_p;
                    grid_add(&grid_acc[node].w, &fixed_mass[node], fixed, mass * scales.mass, mass, counters);
                    if (scatter_momentum) {
                        const float momentum[3] = {w * (u.x * m_p), w * (u.y * m_p), w * (u.z * m_p)};
                        for (int a = 0; a < 3; ++a) {
                            grid_add(&grid_acc[node].x + a, &fixed_momentum[3 * (size_t)node + a], fixed,
                                     momentum[a] * scales.momentum, momentum[a], counters);
                        }
                    }
                })
            }
        }
        __syncthreads();
        if (threadIdx.x == blockDim.x - 1) carried += scan[threadIdx.x];
        __syncthreads();
    }
    if (threadIdx.x == 0) {
        const u32 taken = min(carried, available);
        flow->free_count = (u64)(available - taken);
        flow->sorted = min(flow->sorted, flow->free_count);
        flow->emitted += (u64)taken;
        flow->exhausted += (u64)(carried - taken);
    }
}

// A rank's look at the nozzle points of the emitters in `mask` (see the top of this file): per point,
// 1 where its last particle is live among this rank's first `places` and within the clearance of
// it, else 0. `position` is current for the slots this rank holds; for any other it may name a place
// holding another slot, a parked place, or one past `places`, each of which the look rejects.
extern "C" __global__ void nozzles_blocked(const u32 mask, const float4* __restrict__ points, const u32 num_points,
                                           const float clearance_sq, const u32* __restrict__ last,
                                           const u32* __restrict__ position, const u32 places,
                                           const float4* __restrict__ x, const u32* __restrict__ slot,
                                           u32* __restrict__ blocked) {
    FOR_EACH_INDEX(g, num_points) {
        const float4 at = points[g];
        const u32 previous = last[g];
        u32 near = 0u;
        if ((mask & (1u << __float_as_uint(at.w))) && previous != NO_PARTICLE) {
            const u32 p = position[previous];
            if (p < places && slot[p] == previous) {
                const float4 xp = x[p];
                const float dx = xp.x - at.x, dy = xp.y - at.y, dz = xp.z - at.z;
                near = xp.w == 0.0f && dx * dx + dy * dy + dz * dz < clearance_sq;
            }
        }
        blocked[g] = near;
    }
}
