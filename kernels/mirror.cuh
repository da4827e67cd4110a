// The walls' mirror image (docs/physics.md, "Walls: the mirror boundary"; `mirror_walls` in
// src/sim/cpu.rs), on one reflection orbit at a time. The CPU does, for each axis in turn (x, then y,
// then z) and each wall plane W of it, the pair of nodes (W - d, W + d), d up to the wall's reach:
// both end with the sum of both, W itself with twice its own, the image of momentum given by
// `momentum_image` (`wall_image` here): it pushes fluid off the wall and never pulls it back.
//
// The reflections of different axes map a node n's orbit {R_T(n)} (up to 8 nodes, T a subset of the
// axes on which n lies within a wall's reach) onto itself, so each of the CPU's passes changes an
// orbit's values from the orbit's values alone. `mirror_orbit_channel` does the three passes on one
// channel of an orbit's values in the CPU's order: the same integers in fixed point, the same floats
// added in the same order. Two kernels use it: mirror_walls (one thread per orbit, in place) and, in
// the fused pipeline, grid_update_wall_blocks (each node of an orbit takes its own slot, inside the
// grid update). The scatters list the node blocks that a wall's reach meets apart from the others
// (node_block_on_a_wall), so that only that kernel carries the mirror's code.
#include "common.cuh"

// One axis's two walls: node planes and reaches (the pairs W +- d stay inside the grid).
struct MirrorAxis {
    u32 lo, lo_reach, hi, hi_reach;
};

__device__ __forceinline__ MirrorAxis mirror_axis(const KernelParams& params, int a) {
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

// A node's reflection orbit: the axes on which it lies within a wall's reach (bit b for axis b), which
// wall of each (`mirror_zone`), and the orbit's representative, its node on the fluid's side (or the
// plane) of each of those walls. Slot T of the orbit is R_T(representative).
struct MirrorOrbit {
    u32 axes;
    int zone[3];
    u32 rep[3];
};

__device__ __forceinline__ MirrorOrbit mirror_orbit(const MirrorAxis m[3], const u32 c[3]) {
    MirrorOrbit o;
    o.axes = 0;
    for (int b = 0; b < 3; ++b) {
        o.zone[b] = mirror_zone(m[b], c[b]);
        o.rep[b] = c[b];
        if (o.zone[b] == 0) continue;
        o.axes |= 1u << b;
        if (!mirror_fluid_side(m[b], o.zone[b], c[b])) o.rep[b] = mirror_reflect(m[b], o.zone[b], c[b]);
    }
    return o;
}

// Where the orbit's slot T is stored (T a subset of o.axes), its node in r. The box holds it: a
// rank's box holds both ends of every mirror pair it meets (`Slabs::holds_mirror`).
__device__ __forceinline__ size_t mirror_orbit_node(const KernelParams& params, const MirrorAxis m[3],
                                                    const MirrorOrbit& o, u32 T, u32 r[3]) {
    for (int b = 0; b < 3; ++b) r[b] = (T >> b) & 1u ? mirror_reflect(m[b], o.zone[b], o.rep[b]) : o.rep[b];
    return grid_index(params, r[0], r[1], r[2]);
}

// Adds the images to one channel of an orbit's values (0 the mass, 1 + k momentum k) axis by axis
// (x, y, z), as src/sim/cpu.rs's passes over the whole grid do: in each, every node of the orbit
// gains its partner's image across that axis's plane (the plane's own node, its own). A channel's
// images read that channel alone, so the channels may be done in any order, or only some of them.
// V: i64 in fixed point, float otherwise; slots outside o.axes are neither read nor written.
template <typename V>
__device__ __forceinline__ void mirror_orbit_channel(const MirrorAxis m[3], const MirrorOrbit& o, int ch, V v[8]) {
#pragma unroll
    for (int b = 0; b < 3; ++b) {
        if (!((o.axes >> b) & 1u)) continue;
        const bool low = o.zone[b] == 1;
        const bool on_plane = o.rep[b] == (low ? m[b].lo : m[b].hi);
        const bool normal = ch == 1 + b;
        // On the plane T and P are the same node, on the fluid's side: it gains its own image.
        const WallSide beyond = on_plane ? WallSide{true, low} : WallSide{false, low};
        const WallSide fluid_side{true, low};
#pragma unroll
        for (u32 T = 0; T < 8; ++T) {
            const u32 P = T ^ (1u << b);
            if ((T & ~o.axes) || P < T) continue;  // each pair once: T on the fluid's side, P beyond
            const V own = v[T], partner = v[P];
            v[T] = own + wall_image(own, partner, normal, fluid_side);
            v[P] = partner + wall_image(partner, own, normal, beyond);
        }
    }
}

// Whether the grid update's mirror reads or writes a node of node block (bx, by, bz): whether the
// mirror is on and, along some axis, the block lies at or below the last block of the low wall's
// reach (nodes up to lo + lo_reach) or at or above the first of the high wall's (from hi - hi_reach).
// With the walls' reaches apart, as the host checks, each runs to the grid's edge (lo_reach = lo,
// hi_reach = res - 1 - hi), so these are exactly the blocks a reach meets. The scatters list such
// blocks apart (list_node_block in tiles.cuh) for grid_update_wall_blocks; grid_update_blocks, over
// the others, has no mirror. Written as a prefix and a suffix since the scatters run it: testing each
// reach's two ends spilled one_pass_float_planes (held to 128 registers). Counted on the host by
// `node_blocks_on_walls` (src/cuda/mirror_walls.rs), which sizes the wall kernel's launch.
__device__ __forceinline__ bool node_block_on_a_wall(const KernelParams& params, u32 bx, u32 by, u32 bz) {
    if (params.wall_mirror_lo == 0u) return false;
    const u32 block[3] = {bx, by, bz};
    bool on = false;
    for (int a = 0; a < 3; ++a) {
        const MirrorAxis m = mirror_axis(params, a);
        on |= block[a] <= (m.lo + m.lo_reach) / NODE_BLOCK_EDGE || block[a] >= (m.hi - m.hi_reach) / NODE_BLOCK_EDGE;
    }
    return on;
}

// Whether node coordinate c, within a wall's reach (`zone` non-zero), has its reflection in another
// node block: then two CUDA blocks of grid_update_wall_blocks read it, and neither may zero it (the
// fused pipeline's grid update leaves it to `clear_crossing_orbits`).
__device__ __forceinline__ bool mirror_crosses_blocks(const MirrorAxis& m, int zone, u32 c) {
    return mirror_reflect(m, zone, c) / NODE_BLOCK_EDGE != c / NODE_BLOCK_EDGE;
}

// Channel ch of one node's sums (0 the mass, 1 + k momentum k): fixed-point units, or a float.
__device__ __forceinline__ void mirror_load(size_t n, int ch, const float4* grid_acc, const u64*, const u64*, float& v) {
    const float4 acc = grid_acc[n];
    v = ch == 0 ? acc.w : ch == 1 ? acc.x : ch == 2 ? acc.y : acc.z;
}

__device__ __forceinline__ void mirror_load(size_t n, int ch, const float4*, const u64* fixed_mass,
                                            const u64* fixed_momentum, i64& v) {
    v = (i64)(ch == 0 ? fixed_mass[n] : fixed_momentum[3 * n + ch - 1]);
}

// Reads channel ch of an orbit: slot T from grid index node[T], for T a subset of o.axes.
template <typename V>
__device__ __forceinline__ void mirror_orbit_load(const MirrorOrbit& o, const size_t node[8], int ch,
                                                  const float4* grid_acc, const u64* fixed_mass,
                                                  const u64* fixed_momentum, V v[8]) {
#pragma unroll
    for (u32 T = 0; T < 8; ++T)
        if (!(T & ~o.axes)) mirror_load(node[T], ch, grid_acc, fixed_mass, fixed_momentum, v[T]);
}
