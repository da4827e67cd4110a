// The binned pipeline's grid partition and shared-memory tiles.
//
// The grid is cut into node blocks of 4x4x4 nodes. A particle's bin is the node block of its stencil
// base node floor(x/dx - 0.5) at the last binning (bins.cu), so a particle of bin b touches nodes
// [4b, 4b + 5] per axis while it has not moved. A scatter pass runs one CUDA block per bin: it
// accumulates the bin's particles into a tile of shared memory covering [4b - 2, 4b + 7] per axis
// (10^3 nodes: the bin, the stencil's reach, and a halo of 2 nodes for particles that moved since
// binning), then flushes each non-zero tile node to the global grid with one atomic per channel.
// Neighbouring tiles overlap, which is why the flush still adds atomically.
//
// A thread per particle adds each of its contributions to the tile. Why integers: on sm_90,
// atomicAdd on a shared float, or a shared 64-bit integer, compiles to a compare-and-swap loop
// (ATOMS.CAST.SPIN) that the lanes sharing a cell retry in turn, while a 32-bit integer add is one
// native ATOMS.ADD. Each contribution is rounded to tile units (the fixed-point scale of
// `fixed_point_scales`, 2^TILE_UNIT_SHIFT coarser) on its own, in both scatter modes, so no sum
// depends on the particles' order or on the tile partition (a particle outside its tile is rounded
// the same way); the flush adds a node's sum to the global grid as an integer (fixed-point scatter)
// or a float (float scatter). Measured at bench-655k on the H200 (ncu), the float-CAS tile took
// 0.53 ms for p2g, two 32-bit words per 64-bit sum 0.25 ms, one word 0.20 ms, and one word with the
// registers capped for occupancy 0.16 ms. (A thread per cell summing its particles in registers first
// needed 242 registers and took 1.19 ms.)
//
// - A particle whose base has left [4b - 1, 4b + 4] (moved about a cell since binning) sets
//   `rebin_needed`; the host rebins before the next substep choice's steps.
// - One whose stencil has left the tile altogether (only possible past the CFL bound, or when bins are
//   stale) is scattered with global atomics instead, and counted in `tile_misses`; a particle moving
//   faster than the tile's 32-bit sums are checked for (tile_takes, below) goes the same way,
//   uncounted. Nothing is dropped.
// - Every node block that a scatter covers is marked and listed once per substep (`mark_node_block`),
//   so the grid update visits only those: empty space costs nothing. The blocks that a wall's mirror
//   reaches are listed apart from the others (`list_node_block`), for a kernel of their own.
#include "common.cuh"
#include "mirror.cuh"

#define TILE_HALO 2
#define TILE_EDGE 10  // NODE_BLOCK_EDGE + 2 (the stencil's reach) + 2 TILE_HALO
static_assert(TILE_NODES == TILE_EDGE * TILE_EDGE * TILE_EDGE, "TILE_NODES in src/contract/items.rs");
#define TILE_SPAN 3  // node blocks a tile overlaps per axis: b - 1, b, b + 1
#define TILE_SPAN_BLOCKS (TILE_SPAN * TILE_SPAN * TILE_SPAN)
#define BIN_CELLS 64     // cells of a bin (the sort keys of a bin, bins.cu)
// Blocks per multiprocessor the tiled passes are compiled for (their register caps). Measured on the
// H200 (2026-11-23, mpm bench --steps 1500, phase means at 6 / 8 blocks): g2p2g at 8 (64 registers)
// runs bench-655k in 0.090 ms against 0.103 at 6 (80), bench-65k 0.0176 against 0.0169; p2g_tiled
// at 6 (80, from 130, a few spill) runs bench-655k 0.172 ms against 0.190 at 8, where it spills more.
#define G2P2G_MIN_BLOCKS 8
#define P2G_TILED_MIN_BLOCKS 6
// one_pass's float scatter at 5 (96 registers) against 6 (80), H100, 2026-11-25 (BENCHMARKS.md 0n): the
// dam break -1.4 %, bench-65k -3.9 %, the other presets -0.4 to -0.7 % (its fixed-point scatter at 5
// was then 3.8 % slower at the dam break; see below for now).
#define ONE_PASS_FLOAT_MIN_BLOCKS 5
// Its plane-by-plane float scatter at 4 (128 registers: at 5 its 36 sums spill), H100, 2026-11-26
// (BENCHMARKS.md 0t).
#define ONE_PASS_FLOAT_PLANES_MIN_BLOCKS 4
// Its fixed-point scatter at 5 (96 registers) since the gather sums by rows (common.cuh), which at 6
// (80) spilled: 2.8 % off `dam-break-1m` in fixed point against the rows' gather at 6 with the old
// gather kept for this entry point alone, 0.2 % off the dam break and bench-655k (H100, 2026-11-27,
// BENCHMARKS.md 0y; at 6 with the rows' gather the dam break lost 3 %).
#define ONE_PASS_FIXED_MIN_BLOCKS 5

// Tile units are global fixed-point units / 2^TILE_UNIT_SHIFT: a cell's mass at rest is 2^27 units
// (resolution 7e-9 of it, finer than a float sum), and a tile node's sum stays under 2^31 up to about
// 16 cells' mass, or the momentum of a cell's mass at 16 times the reference speed.
#define TILE_UNIT_SHIFT 13
// The most tile units of a particle's mass for which a tile takes it (tile_takes): its contributions
// (at most 0.75^3 of it, momentum as mass) then stay below 2^27 units, far inside 32 bits. A cell's
// mass is 2^27 units, so a lattice of 1 to 64 particles per cell fits.
#define TILE_UNIT_MASS_LIMIT 268435456.0f /* 2^28 */


// The grid box's node blocks (the box starts on a block's edge: src/cuda/grid.rs `GridBox`). Kernels
// name a block by its domain coordinates (node / NODE_BLOCK_EDGE); the marks and lists by its index
// in the box, which is also the index of the bin of its nodes.
struct NodeBlocks {
    u32 count[3];  // node blocks per axis
    u32 lo[3];     // the box's first block
};

__device__ __forceinline__ NodeBlocks node_blocks(const KernelParams& params) {
    NodeBlocks b;
    for (int a = 0; a < 3; ++a) {
        b.count[a] = (params.box_res[a] + NODE_BLOCK_EDGE - 1) / NODE_BLOCK_EDGE;
        b.lo[a] = params.box_lo[a] / NODE_BLOCK_EDGE;
    }
    return b;
}

__device__ __forceinline__ u32 node_block_index(const NodeBlocks& blocks, u32 bx, u32 by, u32 bz) {
    return (bx - blocks.lo[0]) + blocks.count[0] * ((by - blocks.lo[1]) + blocks.count[1] * (bz - blocks.lo[2]));
}

// The domain coordinates of the block at index b.
__device__ __forceinline__ void node_block_of(const NodeBlocks& blocks, u32 b, u32 block[3]) {
    block[0] = blocks.lo[0] + b % blocks.count[0];
    block[1] = blocks.lo[1] + (b / blocks.count[0]) % blocks.count[1];
    block[2] = blocks.lo[2] + b / (blocks.count[0] * blocks.count[1]);
}

__device__ __forceinline__ u32 node_block_total(const NodeBlocks& blocks) {
    return blocks.count[0] * blocks.count[1] * blocks.count[2];
}

// The work lists that the scatters fill and the grid update walks.
struct BlockMarks {
    u32* marks;        // one per node block: 1 once listed this substep (the grid update clears it)
    u32* list;         // a slot per node block of the grid, in two parts (list_node_block)
    u32* work_counts;  // [WORK_NODE_BLOCKS], [WORK_WALL_NODE_BLOCKS]: the two parts' lengths
};

// Appends node block b, marked just now, to its part of the list. The list has a slot for every node
// block of the grid and is filled from both ends: the blocks that some wall's mirror reaches
// (`on_a_wall`, node_block_on_a_wall) from the back, every other block from the front. The grid
// update walks the two parts in two kernels (kernels/grid_update.cu), the front in one compiled
// without the mirror, whose registers would otherwise slow every block (issue 47), the back in one
// with it. A block is listed at most once a substep, so the parts never meet.
__device__ __forceinline__ void list_node_block(const NodeBlocks& blocks, const BlockMarks& m, u32 b, bool on_a_wall) {
    if (on_a_wall) {
        m.list[node_block_total(blocks) - 1u - atomicAdd(&m.work_counts[WORK_WALL_NODE_BLOCKS], 1u)] = b;
    } else {
        m.list[atomicAdd(&m.work_counts[WORK_NODE_BLOCKS], 1u)] = b;
    }
}

// Lists node block (bx, by, bz) once per substep. The plain read first skips the atomic for blocks
// already listed, which are most of them; only the block that lists it asks which part it goes in.
__device__ __forceinline__ void mark_node_block(const KernelParams& params, const BlockMarks& m,
                                                const NodeBlocks& blocks, u32 bx, u32 by, u32 bz) {
    const u32 b = node_block_index(blocks, bx, by, bz);
    if (m.marks[b] == 0u && atomicExch(&m.marks[b], 1u) == 0u) {
        list_node_block(blocks, m, b, node_block_on_a_wall(params, bx, by, bz));
    }
}

// Marks the node blocks that a stencil's 27 nodes fall in (at most 2 per axis), from global memory:
// for particles scattered outside their tile.
__device__ __forceinline__ void mark_stencil_blocks(const KernelParams& params, const BlockMarks& m,
                                                    const NodeBlocks& blocks, const Stencil& s) {
    for (u32 bz = s.base[2] / NODE_BLOCK_EDGE; bz <= (s.base[2] + 2) / NODE_BLOCK_EDGE; ++bz)
        for (u32 by = s.base[1] / NODE_BLOCK_EDGE; by <= (s.base[1] + 2) / NODE_BLOCK_EDGE; ++by)
            for (u32 bx = s.base[0] / NODE_BLOCK_EDGE; bx <= (s.base[0] + 2) / NODE_BLOCK_EDGE; ++bx)
                mark_node_block(params, m, blocks, bx, by, bz);
}

// A bin's tile: shared accumulators for CHANNELS values per node, floats or fixed-point integers,
// and a mark per node block the tile overlaps.
struct Tile {
    int origin[3];  // grid node of tile node (0, 0, 0): 4 b - TILE_HALO per axis
    u32 bin[3];     // its bin's node block, in domain coordinates
};

__device__ __forceinline__ Tile make_tile(const NodeBlocks& blocks, u32 bin) {
    Tile t;
    node_block_of(blocks, bin, t.bin);
    for (int a = 0; a < 3; ++a) t.origin[a] = (int)(NODE_BLOCK_EDGE * t.bin[a]) - TILE_HALO;
    return t;
}

// Where a stencil starts in the tile. False where it does not fit (the caller scatters globally);
// `far` is set where the base has moved past [4 b - 1, 4 b + 4], the bins' reach.
__device__ __forceinline__ bool tile_stencil(const Tile& t, const Stencil& s, u32& first, bool& far) {
    bool fits = true;
    int local[3];
    for (int a = 0; a < 3; ++a) {
        local[a] = (int)s.base[a] - t.origin[a];
        fits &= local[a] >= 0 && local[a] <= TILE_EDGE - 3;
        far |= local[a] < TILE_HALO - 1 || local[a] > TILE_HALO + (int)NODE_BLOCK_EDGE;
    }
    first = (u32)(local[0] + TILE_EDGE * (local[1] + TILE_EDGE * local[2]));
    return fits;
}

// Marks, in the tile's own marks, the node blocks of a stencil that starts at tile node `first`:
// tile coordinate l lies in the tile's node block (l + TILE_HALO) / 4 (0..2 per axis).
__device__ __forceinline__ void tile_mark_stencil(u32* tile_marks, u32 first) {
    const u32 l[3] = {first % TILE_EDGE, (first / TILE_EDGE) % TILE_EDGE, first / (TILE_EDGE * TILE_EDGE)};
    for (u32 bz = (l[2] + TILE_HALO) / 4; bz <= (l[2] + 2 + TILE_HALO) / 4; ++bz)
        for (u32 by = (l[1] + TILE_HALO) / 4; by <= (l[1] + 2 + TILE_HALO) / 4; ++by)
            for (u32 bx = (l[0] + TILE_HALO) / 4; bx <= (l[0] + 2 + TILE_HALO) / 4; ++bx)
                tile_marks[bx + TILE_SPAN * (by + TILE_SPAN * bz)] = 1u;
}

// The node blocks of the tile's 27 (bit bx + 3 (by + 3 bz), as the tile's marks) that a stencil
// starting at tile node `first` covers: tile_mark_stencil's marks as a word, for a pass that merges a
// warp's marks in registers (warp_list_marked_blocks) instead of in shared memory.
__device__ __forceinline__ u32 tile_stencil_block_bits(u32 first) {
    const u32 l[3] = {first % TILE_EDGE, (first / TILE_EDGE) % TILE_EDGE, first / (TILE_EDGE * TILE_EDGE)};
    u32 bits = 0u;
    for (u32 bz = (l[2] + TILE_HALO) / 4; bz <= (l[2] + 2 + TILE_HALO) / 4; ++bz)
        for (u32 by = (l[1] + TILE_HALO) / 4; by <= (l[1] + 2 + TILE_HALO) / 4; ++by)
            for (u32 bx = (l[0] + TILE_HALO) / 4; bx <= (l[0] + 2 + TILE_HALO) / 4; ++bx)
                bits |= 1u << (bx + TILE_SPAN * (by + TILE_SPAN * bz));
    return bits;
}

// A particle whose stencil does not fit its bin's tile: scattered to the grid instead, its node blocks
// marked there, the miss counted.
__device__ __forceinline__ void tile_miss(const KernelParams& params, const Stencil& s, const BlockMarks& marks,
                                          const NodeBlocks& blocks, u32& misses) {
    ++misses;
    mark_stencil_blocks(params, marks, blocks, s);
}

// Where a particle's contributions go: true where its stencil fits its bin's tile (`first` is the
// tile node of its base, its node blocks marked in the tile's marks); false where it is scattered to
// the grid instead (tile_miss). `far` as in tile_stencil.
__device__ __forceinline__ bool tile_place(const KernelParams& params, const Tile& t, const Stencil& s, u32& first,
                                           bool& far, u32* tile_marks, const BlockMarks& marks,
                                           const NodeBlocks& blocks, u32& misses) {
    if (tile_stencil(t, s, first, far)) {
        tile_mark_stencil(tile_marks, first);
        return true;
    }
    tile_miss(params, s, marks, blocks, misses);
    return false;
}

// tile_place for a pass that merges a warp's marks in registers: the stencil's node blocks go into the
// lane's `covered` bits (tile_stencil_block_bits) instead of the tile's marks.
__device__ __forceinline__ bool tile_place_bits(const KernelParams& params, const Tile& t, const Stencil& s, u32& first,
                                                bool& far, u32& covered, const BlockMarks& marks,
                                                const NodeBlocks& blocks, u32& misses) {
    if (tile_stencil(t, s, first, far)) {
        covered |= tile_stencil_block_bits(first);
        return true;
    }
    tile_miss(params, s, marks, blocks, misses);
    return false;
}

// CHANNELS 32-bit accumulators (tile units) per tile node in dynamic shared memory, channel-major:
// the host sizes it at 4 CHANNELS TILE_NODES bytes.
extern __shared__ __align__(16) int tile_memory[];

// The tile, its accumulators and marks zeroed for a CUDA block's first chunk: each flush leaves them
// zero for the next (FOR_EACH_TILE_NODE_IN_GRID). A block that walks none of the `listed` chunks
// skips the clear (clearing in every block of the launch made bench-65k 9 % slower, BENCHMARKS.md
// 0w). Every thread of the block calls it before the walk; the clear ends with a barrier.
template <int CHANNELS>
__device__ __forceinline__ int* tile_clear(u32* tile_marks, u32 listed) {
    if (blockIdx.x < listed) {
        for (u32 k = threadIdx.x; k < CHANNELS * TILE_NODES; k += blockDim.x) tile_memory[k] = 0;
        for (u32 k = threadIdx.x; k < TILE_SPAN_BLOCKS; k += blockDim.x) tile_marks[k] = 0u;
        __syncthreads();
    }
    return tile_memory;
}

// Tile units per kilogram and per kg m/s: the fixed-point scales (fixed_point_scales) over
// 2^TILE_UNIT_SHIFT. Every fixed-point contribution, in a tile or on the grid, is rounded in these.
struct TileScales {
    float mass, momentum;
};

__device__ __forceinline__ TileScales tile_scales(const KernelParams& params) {
    const float unit = 1.0f / (float)(1 << TILE_UNIT_SHIFT);
    return TileScales{params.fixed_mass_scale * unit, params.fixed_momentum_scale * unit};
}

// A tile node's sum (or a rounded contribution) in global fixed-point units.
__device__ __forceinline__ u64 tile_global_units(i64 units) {
    return (u64)(units << TILE_UNIT_SHIFT);
}

// ---- The tile's 32-bit sums, checked without the atomics' returns ----
// A tile adds each contribution with an atomic whose old value nothing reads: reading it, to catch a
// 32-bit wrap as it happened, held one_pass_fixed's warps on every add's return (the fixed-point
// substep 9 % longer at bench-655k and dam-break-1m, BENCHMARKS.md 0v). Whether a sum may have wrapped
// is settled after the adds instead, from the node's mass, and counted as a fixed-point overflow:
// - the tile takes a particle only where none of its momentum contributions can pass its mass
//   contribution's units (tile_takes: at most the momentum units' reference speed, 4 to 8 times the
//   fastest particle's, Simulation::momentum_scale); a faster one goes to the grid, where its integers are the same. So a
//   node's momentum sums over a chunk of n particles are at most M + n/2 + n/2 in magnitude, M its
//   mass sum in tile units, and a node with M past 2^31 (1 - 2^-8) - n is counted (tile_mass_limit):
//   about 16 cells' mass, within 0.4 % of where the signed sums' check counted a node before;
// - mass contributions are never negative, so a mass sum wraps only past 2^32, and then reads small:
//   where a chunk could put that much on one node, each thread counts the mass units it added
//   (tile_scatter's return) and those it flushed; over a CUDA block the difference is 2^32 times its
//   wraps (tile_count_mass_wraps).
// Neither check runs for a chunk too small to reach 2^31 on any node (tile_chunk_may_wrap): at 8
// particles per cell, any chunk of up to 302 particles (on an H100, every chunk of a scene of up to
// 1.6 million particles).
#define TILE_SUM_LIMIT 2139095040.0f /* 2^31 (1 - 2^-8): room for the bounds' own rounding */
#define TILE_MAX_WEIGHT 0.4219f      /* a stencil node's largest weight, 0.75^3 (rounded up) */

// The most tile units a particle's momentum contributions can have per unit weight: |d| <= 1.5 dx
// per axis (impulse_at). NaN where its state is not finite (fmaxf alone would drop a NaN).
__device__ __forceinline__ float tile_reach(const ParticleImpulse& q, float momentum_tile_scale) {
    float reach = 0.0f, poison = 0.0f;
    for (int row = 0; row < 3; ++row) {
        const float affine = fabsf(q.affine[0][row]) + fabsf(q.affine[1][row]) + fabsf(q.affine[2][row]);
        const float bound = fabsf(q.mv[row]) + 1.5f * affine;
        reach = fmaxf(reach, bound);
        poison += 0.0f * bound;
    }
    return (reach + poison) * momentum_tile_scale;
}

// Whether a tile takes a particle at stencil `s` of reach `reach` (tile_reach; 0 for a mass-only
// tile), given the tile units of a particle's mass. Not one whose position or state is not finite:
// on the grid, fixed_point_units counts its NaN contributions as overflows.
__device__ __forceinline__ bool tile_takes(const Stencil& s, float reach, float unit_mass) {
    const float poison = 0.0f * (s.fx[0] + s.fx[1] + s.fx[2]);
    return reach + poison <= unit_mass && unit_mass <= TILE_UNIT_MASS_LIMIT;
}

// Whether a chunk of n particles could bring any node's tile sums to 2^31: each adds at most
// TILE_MAX_WEIGHT of its unit mass to a node, its momentum no more (tile_takes), each rounded by 1/2.
__device__ __forceinline__ bool tile_chunk_may_wrap(u32 n, float unit_mass) {
    return (float)n * (TILE_MAX_WEIGHT * unit_mass + 0.5f) >= TILE_SUM_LIMIT;
}

// The mass sum (tile units) from which a node's sums over a chunk of n particles may have left 32
// bits: |momentum| <= M + n/2 + n/2.
__device__ __forceinline__ u32 tile_mass_limit(u32 n) {
    return (u32)(TILE_SUM_LIMIT - (float)n);
}

// Counts the mass wraps of a CUDA block's tiles: `balance` is the thread's mass units added
// (tile_scatter) less those it flushed, over its chunks that tile_chunk_may_wrap. Every thread of the
// block calls it, after its last chunk, where any of the block's chunks may have wrapped.
__device__ __forceinline__ void tile_count_mass_wraps(i64 balance, StepCounters* counters) {
    __shared__ i64 warp_balance[TILE_THREADS / 32];
    for (u32 offset = 16; offset > 0; offset >>= 1) balance += __shfl_xor_sync(0xffffffffu, balance, offset);
    if ((threadIdx.x & 31u) == 0u) warp_balance[threadIdx.x / 32] = balance;
    __syncthreads();
    if (threadIdx.x == 0) {
        i64 block = 0;
        for (u32 w = 0; w < blockDim.x / 32; ++w) block += warp_balance[w];
        // A whole number of 2^32s; anything else would be a bug here, reported all the same.
        const u32 wraps = (u32)((u64)block >> 32);
        if (block != 0) atomicAdd(&counters->fixed_overflows, wraps ? wraps : 1u);
    }
}

// The grid node of a stencil node given as its tile offset from the stencil's base (a constant in the
// unrolled stencil loops, so this folds to one multiply-add).
__device__ __forceinline__ u32 stencil_node(const Stencil& s, const KernelParams& params, u32 offset) {
    const u32 o[3] = {offset % TILE_EDGE, (offset / TILE_EDGE) % TILE_EDGE, offset / (TILE_EDGE * TILE_EDGE)};
    return s.base_index + o[0] + params.box_res[0] * (o[1] + params.box_res[1] * o[2]);
}

// A contribution the tile did not take, to the global grid: fixed point rounded as the tile rounds
// (so sums do not depend on which particles a tile held), or a float.
__device__ __forceinline__ void grid_add(float* grid_float, u64* grid_fixed, bool fixed, float tile_scaled,
                                         float value, StepCounters* counters) {
    if (!fixed) {
        atomicAdd(grid_float, value);
    } else if (const i64 units = fixed_point_units(tile_scaled, counters)) {
        atomicAdd(grid_fixed, tile_global_units(units));
    }
}

// One axis of a stencil in a lane's own order: its entry i is node (i + r) mod 3 of the axis, with
// that node's weight, offset d (node - fx, as FOR_EACH_STENCIL_NODE_AT computes it) and tile stride.
struct StaggeredAxis {
    float w[3], d[3];
    u32 offset[3];
};

// Selected, not indexed: a dynamic index would put the stencil in local memory.
__device__ __forceinline__ StaggeredAxis staggered_axis(const Stencil& s, int a, u32 r, u32 stride) {
    const float d[3] = {0.0f - s.fx[a], 1.0f - s.fx[a], 2.0f - s.fx[a]};
    StaggeredAxis o;
#pragma unroll
    for (u32 i = 0; i < 3; ++i) {
        const u32 j = i + r >= 3 ? i + r - 3 : i + r;
        o.w[i] = j == 0 ? s.w[0][a] : j == 1 ? s.w[1][a] : s.w[2][a];
        o.d[i] = j == 0 ? d[0] : j == 1 ? d[1] : d[2];
        o.offset[i] = j * stride;
    }
    return o;
}

// FOR_EACH_STENCIL_NODE_AT over a tile, each lane starting its x and y rows at its own node (lane mod
// 9 chooses): lanes of a warp whose particles share a cell add to nine different nodes at each step
// instead of all to one, which a shared atomic serialises. The same values as the plain order, so
// the same integers summed. Measured on the H100 (BENCHMARKS.md 0w): one_pass_fixed's bank conflicts
// 10.8 -> 4.3 million at the dam break, its substep 22 % shorter; all three axes (lane mod 27) took
// the conflicts to 2.9 million and the time nowhere.
#define FOR_EACH_TILE_STENCIL_NODE_STAGGERED(s, first, k, weight, d0, d1, d2, ...)                   \
    {                                                                                              \
        const u32 _lane = threadIdx.x & 31u;                                                       \
        const StaggeredAxis _x = staggered_axis((s), 0, _lane % 3u, 1u);                           \
        const StaggeredAxis _y = staggered_axis((s), 1, (_lane / 3u) % 3u, TILE_EDGE);             \
        _Pragma("unroll") for (int _oz = 0; _oz < 3; ++_oz) {                                      \
            const float _wz = (s).w[_oz][2];                                                       \
            const float d2 = (float)_oz - (s).fx[2];                                               \
            _Pragma("unroll") for (int _oy = 0; _oy < 3; ++_oy) {                                  \
                const float _wyz = _y.w[_oy] * _wz;                                                \
                const float d1 = _y.d[_oy];                                                        \
                const u32 _row = (first) + _y.offset[_oy] + _oz * (TILE_EDGE * TILE_EDGE);         \
                _Pragma("unroll") for (int _ox = 0; _ox < 3; ++_ox) {                              \
                    const float d0 = _x.d[_ox];                                                    \
                    const u32 k = _row + _x.offset[_ox];                                           \
                    const float weight = _x.w[_ox] * _wyz;                                         \
                    __VA_ARGS__                                                                    \
                }                                                                                  \
            }                                                                                      \
        }                                                                                          \
    }

// A particle's scatter: CHANNELS contributions to each stencil node, computed by
// `values(w, d0, d1, d2, value)`, `tile_scale` their tile units per unit; into its bin's tile where
// the tile takes it (`taken`: its stencil fits, tile_place, and tile_takes), to the grid through
// `to_grid(node, channel, tile_scaled, value)` otherwise. Returns the units it added to the tile's
// channel 0 (the mass balance's, where channel 0 is mass). `values` runs in both branches and a
// particle's integers must not depend on which one added them, so it rounds as written (__fmul_rn,
// __fadd_rn, impulse_at_pinned): left to itself, NVRTC contracted one branch into fused multiply-adds
// and not the other. Measured on the H100 (BENCHMARKS.md 0u): with a branch and a fallback for each of
// one_pass_fixed's 108 contributions, instruction fetch stalled 23 % of its samples and its
// fixed-point substep took 0.239 ms at bench-655k, 0.178 without.
template <int CHANNELS, typename Values, typename ToGrid>
__device__ __forceinline__ u32 tile_scatter(const Stencil& s, const KernelParams& params, u32 first, bool taken, int* tile,
                                            const float (&tile_scale)[CHANNELS], Values values, ToGrid to_grid) {
    u32 added = 0;
    if (taken) {
        FOR_EACH_TILE_STENCIL_NODE_STAGGERED(s, first, k, w, d0, d1, d2, {
            float value[CHANNELS];
            values(w, d0, d1, d2, value);
            for (int ch = 0; ch < CHANNELS; ++ch) {
                // Rounded as fixed_point_units rounds (no contribution the tile takes reaches 2^27 units).
                const int units = __float2int_rn(__fmul_rn(value[ch], tile_scale[ch]));
                atomicAdd(&tile[ch * TILE_NODES + k], units);
                if (ch == 0) added += (u32)units;
            }
        })
    } else {
        FOR_EACH_STENCIL_NODE_AT(s, first, TILE_EDGE, TILE_EDGE * TILE_EDGE, k, w, d0, d1, d2, {
            float value[CHANNELS];
            values(w, d0, d1, d2, value);
            const u32 node = stencil_node(s, params, k - first);
            for (int ch = 0; ch < CHANNELS; ++ch) to_grid(node, ch, __fmul_rn(value[ch], tile_scale[ch]), value[ch]);
        })
    }
    return added;
}

// Lists the grid's node block of the tile's node block k (0..26, as the tile's marks), once per
// substep.
__device__ __forceinline__ void mark_tile_node_block(const KernelParams& params, const Tile& t, const NodeBlocks& blocks,
                                                     const BlockMarks& marks, u32 k) {
    mark_node_block(params, marks, blocks, t.bin[0] + k % TILE_SPAN - 1, t.bin[1] + (k / TILE_SPAN) % TILE_SPAN - 1,
                    t.bin[2] + k / (TILE_SPAN * TILE_SPAN) - 1);
}

// Lists, once per substep, the node blocks marked in the tile's marks (global atomics), clearing the
// marks for the next chunk. Every thread of the block calls it after a barrier; it ends with one.
__device__ __forceinline__ void tile_list_marked_blocks(const KernelParams& params, const Tile& t,
                                                        const NodeBlocks& blocks, const BlockMarks& marks,
                                                        u32* tile_marks) {
    for (u32 k = threadIdx.x; k < TILE_SPAN_BLOCKS; k += blockDim.x) {
        if (tile_marks[k]) mark_tile_node_block(params, t, blocks, marks, k);
        tile_marks[k] = 0u;
    }
    __syncthreads();
}

// Lists, once per substep, the node blocks that any lane of the warp covered (`covered`: each lane's
// tile_stencil_block_bits merged), a lane per block, with no barrier: the warp goes on to its next
// chunk while the others of its CUDA block are still in this one. Every lane of the warp calls it.
__device__ __forceinline__ void warp_list_marked_blocks(const KernelParams& params, const Tile& t,
                                                        const NodeBlocks& blocks, const BlockMarks& marks,
                                                        u32 covered) {
#if __CUDA_ARCH__ >= 800
    covered = __reduce_or_sync(0xffffffffu, covered);
#else
    for (u32 offset = 16; offset > 0; offset >>= 1) covered |= __shfl_xor_sync(0xffffffffu, covered, offset);
#endif
    const u32 k = threadIdx.x & 31u;
    if (k < TILE_SPAN_BLOCKS && (covered >> k & 1u)) mark_tile_node_block(params, t, blocks, marks, k);
}

// Calls body(k, node, sums) for each tile node k inside the grid, `node` its grid index and `sums` its
// CHANNELS accumulators. Every node's accumulators are zeroed as they are read, inside the grid or
// not, so the next chunk finds the tile clear without a pass of its own (tile_clear runs once, before
// the first). Starts with a barrier; the caller ends with one before the tile is added to again.
#define FOR_EACH_TILE_NODE_FLUSHED(CHANNELS, tile, t, params, k, node, sums, ...)                                \
    {                                                                                                            \
        __syncthreads();                                                                                         \
        for (u32 k = threadIdx.x; k < TILE_NODES; k += blockDim.x) {                                             \
            int sums[CHANNELS];                                                                                  \
            for (int _ch = 0; _ch < (CHANNELS); ++_ch) {                                                         \
                sums[_ch] = (tile)[_ch * TILE_NODES + k];                                                        \
                (tile)[_ch * TILE_NODES + k] = 0;                                                                \
            }                                                                                                    \
            const u32 _g[3] = {(u32)((t).origin[0] + (int)(k % TILE_EDGE)),                                  \
                               (u32)((t).origin[1] + (int)((k / TILE_EDGE) % TILE_EDGE)),                        \
                               (u32)((t).origin[2] + (int)(k / (TILE_EDGE * TILE_EDGE)))};                       \
            if (!in_grid_box((params), _g)) continue; /* a node below 0 wraps past every box */                  \
            const u32 node = grid_index((params), _g[0], _g[1], _g[2]);                                          \
            __VA_ARGS__                                                                                          \
        }                                                                                                        \
    }

// FOR_EACH_TILE_NODE_FLUSHED, then the marked node blocks listed (and the marks cleared as they are),
// ending with the barrier.
#define FOR_EACH_TILE_NODE_IN_GRID(CHANNELS, tile, t, params, blocks, block_marks, tile_marks, k, node, sums, ...) \
    {                                                                                                            \
        FOR_EACH_TILE_NODE_FLUSHED(CHANNELS, tile, t, params, k, node, sums, __VA_ARGS__)                        \
        tile_list_marked_blocks((params), (t), (blocks), (block_marks), tile_marks);                             \
    }
