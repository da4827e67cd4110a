// Particles sorted by the cell of their stencil base into an index buffer `order` (the sort moves
// no particle; the fused pipeline then moves them into it, bin_order.cu), the cells of one bin (`edge`^3
// cells) consecutive: key = bin * edge^3 + the cell's place in the bin. A counting sort:
// - bin_count ranks each particle within its cell; scan_tiles/scan_add turn the per-cell counts into
//   starts (`cell_starts`); sort_scatter writes each particle's index at start + rank.
// - bin_list lists the bins that hold particles, in chunks with their ranges (tiles.cuh's BinEntry),
//   for the binned pipeline's tiled passes (edge 4). The report's pipeline sorts by plain cell
//   (edge 1) and walks `order` whole; so does every warp-aggregated scatter, whose warp runs want
//   the particles of a cell side by side.
//
// The rank comes from one atomic per warp and bin: lanes with the same bin find each other
// (match_any), the lowest adds the group's size, and each takes the leader's start plus the number of
// its peers below it. Consecutive particles of one bin thus stay consecutive in `order` (the spawn
// lattice's rows), so the passes that walk it read and write the particle arrays in runs. Which
// warp comes first varies from run to run; no result depends on it (the fixed-point scatter sums
// integers, and every other kernel is per particle).
//
// The report's pipeline sorts by cell (edge 1): the 32 lanes of a warp then hold particles of a few
// neighbouring cells, so their warp-aggregated atomics merge many contributions (bench-655k after the
// column collapses: p2g_init + p2g 0.55 ms per step unsorted, 0.29 sorted).
#include "tiles.cuh"

// Key = the bin of the stencil's base node times edge^3, plus the base's cell within the bin.
extern "C" __global__ void bin_count(const KernelParams params,
                                    const u32 edge,
                                    const float4* __restrict__ x,
                                    u32* __restrict__ cell_counts,  // zeroed, one per key and parked key
                                    u32* __restrict__ key,
                                    u32* __restrict__ rank) {
    u32 bins[3];
    for (int a = 0; a < 3; ++a) bins[a] = (params.box_res[a] + edge - 1) / edge;
    // Parked slots (kernels/lifecycle.cu) take the PARKED_KEYS keys past every bin's, a warp to a
    // key: they sort to the end of `order`, in no bin and no list, and the warps' atomics spread over
    // PARKED_KEYS counters instead of queuing on one.
    const u32 parked_key = bins[0] * bins[1] * bins[2] * edge * edge * edge;
    FOR_EACH_INDEX_CONVERGED(p, live, first, params.num_particles) {
        u32 k = 0xffffffffu;  // lanes past the end form a group of their own and add nothing
        if (live && is_parked(x[p])) {
            k = parked_key + (first + threadIdx.x) / 32u % PARKED_KEYS;
        } else if (live) {
            const Stencil s = make_stencil(x[p], params);
            // Bins (and their cells) count from the grid box's first node.
            u32 b[3];
            for (int a = 0; a < 3; ++a) b[a] = s.base[a] - params.box_lo[a];
            const u32 bin = b[0] / edge + bins[0] * (b[1] / edge + bins[1] * (b[2] / edge));
            const u32 cell = b[0] % edge + edge * (b[1] % edge + edge * (b[2] % edge));
            k = bin * edge * edge * edge + cell;
        }
        const u32 lane = threadIdx.x & 31u;
        const u32 peers = __match_any_sync(0xffffffffu, k);
        const u32 leader = (u32)__ffs(peers) - 1u;
        u32 start = 0;
        if (live && lane == leader) start = atomicAdd(&cell_counts[k], (u32)__popc(peers));
        start = __shfl_sync(0xffffffffu, start, leader);
        if (live) {
            key[p] = k;
            rank[p] = start + (u32)__popc(peers & ((1u << lane) - 1u));
        }
    }
}


// In-place exclusive scan of each tile of blockDim.x * SCAN_ITEMS_PER_THREAD values; tile_sums gets
// each tile's total. Needs blockDim.x * sizeof(u32) bytes of dynamic shared memory.
extern "C" __global__ void scan_tiles(u32* __restrict__ data, u32 count, u32* __restrict__ tile_sums) {
    extern __shared__ u32 thread_sums[];
    const u32 tile_start = blockIdx.x * blockDim.x * SCAN_ITEMS_PER_THREAD;
    const u32 mine = tile_start + threadIdx.x * SCAN_ITEMS_PER_THREAD;
    u32 items[SCAN_ITEMS_PER_THREAD];
    u32 sum = 0;
    for (int k = 0; k < SCAN_ITEMS_PER_THREAD; ++k) {
        const u32 i = mine + k;
        items[k] = i < count ? data[i] : 0u;
        sum += items[k];
    }
    thread_sums[threadIdx.x] = sum;
    __syncthreads();
    // Hillis-Steele inclusive scan of the per-thread sums (blockDim.x is at most 1024).
    for (u32 offset = 1; offset < blockDim.x; offset <<= 1) {
        const u32 add = threadIdx.x >= offset ? thread_sums[threadIdx.x - offset] : 0u;
        __syncthreads();
        thread_sums[threadIdx.x] += add;
        __syncthreads();
    }
    u32 running = thread_sums[threadIdx.x] - sum;  // exclusive prefix of this thread
    for (int k = 0; k < SCAN_ITEMS_PER_THREAD; ++k) {
        const u32 i = mine + k;
        if (i < count) data[i] = running;
        running += items[k];
    }
    if (threadIdx.x == blockDim.x - 1) tile_sums[blockIdx.x] = thread_sums[threadIdx.x];
}

// Adds each tile's offset (the scanned tile_sums) to its values.
extern "C" __global__ void scan_add(u32* __restrict__ data, u32 count, const u32* __restrict__ tile_offsets) {
    const u32 tile_start = blockIdx.x * blockDim.x * SCAN_ITEMS_PER_THREAD;
    const u32 offset = tile_offsets[blockIdx.x];
    for (int k = 0; k < SCAN_ITEMS_PER_THREAD; ++k) {
        const u32 i = tile_start + k * blockDim.x + threadIdx.x;
        if (i < count) data[i] += offset;
    }
}

extern "C" __global__ void sort_scatter(u32 num_particles,
                                       const u32* __restrict__ key,
                                       const u32* __restrict__ rank,
                                       const u32* __restrict__ cell_start,
                                       u32* __restrict__ order) {
    FOR_EACH_INDEX(p, num_particles) {
        order[cell_start[key[p]] + rank[p]] = p;
    }
}

// The bins that hold particles, as chunks of at most `chunk` particles each (a bin's run in `order`
// cut in turn), with the start and length of each chunk; the list's length goes to
// work_counts[WORK_BINS] (zeroed before). `cell_starts` has one more entry past the bins' cells: the
// parked slots' start, where the last bin ends. A tiled pass takes a chunk per CUDA block: small chunks
// (a thread per particle) keep a GPU busy when bins are few, so a bin of 512 particles feeds 4 blocks
// rather than one thread on 4 particles; where bins are plentiful, whole bins save the tiles' clears
// and flushes (the host chooses, src/cuda/bins.rs). The cells inside a bin are sorted, so a chunk
// covers a compact slab of them. The list's order varies from run to run.
extern "C" __global__ void bin_list(const u32 num_bins,
                                   const u32 chunk,
                                   const u32* __restrict__ cell_starts,  // BIN_CELLS per bin
                                   BinEntry* __restrict__ list,
                                   u32* __restrict__ work_counts) {
    FOR_EACH_INDEX_CONVERGED(b, live, first, num_bins) {
        u32 count = 0, start = 0;
        if (live) {
            start = cell_starts[b * BIN_CELLS];
            count = cell_starts[(b + 1) * BIN_CELLS] - start;  // the last bin ends where the parked slots start
        }
        const u32 chunks = (count + chunk - 1) / chunk;
        // An exclusive scan of the warp's chunk counts, then one atomic for the warp's total.
        const u32 lane = threadIdx.x & 31u;
        u32 before = chunks;
        for (u32 offset = 1; offset < 32; offset <<= 1) {
            const u32 other = __shfl_up_sync(0xffffffffu, before, offset);
            if (lane >= offset) before += other;
        }
        const u32 total = __shfl_sync(0xffffffffu, before, 31);
        before -= chunks;
        u32 slot = 0;
        if (lane == 0 && total) slot = atomicAdd(&work_counts[WORK_BINS], total);
        slot = __shfl_sync(0xffffffffu, slot, 0) + before;
        for (u32 k = 0; k < chunks; ++k) {
            list[slot + k] = BinEntry{b, start + k * chunk, min(chunk, count - k * chunk), 0u};
        }
    }
}
