// mirror_walls: adds the mirror image of the fluid beyond the two walls of one axis to the grid, in
// place; the rule and the summation order of `mirror_walls` in src/sim/cpu.rs. For the wall plane at
// node W, the pair of nodes (W - d, W + d) ends with the sum of both (the image's share), W itself
// with twice its own; momentum is reflected (its wall-normal component negated), so the normal
// momentum cancels on the plane. Launched once per axis, x then y then z, which also gives the images
// at edges and corners: for the mass after p2g_init, for the momentum after p2g.
// One thread per grid line along the axis: it owns every node it touches, so no atomics are needed.
// In the binned pipeline (marks given), a pair whose two node blocks no scatter touched holds zeros
// and is skipped, and a pair written marks its blocks, so grid_update_blocks consumes what the images
// add; the report's pipeline passes null marks and walks every line.
#include "tiles.cuh"

#define MIRROR_MASS 0u
#define MIRROR_MOMENTUM 1u

// out = a + reflect(b) and in = b + reflect(a), for the pair (a at `out`, b at `in`); out == in on the plane.
__device__ __forceinline__ void mirror_pair(const Params& params, u32 axis, u32 quantity, size_t out, size_t in,
                                            float4* grid_acc, u64* fixed_mass, u64* fixed_momentum) {
    const bool fixed = params.scatter_mode == SCATTER_FIXED_POINT;
    if (quantity == MIRROR_MASS) {
        if (fixed) {
            const u64 a = fixed_mass[out], b = fixed_mass[in];
            fixed_mass[out] = a + b;
            fixed_mass[in] = b + a;
        } else {
            const float a = grid_acc[out].w, b = grid_acc[in].w;
            grid_acc[out].w = a + b;
            grid_acc[in].w = b + a;
        }
        return;
    }
    if (fixed) {
        u64 a[3], b[3];
        for (int c = 0; c < 3; ++c) {
            a[c] = fixed_momentum[3 * out + c];
            b[c] = fixed_momentum[3 * in + c];
        }
        for (int c = 0; c < 3; ++c) {
            const bool normal = c == (int)axis;
            fixed_momentum[3 * out + c] = a[c] + (normal ? (u64)(-(i64)b[c]) : b[c]);
            fixed_momentum[3 * in + c] = b[c] + (normal ? (u64)(-(i64)a[c]) : a[c]);
        }
    } else {
        const float4 a = grid_acc[out], b = grid_acc[in];
        float ra[3] = {a.x, a.y, a.z}, rb[3] = {b.x, b.y, b.z};
        ra[axis] = -ra[axis];
        rb[axis] = -rb[axis];
        grid_acc[out] = make_float4(a.x + rb[0], a.y + rb[1], a.z + rb[2], a.w);
        grid_acc[in] = make_float4(b.x + ra[0], b.y + ra[1], b.z + ra[2], b.w);
    }
}

__device__ __forceinline__ u32 node_block_of(const Params& params, const NodeBlocks& blocks, size_t i) {
    const u32 rx = params.grid_res[0], ry = params.grid_res[1];
    return node_block_index(blocks, (u32)(i % rx) / NODE_BLOCK_EDGE, (u32)((i / rx) % ry) / NODE_BLOCK_EDGE,
                            (u32)(i / ((size_t)rx * ry)) / NODE_BLOCK_EDGE);
}

extern "C" __global__ void mirror_walls(const Params params, const u32 axis, const u32 quantity,
                                        float4* __restrict__ grid_acc,
                                        u64* __restrict__ fixed_mass,
                                        u64* __restrict__ fixed_momentum,
                                        u32* block_marks, u32* block_list, u32* work_counts) {
    if (params.wall_mirror_lo == 0) return;
    const u32 res[3] = {params.grid_res[0], params.grid_res[1], params.grid_res[2]};
    const size_t stride[3] = {1, res[0], (size_t)res[0] * res[1]};
    // The two axes across the lines; consecutive threads take neighbouring lines along the smaller
    // stride (x before y before z), so their accesses coalesce where the layout allows.
    const u32 inner = axis == 0 ? 1 : 0, outer = axis == 2 ? 1 : 2;
    const u32 walls[2] = {params.wall_mirror_lo, params.wall_mirror_hi[axis]};
    const NodeBlocks blocks = node_blocks(params);
    const BlockMarks marks{block_marks, block_list, work_counts};
    // The report's pipeline (no marks) mirrors every pair; the binned one only pairs that hold something.
    auto mirror = [&](size_t out, size_t in) {
        if (block_marks) {
            const u32 bo = node_block_of(params, blocks, out), bi = node_block_of(params, blocks, in);
            if (!block_marks[bo] && !block_marks[bi]) return;
            mark_node_block(marks, bo);
            mark_node_block(marks, bi);
        }
        mirror_pair(params, axis, quantity, out, in, grid_acc, fixed_mass, fixed_momentum);
    };

    FOR_EACH_INDEX(line_index, res[inner] * res[outer]) {
        const size_t line = (line_index % res[inner]) * stride[inner] + (line_index / res[inner]) * stride[outer];
        for (int k = 0; k < 2; ++k) {
            const u32 wall = walls[k];
            const u32 reach = min(wall, res[axis] - 1 - wall);
            const size_t plane = line + wall * stride[axis];
            mirror(plane, plane);
            for (u32 d = 1; d <= reach; ++d) mirror(line + (wall - d) * stride[axis], line + (wall + d) * stride[axis]);
        }
    }
}
