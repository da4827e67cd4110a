// solid_laws_check: every solid-law function of solid.cuh and svd.cuh on a batch of matrices, so
// that tests/gpu_solids.rs can compare each with its CPU twin (src/sim/svd.rs, src/sim/solid.rs).
// Not part of any pipeline; src/cuda/solid_laws.rs launches it.
#include "material.cuh"

// Floats written per matrix, in this order (SolidLawsResult in src/cuda/solid_laws.rs, which
// states the same count): U (9), sigma (3), V (9), the returned F_E (9) and plastic scalar (1), the
// stress of the input (9), the stress of the returned state (9), the wave speed after the return (1).
#define SOLID_LAWS_OUT 50

// Matrices as 9 floats, [column][row]; one thread per matrix, grid-stride. `rows` names each
// matrix's row of material_table.
extern "C" __global__ void solid_laws_check(u32 count, const float* __restrict__ f, const float* __restrict__ plastic,
                                            const u32* __restrict__ rows, float* __restrict__ out) {
    for (u32 i = blockIdx.x * blockDim.x + threadIdx.x; i < count; i += blockDim.x * gridDim.x) {
        float fm[3][3];
#pragma unroll
        for (int c = 0; c < 3; ++c)
#pragma unroll
            for (int r = 0; r < 3; ++r) fm[c][r] = f[9 * i + 3 * c + r];
        const Material& mat = material_table[min(rows[i], MAX_MATERIALS - 1u)];
        float u[3][3], sigma[3], v[3][3];
        svd3(fm, u, sigma, v);
        float stress[3][3];
        solid_kirchhoff_stress(mat, fm, plastic[i], stress);
        float elastic[3][3];
#pragma unroll
        for (int c = 0; c < 3; ++c)
#pragma unroll
            for (int r = 0; r < 3; ++r) elastic[c][r] = fm[c][r];
        // The stress of the returned state as the fused pass scatters it: the return mapping's own,
        // where the law has one, else its law's of F_E.
        float returned_stress[3][3];
        const float returned = solid_plastic_return(mat, elastic, plastic[i], returned_stress);
        if (!solid_has_return(mat.law)) solid_kirchhoff_stress(mat, elastic, returned, returned_stress);

        float* o = out + (size_t)SOLID_LAWS_OUT * i;
#pragma unroll
        for (int c = 0; c < 3; ++c)
#pragma unroll
            for (int r = 0; r < 3; ++r) {
                o[3 * c + r] = u[c][r];
                o[12 + 3 * c + r] = v[c][r];
                o[21 + 3 * c + r] = elastic[c][r];
                o[31 + 3 * c + r] = stress[c][r];
                o[40 + 3 * c + r] = returned_stress[c][r];
            }
#pragma unroll
        for (int k = 0; k < 3; ++k) o[9 + k] = sigma[k];
        o[30] = returned;
        o[49] = solid_wave_speed(mat, returned);
    }
}
