// halo: the ghost exchange's two ends on one rank's grid (src/cuda/halo.rs; src/dist/halo.rs is the
// CPU ranks' version of the same rule). A rank's grid holds its slab and one block of ghost planes
// on each inner face (its box; planes are named in the domain's node numbering). After the scatter,
// the ghost planes' partial sums are packed (and zeroed, as the grid update would), carried to the owner and
// added to its edge planes; after the grid update, the owner's edge planes' velocities are packed,
// carried back and written over the ghosts. The carrier (a device copy on one GPU, NCCL across GPUs)
// sees only the packed buffers.
//
// The packed buffers are of 32-bit words. Packed sums hold `halo_sum_words` per node: mass,
// momentum x, y, z (a float each under the float scatter; the fixed-point units, 64 bits each, as
// two words, low first), then whether the sender's scatter listed the node's block. The owner lists
// every such block, so its grid update visits the nodes the one-rank run would, zeros included.
// Packed velocities are a float4 per node. Where the rest densities differ (Params::volume_density),
// the grid's volume (volume.cu) travels too, 64 bits per node after all the nodes' sums or
// velocities: summed to the owner with the scatter's sums, written over the ghosts with the
// velocities.
#include "tiles.cuh"

// Words per node of packed sums (src/cuda/halo.rs `sum_words`): the float scatter's 20 bytes are
// half of what 64-bit words for every sum took (measured: BENCHMARKS.md M28).
__device__ __forceinline__ u32 halo_sum_words(const KernelParams& params) {
    return params.scatter_mode == SCATTER_FIXED_POINT ? 9u : 5u;
}

__device__ __forceinline__ void put_u64(u32* out, u64 value) {
    out[0] = (u32)value;
    out[1] = (u32)(value >> 32);
}

__device__ __forceinline__ u64 get_u64(const u32* in) {
    return (u64)in[0] | ((u64)in[1] << 32);
}

// Node `j` of the `num_nodes` nodes of the planes from `first` (a domain coordinate) across `axis`,
// counted in the grid's memory order (x fastest), so that neighbouring threads read neighbouring
// nodes whichever the axis: where it is stored, its node in c.
__device__ __forceinline__ u32 halo_node(const KernelParams& params, u32 axis, u32 first, u32 num_nodes, u32 j,
                                         u32 c[3]) {
    u32 box[3] = {params.box_res[0], params.box_res[1], params.box_res[2]};
    box[axis] = num_nodes / (box[0] * box[1] * box[2] / box[axis]);
    c[0] = j % box[0];
    c[1] = (j / box[0]) % box[1];
    c[2] = j / (box[0] * box[1]);
    for (u32 a = 0; a < 3u; ++a) c[a] += a == axis ? first : params.box_lo[a];
    return grid_index(params, c[0], c[1], c[2]);
}

// The index of node c's block (node_block_index).
__device__ __forceinline__ u32 halo_node_block(const NodeBlocks& blocks, const u32 c[3]) {
    return node_block_index(blocks, c[0] / NODE_BLOCK_EDGE, c[1] / NODE_BLOCK_EDGE, c[2] / NODE_BLOCK_EDGE);
}

// Packs and zeroes the scatter's sums on `num_nodes` nodes of the ghost planes from `first`.
extern "C" __global__ void halo_pack_sums(const KernelParams params, const u32 axis, const u32 first, const u32 num_nodes,
                                          float4* __restrict__ grid_acc, u64* __restrict__ fixed_mass,
                                          u64* __restrict__ fixed_momentum, u64* __restrict__ volume,
                                          const u32* __restrict__ block_marks, u32* __restrict__ out) {
    const NodeBlocks blocks = node_blocks(params);
    const u32 words = halo_sum_words(params);
    FOR_EACH_INDEX(j, num_nodes) {
        u32 c[3];
        const u32 i = halo_node(params, axis, first, num_nodes, j, c);
        u32* o = out + (size_t)words * j;
        if (params.scatter_mode == SCATTER_FIXED_POINT) {
            put_u64(o, fixed_mass[i]);
            fixed_mass[i] = 0;
            for (u32 a = 0; a < 3u; ++a) {
                put_u64(o + 2 + 2 * a, fixed_momentum[3 * (size_t)i + a]);
                fixed_momentum[3 * (size_t)i + a] = 0;
            }
        } else {
            const float4 acc = grid_acc[i];
            grid_acc[i] = make_float4(0.0f, 0.0f, 0.0f, 0.0f);
            o[0] = __float_as_uint(acc.w);
            o[1] = __float_as_uint(acc.x);
            o[2] = __float_as_uint(acc.y);
            o[3] = __float_as_uint(acc.z);
        }
        o[words - 1] = block_marks[halo_node_block(blocks, c)];
        if (params.volume_density) {
            put_u64(out + (size_t)words * num_nodes + 2 * (size_t)j, volume[i]);
            volume[i] = 0;
        }
    }
}

// Adds packed sums to the edge planes from `first` and lists the blocks the sender listed.
extern "C" __global__ void halo_add_sums(const KernelParams params, const u32 axis, const u32 first, const u32 num_nodes,
                                         const u32* __restrict__ in, float4* __restrict__ grid_acc,
                                         u64* __restrict__ fixed_mass, u64* __restrict__ fixed_momentum,
                                         u64* __restrict__ volume, u32* __restrict__ block_marks, u32* __restrict__ block_list,
                                         u32* __restrict__ work_counts) {
    const NodeBlocks blocks = node_blocks(params);
    const BlockMarks marks{block_marks, block_list, work_counts};
    const u32 words = halo_sum_words(params);
    FOR_EACH_INDEX(j, num_nodes) {
        u32 c[3];
        const u32 i = halo_node(params, axis, first, num_nodes, j, c);
        const u32* w = in + (size_t)words * j;
        if (params.scatter_mode == SCATTER_FIXED_POINT) {
            fixed_mass[i] += get_u64(w);
            for (u32 a = 0; a < 3u; ++a) fixed_momentum[3 * (size_t)i + a] += get_u64(w + 2 + 2 * a);
        } else {
            float4 acc = grid_acc[i];
            acc.w += __uint_as_float(w[0]);
            acc.x += __uint_as_float(w[1]);
            acc.y += __uint_as_float(w[2]);
            acc.z += __uint_as_float(w[3]);
            grid_acc[i] = acc;
        }
        if (w[words - 1]) mark_node_block(params, marks, blocks, c[0] / NODE_BLOCK_EDGE, c[1] / NODE_BLOCK_EDGE,
                                          c[2] / NODE_BLOCK_EDGE);
        if (params.volume_density) volume[i] += get_u64(in + (size_t)words * num_nodes + 2 * (size_t)j);
    }
}

// Copies the grid update's velocity and mass of `num_nodes` nodes of the planes from `first` (and
// the volume, mirrored, after them).
extern "C" __global__ void halo_pack_velocities(const KernelParams params, const u32 axis, const u32 first,
                                                const u32 num_nodes, const float4* __restrict__ grid_vel,
                                                const u64* __restrict__ volume, float4* __restrict__ out) {
    u64* volume_out = reinterpret_cast<u64*>(out + num_nodes);
    FOR_EACH_INDEX(j, num_nodes) {
        u32 c[3];
        const u32 i = halo_node(params, axis, first, num_nodes, j, c);
        out[j] = grid_vel[i];
        if (params.volume_density) volume_out[j] = volume[i];
    }
}

// Writes packed velocities (and volumes) over the ghost planes from `first`.
extern "C" __global__ void halo_fill_velocities(const KernelParams params, const u32 axis, const u32 first,
                                                const u32 num_nodes, const float4* __restrict__ in,
                                                float4* __restrict__ grid_vel, u64* __restrict__ volume) {
    const u64* volume_in = reinterpret_cast<const u64*>(in + num_nodes);
    FOR_EACH_INDEX(j, num_nodes) {
        u32 c[3];
        const u32 i = halo_node(params, axis, first, num_nodes, j, c);
        grid_vel[i] = in[j];
        if (params.volume_density) volume[i] = volume_in[j];
    }
}
