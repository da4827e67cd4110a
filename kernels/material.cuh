// A liquid's constitutive law, the one place a kernel computes it: the Tait equation of state with
// its pressure floor, the viscosity as the material's law makes it of the shear rate, the viscous
// stress, and the sound speed the time step follows (docs/physics.md). `Material`'s methods in
// src/sim/material.rs are the CPU twins, operation for operation. A new law changes these functions
// and their twins, nothing else.
#include "contract.cuh"

// The scene's material table (sim::Params::materials): in constant memory, where a warp whose
// particles share a row reads it in one broadcast. Each module holds its own copy; the host writes
// every module's where the table changes (src/cuda/modules.rs). Rows past material_count are zero.
__constant__ Material material_table[MAX_MATERIALS];

// powf out of line, for exponents material_power cannot square (no preset has one), so that the
// particle pass's code stays near its size without it: with no fallback at all the fountain ran
// 1.3 % faster than with powf inlined there (H100, BENCHMARKS.md 0y).
__device__ __noinline__ float material_powf(float x, float e) { return powf(x, e); }

// x^e for the law's exponents: by squaring where 2e is a whole number up to 32 (water's gamma = 7
// and (gamma - 1) / 2 = 3), with a square root for a half, where powf takes about 90 instructions,
// twice a particle every substep; powf otherwise. The exponent is the scene's, the same for every
// thread. Measured on the H100 (BENCHMARKS.md 0y): 1.2 to 1.8 % off the float substep of the large
// presets.
__device__ __forceinline__ float material_power(float x, float e) {
    const float twice = 2.0f * e;
    if (!(twice >= 0.0f && twice <= 32.0f && twice == floorf(twice))) return material_powf(x, e);
    u32 n = (u32)twice;
    float result = (n & 1u) ? sqrtf(x) : 1.0f;
    float base = x;
#pragma unroll
    for (int bit = 1; bit < 6; ++bit) {  // 2e <= 32: five bits above the half's
        if ((n >> bit) & 1u) result *= base;
        base *= base;
    }
    return result;
}

// p(rho) = max(p_min, k ((rho / rho0)^gamma - 1)).
__device__ __forceinline__ float material_pressure(const Material& mat, float rho) {
    return fmaxf(mat.eos_stiffness * (material_power(rho / mat.rest_density, mat.eos_power) - 1.0f),
                 mat.pressure_floor);
}

// The particle's material: its row of the scene's table (material_table), named by the bits of
// v.w; row 0 in a scene of one material, without reading the index (a scene of one material keeps
// 0 there, but the passes need not look).
__device__ __forceinline__ u32 material_row(const KernelParams& params, float material_tag) {
    return params.material_count > 1u ? min(__float_as_uint(material_tag), MAX_MATERIALS - 1u) : 0u;
}

__device__ __forceinline__ u32 material_index(const KernelParams& params, float4 vp) {
    return material_row(params, vp.w);
}

// The shear rate gammadot = sqrt(2 D':D'), D' the deviatoric part of D = (C + C^T) / 2, with C given
// as cm[column][row] (src/sim/material.rs shear_rate).
__device__ __forceinline__ float material_shear_rate(const float (&cm)[3][3]) {
    const float third_trace = (cm[0][0] + cm[1][1] + cm[2][2]) * (1.0f / 3.0f);
    const float d0 = cm[0][0] - third_trace, d1 = cm[1][1] - third_trace, d2 = cm[2][2] - third_trace;
    const float d01 = 0.5f * (cm[1][0] + cm[0][1]);
    const float d02 = 0.5f * (cm[2][0] + cm[0][2]);
    const float d12 = 0.5f * (cm[2][1] + cm[1][2]);
    const float squares = d0 * d0 + d1 * d1 + d2 * d2 + 2.0f * (d01 * d01 + d02 * d02 + d12 * d12);
    return sqrtf(2.0f * squares);
}

// The non-Newtonian laws, out of line: a water scene's particle pass keeps its size and registers.
// Its parameters are the row's scalars, not the row: a struct passed to a call goes through the stack.
// An elastoviscoplastic liquid passes a yield stress of 0: its elastic part bears it (solid.cuh).
__device__ __noinline__ float material_law_viscosity(u32 law, float consistency, float n, float yield_stress,
                                                     float min_viscosity, float max_viscosity, float lambda, float a,
                                                     float rate) {
    float viscosity = consistency;
    if (law == LAW_POWER_LAW) {
        viscosity = consistency * material_power(rate, n - 1.0f);
    } else if (law == LAW_CARREAU_YASUDA) {
        const float thinning = material_power(1.0f + material_power(lambda * rate, a), (n - 1.0f) / a);
        viscosity = min_viscosity + (consistency - min_viscosity) * thinning;
    } else if (law == LAW_HERSCHEL_BULKLEY) {
        viscosity = consistency * material_power(rate, n - 1.0f);
        if (yield_stress > 0.0f) viscosity += yield_stress / rate;
    }
    return fminf(fmaxf(viscosity, min_viscosity), max_viscosity);
}

// Whether the liquid scatters its viscous stress with its rest volume (`viscous_at_rest_volume` in
// src/sim/material.rs).
__device__ __forceinline__ bool material_viscous_at_rest_volume(const Material& mat) {
    return mat.law != LAW_NEWTONIAN || mat.viscosity >= VISCOUS_REST_VOLUME_FROM;
}

// The viscosity the particle's stress is scattered with at density rho (`scattered_viscosity` in
// src/sim/material.rs): the constant one of a Newtonian liquid, else its law's at the shear rate,
// held within [min_viscosity, max_viscosity]; times rho / rho0 where the liquid scatters at its rest
// volume and reads less than its rest density, so that V mu = (m / rho) mu (rho / rho0) = (m / rho0) mu.
__device__ __forceinline__ float material_viscosity(const Material& mat, const float (&cm)[3][3], float rho) {
    float viscosity = mat.viscosity;
    if (mat.law != LAW_NEWTONIAN)
        viscosity = material_law_viscosity(mat.law, mat.viscosity, mat.flow_index,
                                           mat.shear_modulus > 0.0f ? 0.0f : mat.yield_stress,
                                           mat.min_viscosity, mat.max_viscosity, mat.relaxation_time,
                                           mat.transition_exponent, material_shear_rate(cm));
    if (material_viscous_at_rest_volume(mat) && rho < mat.rest_density) viscosity *= rho / mat.rest_density;
    return viscosity;
}

// Component (row, col) of sigma = -p I + mu (C + C^T), with C given as cm[column][row] and mu the
// effective viscosity (material_viscosity).
__device__ __forceinline__ float material_stress(float viscosity, float pressure, const float (&cm)[3][3], int row,
                                                 int col) {
    float stress = (cm[col][row] + cm[row][col]) * viscosity;
    if (row == col) stress += -pressure;
    return stress;
}

// c(rho) = c0 (rho / rho0)^((gamma - 1) / 2), c0 = sqrt(k gamma / rho0).
__device__ __forceinline__ float material_sound_speed(const Material& mat, float rho) {
    const float sound_speed = sqrtf(mat.eos_stiffness * mat.eos_power / mat.rest_density);
    return sound_speed * material_power(fmaxf(rho / mat.rest_density, 0.0f), 0.5f * (mat.eos_power - 1.0f));
}

// c(rho) + speed, the signal speed of the CFL bound.
__device__ __forceinline__ float material_signal_speed(const Material& mat, float rho, float speed) {
    return material_sound_speed(mat, rho) + speed;
}

// An elastoviscoplastic liquid's: sqrt(c(rho)^2 + 4 mu / (3 rho0)) + speed, the P-wave speed of bulk
// modulus rho0 c^2 and its elastic part's shear modulus mu (`Material::sound_speed_at`).
__device__ __forceinline__ float material_elastic_signal_speed(const Material& mat, float rho, float speed) {
    const float sound = material_sound_speed(mat, rho);
    return sqrtf(sound * sound + 4.0f * mat.shear_modulus / (3.0f * mat.rest_density)) + speed;
}

// The laws of rows that carry a deformation (the solids, and the elastic part of an elastoviscoplastic
// liquid), beside the liquids' and taking the same rows.
#include "solid.cuh"
