// mirror_walls: adds the mirror image of the fluid beyond the two walls of one axis to the grid, in
// place; the rule and the summation order of `mirror_walls` in src/sim/cpu.rs. For the wall plane at
// node W, the pair of nodes (W - d, W + d) ends with the sum of both (the image's share), W itself
// with twice its own; momentum is reflected (its wall-normal component negated), so the normal
// momentum cancels on the plane. Launched once per axis, x then y then z, which also gives the images
// at edges and corners: for the mass after p2g_init, for the momentum after p2g.
// One thread per grid line along the axis: it owns every node it touches, so no atomics are needed.
#include "common.cuh"

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

extern "C" __global__ void mirror_walls(const Params params, const u32 axis, const u32 quantity,
                                        float4* __restrict__ grid_acc,
                                        u64* __restrict__ fixed_mass,
                                        u64* __restrict__ fixed_momentum) {
    if (params.wall_mirror_lo == 0) return;
    const u32 res[3] = {params.grid_res[0], params.grid_res[1], params.grid_res[2]};
    const size_t stride[3] = {1, res[0], (size_t)res[0] * res[1]};
    const u32 across_1 = (axis + 1) % 3, across_2 = (axis + 2) % 3;
    const u32 walls[2] = {params.wall_mirror_lo, params.wall_mirror_hi[axis]};

    FOR_EACH_INDEX(line_index, res[across_1] * res[across_2]) {
        const size_t line = (line_index % res[across_1]) * stride[across_1] + (line_index / res[across_1]) * stride[across_2];
        for (int k = 0; k < 2; ++k) {
            const u32 wall = walls[k];
            const u32 reach = min(wall, res[axis] - 1 - wall);
            const size_t plane = line + wall * stride[axis];
            mirror_pair(params, axis, quantity, plane, plane, grid_acc, fixed_mass, fixed_momentum);
            for (u32 d = 1; d <= reach; ++d) {
                mirror_pair(params, axis, quantity, line + (wall - d) * stride[axis], line + (wall + d) * stride[axis],
                            grid_acc, fixed_mass, fixed_momentum);
            }
        }
    }
}
