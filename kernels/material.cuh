// The fluid's constitutive law, the one place a kernel computes it: the Tait equation of state with
// its pressure floor, the viscous stress, and the sound speed the time step follows
// (docs/physics.md). `Material`'s methods in src/sim/material.rs are the CPU twins, operation for
// operation, so the reference and the kernels round alike. A new law (a non-Newtonian viscosity,
// say) changes these functions and their twins, nothing else.
#include "contract.cuh"

// p(rho) = max(p_min, k ((rho / rho0)^gamma - 1)).
__device__ __forceinline__ float material_pressure(const Material& mat, float rho) {
    return fmaxf(mat.eos_stiffness * (powf(rho / mat.rest_density, mat.eos_power) - 1.0f), mat.pressure_floor);
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
    return sound_speed * powf(fmaxf(rho / mat.rest_density, 0.0f), 0.5f * (mat.eos_power - 1.0f)) + speed;
}
