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
//   stale) is scattered with global atomics instead, and counted in `tile_misses`; a single
//   contribution too large for the tile's 32-bit units (several times the scale's reference speed)
//   goes the same way, uncounted. Nothing is dropped.
// - Every node block that a scatter covers is marked and listed once per substep (`mark_node_block`),
//   so grid_update_blocks visits only those: empty space costs nothing.
#include "common.cuh"

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
// dam break -1.4 %, bench-65k -3.9 %, the other presets -0.4 to -0.7 %; its fixed-point scatter at 5
// was 3.8 % slower at the dam break, so it stays at 6.
#define ONE_PASS_FLOAT_MIN_BLOCKS 5
// Its plane-by-plane float scatter at 4 (128 registers: at 5 its 36 sums spill), H100, 2026-11-26
// (BENCHMARKS.md 0t).
#define ONE_PASS_FLOAT_PLANES_MIN_BLOCKS 4
#define ONE_PASS_FIXED_MIN_BLOCKS 6

// Tile units are global fixed-point units / 2^TILE_UNIT_SHIFT: a cell's mass at rest is 2^27 units
// (resolution 7e-9 of it, finer than a float sum), and a tile node's sum stays under 2^31 up to about
// 16 cells' mass, or the momentum of a cell's mass at 16 times the reference speed.
#define TILE_UNIT_SHIFT 13
// Largest contribution a tile takes, in tile units; larger ones go to the grid (tile_scatter).
#define TILE_CONTRIBUTION_LIMIT 67108864.0f /* 2^26 */


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
__device__ __forceinline__ void tile_miss(const Stencil& s, const BlockMarks& marks, const NodeBlocks& blocks,
                                          u32& misses) {
    ++misses;
    mark_stencil_blocks(marks, blocks, s);
}

// Where a particle's contributions go: true where its stencil fits its bin's tile (`first` is the
// tile node of its base, its node blocks marked in the tile's marks); false where it is scattered to
// the grid instead (tile_miss). `far` as in tile_stencil.
__device__ __forceinline__ bool tile_place(const Tile& t, const Stencil& s, u32& first, bool& far, u32* tile_marks,
                                           const BlockMarks& marks, const NodeBlocks& blocks, u32& misses) {
    if (tile_stencil(t, s, first, far)) {
        tile_mark_stencil(tile_marks, first);
        return true;
    }
    tile_miss(s, marks, blocks, misses);
    return false;
}

// tile_place for a pass that merges a warp's marks in registers: the stencil's node blocks go into the
// lane's `covered` bits (tile_stencil_block_bits) instead of the tile's marks.
__device__ __forceinline__ bool tile_place_bits(const Tile& t, const Stencil& s, u32& first, bool& far, u32& covered,
                                                const BlockMarks& marks, const NodeBlocks& blocks, u32& misses) {
    if (tile_stencil(t, s, first, far)) {
        covered |= tile_stencil_block_bits(first);
        return true;
    }
    tile_miss(s, marks, blocks, misses);
    return false;
}

// CHANNELS 32-bit accumulators (tile units) per tile node in dynamic shared memory, channel-major:
// the host sizes it at 4 CHANNELS TILE_NODES bytes.
extern __shared__ __align__(16) int tile_memory[];

// Zeroes the tile's marks alone, for a pass that accumulates elsewhere. Ends with a barrier.
__device__ __forceinline__ void tile_clear_marks(u32* tile_marks) {
    for (u32 k = threadIdx.x; k < TILE_SPAN_BLOCKS; k += blockDim.x) tile_marks[k] = 0u;
    __syncthreads();
}

// Zeroes the accumulators and the tile's marks. Ends with a barrier.
template <int CHANNELS>
__device__ __forceinline__ int* tile_clear(u32* tile_marks) {
    for (u32 k = threadIdx.x; k < CHANNELS * TILE_NODES; k += blockDim.x) tile_memory[k] = 0;
    tile_clear_marks(tile_marks);
    return tile_memory;
}

// A tile node's sum (or a rounded contribution) in global fixed-point units.
__device__ __forceinline__ u64 tile_global_units(i64 units) {
    return (u64)(units << TILE_UNIT_SHIFT);
}

// Whether a contribution (in tile units, before rounding) is small enough for the tile; not NaN.
__device__ __forceinline__ bool tile_takes(float tile_scaled) {
    return fabsf(tile_scaled) < TILE_CONTRIBUTION_LIMIT;
}

// Adds a contribution the tile takes (tile_takes), rounded as fixed_point_units rounds, to tile
// accumulator `slot`; true where the 32-bit sum overflowed, for the caller to count.
__device__ __forceinline__ bool tile_add_taken(int* slot, float tile_scaled) {
    const int units = (int)__float2ll_rn(tile_scaled);
    const int before = atomicAdd(slot, units);
    const int after = (int)((u32)before + (u32)units);
    return (units > 0) ? after < before : after > before;
}

// The grid node of a stencil node given as its tile offset from the stencil's base (a constant in the
// unrolled stencil loops, so this folds to one multiply-add).
__device__ __forceinline__ u32 stencil_node(const Stencil& s, const Params& params, u32 offset) {
    const u32 o[3] = {offset % TILE_EDGE, (offset / TILE_EDGE) % TILE_EDGE, offset / (TILE_EDGE * TILE_EDGE)};
    return s.base_index + o[0] + params.grid_res[0] * (o[1] + params.grid_res[1] * o[2]);
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

// A particle's scatter into its bin's tile: CHANNELS contributions to each stencil node, computed by
// `values(w, d0, d1, d2, value)`, `tile_scale` their tile units per unit. Without a branch per
// contribution: one too large for the tile adds 0 there and sends the particle through a second
// loop, which gives what the tile did not take to `to_grid(node, channel, tile_scaled, value)`, as
// it does every contribution of a particle whose stencil is outside the tile (`in_tile` false); both
// are rare. The tile's 32-bit overflows are counted once. Measured on the H100 (BENCHMARKS.md 0u):
// with a branch and a fallback for each of one_pass_fixed's 108 contributions, instruction fetch
// stalled 23 % of its samples and its fixed-point substep took 0.239 ms at bench-655k, 0.178 without.
// `values` runs in both loops and a particle's integers must not depend on which one added them, so
// it rounds as written (__fmul_rn, __fadd_rn, impulse_at_pinned): left to itself, NVRTC contracted
// one loop into fused multiply-adds and not the other.
template <int CHANNELS, typename Values, typename ToGrid>
__device__ __forceinline__ void tile_scatter(const Stencil& s, const Params& params, u32 first, bool in_tile,
                                             int* tile, const float (&tile_scale)[CHANNELS], Values values,
                                             ToGrid to_grid, StepCounters* counters) {
    bool missed = !in_tile;
    u32 overflows = 0;
    if (in_tile) {
        FOR_EACH_STENCIL_NODE_AT(s, first, TILE_EDGE, TILE_EDGE * TILE_EDGE, k, w, d0, d1, d2, {
            float value[CHANNELS];
            values(w, d0, d1, d2, value);
            for (int ch = 0; ch < CHANNELS; ++ch) {
                const float scaled = __fmul_rn(value[ch], tile_scale[ch]);
                const bool takes = tile_takes(scaled);
                missed |= !takes;
                overflows += tile_add_taken(&tile[ch * TILE_NODES + k], takes ? scaled : 0.0f);
            }
        })
    }
    if (missed) {
        FOR_EACH_STENCIL_NODE_AT(s, first, TILE_EDGE, TILE_EDGE * TILE_EDGE, k, w, d0, d1, d2, {
            float value[CHANNELS];
            values(w, d0, d1, d2, value);
            const u32 node = stencil_node(s, params, k - first);
            for (int ch = 0; ch < CHANNELS; ++ch) {
                const float scaled = __fmul_rn(value[ch], tile_scale[ch]);
                if (!(in_tile && tile_takes(scaled))) to_grid(node, ch, scaled, value[ch]);
            }
        })
    }
    if (overflows) atomicAdd(&counters->fixed_overflows, overflows);
}



// The grid's node block of the tile's node block k (0..26, as the tile's marks).
__device__ __forceinline__ u32 tile_node_block(const Tile& t, const NodeBlocks& blocks, u32 k) {
    return node_block_index(blocks, t.bin[0] + k % TILE_SPAN - 1, t.bin[1] + (k / TILE_SPAN) % TILE_SPAN - 1,
                            t.bin[2] + k / (TILE_SPAN * TILE_SPAN) - 1);
}

// Lists, once per substep, the node blocks marked in the tile's marks (global atomics). Every thread of
// the block calls it after a barrier; it ends with one, so the marks can be cleared for the next bin.
__device__ __forceinline__ void tile_list_marked_blocks(const Tile& t, const NodeBlocks& blocks, const BlockMarks& marks,
                                                        const u32* tile_marks) {
    for (u32 k = threadIdx.x; k < TILE_SPAN_BLOCKS; k += blockDim.x) {
        if (tile_marks[k]) mark_node_block(marks, tile_node_block(t, blocks, k));
    }
    __syncthreads();
}

// Lists, once per substep, the node blocks that any lane of the warp covered (`covered`: each lane's
// tile_stencil_block_bits merged), a lane per block, with no barrier: the warp goes on to its next
// chunk while the others of its CUDA block are still in this one. Every lane of the warp calls it.
__device__ __forceinline__ void warp_list_marked_blocks(const Tile& t, const NodeBlocks& blocks,
                                                        const BlockMarks& marks, u32 covered) {
#if __CUDA_ARCH__ >= 800
    covered = __reduce_or_sync(0xffffffffu, covered);
#else
    for (u32 offset = 16; offset > 0; offset >>= 1) covered |= __shfl_xor_sync(0xffffffffu, covered, offset);
#endif
    const u32 k = threadIdx.x & 31u;
    if (k < TILE_SPAN_BLOCKS && (covered >> k & 1u)) mark_node_block(marks, tile_node_block(t, blocks, k));
}

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
        tile_list_marked_blocks((t), (blocks), (block_marks), tile_marks);                                       \
    }

