// grid_update (docs/physics.md step 3): momentum to velocity, gravity, free slip in the boundary band
// (update_node in common.cuh). It is also the grid clear: each accumulator has exactly one reader
// here (its node's thread), so the thread zeroes what it read (consume-and-zero) and the next step's
// scatter finds a clean grid.
//
// Two walks over the grid:
// - grid_update (the report's pipeline): every node, so g2p never reads a stale velocity.
// - grid_update_blocks (the binned pipeline): only the 4x4x4-node blocks that this substep's scatters
//   and mirror passes touched (tiles.cuh marks them and lists each once). A block that no particle's
//   stencil covers is read by no particle, so its stale velocities are never used; its accumulators
//   are zero, since every write marks its block.
#include "tiles.cuh"

extern "C" __global__ void grid_update(const Params params,
                                       float4* __restrict__ grid_acc,     // in: momentum, mass; zeroed
                                       float4* __restrict__ grid_vel,     // out: .xyz velocity, .w mass
                                       u64* __restrict__ fixed_mass,      // in (fixed-point); zeroed
                                       u64* __restrict__ fixed_momentum,  // in (fixed-point); zeroed
                                       StepCounters* __restrict__ counters) {
    const u32 num_nodes = params.grid_res[0] * params.grid_res[1] * params.grid_res[2];
    FOR_EACH_INDEX(i, num_nodes) {
        // The report's pipeline applies no colliders (the host refuses scenes that have them).
        update_node(params, i, grid_acc, grid_vel, fixed_mass, fixed_momentum, counters, Colliders{nullptr, 0u, nullptr});
    }
}

// One CUDA block of NODE_BLOCK_NODES (64) threads per listed block; clears the block's mark, so the
// next substep starts with none (the host zeroes the list's length after this launch).
extern "C" __global__ void grid_update_blocks(const Params params,
                                              const u32* __restrict__ block_list,
                                              const u32* __restrict__ work_counts,
                                              u32* __restrict__ block_marks,
                                              float4* __restrict__ grid_acc,
                                              float4* __restrict__ grid_vel,
                                              u64* __restrict__ fixed_mass,
                                              u64* __restrict__ fixed_momentum,
                                              StepCounters* __restrict__ counters,
                                              const ColliderState* __restrict__ collider_states,
                                              const u32 num_colliders,
                                              const float* __restrict__ collider_sdf) {
    const Colliders colliders{collider_states, num_colliders, collider_sdf};
    const u32 listed = work_counts[WORK_NODE_BLOCKS];
    const NodeBlocks blocks = node_blocks(params);
    for (u32 k = blockIdx.x; k < listed; k += gridDim.x) {
        const u32 b = block_list[k];
        const u32 origin[3] = {NODE_BLOCK_EDGE * (b % blocks.count[0]),
                               NODE_BLOCK_EDGE * ((b / blocks.count[0]) % blocks.count[1]),
                               NODE_BLOCK_EDGE * (b / (blocks.count[0] * blocks.count[1]))};
        const u32 node[3] = {origin[0] + (threadIdx.x & 3u), origin[1] + ((threadIdx.x >> 2) & 3u),
                             origin[2] + (threadIdx.x >> 4)};
        if (node[0] < params.grid_res[0] && node[1] < params.grid_res[1] && node[2] < params.grid_res[2]) {
            const u32 i = node[0] + params.grid_res[0] * (node[1] + params.grid_res[1] * node[2]);
            update_node(params, i, grid_acc, grid_vel, fixed_mass, fixed_momentum, counters, colliders);
        }
        if (threadIdx.x == 0) block_marks[b] = 0;
    }
}
