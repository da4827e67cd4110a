// The fluid's constitutive law, the one place a kernel computes it: the Tait equation of state with
// its pressure floor, the viscous stress, and the sound speed the time step follows
// (docs/physics.md). `Material`'s methods in src/sim/material.rs are the CPU twins, operation for
// operation, so the reference and the kernels round alike. A new law (a non-Newtonian viscosity,
// say) changes these functions and their twins, nothing else.
#include "contract.cuh"

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

// Component (row, col) of sigma = -p I + mu (C + C^T), with C given as cm[column][row].
__device__ __forceinline__ float material_stress(const Material& mat, float pressure, const float (&cm)[3][3], int row,
                                                 int col) {
    float stress = (cm[col][row] + cm[row][col]) * mat.viscosity;
    if (row == col) stress += -pressure;
    return stress;
}

// c(rho) + speed, the signal speed of the CFL bound: c(rho) = c0 (rho / rho0)^((gamma - 1) / 2),
// c0 = sqrt(k gamma / rho0).
__device__ __forceinline__ float material_signal_speed(const Material& mat, float rho, float speed) {
    const float sound_speed = sqrtf(mat.eos_stiffness * mat.eos_power / mat.rest_density);
    return sound_speed * material_power(fmaxf(rho / mat.rest_density, 0.0f), 0.5f * (mat.eos_power - 1.0f)) + speed;
}
