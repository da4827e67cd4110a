// mirror_walls: adds the mirror image of the fluid beyond the walls to the grid, in place, for the
// mass (after the mass scatter), the momentum (after p2g), or both at once (the fused pipeline, whose
// one_pass scattered both); the rule of `mirror_walls` in
// src/sim/cpu.rs. There, for each axis in turn (x, then y, then z) and each wall plane W of it, the
// pair of nodes (W - d, W + d), d up to the wall's reach, ends with the sum of both, W itself with
// twice its own, the image of momentum given by `momentum_image` (`wall_image` here): it pushes fluid
// off the wall and never pulls it back. Doing the axes in turn gives the images at edges and corners.
//
// Here in one launch: the reflections of different axes map a node n's orbit {R_T(n)} (up to 8
// nodes, T a subset of the axes on which n lies within a wall's reach) onto itself, so each pass
// changes an orbit's values from the orbit's values alone. One thread per orbit reads its values, does
// the three passes on them in the same order as the CPU, writes them back, and touches no other
// thread's nodes: the same integers in fixed point, the same floats added in the same order. The
// orbit's thread is the one at its representative, the node on the fluid's side of every wall it is
// near; the launch covers, per axis, the slabs of the fluid's side of that axis's two walls, and a node
// in several slabs (an edge or corner) is taken by the slab of its lowest such axis.
//
// In the binned pipeline (marks given), an orbit whose node blocks no scatter touched holds zeros and
// is skipped, and one written marks its blocks, so grid_update_blocks consumes what the images add;
// the report's pipeline passes null marks and visits every orbit.
#include "tiles.cuh"


// One axis's two walls: node planes and reaches (the pairs W +- d stay inside the grid).
struct MirrorAxis {
    u32 lo, lo_reach, hi, hi_reach;
};

__device__ __forceinline__ MirrorAxis mirror_axis(const Params& params, int a) {
    const u32 r = params.grid_res[a];
    const u32 lo = params.wall_mirror_lo, hi = params.wall_mirror_hi[a];
    return MirrorAxis{lo, min(lo, r - 1 - lo), hi, min(hi, r - 1 - hi)};
}

// 1: within the low wall's reach, 2: the high wall's, 0: neither (the host checks they are apart).
__device__ __forceinline__ int mirror_zone(const MirrorAxis& m, u32 c) {
    if (c + m.lo_reach >= m.lo && c <= m.lo + m.lo_reach) return 1;
    if (c + m.hi_reach >= m.hi && c <= m.hi + m.hi_reach) return 2;
    return 0;
}

__device__ __forceinline__ bool mirror_fluid_side(const MirrorAxis& m, int zone, u32 c) {
    return zone == 1 ? c >= m.lo : c <= m.hi;
}

__device__ __forceinline__ u32 mirror_reflect(const MirrorAxis& m, int zone, u32 c) {
    return zone == 1 ? 2 * m.lo - c : 2 * m.hi - c;
}

// Where a node lies against one wall's plane: on the plane or the fluid's side of it, or beyond it,
// of the low wall or the high one.
struct WallSide {
    bool fluid, low;
};

// What `partner` adds across a wall's plane to a node holding `own` (`momentum_image` in
// src/sim/cpu.rs, operation for operation): the mass and the tangential momentum as they are; the
// wall-normal momentum so that the image pushes fluid off the wall and never pulls it back: on the
// fluid's side pointing off the wall whatever its sign, beyond the plane reflected while the fluid
// there presses on the wall and as it is where its own momentum points off the wall by more than a
// millionth of the partner's (OFF_THE_WALL: a margin far above any backend's rounding).
__device__ __forceinline__ float off_the_wall_margin(float partner) { return fabsf(partner) * 1e-6f; }
__device__ __forceinline__ i64 off_the_wall_margin(i64 partner) { return (partner < 0 ? -partner : partner) / 1000000; }

template <typename T>
__device__ __forceinline__ T wall_image(T own, T partner, bool normal, WallSide side) {
    if (!normal) return partner;
    const T magnitude = partner < T(0) ? -partner : partner;
    if (side.fluid) return side.low ? magnitude : -magnitude;
    const bool off_the_wall = (side.low ? own : -own) > off_the_wall_margin(partner);
    return off_the_wall ? partner : -partner;
}

// Fluid-side coordinates of an axis's two walls: lo..lo + lo_reach, then hi - hi_reach..hi.
__device__ __forceinline__ u32 mirror_slab_width(const MirrorAxis& m) {
    return m.lo_reach + 1 + m.hi_reach + 1;
}

__device__ __forceinline__ u32 mirror_slab_coordinate(const MirrorAxis& m, u32 k) {
    return k <= m.lo_reach ? m.lo + k : m.hi - m.hi_reach + (k - m.lo_reach - 1);
}

extern "C" __global__ void mirror_walls(const Params params, const u32 quantity,
                                        float4* __restrict__ grid_acc,
                                        u64* __restrict__ fixed_mass,
                                        u64* __restrict__ fixed_momentum,
                                        u32* block_marks, u32* block_list, u32* work_counts) {
    if (params.wall_mirror_lo == 0) return;
    const bool fixed = params.scatter_mode == SCATTER_FIXED_POINT;
    const u32 res[3] = {params.grid_res[0], params.grid_res[1], params.grid_res[2]};
    const MirrorAxis m[3] = {mirror_axis(params, 0), mirror_axis(params, 1), mirror_axis(params, 2)};
    // Slab of axis a: its fluid-side coordinates (fastest), then the other two axes in order.
    u32 slab[3];
    for (int a = 0; a < 3; ++a) slab[a] = mirror_slab_width(m[a]) * res[(a + 1) % 3] * res[(a + 2) % 3];
    const NodeBlocks blocks = node_blocks(params);

    FOR_EACH_INDEX(t, slab[0] + slab[1] + slab[2]) {
        const int a = t < slab[0] ? 0 : t < slab[0] + slab[1] ? 1 : 2;
        const u32 i = t - (a > 0 ? slab[0] : 0) - (a > 1 ? slab[1] : 0);
        const u32 width = mirror_slab_width(m[a]);
        u32 c[3];
        c[a] = mirror_slab_coordinate(m[a], i % width);
        c[(a + 1) % 3] = (i / width) % res[(a + 1) % 3];
        c[(a + 2) % 3] = i / (width * res[(a + 1) % 3]);

        // The orbit's axes; this node is its representative only on the fluid side of each of them,
        // and only in the slab of the lowest.
        int zone[3];
        u32 axes = 0;
        bool representative = true;
        for (int b = 0; b < 3; ++b) {
            zone[b] = mirror_zone(m[b], c[b]);
            if (zone[b] == 0) continue;
            axes |= 1u << b;
            representative &= b >= a && mirror_fluid_side(m[b], zone[b], c[b]);
        }
        if (!representative) continue;

        // The orbit: node[T] = R_T(this node) for T a subset of `axes` (other slots unused), and the
        // marks of its node blocks, all loaded at once (a chain of dependent loads would be the
        // kernel's whole cost).
        size_t node[8];
        u32 block[8], marked[8];
        bool touched = block_marks == nullptr;
#pragma unroll
        for (u32 T = 0; T < 8; ++T) {
            if (T & ~axes) continue;
            u32 r[3];
            for (int b = 0; b < 3; ++b) r[b] = (T >> b) & 1u ? mirror_reflect(m[b], zone[b], c[b]) : c[b];
            node[T] = r[0] + (size_t)res[0] * (r[1] + (size_t)res[1] * r[2]);
            block[T] = node_block_index(blocks, r[0] / NODE_BLOCK_EDGE, r[1] / NODE_BLOCK_EDGE, r[2] / NODE_BLOCK_EDGE);
            if (block_marks) marked[T] = block_marks[block[T]];
        }
        if (block_marks) {
#pragma unroll
            for (u32 T = 0; T < 8; ++T) touched |= !(T & ~axes) && marked[T] != 0u;
        }
        if (!touched) continue;  // every node of the orbit holds zeros

        // Read the orbit, then add the images axis by axis (x, y, z), as src/sim/cpu.rs's passes over
        // the whole grid do: in each, every node of the orbit gains its partner's image across that
        // axis's plane (the plane's own node, its own). The passes see only the orbit's values, so
        // doing them here gives the same integers, and the same floats added in the same order.
        // Channels: 0 the mass, 1 + k momentum k; each channel's images read that channel alone,
        // so mirroring both quantities in one launch gives what two launches give.
        const int first = quantity == MIRROR_MOMENTUM ? 1 : 0;
        const int end = quantity == MIRROR_MASS ? 1 : 4;
        i64 q[8][4];
        float f[8][4];
#pragma unroll
        for (u32 T = 0; T < 8; ++T) {
            if (T & ~axes) continue;
            float4 acc;
            if (!fixed) acc = grid_acc[node[T]];
#pragma unroll
            for (int ch = 0; ch < 4; ++ch) {
                if (ch < first || ch >= end) continue;
                if (fixed) q[T][ch] = (i64)(ch == 0 ? fixed_mass[node[T]] : fixed_momentum[3 * node[T] + ch - 1]);
                else f[T][ch] = ch == 0 ? acc.w : ch == 1 ? acc.x : ch == 2 ? acc.y : acc.z;
            }
        }
#pragma unroll
        for (int b = 0; b < 3; ++b) {
            if (!((axes >> b) & 1u)) continue;
            const bool low = zone[b] == 1;
            const bool on_plane = c[b] == (low ? m[b].lo : m[b].hi);
#pragma unroll
            for (u32 T = 0; T < 8; ++T) {
                const u32 P = T ^ (1u << b);
                if ((T & ~axes) || P < T) continue;  // each pair once: T on the fluid's side, P beyond
                // On the plane T and P are the same node, on the fluid's side: it gains its own image.
                const WallSide beyond = on_plane ? WallSide{true, low} : WallSide{false, low};
                const WallSide fluid_side{true, low};
#pragma unroll
                for (int ch = 0; ch < 4; ++ch) {
                    if (ch < first || ch >= end) continue;
                    const bool normal = ch == 1 + b;
                    if (fixed) {
                        const i64 own = q[T][ch], partner = q[P][ch];
                        q[T][ch] = own + wall_image(own, partner, normal, fluid_side);
                        q[P][ch] = partner + wall_image(partner, own, normal, beyond);
                    } else {
                        const float own = f[T][ch], partner = f[P][ch];
                        f[T][ch] = own + wall_image(own, partner, normal, fluid_side);
                        f[P][ch] = partner + wall_image(partner, own, normal, beyond);
                    }
                }
            }
        }
#pragma unroll
        for (u32 T = 0; T < 8; ++T) {
            if (T & ~axes) continue;
            if (fixed) {
#pragma unroll
                for (int ch = 0; ch < 4; ++ch) {
                    if (ch < first || ch >= end) continue;
                    if (ch == 0) fixed_mass[node[T]] = (u64)q[T][0];
                    else fixed_momentum[3 * node[T] + ch - 1] = (u64)q[T][ch];
                }
            } else if (quantity == MIRROR_MASS) {
                grid_acc[node[T]].w = f[T][0];
            } else if (quantity == MIRROR_MOMENTUM) {
                grid_acc[node[T]].x = f[T][1];
                grid_acc[node[T]].y = f[T][2];
                grid_acc[node[T]].z = f[T][3];
            } else {
                grid_acc[node[T]] = make_float4(f[T][1], f[T][2], f[T][3], f[T][0]);
            }
            // An image written into an unmarked block: list it (mark_node_block, less its plain read).
            if (block_marks && marked[T] == 0u && atomicExch(&block_marks[block[T]], 1u) == 0u) {
                block_list[atomicAdd(&work_counts[WORK_NODE_BLOCKS], 1u)] = block[T];
            }
        }
    }
}
