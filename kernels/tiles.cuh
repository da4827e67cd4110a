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
// - A particle whose base has left [4b - 1, 4b + 4] (moved about a cell since binning) sets
//   `rebin_needed`; the host rebins before the next substep choice's steps.
// - One whose stencil has left the tile altogether (only possible past the CFL bound) is scattered
//   with global atomics instead, and counted in `tile_misses`: nothing is dropped.
// - Every node block that a scatter covers is marked and listed once per substep (`mark_node_block`),
//   so grid_update_blocks visits only those: empty space costs nothing.
//
// Tiles accumulate 64-bit fixed point in both scatter modes (the scales of `fixed_point_scales`),
// each contribution rounded on its own: integer adds commute, so neither the bin order nor the tile
// partition changes a tile's sums. The flush adds them to the global grid as integers (fixed-point
// scatter) or as floats (float scatter). Why not float tiles: on sm_90, atomicAdd on a shared float,
// and on a shared 64-bit integer, compiles to a compare-and-swap loop (ATOMS.CAST.SPIN), which the
// lanes of a warp that share a cell retry in turn; a 32-bit integer add is one native ATOMS.ADD. So
// each 64-bit accumulator is two 32-bit words (tile_add).
#include "common.cuh"

#define NODE_BLOCK_EDGE 4u
#define NODE_BLOCK_NODES 64u
#define TILE_HALO 2
#define TILE_EDGE 10  // NODE_BLOCK_EDGE + 2 (the stencil's reach) + 2 TILE_HALO
#define TILE_NODES (TILE_EDGE * TILE_EDGE * TILE_EDGE)
#define TILE_SPAN 3  // node blocks a tile overlaps per axis: b - 1, b, b + 1
#define TILE_SPAN_BLOCKS (TILE_SPAN * TILE_SPAN * TILE_SPAN)

// Slots of the work-count buffer (src/cuda/bins.rs): list lengths the passes read on the device, so
// no launch waits for the host to learn them.
#define WORK_BINS 0
#define WORK_NODE_BLOCKS 1

// One listed bin: its node block and its particles' range in the bin order. Mirrors `BinEntry` in
// src/cuda/bins.rs.
struct BinEntry {
    u32 bin;
    u32 start;
    u32 count;
    u32 _pad;
};
static_assert(sizeof(BinEntry) == 16, "BinEntry must match src/cuda/bins.rs");

struct NodeBlocks {
    u32 count[3];  // node blocks per axis
};

__device__ __forceinline__ NodeBlocks node_blocks(const Params& params) {
    NodeBlocks b;
    for (int a = 0; a < 3; ++a) b.count[a] = (params.grid_res[a] + NODE_BLOCK_EDGE - 1) / NODE_BLOCK_EDGE;
    return b;
}

__device__ __forceinline__ u32 node_block_index(const NodeBlocks& blocks, u32 bx, u32 by, u32 bz) {
    return bx + blocks.count[0] * (by + blocks.count[1] * bz);
}

// The work lists that the scatters fill and grid_update_blocks walks.
struct BlockMarks {
    u32* marks;        // one per node block: 1 once listed this substep (grid_update_blocks clears it)
    u32* list;         // the listed node blocks
    u32* work_counts;  // [WORK_NODE_BLOCKS]: the list's length
};

// Lists node block b once per substep. The plain read first skips the atomic for blocks already
// listed, which are most of them.
__device__ __forceinline__ void mark_node_block(const BlockMarks& m, u32 b) {
    if (m.marks[b] == 0u && atomicExch(&m.marks[b], 1u) == 0u) {
        m.list[atomicAdd(&m.work_counts[WORK_NODE_BLOCKS], 1u)] = b;
    }
}

// Marks the node blocks that a stencil's 27 nodes fall in (at most 2 per axis), from global memory:
// for particles scattered outside their tile.
__device__ __forceinline__ void mark_stencil_blocks(const BlockMarks& m, const NodeBlocks& blocks, const Stencil& s) {
    for (u32 bz = s.base[2] / NODE_BLOCK_EDGE; bz <= (s.base[2] + 2) / NODE_BLOCK_EDGE; ++bz)
        for (u32 by = s.base[1] / NODE_BLOCK_EDGE; by <= (s.base[1] + 2) / NODE_BLOCK_EDGE; ++by)
            for (u32 bx = s.base[0] / NODE_BLOCK_EDGE; bx <= (s.base[0] + 2) / NODE_BLOCK_EDGE; ++bx)
                mark_node_block(m, node_block_index(blocks, bx, by, bz));
}

// A bin's tile: shared accumulators for CHANNELS values per node, floats or fixed-point integers,
// and a mark per node block the tile overlaps.
struct Tile {
    int origin[3];  // grid node of tile node (0, 0, 0): 4 b - TILE_HALO per axis
    u32 bin[3];
};

__device__ __forceinline__ Tile make_tile(const NodeBlocks& blocks, u32 bin) {
    Tile t;
    t.bin[0] = bin % blocks.count[0];
    t.bin[1] = (bin / blocks.count[0]) % blocks.count[1];
    t.bin[2] = bin / (blocks.count[0] * blocks.count[1]);
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

// CHANNELS 64-bit fixed-point accumulators per tile node, each as a low and a high 32-bit word, in
// the dynamic shared memory (the host sizes it: 8 CHANNELS TILE_NODES bytes).
template <int CHANNELS>
struct TileAccumulators {
    u32* lo;  // [CHANNELS][TILE_NODES]
    u32* hi;  // [CHANNELS][TILE_NODES]
};

extern __shared__ __align__(16) u32 tile_memory[];

// Zeroes the accumulators and the tile's marks. Ends with a barrier.
template <int CHANNELS>
__device__ __forceinline__ TileAccumulators<CHANNELS> tile_clear(u32* tile_marks) {
    for (u32 k = threadIdx.x; k < 2 * CHANNELS * TILE_NODES; k += blockDim.x) tile_memory[k] = 0u;
    for (u32 k = threadIdx.x; k < TILE_SPAN_BLOCKS; k += blockDim.x) tile_marks[k] = 0u;
    __syncthreads();
    return TileAccumulators<CHANNELS>{tile_memory, tile_memory + CHANNELS * TILE_NODES};
}

// Adds `scaled` (fixed-point units, rounded here) to accumulator k: the low word natively, and the
// high word plus the low word's carry. The carries add up to the same total in any order, so the
// 64-bit sum is exact. Out-of-range contributions are counted, as fixed_point_add does.
template <int CHANNELS>
__device__ __forceinline__ void tile_add(const TileAccumulators<CHANNELS>& t, u32 k, float scaled,
                                         StepCounters* counters) {
    if (!(fabsf(scaled) < FIXED_CONTRIBUTION_LIMIT)) {  // also catches NaN
        atomicAdd(&counters->fixed_overflows, 1u);
        return;
    }
#ifdef TILE_WORDS32
    const int units = __float2int_rn(scaled * (1.0f / (float)(1 << TILE_WORDS32)));
#ifdef EXPERIMENT_PLAIN_STORES
    t.lo[k] += (u32)units;
    return;
#endif
    const int before = (int)atomicAdd(&t.lo[k], (u32)units);
    const int after = (int)((u32)before + (u32)units);
    if ((units > 0 && after < before) || (units < 0 && after > before)) atomicAdd(&counters->fixed_overflows, 1u);
#else
    const u64 units = (u64)__float2ll_rn(scaled);
    const u32 lo = (u32)units, hi = (u32)(units >> 32);
    const u32 before = lo ? atomicAdd(&t.lo[k], lo) : 0u;
    const u32 carry = before + lo < before ? 1u : 0u;
    if (hi + carry) atomicAdd(&t.hi[k], hi + carry);
#endif
}

template <int CHANNELS>
__device__ __forceinline__ u64 tile_units(const TileAccumulators<CHANNELS>& t, u32 k) {
#ifdef TILE_WORDS32
    return (u64)((i64)(int)t.lo[k] << TILE_WORDS32);
#else
    return ((u64)t.hi[k] << 32) | t.lo[k];
#endif
}

#ifdef TILE_MIN_BLOCKS
#define TILE_LAUNCH_BOUNDS __launch_bounds__(128, TILE_MIN_BLOCKS)
#else
#define TILE_LAUNCH_BOUNDS
#endif

// Calls body(k, node) for each tile node k inside the grid, `node` its grid index; then lists the
// marked node blocks. Starts and ends with a barrier, so the tile can be cleared for the next bin.
#define FOR_EACH_TILE_NODE_IN_GRID(t, params, blocks, block_marks, tile_marks, k, node, ...)                     \
    {                                                                                                            \
        __syncthreads();                                                                                         \
        for (u32 k = threadIdx.x; k < TILE_NODES; k += blockDim.x) {                                             \
            const int _g[3] = {(t).origin[0] + (int)(k % TILE_EDGE), (t).origin[1] + (int)((k / TILE_EDGE) % TILE_EDGE), \
                               (t).origin[2] + (int)(k / (TILE_EDGE * TILE_EDGE))};                              \
            if (_g[0] < 0 || _g[1] < 0 || _g[2] < 0 || _g[0] >= (int)(params).grid_res[0] ||                     \
                _g[1] >= (int)(params).grid_res[1] || _g[2] >= (int)(params).grid_res[2])                        \
                continue;                                                                                        \
            const u32 node = (u32)_g[0] + (params).grid_res[0] * ((u32)_g[1] + (params).grid_res[1] * (u32)_g[2]); \
            __VA_ARGS__                                                                                          \
        }                                                                                                        \
        for (u32 _k = threadIdx.x; _k < TILE_SPAN_BLOCKS; _k += blockDim.x) {                                    \
            if (tile_marks[_k]) {                                                                                \
                mark_node_block((block_marks), node_block_index((blocks), (t).bin[0] + _k % TILE_SPAN - 1,         \
                                                                (t).bin[1] + (_k / TILE_SPAN) % TILE_SPAN - 1,     \
                                                                (t).bin[2] + _k / (TILE_SPAN * TILE_SPAN) - 1));   \
            }                                                                                                    \
        }                                                                                                        \
        __syncthreads();                                                                                         \
    }

// The bin's j-th particle for a pass: consecutive j (the lanes of a warp) step through the bin's run
// of `order` with a stride coprime to its length, so that lanes rarely share a cell and so rarely
// add to the same tile node at once (same-address shared atomics serialise). 1: in order.
__device__ __forceinline__ u32 bin_slot(u32 j, u32 count, u32 stride) {
    return stride > 1 ? (u32)(((unsigned long long)j * stride) % count) : j;
}

__device__ __forceinline__ u32 coprime_stride(u32 stride, u32 count) {
    if (stride <= 1) return 1;
    for (;; ++stride) {
        u32 a = stride, b = count;
        while (b) { const u32 t = a % b; a = b; b = t; }
        if (a == 1) return stride;
    }
}
