// Shared by every kernel: the quadratic B-spline stencil, the fixed-point scatter and the extremes
// reductions. The structs kernels receive by value and the constants they share with the host come
// from contract.cuh, which build.rs writes from src/contract/items.rs.
//
// build.rs pastes this file in place of `#include "common.cuh"`, with #line markers so that NVRTC's
// messages still name this file and line. No standard headers: NVRTC ships none.

#include "contract.cuh"
#include "material.cuh"

#include "colliders.cuh"


// ---------------------------------------------------------------------------------------------
// Grid-stride loops: any launch size covers any count, so launches need no 2D/3D grid tricks.
// FOR_EACH_INDEX leaves lanes past the end idle; FOR_EACH_INDEX_CONVERGED keeps every lane of a warp in
// the loop (the bound depends only on the block's first index, and blocks are whole warps), with
// `live` false past the end, for loops that use warp-wide operations.

#define FOR_EACH_INDEX(index, count)                                                      \
    for (u32 index = blockIdx.x * blockDim.x + threadIdx.x; index < (count);             \
         index += blockDim.x * gridDim.x)

#define FOR_EACH_INDEX_CONVERGED(index, live, first, count)                                 \
    for (u32 first = blockIdx.x * blockDim.x; first < (count); first += blockDim.x * gridDim.x) \
        if (const u32 index = first + threadIdx.x; true)                                        \
            if (const bool live = index < (count); true)

// ---------------------------------------------------------------------------------------------
// Where a node is stored. Kernels work in the domain's node coordinates; a GPU's grid holds the box
// params.box_lo .. box_lo + box_res of them (one GPU: the whole grid; a rank of several: its slab and
// ghost planes along the slab axis, src/cuda/grid.rs `GridBox`), x fastest. Only the address of a
// node depends on the box.

__device__ __forceinline__ u32 grid_index(const KernelParams& params, u32 x, u32 y, u32 z) {
    return (x - params.box_lo[0]) + params.box_res[0] * ((y - params.box_lo[1]) + params.box_res[1] * (z - params.box_lo[2]));
}

// The domain coordinates of the node stored at i.
__device__ __forceinline__ void grid_node_of(const KernelParams& params, u32 i, u32 c[3]) {
    const u32 rx = params.box_res[0], ry = params.box_res[1];
    c[0] = params.box_lo[0] + i % rx;
    c[1] = params.box_lo[1] + (i / rx) % ry;
    c[2] = params.box_lo[2] + i / (rx * ry);
}

// Whether the box holds node c.
__device__ __forceinline__ bool in_grid_box(const KernelParams& params, const u32 c[3]) {
    return c[0] - params.box_lo[0] < params.box_res[0] && c[1] - params.box_lo[1] < params.box_res[1] &&
           c[2] - params.box_lo[2] < params.box_res[2];
}

// ---------------------------------------------------------------------------------------------
// The quadratic B-spline stencil of docs/physics.md, in the same operation order as `Stencil` in
// src/sim/cpu.rs, so that the CPU reference and the kernels round alike wherever they can.

struct Stencil {
    u32 base[3];     // base = floor(X - 0.5), the lowest stencil node
    u32 base_index;  // where its node is stored (grid_index)
    float fx[3];     // X - base, each in [0.5, 1.5)
    float w[3][3];   // w[o][axis]: weight of node base + o along axis
};

__device__ __forceinline__ Stencil make_stencil(float4 x, const KernelParams& params) {
    Stencil s;
    float xg[3] = {x.x * params.inv_dx, x.y * params.inv_dx, x.z * params.inv_dx};
    for (int a = 0; a < 3; ++a) {
        float b = floorf(xg[a] - 0.5f);
        s.base[a] = (u32)(int)b;
        float f = xg[a] - b;
        s.fx[a] = f;
        s.w[0][a] = 0.5f * (1.5f - f) * (1.5f - f);
        s.w[1][a] = 0.75f - (f - 1.0f) * (f - 1.0f);
        s.w[2][a] = 0.5f * (f - 0.5f) * (f - 0.5f);
    }
    s.base_index = grid_index(params, s.base[0], s.base[1], s.base[2]);
    return s;
}

// Calls body(node, w, d0, d1, d2) for the 27 nodes, z outermost, x innermost (cpu.rs order), with
// node = first + ox + oy row_stride + oz plane_stride: grid indices, or a shared tile's (tiles.cuh).
#define FOR_EACH_STENCIL_NODE_AT(s, first, row_stride, plane_stride, node, weight, d0, d1, d2, ...)  \
    {                                                                                              \
        const u32 _sx = (row_stride);                                                              \
        const u32 _sxy = (plane_stride);                                                           \
        _Pragma("unroll") for (int _oz = 0; _oz < 3; ++_oz) {                                      \
            const float _wz = (s).w[_oz][2];                                                       \
            const float d2 = (float)_oz - (s).fx[2];                                               \
            _Pragma("unroll") for (int _oy = 0; _oy < 3; ++_oy) {                                  \
                const float _wyz = (s).w[_oy][1] * _wz;                                            \
                const float d1 = (float)_oy - (s).fx[1];                                           \
                const u32 _row = (first) + _oy * _sx + _oz * _sxy;                                 \
                _Pragma("unroll") for (int _ox = 0; _ox < 3; ++_ox) {                              \
                    const float d0 = (float)_ox - (s).fx[0];                                       \
                    const u32 node = _row + _ox;                                                   \
                    const float weight = (s).w[_ox][0] * _wyz;                                     \
                    (void)d0, (void)d1, (void)d2;                                                  \
                    __VA_ARGS__                                                                    \
                }                                                                                  \
            }                                                                                      \
        }                                                                                          \
    }

// The same over the grid's own node indices.
#define FOR_EACH_STENCIL_NODE(s, params, node, weight, d0, d1, d2, ...)                            \
    FOR_EACH_STENCIL_NODE_AT(s, (s).base_index, (params).box_res[0],                               \
                             (params).box_res[0] * (params).box_res[1], node, weight, d0, d1, d2, __VA_ARGS__)

// ---------------------------------------------------------------------------------------------
// Fixed-point scatter. Each contribution is scaled and rounded to the nearest integer (not truncated:
// truncation biases every sum towards zero), then summed as integers (in a warp run, a tile, or by
// 64-bit atomics), which commute, so the sums do not depend on the order threads arrive in. A
// contribution above 2^52 units could, summed with a few thousand others, wrap the 64-bit accumulator:
// it is counted (and reported by the host) instead of added. The host picks the scales so that real
// contributions stay near 2^40.

#define FIXED_CONTRIBUTION_LIMIT 4503599627370496.0f /* 2^52 */
#define FIXED_SUM_LIMIT 4611686018427387904LL        /* 2^62 */

// A contribution in fixed-point units, rounded; 0, and counted, where it is out of range.
__device__ __forceinline__ i64 fixed_point_units(float scaled, StepCounters* counters) {
    if (!(fabsf(scaled) < FIXED_CONTRIBUTION_LIMIT)) {  // also catches NaN
        atomicAdd(&counters->fixed_overflows, 1u);
        return 0;
    }
    return __float2ll_rn(scaled);
}

__device__ __forceinline__ float fixed_point_value(u64 units, float inv_scale) {
    return __ll2float_rn((i64)units) * inv_scale;
}

// ---------------------------------------------------------------------------------------------
// Warp-aggregated float scatter. The scatters walk particles sorted by cell (kernels/bins.cu), so the
// 32 lanes of a warp hold a few runs of consecutive lanes whose particles share a cell, and so all 27
// stencil nodes: without aggregation each node of a run gets one atomic per lane, and same-address
// atomics serialise. Each lane finds its run once per particle (warp_run: one ballot), then for every
// node the run's values are summed towards its first lane in five shuffle steps (warp_run_sum), and
// that lane alone issues the atomic: about 8x fewer atomics at 8 particles per cell. Lanes with the
// same cell that are not adjacent form runs of their own: more atomics, never a wrong sum.
// (Measured at bench-655k on the H200: match_any per node and a serial sum over the group cost
// 0.12 ms in p2g; see BENCHMARKS.md for the figure with runs.)
// Every lane of the warp must call these together (they shuffle with a full mask).

struct WarpRun {
    u32 last;   // the run's last lane
    bool head;  // the run's first lane: the one that adds the run's sum
};

__device__ __forceinline__ WarpRun warp_run(u32 key) {
    const u32 lane = threadIdx.x & 31u;
    const u32 before = __shfl_up_sync(0xffffffffu, key, 1);
    const bool head = lane == 0 || before != key;
    const u32 heads_after = __ballot_sync(0xffffffffu, head) & ~((2u << lane) - 1u);  // heads past this lane
    return WarpRun{heads_after ? (u32)__ffs(heads_after) - 2u : 31u, head};
}

// Sums N values over the run into its first lane's `values` (the other lanes keep partial sums), in
// the shuffle steps that runs of up to `lanes` lanes need: five for any run (32), three for runs of
// up to 8 (warp_longest_run tells a pass that sums many values at once how few it may take; the
// steps left out would add nothing to the heads' sums, so these are the same bits).
// Floats for the float scatter; 64-bit integers for the fixed-point one, each lane's contribution
// rounded before the sum, so the sums stay exact and independent of which lanes share a run.
template <typename T, int N>
__device__ __forceinline__ void warp_run_sum(WarpRun run, T (&values)[N], u32 lanes = 32) {
    const u32 lane = threadIdx.x & 31u;
    for (u32 offset = 1; offset < lanes; offset <<= 1) {
#pragma unroll
        for (int k = 0; k < N; ++k) {
            const T x = __shfl_down_sync(0xffffffffu, values[k], offset);
            if (lane + offset <= run.last) values[k] += x;
        }
    }
}

// The warp's longest run, in lanes, the same in every lane.
__device__ __forceinline__ u32 warp_longest_run(WarpRun run) {
    const u32 length = run.head ? run.last - (threadIdx.x & 31u) + 1u : 0u;
#if __CUDA_ARCH__ >= 800
    return __reduce_max_sync(0xffffffffu, length);
#else
    u32 longest = length;
    for (u32 offset = 16; offset > 0; offset >>= 1) longest = max(longest, __shfl_xor_sync(0xffffffffu, longest, offset));
    return longest;
#endif
}

// ---------------------------------------------------------------------------------------------
// Float scatter of a momentum into a node's float4 accumulator (.w, the mass, is left unchanged).
// sm_90 has a vector atomic: one 16-byte red.global.add instead of three, a third of the atomic
// traffic of p2g. build.rs compiles a compute_90 PTX for it next to the compute_75 one.

__device__ __forceinline__ void atomic_add_momentum(float4* acc, float x, float y, float z) {
#if __CUDA_ARCH__ >= 900
    atomicAdd(acc, make_float4(x, y, z, 0.0f));  // adds 0 to the mass: unchanged for its readers
#else
    atomicAdd(&acc->x, x);
    atomicAdd(&acc->y, y);
    atomicAdd(&acc->z, z);
#endif
}

// The same for a whole scatter, momentum xyz and mass w, in one vector atomic on sm_90.
__device__ __forceinline__ void atomic_add_mass_momentum(float4* acc, float x, float y, float z, float m) {
#if __CUDA_ARCH__ >= 900
    atomicAdd(acc, make_float4(x, y, z, m));
#else
    atomicAdd(&acc->x, x);
    atomicAdd(&acc->y, y);
    atomicAdd(&acc->z, z);
    atomicAdd(&acc->w, m);
#endif
}

// ---------------------------------------------------------------------------------------------
// Block-wide max of a non-negative float into a counter, at most one atomic per warp. Every thread of
// the block must call it (it shuffles with a full mask), after its grid-stride loop.
//
// A warp whose max does not exceed the counter as it reads it skips the atomic. The read may be
// stale, but never above the current value: a launch sees what earlier work in the stream wrote (the
// host's reset included), and during the launch the counter only grows; so no raise is lost. Every
// warp of a pass ends on the same few words, and their atomics serialise there: measured on the H100
// (BENCHMARKS.md 0m), one_pass at the dam break took 0.111 ms with an atomic per warp and 0.102 with
// the read first.

__device__ __forceinline__ void atomic_max_nonnegative(u32* target, float value) {
    u32 bits = __float_as_uint(value);  // NaN has larger bits than +inf, so a NaN wins and shows
    for (int offset = 16; offset > 0; offset >>= 1) {
        bits = max(bits, __shfl_xor_sync(0xffffffffu, bits, offset));
    }
    if ((threadIdx.x & 31u) == 0 && bits > *target) atomicMax(target, bits);
}

// ---------------------------------------------------------------------------------------------
// The per-particle and per-node physics that both pipelines run (the report's four kernels and the
// binned, tiled passes), so the two cannot drift apart. Operation order follows src/sim/cpu.rs.

// Grid mass at the stencil, as a density: rho_p = sum_i w m_i / dx^3 (docs/physics.md step 2).
__device__ __forceinline__ float gather_density(const Stencil& s, const KernelParams& params, const float4* grid_acc,
                                                const u64* fixed_mass) {
    const bool fixed = params.scatter_mode == SCATTER_FIXED_POINT;
    const float inv_mass_scale = fixed ? 1.0f / params.fixed_mass_scale : 0.0f;
    const float* grid_mass_words = reinterpret_cast<const float*>(grid_acc) + 3;  // stride 4
    float grid_mass = 0.0f;  // with the walls' image mass, which mirror_walls added after the mass scatter
    FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
        const float m_i = fixed ? fixed_point_value(fixed_mass[node], inv_mass_scale) : grid_mass_words[4 * (size_t)node];
        grid_mass += w * m_i;
    })
    return grid_mass * params.inv_dx * params.inv_dx * params.inv_dx;
}

// The grid's volume at the stencil times the particle's own mass, as a density (Params::volume_density:
// the rest densities differ): rho_p = m_p sum_i w V_i / dx^3, V_i the node's weights in
// VOLUME_UNITS_PER_WEIGHT (volume.cu, the walls' images added). `volume_density` in src/sim/cpu.rs
// is the twin.
__device__ __forceinline__ float gather_volume_density(const Stencil& s, const KernelParams& params,
                                                       const u64* volume, float m_p) {
    const float inv_units = 1.0f / VOLUME_UNITS_PER_WEIGHT;
    float weights = 0.0f;
    FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, { weights += w * fixed_point_value(volume[node], inv_units); })
    return weights * m_p * (params.inv_dx * params.inv_dx * params.inv_dx);
}

// What a particle scatters to node d (in cells from it): w (mv + affine d), with
//   affine = m_p dx C - (4 dt V_p / dx) sigma,  sigma = -p I + mu (C + C^T),  V_p = m_p / rho.
struct ParticleImpulse {
    float mv[3];
    float affine[3][3];  // [column][row]
    float mass;          // m_p, the mass it scatters with the momentum
};

// MATERIALS false: a scene of one Newtonian liquid (water), whose pass is compiled without the
// table's index and the laws' call (one_pass.cu's water entries).
template <bool MATERIALS = true>
__device__ __forceinline__ ParticleImpulse particle_impulse(const KernelParams& params, float rho, float4 vp, float4 c0,
                                                            float4 c1, float4 c2) {
    const Material& mat = material_table[MATERIALS ? material_index(params, vp) : 0u];
    const float m_p = mat.particle_mass;
    const float dx = params.dx;
    const float volume = m_p / rho;
    const float pressure = material_pressure(mat, rho);
    const float cm[3][3] = {{c0.x, c0.y, c0.z}, {c1.x, c1.y, c1.z}, {c2.x, c2.y, c2.z}};  // C as cm[column][row]
    const float viscosity = MATERIALS ? material_viscosity(mat, cm, rho) : mat.viscosity;
    const float stress_factor = 4.0f * params.dt * volume / dx;
    ParticleImpulse out;
    for (int col = 0; col < 3; ++col) {
        for (int row = 0; row < 3; ++row) {
            const float stress = material_stress(viscosity, pressure, cm, row, col);
            out.affine[col][row] = cm[col][row] * (m_p * dx) - stress * stress_factor;
        }
    }
    out.mass = m_p;
    out.mv[0] = vp.x * m_p;
    out.mv[1] = vp.y * m_p;
    out.mv[2] = vp.z * m_p;
    return out;
}

// A particle's deformation (a solid's, or an elastoviscoplastic liquid's) as the particle pass holds
// it (Deformation in src/sim/scene.rs):
// F_E as f[column][row] and its law's plastic scalar; stored as three float4 arrays of n, F_E's
// columns, the scalar in column 0's w.
struct Deformation {
    float f[3][3];
    float plastic;
};

__device__ __forceinline__ Deformation load_deformation(const float4* deformation, u32 n, u32 p) {
    Deformation d;
    for (int col = 0; col < 3; ++col) {
        const float4 column = deformation[(size_t)col * n + p];
        d.f[col][0] = column.x;
        d.f[col][1] = column.y;
        d.f[col][2] = column.z;
        if (col == 0) d.plastic = column.w;
    }
    return d;
}

__device__ __forceinline__ void store_deformation(float4* deformation, u32 n, u32 p, const Deformation& d) {
    for (int col = 0; col < 3; ++col)
        deformation[(size_t)col * n + p] = make_float4(d.f[col][0], d.f[col][1], d.f[col][2], col == 0 ? d.plastic : 0.0f);
}

// g2p's update of a particle's deformation from its new velocity gradient C (c[column]): F carried over
// the substep, F <- (I + dt C) F, then its law's return mapping (solid.cuh). `advance_deformation` in
// src/sim/cpu.rs, with glam's order: column j of A F is ((A_0 F_0j + A_1 F_1j) + A_2 F_2j). Returns
// whether the law has a return mapping, which then wrote the Kirchhoff stress of the result into tau
// (solid_plastic_return).
__device__ __forceinline__ bool advance_deformation(const KernelParams& params, const Material& mat,
                                                    const float4 (&c)[3], Deformation& d, float (&tau)[3][3]) {
    const float dt = params.dt;
    const float a[3][3] = {{1.0f + c[0].x * dt, c[0].y * dt, c[0].z * dt},
                           {c[1].x * dt, 1.0f + c[1].y * dt, c[1].z * dt},
                           {c[2].x * dt, c[2].y * dt, 1.0f + c[2].z * dt}};
    const float f[3][3] = {{d.f[0][0], d.f[0][1], d.f[0][2]}, {d.f[1][0], d.f[1][1], d.f[1][2]},
                           {d.f[2][0], d.f[2][1], d.f[2][2]}};
    for (int col = 0; col < 3; ++col) {
        for (int row = 0; row < 3; ++row) d.f[col][row] = a[0][row] * f[col][0] + a[1][row] * f[col][1] + a[2][row] * f[col][2];
    }
    d.plastic = solid_plastic_return(mat, d.f, d.plastic, tau);
    return solid_has_return(mat.law);
}

// The Kirchhoff stress of deformation d: `given` where the pass's return mapping wrote it from its own
// decomposition (advance_deformation; null otherwise), else its law's of d.
__device__ __forceinline__ void deformed_stress(const Material& mat, const Deformation& d, const float (*given)[3],
                                                float (&tau)[3][3]) {
    if (given) {
#pragma unroll
        for (int c = 0; c < 3; ++c)
#pragma unroll
            for (int r = 0; r < 3; ++r) tau[c][r] = given[c][r];
    } else {
        solid_kirchhoff_stress(mat, d.f, d.plastic, tau);
    }
}

// What a solid particle scatters (p2g_particle in src/sim/cpu.rs): its law's Kirchhoff stress tau =
// J sigma (deformed_stress) over its rest volume V0 = m_p / rho0, as V sigma = V0 tau, in place of
// the liquids' pressure and viscous stress: affine = m_p dx C - (4 dt V0 / dx) tau.
__device__ __forceinline__ ParticleImpulse solid_impulse(const KernelParams& params, const Material& mat, float4 vp,
                                                         float4 c0, float4 c1, float4 c2, const Deformation& d,
                                                         const float (*given)[3]) {
    const float m_p = mat.particle_mass;
    const float dx = params.dx;
    float tau[3][3];
    deformed_stress(mat, d, given, tau);
    const float cm[3][3] = {{c0.x, c0.y, c0.z}, {c1.x, c1.y, c1.z}, {c2.x, c2.y, c2.z}};
    const float stress_factor = 4.0f * params.dt * (m_p / mat.rest_density) / dx;
    ParticleImpulse out;
    for (int col = 0; col < 3; ++col) {
        for (int row = 0; row < 3; ++row) out.affine[col][row] = cm[col][row] * (m_p * dx) - tau[col][row] * stress_factor;
    }
    out.mass = m_p;
    out.mv[0] = vp.x * m_p;
    out.mv[1] = vp.y * m_p;
    out.mv[2] = vp.z * m_p;
    return out;
}

// What a particle that carries a deformation scatters (p2g_particle in src/sim/cpu.rs): a solid's
// (solid_impulse), or an elastoviscoplastic liquid's: the liquid's pressure and viscous stress, then
// its elastic part's deviatoric Kirchhoff stress over its rest volume as a solid's. `given`: the
// stress the pass's return mapping wrote, or null (deformed_stress).
__device__ __forceinline__ ParticleImpulse deformed_impulse(const KernelParams& params, const Material& mat, float rho,
                                                            float4 vp, float4 c0, float4 c1, float4 c2,
                                                            const Deformation& d, const float (*given)[3]) {
    if (solid_is_solid(mat.law)) return solid_impulse(params, mat, vp, c0, c1, c2, d, given);
    ParticleImpulse out = particle_impulse<true>(params, rho, vp, c0, c1, c2);
    float elastic[3][3];
    deformed_stress(mat, d, given, elastic);
    const float stress_factor = 4.0f * params.dt * (mat.particle_mass / mat.rest_density) / params.dx;
    for (int col = 0; col < 3; ++col) {
        for (int row = 0; row < 3; ++row) out.affine[col][row] -= elastic[col][row] * stress_factor;
    }
    return out;
}

// The signal speed of a particle that carries a deformation: a solid's own wave speed (snow's
// hardening included), or an elastoviscoplastic liquid's (`GatherExtremes` in src/sim/cpu.rs).
__device__ __forceinline__ float deformed_signal_speed(const Material& mat, float rho, float speed,
                                                       const Deformation& d) {
    return solid_is_solid(mat.law) ? solid_wave_speed(mat, d.plastic) + speed
                                   : material_elastic_signal_speed(mat, rho, speed);
}

// The affine product is summed z first and x last, so the terms before x are the same for a plane
// or a row of the stencil and the compiler computes them once there: 6 instructions a node (an FMA
// and a multiply a row) where summed x first they took 9 to 15.
__device__ __forceinline__ void impulse_at(const ParticleImpulse& q, float w, float d0, float d1, float d2,
                                           float (&impulse)[3]) {
    for (int row = 0; row < 3; ++row) {
        const float plane = fmaf(q.affine[2][row], d2, q.mv[row]);
        impulse[row] = w * fmaf(q.affine[0][row], d0, fmaf(q.affine[1][row], d1, plane));
    }
}

// impulse_at with every operation rounded as written (__fmaf_rn and __fmul_rn are neither contracted
// nor split), for a scatter that computes a contribution in two places and must get the same bits in
// both (tile_scatter in tiles.cuh).
__device__ __forceinline__ void impulse_at_pinned(const ParticleImpulse& q, float w, float d0, float d1, float d2,
                                                  float (&impulse)[3]) {
    for (int row = 0; row < 3; ++row) {
        const float plane = __fmaf_rn(q.affine[2][row], d2, q.mv[row]);
        impulse[row] = __fmul_rn(w, __fmaf_rn(q.affine[0][row], d0, __fmaf_rn(q.affine[1][row], d1, plane)));
    }
}

// g2p for one particle (docs/physics.md step 4): gather v and C = (4/dx) sum w v_i d^T from the node
// velocities, the optional soft wall, advection and the clamp to [1, R-2] dx; also the particle's
// speed and signal speed c(rho) + |v| for the time-step extremes.
struct G2pResult {
    float4 x, v, c[3];
    float speed, signal;
};

// What the fused pipeline's density needs from the same gather (g2p_particle_and_density): the grid
// mass at the particle's position before the advection, sum w m_i (grid_vel.w), and the fluid's
// velocity divergence there (DensityRule::fluid_divergence in src/sim/params.rs).
struct GridDensity {
    float mass, divergence;
};

template <bool DENSITY>
__device__ __forceinline__ G2pResult g2p_gather(const KernelParams& params, float4 xp, float material_tag, float rho,
                                                const float4* grid_vel, GridDensity* density) {
    const float dx = params.dx, dt = params.dt, tau = params.soft_wall_tau;
    const float res[3] = {(float)params.grid_res[0], (float)params.grid_res[1], (float)params.grid_res[2]};
    const float wall_lo = (float)(params.boundary_band + 1) * dx;
    const float wall_offset = (float)(params.boundary_band + 2);
    const Stencil s = make_stencil(xp, params);
    float vel[3] = {0.0f, 0.0f, 0.0f};
    float b[3][3] = {{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}};  // b[column][row]
    float grid_mass = 0.0f;
    float filled_w_d[3] = {0.0f, 0.0f, 0.0f};
    // Summed a stencil row at a time: each row's nodes weighted along x alone (sum wx v, sum wx d0 v,
    // and the mass's and the filled nodes' sums), then the row weighted by wy wz, so the products
    // with the weight and the offsets along y and z are taken once a row, not once a node (the same
    // sums, added in another order). Measured on the H100 with the scatter's impulse below
    // (BENCHMARKS.md 0y): the float substep 2 to 8 % shorter, the most where the GPU is full.
    const float wd0[3] = {s.w[0][0] * (0.0f - s.fx[0]), s.w[1][0] * (1.0f - s.fx[0]), s.w[2][0] * (2.0f - s.fx[0])};
    const u32 row_stride = params.box_res[0], plane_stride = params.box_res[0] * params.box_res[1];
#pragma unroll
    for (int oz = 0; oz < 3; ++oz) {
        const float d2 = (float)oz - s.fx[2];
#pragma unroll
        for (int oy = 0; oy < 3; ++oy) {
            const float d1 = (float)oy - s.fx[1];
            const u32 first = s.base_index + (u32)oy * row_stride + (u32)oz * plane_stride;
            float row_v[3] = {0.0f, 0.0f, 0.0f}, row_vd[3] = {0.0f, 0.0f, 0.0f};
            float row_mass = 0.0f, row_filled = 0.0f, row_filled_d = 0.0f;
#pragma unroll
            for (int ox = 0; ox < 3; ++ox) {
                const float4 vi = grid_vel[first + (u32)ox];
                const float wx = s.w[ox][0];
                const float v[3] = {vi.x, vi.y, vi.z};
                for (int k = 0; k < 3; ++k) {
                    row_v[k] = fmaf(wx, v[k], row_v[k]);
                    row_vd[k] = fmaf(wd0[ox], v[k], row_vd[k]);
                }
                if (DENSITY) {
                    row_mass = fmaf(wx, vi.w, row_mass);
                    if (vi.w > 0.0f) {
                        row_filled += wx;
                        row_filled_d += wd0[ox];
                    }
                }
            }
            const float wyz = s.w[oy][1] * s.w[oz][2];
            const float wyz_d1 = wyz * d1, wyz_d2 = wyz * d2;
            for (int k = 0; k < 3; ++k) {
                vel[k] = fmaf(wyz, row_v[k], vel[k]);
                b[0][k] = fmaf(wyz, row_vd[k], b[0][k]);
                b[1][k] = fmaf(wyz_d1, row_v[k], b[1][k]);
                b[2][k] = fmaf(wyz_d2, row_v[k], b[2][k]);
            }
            if (DENSITY) {
                grid_mass = fmaf(wyz, row_mass, grid_mass);
                filled_w_d[0] = fmaf(wyz, row_filled_d, filled_w_d[0]);
                filled_w_d[1] = fmaf(wyz_d1, row_filled, filled_w_d[1]);
                filled_w_d[2] = fmaf(wyz_d2, row_filled, filled_w_d[2]);
            }
        }
    }
    if (DENSITY) {
        const float drift = vel[0] * filled_w_d[0] + vel[1] * filled_w_d[1] + vel[2] * filled_w_d[2];
        const float sum_v_dot_d = b[0][0] + b[1][1] + b[2][2];  // sum w v_i . d
        density->mass = grid_mass;
        density->divergence = 4.0f * params.inv_dx * (sum_v_dot_d - drift);
    }
    const float pos[3] = {xp.x, xp.y, xp.z};
    float next[3];
    float speed_sq = 0.0f;
    for (int a = 0; a < 3; ++a) {
        if (tau > 0.0f) {
            const float predicted = pos[a] + vel[a] * tau;
            const float wall_hi = (res[a] - wall_offset) * dx;
            vel[a] += fmaxf(wall_lo - predicted, 0.0f) / tau;
            vel[a] -= fmaxf(predicted - wall_hi, 0.0f) / tau;
        }
        next[a] = fminf(fmaxf(pos[a] + vel[a] * dt, dx), (res[a] - 2.0f) * dx);
        speed_sq += vel[a] * vel[a];
    }
    G2pResult r;
    const float scale = 4.0f * params.inv_dx;
    for (int col = 0; col < 3; ++col) {
        r.c[col] = make_float4(b[col][0] * scale, b[col][1] * scale, b[col][2] * scale, 0.0f);
    }
    r.v = make_float4(vel[0], vel[1], vel[2], material_tag);
    r.x = make_float4(next[0], next[1], next[2], 0.0f);
    r.speed = sqrtf(speed_sq);
    r.signal = material_signal_speed(material_table[material_index(params, r.v)], rho, r.speed);
    return r;
}

// The largest particle mass of the table: what bounds a tile's sums.
__device__ __forceinline__ float heaviest_particle_mass(const KernelParams& params) {
    float heaviest = material_table[0].particle_mass;
    for (u32 row = 1; row < params.material_count; ++row) heaviest = fmaxf(heaviest, material_table[row].particle_mass);
    return heaviest;
}

// v.w of particle p: the bits of its material's row (particle_material_tag), 0 in a scene of one
// material, whose passes do not read it.
__device__ __forceinline__ float particle_material_tag(const KernelParams& params, const float4* v, u32 p) {
    return params.material_count > 1u ? reinterpret_cast<const float*>(v)[4 * (size_t)p + 3] : 0.0f;
}

// The mass of particle p, from its material's row.
__device__ __forceinline__ float particle_mass_of(const KernelParams& params, const float4* v, u32 p) {
    return material_table[material_row(params, particle_material_tag(params, v, p))].particle_mass;
}

__device__ __forceinline__ G2pResult g2p_particle(const KernelParams& params, float4 xp, float material_tag, float rho,
                                                  const float4* grid_vel) {
    return g2p_gather<false>(params, xp, material_tag, rho, grid_vel, nullptr);
}

__device__ __forceinline__ G2pResult g2p_particle_and_density(const KernelParams& params, float4 xp, float material_tag,
                                                              const float4* grid_vel, GridDensity& density) {
    return g2p_gather<true>(params, xp, material_tag, 0.0f, grid_vel, &density);
}

// DensityRule::advect (src/sim/params.rs): `rho_grid`, the density gathered at the particle's position
// before the advection (from the grid's mass, mass_density, or its volume where the rest densities
// differ), carried over the substep by the fluid's velocity divergence there, the volume factor held
// within MAX_VOLUME_CHANGE of 1.
__device__ __forceinline__ float advected_density(const KernelParams& params, float rho_grid, const GridDensity& g) {
    const float volume_factor =
        fminf(fmaxf(1.0f + params.dt * g.divergence, 1.0f - MAX_VOLUME_CHANGE), 1.0f + MAX_VOLUME_CHANGE);
    return rho_grid / volume_factor;
}

// The density of the grid's mass the gather found (GridDensity::mass).
__device__ __forceinline__ float mass_density(const KernelParams& params, const GridDensity& g) {
    return g.mass * (params.inv_dx * params.inv_dx * params.inv_dx);
}

// The density a particle reports for the time step: in row 0's terms, rho rho0_0 / rho0
// (Material::reported_density in src/sim/material.rs), rho itself in a scene of one material.
__device__ __forceinline__ float reported_density(const KernelParams& params, float4 vp, float rho) {
    if (params.material_count == 1u) return rho;
    return rho * (material_table[0].rest_density / material_table[material_index(params, vp)].rest_density);
}

// The colliders' backstop after g2p_particle (src/sim/cpu.rs g2p_backstop): a particle that ended inside a
// collider goes back to its surface, then g2p's clamp again; its speed and signal speed follow.
// Not inlined, and everything by value: g2p2g is compiled for 80 registers (tiles.cuh), and its path
// without colliders should pay neither for this one's registers nor for an address taken.
struct Backstop {
    G2pResult r;
    bool pushed;
};

__device__ __noinline__ Backstop collider_backstop_moves(const float dx, const float3 res, const Colliders colliders,
                                                         const float mass, G2pResult r) {
    float x[3] = {r.x.x, r.x.y, r.x.z};
    float vel[3] = {r.v.x, r.v.y, r.v.z};
    if (!collider_backstop(colliders, mass, x, vel)) return Backstop{r, false};
    const float high[3] = {res.x - 2.0f, res.y - 2.0f, res.z - 2.0f};
    float speed_sq = 0.0f;
    for (int a = 0; a < 3; ++a) {
        x[a] = fminf(fmaxf(x[a], dx), high[a] * dx);
        speed_sq += vel[a] * vel[a];
    }
    r.x = make_float4(x[0], x[1], x[2], 0.0f);
    r.v = make_float4(vel[0], vel[1], vel[2], r.v.w);
    r.speed = sqrtf(speed_sq);
    return Backstop{r, true};
}

// The backstop's move (out of line, given only the scalars it needs: a kernel's parameters passed
// whole to a call would be copied to the stack), then the signal speed at the particle's density.
__device__ __forceinline__ Backstop collider_backstop_particle(const KernelParams& params, const Colliders& colliders,
                                                               float rho, const G2pResult& r) {
    const float3 res = make_float3((float)params.grid_res[0], (float)params.grid_res[1], (float)params.grid_res[2]);
    // The particle's mass only where a rigid body may take its push (the binned pipeline has none).
    const float mass = colliders.impulses ? material_table[material_index(params, r.v)].particle_mass : 0.0f;
    Backstop b = collider_backstop_moves(params.dx, res, colliders, mass, r);
    if (b.pushed) b.r.signal = material_signal_speed(material_table[material_index(params, b.r.v)], rho, b.r.speed);
    return b;
}

// A node's sums: mass and momentum; `own_m`, the particles' own mass there without the walls'
// mirror images (the fused pipeline adds those in the grid update; elsewhere own_m = m); and `push`,
// the velocity the images gave the node (image_push in src/sim/cpu.rs; zero where nothing reads it),
// which a Coulomb collider under the mirror counts as normal velocity removed.
struct NodeSums {
    float m, mv[3];
    float own_m;
    float push[3];
};

// Fixed-point sums (mass, then momentum) as floats.
__device__ __forceinline__ NodeSums fixed_point_floats(const KernelParams& params, const i64 q[4]) {
    NodeSums s;
    s.m = fixed_point_value((u64)q[0], 1.0f / params.fixed_mass_scale);
    const float inv_momentum_scale = 1.0f / params.fixed_momentum_scale;
    for (int a = 0; a < 3; ++a) s.mv[a] = fixed_point_value((u64)q[1 + a], inv_momentum_scale);
    s.own_m = s.m;
    s.push[0] = s.push[1] = s.push[2] = 0.0f;
    return s;
}

// fixed_point_floats of a node's sums; a sum at or beyond FIXED_SUM_LIMIT is counted.
__device__ __forceinline__ NodeSums fixed_point_sums(const KernelParams& params, const i64 q[4], StepCounters* counters) {
    bool out_of_range = false;
    for (int ch = 0; ch < 4; ++ch) out_of_range |= q[ch] >= FIXED_SUM_LIMIT || q[ch] <= -FIXED_SUM_LIMIT;
    if (out_of_range) atomicAdd(&counters->fixed_overflows, 1u);
    return fixed_point_floats(params, q);
}

__device__ __forceinline__ NodeSums float_sums(float4 acc) {
    return NodeSums{acc.w, {acc.x, acc.y, acc.z}, acc.w, {0.0f, 0.0f, 0.0f}};
}

// Zeroes node i's accumulators (the grid clear, done by their one reader).
__device__ __forceinline__ void zero_node_sums(const KernelParams& params, u32 i, float4* grid_acc, u64* fixed_mass,
                                               u64* fixed_momentum) {
    if (params.scatter_mode == SCATTER_FIXED_POINT) {
        fixed_mass[i] = 0;
        fixed_momentum[3 * (size_t)i] = 0;
        fixed_momentum[3 * (size_t)i + 1] = 0;
        fixed_momentum[3 * (size_t)i + 2] = 0;
    } else {
        grid_acc[i] = make_float4(0.0f, 0.0f, 0.0f, 0.0f);
    }
}

// grid_update for node i (docs/physics.md step 3) from its sums: momentum to velocity, gravity, the
// colliders' boundary conditions, free slip in the walls' boundary band (last, as in src/sim/cpu.rs).
__device__ __forceinline__ void update_node_velocity(const KernelParams& params, u32 i, const NodeSums& s,
                                                     float4* grid_vel, const Colliders& colliders) {
    const u32 band = params.boundary_band;
    float vel[3] = {0.0f, 0.0f, 0.0f};
    if (s.m > 0.0f) {
        u32 node[3];
        grid_node_of(params, i, node);
        const u32 res[3] = {params.grid_res[0], params.grid_res[1], params.grid_res[2]};
        for (int a = 0; a < 3; ++a) vel[a] = s.mv[a] / s.m + params.gravity[a] * params.dt;
        if (colliders.count) {
            const Vec3f x = v3((float)node[0] * params.dx, (float)node[1] * params.dx, (float)node[2] * params.dx);
            collider_project_node(colliders, x, s.own_m, s.push, vel);
        }
        // Only motion into the wall is removed (as a collider's boundary does): fluid leaves freely.
        for (int a = 0; a < 3; ++a) {
            if (node[a] < band) vel[a] = fmaxf(vel[a], 0.0f);
            else if (node[a] >= res[a] - band) vel[a] = fminf(vel[a], 0.0f);
        }
    }
    grid_vel[i] = make_float4(vel[0], vel[1], vel[2], s.m);
}

// The grid update of node i as it was scattered. Consume-and-zero: the accumulators are zeroed as they
// are read, which is the grid clear.
__device__ __forceinline__ void update_node(const KernelParams& params, u32 i, float4* grid_acc, float4* grid_vel,
                                            u64* fixed_mass, u64* fixed_momentum, StepCounters* counters,
                                            const Colliders& colliders) {
    NodeSums s;
    if (params.scatter_mode == SCATTER_FIXED_POINT) {
        const i64 q[4] = {(i64)fixed_mass[i], (i64)fixed_momentum[3 * (size_t)i],
                          (i64)fixed_momentum[3 * (size_t)i + 1], (i64)fixed_momentum[3 * (size_t)i + 2]};
        zero_node_sums(params, i, grid_acc, fixed_mass, fixed_momentum);
        s = fixed_point_sums(params, q, counters);
    } else {
        const float4 acc = grid_acc[i];
        zero_node_sums(params, i, grid_acc, fixed_mass, fixed_momentum);
        s = float_sums(acc);
    }
    update_node_velocity(params, i, s, grid_vel, colliders);
}

// ---------------------------------------------------------------------------------------------
// The particle lifecycle (src/sim/flow.rs, kernels/lifecycle.cu): x.w of a parked slot.

__device__ __forceinline__ bool is_parked(float4 x) { return x.w != 0.0f; }


// A sink is a box [lo, hi) given as two float4.
__device__ __forceinline__ bool in_a_sink(float4 x, const float4* sinks, u32 num_sinks) {
    for (u32 k = 0; k < num_sinks; ++k) {
        const float4 lo = sinks[2 * k], hi = sinks[2 * k + 1];
        if (x.x >= lo.x && x.y >= lo.y && x.z >= lo.z && x.x < hi.x && x.y < hi.y && x.z < hi.z) return true;
    }
    return false;
}
