// Particle sort by grid cell, into an index buffer (the particle arrays stay index-stable, as the
// design asks). The scatter kernels (p2g_init, p2g) walk particles in `order`, so the 32 lanes of a
// warp hold particles of a few neighbouring cells: their stencils overlap, the warp-aggregated atomics
// merge many contributions, and grid reads hit the same lines. Without it, the lattice order of the
// spawn decays as the fluid stretches and shears, and the scatters slow down about twofold
// (bench-655k after the column collapses: p2g_init + p2g 0.55 ms per step unsorted, 0.29 sorted).
//
// A counting sort: sort_count ranks each particle within its cell (atomics: the order inside a cell
// varies from run to run, which no result depends on: the fixed-point scatter sums integers, and
// every other kernel is per particle); scan_tiles/scan_add turn the per-cell counts into starts;
// sort_scatter writes each particle's index at start + rank.
#include "common.cuh"

// Key = the stencil's base node: particles with the same key have the same 27 nodes.
extern "C" __global__ void sort_count(const Params params,
                                     const float4* __restrict__ x,
                                     u32* __restrict__ cell_count,  // zeroed, one per node
                                     u32* __restrict__ key,
                                     u32* __restrict__ rank) {
    FOR_EACH_INDEX(p, params.num_particles) {
        const u32 k = make_stencil(x[p], params).base_index;
        key[p] = k;
        rank[p] = atomicAdd(&cell_count[k], 1u);
    }
}

#define SCAN_ITEMS_PER_THREAD 8

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
