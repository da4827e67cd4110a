// Shared by every kernel: the mirrors of the Rust structs that kernels receive by value, the quadratic
// B-spline stencil, the fixed-point scatter and the extremes reductions.
//
// build.rs pastes this file in place of `#include "common.cuh"`, with #line markers so that NVRTC's
// messages still name this file and line. No standard headers: NVRTC ships none.

typedef unsigned int u32;
typedef unsigned long long u64;
typedef long long i64;

// ---------------------------------------------------------------------------------------------
// Mirrors of src/sim/params.rs. Field for field; the static_asserts below and the `const _` asserts
// there must agree, or Params arrives in the kernels shifted.

struct Material {
    float rest_density;    // rho0, kg/m^3
    float eos_stiffness;   // Tait k, Pa
    float eos_power;       // Tait gamma
    float viscosity;       // mu, Pa s
    float pressure_floor;  // p_min, Pa
    float particle_mass;   // m_p, kg
    u32 _pad[2];
};

struct Params {
    Material material;
    float gravity[3];  // m/s^2
    float dt;          // s
    u32 grid_res[3];   // nodes per axis; node (i, j, k) is stored at i + rx (j + ry k)
    float dx;
    float inv_dx;
    u32 boundary_band;
    float soft_wall_tau;  // s; 0 = off
    u32 num_particles;
    u32 scatter_mode;            // SCATTER_FLOAT or SCATTER_FIXED_POINT
    float fixed_mass_scale;      // fixed-point units per kg
    float fixed_momentum_scale;  // fixed-point units per kg m/s
    u32 wall_mirror_lo;          // node plane of the low walls' mirror (mirror_walls.cu); 0 = off
    u32 wall_mirror_hi[3];       // node planes of the high walls' mirror, per axis
    u32 _pad;
};

static_assert(sizeof(Material) == 32, "Material must match src/sim/params.rs");
static_assert(sizeof(Params) == 112, "Params must match src/sim/params.rs");
// NVRTC has no offsetof (no <cstddef>, no __builtin_offsetof), so offsets are checked on a constexpr
// instance: the field's address must equal the first word's address plus the offset in words.
#define ASSERT_FIELD_AT(object, first_word, field, byte_offset)                               \
    static_assert((const void*)&(object).field == (const void*)(&(object).first_word + (byte_offset) / sizeof((object).first_word)), \
                  #field " must sit at byte " #byte_offset " of " #first_word ", as in the Rust mirror")
__device__ constexpr Params params_layout_probe{};
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, material, 0);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, gravity, 32);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, dt, 44);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, grid_res, 48);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, dx, 60);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, inv_dx, 64);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, boundary_band, 68);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, soft_wall_tau, 72);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, num_particles, 76);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, scatter_mode, 80);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, fixed_mass_scale, 84);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, fixed_momentum_scale, 88);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, wall_mirror_lo, 92);
ASSERT_FIELD_AT(params_layout_probe, material.rest_density, wall_mirror_hi, 96);

#define SCATTER_FLOAT 0u
#define SCATTER_FIXED_POINT 1u

// Mirror of `StepCounters` in src/cuda/buffers.rs: what the host reads back once per frame.
struct StepCounters {
    u32 max_density_bits;  // bits of the largest rho (non-negative floats order like their bits)
    u32 max_speed_bits;    // bits of the largest |v|
    u32 fixed_overflows;   // fixed-point contributions or sums out of range (must stay 0)
    u32 max_signal_bits;   // bits of the largest c(rho_p) + |v_p| of one particle
};
static_assert(sizeof(StepCounters) == 16, "StepCounters must match src/cuda/buffers.rs");

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
// The quadratic B-spline stencil of docs/physics.md, in the same operation order as `Stencil` in
// src/sim/cpu.rs, so that the CPU reference and the kernels round alike wherever they can.

struct Stencil {
    u32 base_index;  // node index of base = floor(X - 0.5)
    float fx[3];     // X - base, each in [0.5, 1.5)
    float w[3][3];   // w[o][axis]: weight of node base + o along axis
};

__device__ __forceinline__ Stencil make_stencil(float4 x, const Params& params) {
    Stencil s;
    float xg[3] = {x.x * params.inv_dx, x.y * params.inv_dx, x.z * params.inv_dx};
    u32 base[3];
    for (int a = 0; a < 3; ++a) {
        float b = floorf(xg[a] - 0.5f);
        base[a] = (u32)(int)b;
        float f = xg[a] - b;
        s.fx[a] = f;
        s.w[0][a] = 0.5f * (1.5f - f) * (1.5f - f);
        s.w[1][a] = 0.75f - (f - 1.0f) * (f - 1.0f);
        s.w[2][a] = 0.5f * (f - 0.5f) * (f - 0.5f);
    }
    s.base_index = base[0] + params.grid_res[0] * (base[1] + params.grid_res[1] * base[2]);
    return s;
}

// Calls body(node_index, w, dx_, dy_, dz_) for the 27 nodes, z outermost, x innermost (cpu.rs order).
#define FOR_EACH_STENCIL_NODE(s, params, node, weight, d0, d1, d2, ...)                          \
    {                                                                                              \
        const u32 _sx = (params).grid_res[0];                                                      \
        const u32 _sxy = _sx * (params).grid_res[1];                                               \
        _Pragma("unroll") for (int _oz = 0; _oz < 3; ++_oz) {                                      \
            const float _wz = (s).w[_oz][2];                                                       \
            const float d2 = (float)_oz - (s).fx[2];                                               \
            _Pragma("unroll") for (int _oy = 0; _oy < 3; ++_oy) {                                  \
                const float _wyz = (s).w[_oy][1] * _wz;                                            \
                const float d1 = (float)_oy - (s).fx[1];                                           \
                const u32 _row = (s).base_index + _oy * _sx + _oz * _sxy;                          \
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

// ---------------------------------------------------------------------------------------------
// Fixed-point scatter. Each contribution is scaled and rounded to the nearest integer (not truncated:
// truncation biases every sum towards zero), then added with 64-bit integer atomics, which commute, so
// the sums do not depend on the order threads arrive in. A contribution above 2^52 units could, summed
// with a few thousand others, wrap the 64-bit accumulator: it is counted (and reported by the host)
// instead of added. The host picks the scales so that real contributions stay near 2^40.

#define FIXED_CONTRIBUTION_LIMIT 4503599627370496.0f /* 2^52 */
#define FIXED_SUM_LIMIT 4611686018427387904LL        /* 2^62 */

__device__ __forceinline__ void fixed_point_add(u64* accumulator, float scaled, StepCounters* counters) {
    if (!(fabsf(scaled) < FIXED_CONTRIBUTION_LIMIT)) {  // also catches NaN
        atomicAdd(&counters->fixed_overflows, 1u);
        return;
    }
    const i64 units = __float2ll_rn(scaled);
    if (units != 0) atomicAdd(accumulator, (u64)units);  // two's complement: adding u64 adds i64
}

__device__ __forceinline__ float fixed_point_value(u64 units, float inv_scale) {
    return __ll2float_rn((i64)units) * inv_scale;
}

// ---------------------------------------------------------------------------------------------
// Warp-aggregated float scatter. Particles are stored in spawn (lattice) order, so the 32 particles of
// a warp are neighbours and each stencil node is hit by several of them: without aggregation every
// hit is one atomic on the same address, and the atomics serialise. Here the lanes that target the
// same node find each other (match_any), the lowest lane of each group sums the group's values with
// shuffles, and it alone issues the atomic: about 5x fewer atomics at 8 particles per cell.
// Every lane of the warp must call these together (they shuffle with a full mask).

struct WarpGroup {
    u32 others;   // the leader's fellow lanes (the leader itself excluded); 0 for non-leaders
    bool leader;  // lowest lane of the group: the one that adds the group's sum
};

__device__ __forceinline__ WarpGroup warp_group(u32 key) {
    const u32 lane = threadIdx.x & 31u;
    const u32 peers = __match_any_sync(0xffffffffu, key);
    const bool leader = (u32)(__ffs(peers) - 1) == lane;
    return WarpGroup{leader ? (peers & (peers - 1u)) : 0u, leader};
}

// Sums N values over the group into the leader's `values` (other lanes' values are left as they were).
template <int N>
__device__ __forceinline__ void warp_group_sum(WarpGroup group, float (&values)[N]) {
    const u32 lane = threadIdx.x & 31u;
    float own[N];
    for (int k = 0; k < N; ++k) own[k] = values[k];
    u32 others = group.others;
    while (__any_sync(0xffffffffu, others != 0u)) {
        const int source = others ? __ffs(others) - 1 : (int)lane;
        for (int k = 0; k < N; ++k) {
            const float x = __shfl_sync(0xffffffffu, own[k], source);
            if (others) values[k] += x;
        }
        if (others) others &= others - 1u;
    }
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

// ---------------------------------------------------------------------------------------------
// Block-wide max of a non-negative float into a counter, one atomic per warp. Every thread of the
// block must call it (it shuffles with a full mask), after its grid-stride loop.

__device__ __forceinline__ void atomic_max_nonnegative(u32* target, float value) {
    u32 bits = __float_as_uint(value);  // NaN has larger bits than +inf, so a NaN wins and shows
    for (int offset = 16; offset > 0; offset >>= 1) {
        bits = max(bits, __shfl_xor_sync(0xffffffffu, bits, offset));
    }
    if ((threadIdx.x & 31u) == 0 && bits != 0) atomicMax(target, bits);
}
