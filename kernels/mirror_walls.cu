// mirror_walls: adds the mirror image of the fluid beyond the walls to the grid, in place, for the
// mass (after the mass scatter), the momentum (after p2g), or the volume of a scene whose rest
// densities differ (after scatter_volume, passed as the fixed-point mass); the rule of `mirror_walls`
// in src/sim/cpu.rs (mirror.cuh says how an orbit's images are added). The fused pipeline mirrors
// inside its grid update instead (grid_update.cu).
//
// All three axes in one launch: one thread per orbit reads its values, does the three passes on them
// (`mirror_orbit_channel`), writes them back, and touches no other thread's nodes. The orbit's thread
// is the one at its representative, the node on the fluid's side of every wall it is near; the launch
// covers, per axis, the slabs of the fluid's side of that axis's two walls, and a node in several
// slabs (an edge or corner) is taken by the slab of its lowest such axis.
//
// In the binned pipeline (marks given), an orbit whose node blocks no scatter touched holds zeros and
// is skipped, and one written marks its blocks, so the grid update consumes what the images add;
// the report's pipeline passes null marks and visits every orbit.
#include "tiles.cuh"


// Fluid-side coordinates of an axis's two walls: lo..lo + lo_reach, then hi - hi_reach..hi.
__device__ __forceinline__ u32 mirror_slab_width(const MirrorAxis& m) {
    return m.lo_reach + 1 + m.hi_reach + 1;
}

__device__ __forceinline__ u32 mirror_slab_coordinate(const MirrorAxis& m, u32 k) {
    return k <= m.lo_reach ? m.lo + k : m.hi - m.hi_reach + (k - m.lo_reach - 1);
}

// Writes channel ch of one node back: fixed-point units, or a float of the float4 (w the mass).
__device__ __forceinline__ void mirror_store(size_t n, int ch, float4*, u64* fixed_mass, u64* fixed_momentum, i64 v) {
    if (ch == 0) fixed_mass[n] = (u64)v;
    else fixed_momentum[3 * n + ch - 1] = (u64)v;
}

__device__ __forceinline__ void mirror_store(size_t n, int ch, float4* grid_acc, u64*, u64*, float v) {
    float* acc = reinterpret_cast<float*>(&grid_acc[n]);
    acc[ch == 0 ? 3 : ch - 1] = v;
}

// Reads an orbit's channels [first, end), adds their images, writes them back; the orbit's loads all
// at once, before any pass (a chain of dependent loads would be the kernel's whole cost).
template <typename V>
__device__ __forceinline__ void mirror_orbit_in_place(const MirrorAxis m[3], const MirrorOrbit& o, const size_t node[8],
                                                      int first, int end, float4* grid_acc, u64* fixed_mass,
                                                      u64* fixed_momentum) {
    V v[4][8];
#pragma unroll
    for (int ch = 0; ch < 4; ++ch)
        if (ch >= first && ch < end) mirror_orbit_load(o, node, ch, grid_acc, fixed_mass, fixed_momentum, v[ch]);
#pragma unroll
    for (int ch = 0; ch < 4; ++ch)
        if (ch >= first && ch < end) mirror_orbit_channel(m, o, ch, v[ch]);
#pragma unroll
    for (int ch = 0; ch < 4; ++ch) {
        if (ch < first || ch >= end) continue;
#pragma unroll
        for (u32 T = 0; T < 8; ++T)
            if (!(T & ~o.axes)) mirror_store(node[T], ch, grid_acc, fixed_mass, fixed_momentum, v[ch][T]);
    }
}

extern "C" __global__ void mirror_walls(const KernelParams params, const u32 quantity,
                                        float4* __restrict__ grid_acc,
                                        u64* __restrict__ fixed_mass,
                                        u64* __restrict__ fixed_momentum,
                                        u32* block_marks, u32* block_list, u32* work_counts) {
    if (params.wall_mirror_lo == 0) return;
    // The volume is fixed-point units whatever the scatter mode.
    const bool fixed = quantity == MIRROR_VOLUME || params.scatter_mode == SCATTER_FIXED_POINT;
    // Across each axis, the grid box's nodes: a rank meets the walls of its own box.
    const u32 res[3] = {params.box_res[0], params.box_res[1], params.box_res[2]};
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
        c[(a + 1) % 3] = params.box_lo[(a + 1) % 3] + (i / width) % res[(a + 1) % 3];
        c[(a + 2) % 3] = params.box_lo[(a + 2) % 3] + i / (width * res[(a + 1) % 3]);
        if (!in_grid_box(params, c)) continue;

        // This node is its orbit's representative only on the fluid side of each of its walls, and
        // only in the slab of the lowest of their axes.
        const MirrorOrbit o = mirror_orbit(m, c);
        const u32 axes = o.axes;
        if (o.rep[0] != c[0] || o.rep[1] != c[1] || o.rep[2] != c[2] || (axes & ((1u << a) - 1u))) continue;

        // The orbit's nodes and the marks of their node blocks, all loaded at once (a chain of
        // dependent loads would be the kernel's whole cost).
        size_t node[8];
        u32 block[8], marked[8];
        bool touched = block_marks == nullptr;
#pragma unroll
        for (u32 T = 0; T < 8; ++T) {
            if (T & ~axes) continue;
            u32 r[3];
            node[T] = mirror_orbit_node(params, m, o, T, r);
            block[T] = node_block_index(blocks, r[0] / NODE_BLOCK_EDGE, r[1] / NODE_BLOCK_EDGE, r[2] / NODE_BLOCK_EDGE);
            if (block_marks) marked[T] = block_marks[block[T]];
        }
        if (block_marks) {
#pragma unroll
            for (u32 T = 0; T < 8; ++T) touched |= !(T & ~axes) && marked[T] != 0u;
        }
        if (!touched) continue;  // every node of the orbit holds zeros

        const int first = quantity == MIRROR_MOMENTUM ? 1 : 0;
        const int end = quantity == MIRROR_MOMENTUM ? 4 : 1;
        if (fixed) mirror_orbit_in_place<i64>(m, o, node, first, end, grid_acc, fixed_mass, fixed_momentum);
        else mirror_orbit_in_place<float>(m, o, node, first, end, grid_acc, fixed_mass, fixed_momentum);
#pragma unroll
        for (u32 T = 0; T < 8; ++T) {
            if (T & ~axes) continue;
            // An image written into an unmarked block: list it (mark_node_block, less its plain read),
            // with the wall blocks: every node of an orbit lies within the reach of the walls of the
            // orbit's axes, so its block meets a wall (node_block_on_a_wall), and the mirror is on.
            if (block_marks && marked[T] == 0u && atomicExch(&block_marks[block[T]], 1u) == 0u) {
                list_node_block(blocks, BlockMarks{block_marks, block_list, work_counts}, block[T], true);
            }
        }
    }
}
