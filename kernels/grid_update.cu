// grid_update (docs/physics.md step 3): momentum to velocity, gravity, free slip in the boundary band
// (update_node in common.cuh). It is also the grid clear: each accumulator has exactly one reader
// here (its node's thread), so the thread zeroes what it read (consume-and-zero) and the next step's
// scatter finds a clean grid.
//
// Two walks over the grid:
// - grid_update (the report's pipeline): every node, so g2p never reads a stale velocity.
// - The binned pipeline's: only the 4x4x4-node blocks that this substep's scatters and mirror passes
//   touched (tiles.cuh marks them and lists each once). A block that no particle's stencil covers is
//   read by no particle, so its stale velocities are never used; its accumulators are zero, since
//   every write marks its block. The list comes in two parts, the blocks that a wall's mirror reaches
//   and the others (list_node_block), and two kernels walk them: grid_update_blocks the interior,
//   with no mirror code and so few registers, grid_update_wall_blocks the blocks at the walls.
//
// The fused pipeline adds the walls' mirror image here (mirror.cuh) instead of in a launch of its own
// before: each node near a wall reads its orbit's sums as the scatter left them, takes its own slot of
// `mirror_orbit_channel`, the very values mirror_walls would have written, and only then, after the
// block's barrier, zeroes its own. An orbit within one node block needs nothing more. A node whose
// reflection lies in another node block is read by two CUDA blocks in no fixed order, so neither
// zeroes it: clear_crossing_orbits does, after the launch. Images never reach the global grid, so no
// block is listed for them: a block no scatter touched is read by no particle.
#include "tiles.cuh"

// Listed blocks a step of water's interior kernels (update_interior_blocks), a kernel for each
// scatter, each with the registers of its own sums: four of float sums (53 registers), two of
// fixed-point sums, a node's four sums 64-bit (49). Measured on the H200 (BENCHMARKS.md M17): one
// kernel for both at four entries, 72 registers, took the 16.8M column's walk to 0.145 ms from 0.227
// at two (56), but cost the fixed-point dam break 2.5 %; float alone at four, 0.065 ms; at eight (80
// registers) 0.092 ms, and the walk 25 to 35 % slower at the dam break and bench-65k, whose short
// lists then spread over fewer CUDA blocks.
constexpr int WATER_FLOAT_GROUP = 4;
constexpr int WATER_FIXED_GROUP = 2;

extern "C" __global__ void grid_update(const KernelParams params,
                                       float4* __restrict__ grid_acc,     // in: momentum, mass; zeroed
                                       float4* __restrict__ grid_vel,     // out: .xyz velocity, .w mass
                                       u64* __restrict__ fixed_mass,      // in (fixed-point); zeroed
                                       u64* __restrict__ fixed_momentum,  // in (fixed-point); zeroed
                                       StepCounters* __restrict__ counters) {
    const u32 num_nodes = params.box_res[0] * params.box_res[1] * params.box_res[2];
    FOR_EACH_INDEX(i, num_nodes) {
        // The report's pipeline applies no colliders (the host refuses scenes that have them).
        update_node(params, i, grid_acc, grid_vel, fixed_mass, fixed_momentum, counters, Colliders{nullptr, 0u, nullptr, nullptr});
    }
}

// The scatter's sums of one node as floats (fixed-point units converted, out-of-range sums counted).
__device__ __forceinline__ NodeSums node_sums(const KernelParams& params, const i64 v[4], StepCounters* counters) {
    return fixed_point_sums(params, v, counters);
}

__device__ __forceinline__ NodeSums node_sums(const KernelParams&, const float v[4], StepCounters*) {
    return NodeSums{v[0], {v[1], v[2], v[3]}, v[0]};
}

// A node's own sums (before the images) as floats; uncounted, as the sums with the images are what
// its velocity is made from.
__device__ __forceinline__ NodeSums own_node_sums(const KernelParams& params, const i64 v[4]) {
    return fixed_point_floats(params, v);
}

__device__ __forceinline__ NodeSums own_node_sums(const KernelParams&, const float v[4]) {
    return NodeSums{v[0], {v[1], v[2], v[3]}, v[0], {0.0f, 0.0f, 0.0f}};
}

// Slot `own` of an orbit's values, by unrolled compares (a dynamic index would put the orbit in local
// memory).
template <typename V>
__device__ __forceinline__ V orbit_slot(const V v[8], u32 own) {
    V picked = V(0);
#pragma unroll
    for (u32 T = 0; T < 8; ++T)
        if (T == own) picked = v[T];
    return picked;
}

// Slot `own` of an orbit's four channels with the images added, channel by channel from the grid (a
// channel's images read that channel alone), so that only one channel of the orbit is held at a time.
// While this path shared its launch with the interior blocks it set their register count too, and the
// grid update of a large scene is latency-bound on its occupancy. Measured on the H100 (BENCHMARKS.md
// 0k, 0l): the whole orbit at once, 160 registers; the float orbit's float4s at once, 130; the orbit's
// indices held as 64-bit, 108, and the 16.8M column's substep 3.56 ms against 3.30 with mirror_walls'
// own launch; as 32-bit, 90 (3.41 ms); recomputed for each channel, as here, 72 (3.31 ms; bench-65k
// 0.0356 ms against 0.0348 at 90). UNROLL: channels a step of the loop (1 or 4). The wall blocks'
// kernel unrolls it, its registers weighing on the wall blocks alone now (BENCHMARKS.md M14, w5:
// unrolled in the shared launch, 1 to 3 % off the small scenes, whose blocks nearly all meet a wall).
template <typename V, int UNROLL>
__device__ __forceinline__ void mirrored_channels(const KernelParams& params, const MirrorAxis m[3],
                                                  const MirrorOrbit& o, u32 own, const float4* grid_acc, const u64* fixed_mass,
                                                  const u64* fixed_momentum, V mine[4]) {
#pragma unroll
    for (int k = 0; k < 4; ++k) mine[k] = V(0);
#pragma unroll UNROLL
    for (int ch = 0; ch < 4; ++ch) {
        V v[8];
        // The orbit's grid indices again for each channel: held across the loop they cost every
        // block of the launch 18 to 36 registers.
#pragma unroll
        for (u32 T = 0; T < 8; ++T) {
            u32 r[3];
            if (!(T & ~o.axes)) mirror_load(mirror_orbit_node(params, m, o, T, r), ch, grid_acc, fixed_mass, fixed_momentum, v[T]);
        }
        mirror_orbit_channel(m, o, ch, v);
        const V picked = orbit_slot(v, own);
#pragma unroll
        for (int k = 0; k < 4; ++k)  // mine[ch] with a loop-carried ch would be local memory too
            if (k == ch) mine[k] = picked;
    }
}

// A node near a wall, for the fused pipeline's mirror: its sums with the images added (the values
// mirror_walls would have written), and whether another node block reads it too (`crossing`: it
// must be left unzeroed). V: i64 in fixed point, float otherwise. OWN_SUMS: also its particles' own
// sums, read again from the grid after the orbit (nothing zeroes them before the block's barrier):
// own_m, which a rigid body's exchange counts, and the images' push (image_push in src/sim/cpu.rs),
// which a Coulomb collider's friction counts. Read there rather than taken from the orbit inside the
// channel loop, they hold no registers across it (taken inside, the wave tank's substep was 3.2 %
// slower than before them, against 2.6 % with bounds of its own; BENCHMARKS.md M13). Without it
// own_m is the sum's and the push zero. UNROLL as in mirrored_channels.
template <typename V, bool OWN_SUMS, int UNROLL>
__device__ __forceinline__ NodeSums mirrored_sums(const KernelParams& params, const MirrorAxis m[3], const u32 c[3],
                                                  const float4* grid_acc, const u64* fixed_mass,
                                                  const u64* fixed_momentum, StepCounters* counters,
                                                  bool& crossing) {
    const MirrorOrbit o = mirror_orbit(m, c);
    // This node's slot: the axes on which it lies beyond the wall from the representative.
    u32 own = 0;
    crossing = false;
    for (int b = 0; b < 3; ++b) {
        if (!((o.axes >> b) & 1u)) continue;
        if (o.rep[b] != c[b]) own |= 1u << b;
        crossing |= mirror_crosses_blocks(m[b], o.zone[b], c[b]);
    }
    V mine[4];
    mirrored_channels<V, UNROLL>(params, m, o, own, grid_acc, fixed_mass, fixed_momentum, mine);
    NodeSums s = node_sums(params, mine, counters);
    if (OWN_SUMS) {
        const size_t i = grid_index(params, c[0], c[1], c[2]);
        V own_sums[4];
#pragma unroll
        for (int ch = 0; ch < 4; ++ch) mirror_load(i, ch, grid_acc, fixed_mass, fixed_momentum, own_sums[ch]);
        const NodeSums own_s = own_node_sums(params, own_sums);
        s.own_m = own_s.m;
        for (int a = 0; a < 3; ++a)
            s.push[a] = s.mv[a] / s.m - (own_s.m > 0.0f ? own_s.mv[a] / own_s.m : 0.0f);
    }
    return s;
}

// ---- The binned pipeline's walk over the node-block list ----
// The scatters list the blocks a wall's reach meets from the back of the list and the rest from the
// front (list_node_block in tiles.cuh), with each part's length on the device. A kernel walks each
// part, launched over the most blocks that part can hold (grid_update.rs) so that no launch waits on
// the host to learn a length; CUDA blocks past the length walk nothing.
// - grid_update_blocks, the interior, with no mirror compiled in. When one kernel walked both, the
//   interior blocks paid the mirror's registers (72, against 56 with the mirror compiled out;
//   BENCHMARKS.md M14, w3): at the 16.8M column, where few blocks meet a wall, the update is
//   latency-bound on each listed block's two dependent loads (its entry, then its nodes' sums), DRAM
//   4 % busy, and more registers are fewer warps to wait on them.
// - grid_update_wall_blocks: the blocks a wall's reach meets, adding the walls' images where the
//   launch mirrors (the fused pipeline), its channel loop unrolled (mirrored_channels).
// Each clears its blocks' marks and empties its part of the list when done (empty_list_part).

// One CUDA block of NODE_BLOCK_NODES (64) threads to a listed node block: thread t's node of block b,
// where it is stored, and whether it lies inside the grid's box (the last blocks of an axis may stick
// out).
struct BlockNode {
    u32 c[3];
    u32 i;
    bool inside;
};

__device__ __forceinline__ BlockNode block_node(const KernelParams& params, const NodeBlocks& blocks, u32 b) {
    BlockNode n;
    u32 block[3];
    node_block_of(blocks, b, block);
    n.c[0] = NODE_BLOCK_EDGE * block[0] + (threadIdx.x & 3u);
    n.c[1] = NODE_BLOCK_EDGE * block[1] + ((threadIdx.x >> 2) & 3u);
    n.c[2] = NODE_BLOCK_EDGE * block[2] + (threadIdx.x >> 4);
    n.inside = in_grid_box(params, n.c);
    n.i = grid_index(params, n.c[0], n.c[1], n.c[2]);
    return n;
}

// After a kernel's walk over its part of the list (`listed` entries, `per_step` of them a CUDA block's
// step): the last CUDA block to finish empties the part, so the next substep's scatters start with it
// empty. Emptying it here saves a memset launch after this one, a graph node of its own on every
// substep's critical path (BENCHMARKS.md 0p). Only the CUDA blocks that walk entries count: each read
// the length before the last of them zeroes it; an idle one walks nothing, whether it reads the length
// or 0. Every thread calls it.
__device__ __forceinline__ void empty_list_part(u32 listed, u32 per_step, u32* work_counts, int length_slot,
                                                int done_slot) {
    const u32 walkers = min((listed + per_step - 1) / per_step, gridDim.x);
    if (blockIdx.x < walkers) {
        __syncthreads();  // every warp of the block is past its reads of the length and the list
        if (threadIdx.x == 0 && atomicAdd(&work_counts[done_slot], 1u) == walkers - 1) {
            work_counts[length_slot] = 0;
            work_counts[done_slot] = 0;
        }
    }
}

// A node's sums as the scatter left them (0 the mass, 1 + k momentum k, as mirror_load reads them):
// fixed-point units, or floats.
__device__ __forceinline__ void load_node_sums(size_t i, const float4* grid_acc, const u64*, const u64*, float v[4]) {
    const float4 acc = grid_acc[i];
    v[0] = acc.w;
    v[1] = acc.x;
    v[2] = acc.y;
    v[3] = acc.z;
}

__device__ __forceinline__ void load_node_sums(size_t i, const float4*, const u64* fixed_mass,
                                               const u64* fixed_momentum, i64 v[4]) {
    v[0] = (i64)fixed_mass[i];
    for (int a = 0; a < 3; ++a) v[1 + a] = (i64)fixed_momentum[3 * i + a];
}

// The interior part, V the scatter's sums (i64 in fixed point, float otherwise), GROUP entries a CUDA
// block at a time: the entries, then their nodes' sums, loaded before any is used, so that a warp
// waits on GROUP chains of loads at once (the walk is latency-bound: each entry's sums wait on the
// entry). Per node the same as update_node (and so the same bytes): the sums read, zeroed, converted
// by node_sums (fixed_point_sums, or the floats as they are), the velocity made from them.
template <typename V, int GROUP>
__device__ __forceinline__ void update_interior_blocks(const KernelParams& params, const u32* __restrict__ block_list,
                                                       u32* __restrict__ work_counts, u32* __restrict__ block_marks,
                                                       float4* __restrict__ grid_acc, float4* __restrict__ grid_vel,
                                                       u64* __restrict__ fixed_mass, u64* __restrict__ fixed_momentum,
                                                       StepCounters* __restrict__ counters,
                                                       const Colliders& colliders) {
    const u32 listed = work_counts[WORK_NODE_BLOCKS];
    const NodeBlocks blocks = node_blocks(params);
    for (u32 first = GROUP * blockIdx.x; first < listed; first += GROUP * gridDim.x) {
        // An entry past the length reads the first again, and nothing is done with it.
        u32 b[GROUP], i[GROUP];
        bool live[GROUP];
        V v[GROUP][4];
#pragma unroll
        for (int j = 0; j < GROUP; ++j) b[j] = block_list[first + j < listed ? first + j : first];
#pragma unroll
        for (int j = 0; j < GROUP; ++j) {
            const BlockNode n = block_node(params, blocks, b[j]);
            i[j] = n.i;
            live[j] = n.inside && first + j < listed;
            if (live[j]) load_node_sums(i[j], grid_acc, fixed_mass, fixed_momentum, v[j]);
        }
#pragma unroll
        for (int j = 0; j < GROUP; ++j) {
            if (live[j]) {
                zero_node_sums(params, i[j], grid_acc, fixed_mass, fixed_momentum);
                update_node_velocity(params, i[j], node_sums(params, v[j], counters), grid_vel, colliders);
            }
        }
        if (threadIdx.x == 0) {
#pragma unroll
            for (int j = 0; j < GROUP; ++j)
                if (first + j < listed) block_marks[b[j]] = 0;
        }
    }
    empty_list_part(listed, GROUP, work_counts, WORK_NODE_BLOCKS, WORK_NODE_BLOCKS_DONE);
}

// The interior part, the scatter's mode chosen once for the whole walk.
template <int GROUP>
__device__ __forceinline__ void update_interior(const KernelParams& params, const u32* __restrict__ block_list,
                                                u32* __restrict__ work_counts, u32* __restrict__ block_marks,
                                                float4* __restrict__ grid_acc, float4* __restrict__ grid_vel,
                                                u64* __restrict__ fixed_mass, u64* __restrict__ fixed_momentum,
                                                StepCounters* __restrict__ counters, const Colliders& colliders) {
    if (params.scatter_mode == SCATTER_FIXED_POINT) {
        update_interior_blocks<i64, GROUP>(params, block_list, work_counts, block_marks, grid_acc, grid_vel, fixed_mass,
                                           fixed_momentum, counters, colliders);
    } else {
        update_interior_blocks<float, GROUP>(params, block_list, work_counts, block_marks, grid_acc, grid_vel,
                                             fixed_mass, fixed_momentum, counters, colliders);
    }
}

// The wall blocks' part, walked back from the list's last slot, one entry a CUDA block at a time.
// `mirror`: add the walls' images here (the fused pipeline; 0 where mirror_walls ran before, and then
// these blocks are updated as the interior's are). Every block of this part meets a wall's reach, so
// where the launch mirrors, the whole CUDA block takes the mirror's path. OWN_SUMS, UNROLL as in
// mirrored_sums.
template <bool OWN_SUMS, int UNROLL>
__device__ __forceinline__ void update_wall_blocks(const KernelParams& params, const u32 mirror,
                                                   const u32* __restrict__ block_list, u32* __restrict__ work_counts,
                                                   u32* __restrict__ block_marks, float4* __restrict__ grid_acc,
                                                   float4* __restrict__ grid_vel, u64* __restrict__ fixed_mass,
                                                   u64* __restrict__ fixed_momentum,
                                                   StepCounters* __restrict__ counters, const Colliders& colliders) {
    const u32 listed = work_counts[WORK_WALL_NODE_BLOCKS];
    const NodeBlocks blocks = node_blocks(params);
    const u32 last_slot = node_block_total(blocks) - 1u;
    const bool mirrored_here = mirror != 0u && params.wall_mirror_lo != 0u;
    const MirrorAxis m[3] = {mirror_axis(params, 0), mirror_axis(params, 1), mirror_axis(params, 2)};
    for (u32 k = blockIdx.x; k < listed; k += gridDim.x) {
        const u32 b = block_list[last_slot - k];
        const BlockNode n = block_node(params, blocks, b);
        if (mirrored_here) {  // the same for the whole CUDA block
            NodeSums s{};
            bool crossing = false;
            if (n.inside) {
                s = params.scatter_mode == SCATTER_FIXED_POINT
                        ? mirrored_sums<i64, OWN_SUMS, UNROLL>(params, m, n.c, grid_acc, fixed_mass, fixed_momentum,
                                                              counters, crossing)
                        : mirrored_sums<float, OWN_SUMS, UNROLL>(params, m, n.c, grid_acc, fixed_mass,
                                                                fixed_momentum, counters, crossing);
            }
            __syncthreads();  // every orbit of the block read before any of its nodes is zeroed
            if (n.inside) {
                if (!crossing) zero_node_sums(params, n.i, grid_acc, fixed_mass, fixed_momentum);
                update_node_velocity(params, n.i, s, grid_vel, colliders);
            }
        } else if (n.inside) {
            update_node(params, n.i, grid_acc, grid_vel, fixed_mass, fixed_momentum, counters, colliders);
        }
        if (threadIdx.x == 0) block_marks[b] = 0;
    }
    empty_list_part(listed, 1, work_counts, WORK_WALL_NODE_BLOCKS, WORK_WALL_NODE_BLOCKS_DONE);
}

// The kernels over the list, in pairs that grid_update.rs launches side by side (the two parts hold
// different blocks), all with the same arguments (`mirror` unread by the interior's), a pair for each
// kind of scene:
// - water alone: grid_update_blocks (float sums) or grid_update_blocks_fixed, and
//   grid_update_wall_blocks, with no collider code (the count a constant 0). The colliders' boundary
//   condition, compiled in and never run, took the interior kernel from 36 registers to 56 (one
//   entry a step), the wall kernel from 72 to 88. With those registers back, the interior kernels
//   take several entries a step (WATER_FLOAT_GROUP, WATER_FIXED_GROUP); the other interior kernels
//   take one, as two took them from 56 and 64 to 80.
// - static colliders: grid_update_blocks_colliders and grid_update_wall_blocks_colliders.
// - rigid bodies, whose boundaries also add up what they took from the nodes:
//   grid_update_blocks_bodies and grid_update_wall_blocks_bodies.
// - a Coulomb collider that meets the walls' mirror: grid_update_blocks_colliders and
//   grid_update_wall_blocks_friction.
// The last two wall kernels read the nodes' own sums beside the images (mirrored_sums). Elsewhere the
// exchange (its null pointer a constant) and the own sums are compiled out: the other scenes keep the
// registers, and so the occupancy and the speed, they had before bodies existed.
// The list kernels' parameters: the same for each (grid_update.rs passes them alike); `mirror` is
// unread by the interior's, the colliders' by water's. LIST_WALK: what a walk takes of them after
// `params` (and `mirror` for the wall blocks'), before its colliders.
#define LIST_PARAMETERS                                                                                   \
    const KernelParams params, const u32 mirror, const u32 *__restrict__ block_list,                     \
        u32 *__restrict__ work_counts, u32 *__restrict__ block_marks, float4 *__restrict__ grid_acc,     \
        float4 *__restrict__ grid_vel, u64 *__restrict__ fixed_mass, u64 *__restrict__ fixed_momentum,    \
        StepCounters *__restrict__ counters, const ColliderState *__restrict__ collider_states,           \
        const u32 num_colliders, const float *__restrict__ collider_sdf, u64 *__restrict__ body_impulses
#define LIST_WALK block_list, work_counts, block_marks, grid_acc, grid_vel, fixed_mass, fixed_momentum, counters
// No colliders: the count a constant 0, so their code is compiled out.
#define NO_COLLIDERS Colliders{nullptr, 0u, nullptr, nullptr}

extern "C" __global__ void grid_update_blocks(LIST_PARAMETERS) {
    update_interior_blocks<float, WATER_FLOAT_GROUP>(params, LIST_WALK, NO_COLLIDERS);
}

extern "C" __global__ void grid_update_blocks_fixed(LIST_PARAMETERS) {
    update_interior_blocks<i64, WATER_FIXED_GROUP>(params, LIST_WALK, NO_COLLIDERS);
}

extern "C" __global__ void grid_update_blocks_colliders(LIST_PARAMETERS) {
    update_interior<1>(params, LIST_WALK, Colliders{collider_states, num_colliders, collider_sdf, nullptr});
}

extern "C" __global__ void grid_update_blocks_bodies(LIST_PARAMETERS) {
    update_interior<1>(params, LIST_WALK, Colliders{collider_states, num_colliders, collider_sdf, body_impulses});
}

extern "C" __global__ void grid_update_wall_blocks(LIST_PARAMETERS) {
    update_wall_blocks<false, 4>(params, mirror, LIST_WALK, NO_COLLIDERS);
}

extern "C" __global__ void grid_update_wall_blocks_colliders(LIST_PARAMETERS) {
    update_wall_blocks<false, 4>(params, mirror, LIST_WALK,
                                 Colliders{collider_states, num_colliders, collider_sdf, nullptr});
}

// Held to 12 blocks an SM (at most 80 registers): compiled freely it took 113 and 8 blocks, and its node
// blocks' load chains had too few warps to hide behind; ten floating bodies' substep went from
// +5.6 % to +4.2 % over ten static colliders (BENCHMARKS.md M11; 10 blocks: +5.0 %). Its channel loop
// is not unrolled, which would spill under that bound.
extern "C" __global__ void __launch_bounds__(64, 12) grid_update_wall_blocks_bodies(LIST_PARAMETERS) {
    update_wall_blocks<true, 1>(params, mirror, LIST_WALK,
                                Colliders{collider_states, num_colliders, collider_sdf, body_impulses});
}

// The image push without the bodies' exchange (its null pointer a constant), held to 14 blocks an SM
// (at most 72 registers, what the one kernel over the whole list took), its channel loop not
// unrolled.
extern "C" __global__ void __launch_bounds__(64, 14) grid_update_wall_blocks_friction(LIST_PARAMETERS) {
    update_wall_blocks<true, 1>(params, mirror, LIST_WALK,
                                Colliders{collider_states, num_colliders, collider_sdf, nullptr});
}

// The nodes within wall w's reach (0 where w is not in `walls`): 2 reach + 1 planes across the other
// two axes of the grid's box.
__device__ __forceinline__ u32 wall_reach_nodes(const KernelParams& params, u32 walls, u32 w) {
    if (!((walls >> w) & 1u)) return 0;
    const u32 a = w / 2;
    const MirrorAxis m = mirror_axis(params, a);
    const u32 reach = w & 1u ? m.hi_reach : m.lo_reach;
    return (2 * reach + 1) * params.box_res[(a + 1) % 3] * params.box_res[(a + 2) % 3];
}

// After a grid update that mirrored (the fused pipeline) on a grid where some orbit crosses node
// blocks: zeroes the reach of every wall in `walls` (bit 2a: axis a's low wall, 2a + 1 its high
// wall; the host sets those whose reach spans two node blocks), where grid_update_wall_blocks left
// the crossing nodes' sums.
extern "C" __global__ void clear_crossing_orbits(const KernelParams params, const u32 walls,
                                                 float4* __restrict__ grid_acc,
                                                 u64* __restrict__ fixed_mass,
                                                 u64* __restrict__ fixed_momentum) {
    u32 total = 0;
#pragma unroll
    for (u32 w = 0; w < 6; ++w) total += wall_reach_nodes(params, walls, w);
    FOR_EACH_INDEX(t, total) {
        u32 i = t;
        bool found = false;
        // Wall by wall (unrolled: an array indexed by a run-time wall would live in local memory);
        // within a wall, its reach along its axis fastest, then the other two axes in order.
#pragma unroll
        for (u32 w = 0; w < 6; ++w) {
            const u32 nodes = wall_reach_nodes(params, walls, w);
            if (found || i >= nodes) {
                i -= found ? 0 : nodes;
                continue;
            }
            found = true;
            const u32 a = w / 2;
            const MirrorAxis m = mirror_axis(params, a);
            const u32 centre = w & 1u ? m.hi : m.lo, reach = w & 1u ? m.hi_reach : m.lo_reach;
            const u32 width = 2 * reach + 1, across = params.box_res[(a + 1) % 3];
            u32 c[3];
            c[a] = centre - reach + i % width;
            c[(a + 1) % 3] = params.box_lo[(a + 1) % 3] + (i / width) % across;
            c[(a + 2) % 3] = params.box_lo[(a + 2) % 3] + i / (width * across);
            // A rank's box holds a wall of the slab axis whole, or none of it.
            if (in_grid_box(params, c))
                zero_node_sums(params, grid_index(params, c[0], c[1], c[2]), grid_acc, fixed_mass, fixed_momentum);
        }
    }
}
