// A solid's constitutive law (issue 41), the one place a kernel computes it: the plasticity that
// follows the advection of a particle's deformation gradient, the Kirchhoff stress it scatters and
// the wave speed the time step follows; and the elastic part of an elastoviscoplastic liquid (a
// Herschel-Bulkley row with a shear modulus), whose deviatoric stress bears its yield stress.
// src/sim/solid.rs holds the CPU twins, operation for operation, and the formulas with their
// references. Matrices are float[3][3] indexed [column][row]. Included by material.cuh, after the
// material table.
//
// The return mapping and the stress each take an SVD, several hundred instructions: they are out of
// line (__noinline__), taking the row's scalars, not the row (a struct passed to a call goes through
// the stack), so that a particle pass that also serves liquids keeps its size and registers, as the
// non-Newtonian viscosities do (material.cuh). The deformation gradient goes by reference, through
// the caller's stack frame: only solid particles pay for it.
#include "contract.cuh"
#include "svd.cuh"


// Whether particles of `law` are solid: they scatter their deformation's stress in place of a
// pressure (`is_solid`).
__device__ __forceinline__ bool solid_is_solid(u32 law) { return law >= FIRST_SOLID_LAW; }

// Whether a row's particles carry a deformation gradient: a solid's, or an elastoviscoplastic liquid's
// (`carries_deformation`).
__device__ __forceinline__ bool material_carries_deformation(const Material& mat) {
    return solid_is_solid(mat.law) || (mat.law == LAW_HERSCHEL_BULKLEY && mat.shear_modulus > 0.0f);
}

// The plastic scalar at rest (`rest_plastic`): J_p = 1 for snow, 0 otherwise.
__device__ __forceinline__ float solid_rest_plastic(u32 law) { return law == LAW_SNOW ? 1.0f : 0.0f; }

// Snow's hardening exp(xi (1 - J_p)) held within [SNOW_MIN_HARDENING, SNOW_MAX_HARDENING]; 1 for
// other laws (`hardening`).
__device__ __forceinline__ float solid_hardening(u32 law, float xi, float plastic) {
    return law == LAW_SNOW ? fminf(fmaxf(expf(xi * (1.0f - plastic)), SNOW_MIN_HARDENING), SNOW_MAX_HARDENING) : 1.0f;
}

// U diag(s) V^T (`compose`).
__device__ __forceinline__ void solid_compose(const float (&u)[3][3], const float (&s)[3], const float (&v)[3][3],
                                              float (&out)[3][3]) {
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r)
            out[c][r] = u[0][r] * s[0] * v[0][c] + u[1][r] * s[1] * v[1][c] + u[2][r] * s[2] * v[2][c];
}

// U diag(principal) U^T (`principal_stress`).
__device__ __forceinline__ void solid_principal_stress(const float (&u)[3][3], const float (&principal)[3],
                                                       float (&tau)[3][3]) {
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r)
            tau[c][r] = u[0][r] * principal[0] * u[0][c] + u[1][r] * principal[1] * u[1][c] +
                        u[2][r] * principal[2] * u[2][c];
}

// U (2 mu eps + lambda tr(eps) I) U^T (`hencky_stress`).
__device__ __forceinline__ void solid_hencky_stress(float mu, float lambda, const float (&u)[3][3],
                                                    const float (&eps)[3], float (&tau)[3][3]) {
    const float trace = eps[0] + eps[1] + eps[2];
    float principal[3];
#pragma unroll
    for (int i = 0; i < 3; ++i) principal[i] = 2.0f * mu * eps[i] + lambda * trace;
    solid_principal_stress(u, principal, tau);
}

// 2 mu (F - R) F^T + lambda (J - 1) J I of f = U diag(sigma) V^T (`corotated_stress`).
__device__ __forceinline__ void solid_corotated_stress(float mu, float lambda, const float (&u)[3][3],
                                                       const float (&sigma)[3], const float (&v)[3][3],
                                                       const float (&f)[3][3], float (&tau)[3][3]) {
    float rotation[3][3];
    svd_times_transpose(u, v, rotation);
    const float volume = sigma[0] * sigma[1] * sigma[2];
    const float pressure = lambda * (volume - 1.0f) * volume;
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) {
            const float shear = (f[0][r] - rotation[0][r]) * f[0][c] + (f[1][r] - rotation[1][r]) * f[1][c] +
                                (f[2][r] - rotation[2][r]) * f[2][c];
            tau[c][r] = 2.0f * mu * shear;
            if (r == c) tau[c][r] += pressure;
        }
}

// Snow's or sand's return mapping (`plastic_law` in src/sim/solid.rs, which gives the formulas):
// replaces f (F_trial) by F_E, writes the Kirchhoff stress of F_E from the same decomposition into
// tau, and returns the plastic scalar after it.
__device__ __noinline__ float solid_plastic_law(u32 law, float lambda, float mu, float theta_c, float theta_s,
                                                float xi, float alpha, float cohesion, float plastic,
                                                float (&f)[3][3], float (&tau)[3][3]) {
    float u[3][3], sigma[3], v[3][3];
    svd3(f, u, sigma, v);
    if (law == LAW_SNOW) {
        const float lowest = 1.0f - theta_c, highest = 1.0f + theta_s;
        float clamped[3];
#pragma unroll
        for (int i = 0; i < 3; ++i) clamped[i] = fminf(fmaxf(sigma[i], lowest), highest);
        float returned = plastic;
        if (!(clamped[0] == sigma[0] && clamped[1] == sigma[1] && clamped[2] == sigma[2])) {
            const float ratio = fabsf(sigma[0] * sigma[1] * sigma[2]) / (clamped[0] * clamped[1] * clamped[2]);
            solid_compose(u, clamped, v, f);
            returned = plastic * ratio;
        }
        const float scale = solid_hardening(law, xi, returned);
        solid_corotated_stress(mu * scale, lambda * scale, u, clamped, v, f, tau);
        return returned;
    }
    float eps[3];
#pragma unroll
    for (int i = 0; i < 3; ++i) eps[i] = logf(fmaxf(fabsf(sigma[i]), SOLID_MIN_STRETCH));
    const float sum = eps[0] + eps[1] + eps[2];
    const float trace = sum + plastic;
    if (trace >= cohesion) {
        const float third = cohesion / 3.0f;
        const float tip = expf(third);
        const float stretch[3] = {tip, tip, tip};
        solid_compose(u, stretch, v, f);
        const float at_tip[3] = {third, third, third};
        solid_hencky_stress(mu, lambda, u, at_tip, tau);
        return trace - cohesion;
    }
    const float mean = sum / 3.0f;
    float hat[3];
#pragma unroll
    for (int i = 0; i < 3; ++i) hat[i] = eps[i] - mean;
    const float norm = sqrtf(hat[0] * hat[0] + hat[1] * hat[1] + hat[2] * hat[2]);
    const float excess = norm + (3.0f * lambda + 2.0f * mu) / (2.0f * mu) * (trace - cohesion) * alpha;
    if (excess <= 0.0f && plastic == 0.0f && sigma[2] >= SOLID_MIN_STRETCH) {
        solid_hencky_stress(mu, lambda, u, eps, tau);
        return plastic;
    }
    const float shrink = excess > 0.0f ? 1.0f - excess / norm : 1.0f;
    const float third = trace / 3.0f;
    float returned[3], stretch[3];
#pragma unroll
    for (int i = 0; i < 3; ++i) {
        returned[i] = third + shrink * hat[i];
        stretch[i] = expf(returned[i]);
    }
    solid_compose(u, stretch, v, f);
    solid_hencky_stress(mu, lambda, u, returned, tau);
    return 0.0f;
}

// The deviatoric Hencky strain of singular values sigma (`deviatoric_strain`).
__device__ __forceinline__ void solid_deviatoric_strain(const float (&sigma)[3], float (&hat)[3]) {
    float eps[3];
#pragma unroll
    for (int i = 0; i < 3; ++i) eps[i] = logf(fmaxf(fabsf(sigma[i]), SOLID_MIN_STRETCH));
    const float mean = (eps[0] + eps[1] + eps[2]) / 3.0f;
#pragma unroll
    for (int i = 0; i < 3; ++i) hat[i] = eps[i] - mean;
}

// An elastoviscoplastic liquid's return to the von Mises yield surface (`yield_return` in
// src/sim/solid.rs, which gives the formulas): replaces f (F_trial) by its isochoric elastic part
// and writes its deviatoric stress from the same decomposition into tau.
__device__ __noinline__ void solid_yield_return(float mu, float yield_stress, float (&f)[3][3], float (&tau)[3][3]) {
    float u[3][3], sigma[3], v[3][3];
    svd3(f, u, sigma, v);
    float hat[3];
    solid_deviatoric_strain(sigma, hat);
    const float norm = sqrtf(hat[0] * hat[0] + hat[1] * hat[1] + hat[2] * hat[2]);
    const float limit = yield_stress / (1.41421356237309504880f * mu);
    const float shrink = norm > limit ? limit / norm : 1.0f;
    float stretch[3], principal[3];
#pragma unroll
    for (int i = 0; i < 3; ++i) {
        const float returned = shrink * hat[i];
        stretch[i] = expf(returned);
        principal[i] = 2.0f * mu * returned;
    }
    solid_compose(u, stretch, v, f);
    solid_principal_stress(u, principal, tau);
}

// Whether a row's law has a return mapping: snow, sand and an elastoviscoplastic liquid's elastic
// part (the others' F_E is F_trial).
__device__ __forceinline__ bool solid_has_return(u32 law) {
    return law == LAW_SNOW || law == LAW_SAND || law == LAW_HERSCHEL_BULKLEY;
}

// The plasticity of a substep (`plastic_return_with_stress`): f is F_trial = (I + dt C) F on entry,
// F_E on return; returns the plastic scalar, and where the law has a return mapping
// (solid_has_return) writes the Kirchhoff stress of F_E into tau, from the return's decomposition,
// for the scatter of the same pass. The elastic laws make no call and leave tau as it was.
__device__ __forceinline__ float solid_plastic_return(const Material& mat, float (&f)[3][3], float plastic,
                                                      float (&tau)[3][3]) {
    if (mat.law == LAW_HERSCHEL_BULKLEY) {
        solid_yield_return(mat.shear_modulus, mat.yield_stress, f, tau);
        return plastic;
    }
    if (mat.law != LAW_SNOW && mat.law != LAW_SAND) return plastic;
    return solid_plastic_law(mat.law, mat.lame_lambda, mat.shear_modulus, mat.critical_compression,
                             mat.critical_stretch, mat.hardening, mat.friction_alpha, mat.cohesion, plastic, f, tau);
}

// det F by the columns' triple product (`determinant`).
__device__ __forceinline__ float solid_determinant(const float (&f)[3][3]) {
    const float cross0 = f[1][1] * f[2][2] - f[1][2] * f[2][1];
    const float cross1 = f[1][2] * f[2][0] - f[1][0] * f[2][2];
    const float cross2 = f[1][0] * f[2][1] - f[1][1] * f[2][0];
    return f[0][0] * cross0 + f[0][1] * cross1 + f[0][2] * cross2;
}

// The Kirchhoff stress of each solid law (`stress_law` in src/sim/solid.rs, which gives the
// formulas): Neo-Hookean, fixed-corotated, snow (fixed-corotated, hardened), sand (Hencky) and an
// elastoviscoplastic liquid's elastic part (Hencky, deviatoric).
__device__ __noinline__ void solid_stress_law(u32 law, float mu, float lambda, float xi, float plastic,
                                              const float (&f)[3][3], float (&tau)[3][3]) {
    if (law == LAW_NEO_HOOKEAN) {
        const float log_volume = logf(fmaxf(solid_determinant(f), SOLID_MIN_VOLUME));
#pragma unroll
        for (int c = 0; c < 3; ++c)
#pragma unroll
            for (int r = 0; r < 3; ++r) {
                const float left = f[0][r] * f[0][c] + f[1][r] * f[1][c] + f[2][r] * f[2][c];
                tau[c][r] = mu * (left - (r == c ? 1.0f : 0.0f));
                if (r == c) tau[c][r] += lambda * log_volume;
            }
        return;
    }
    float u[3][3], sigma[3], v[3][3];
    svd3(f, u, sigma, v);
    if (law == LAW_SAND) {
        float eps[3];
#pragma unroll
        for (int i = 0; i < 3; ++i) eps[i] = logf(fmaxf(fabsf(sigma[i]), SOLID_MIN_STRETCH));
        solid_hencky_stress(mu, lambda, u, eps, tau);
        return;
    }
    if (law == LAW_HERSCHEL_BULKLEY) {
        float hat[3], principal[3];
        solid_deviatoric_strain(sigma, hat);
#pragma unroll
        for (int i = 0; i < 3; ++i) principal[i] = 2.0f * mu * hat[i];
        solid_principal_stress(u, principal, tau);
        return;
    }
    const float scale = solid_hardening(law, xi, plastic);
    solid_corotated_stress(mu * scale, lambda * scale, u, sigma, v, f, tau);
}

// tau = P F^T of elastic deformation f with plastic scalar `plastic` (`kirchhoff_stress`), Pa: an
// elastoviscoplastic liquid's deviatoric elastic part; zero for a row that carries no deformation.
__device__ __forceinline__ void solid_kirchhoff_stress(const Material& mat, const float (&f)[3][3], float plastic,
                                                       float (&tau)[3][3]) {
    if (!material_carries_deformation(mat)) {
#pragma unroll
        for (int c = 0; c < 3; ++c)
#pragma unroll
            for (int r = 0; r < 3; ++r) tau[c][r] = 0.0f;
        return;
    }
    solid_stress_law(mat.law, mat.shear_modulus, mat.lame_lambda, mat.hardening, plastic, f, tau);
}

// The P-wave speed sqrt((lambda + 2 mu) h / rho0), m/s, h snow's hardening (`solid_wave_speed`).
__device__ __forceinline__ float solid_wave_speed(const Material& mat, float plastic) {
    const float scale = solid_hardening(mat.law, mat.hardening, plastic);
    return sqrtf((mat.lame_lambda + 2.0f * mat.shear_modulus) * scale / mat.rest_density);
}
