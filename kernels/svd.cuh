// The singular value decomposition of a 3x3 matrix, F = U Sigma V^T, for the solid laws
// (solid.cuh): the rotation variant (U and V rotations, the smallest singular value carrying the
// sign of det F), singular values sorted by magnitude, largest first. src/sim/svd.rs is the CPU
// twin, operation for operation, and says why it is built so: McAdams et al. 2011's structure
// (Jacobi sweeps for V, a sort, a Givens QR for U and Sigma) with exact rotations, so that both sides
// round alike but for the fused multiply-adds NVRTC contracts, and one-sided sweeps, which read
// F^T F from the rotated columns of F V and keep the residual at rounding for ill-conditioned F.
// Matrices are float[3][3] indexed [column][row]; every index below is a compile-time constant
// (template arguments, unrolled loops), so the arrays stay in registers.
#include "contract.cuh"

// Cyclic sweeps of three rotations (JACOBI_SWEEPS in src/sim/svd.rs, which says why four).
#define SVD_JACOBI_SWEEPS 4

// 2^e, for e in [-126, 127].
__device__ __forceinline__ float svd_power_of_two(int e) { return __uint_as_float((u32)(127 + e) << 23); }

// Column i of b dotted with column j.
__device__ __forceinline__ float svd_dot(const float (&b)[3][3], int i, int j) {
    return b[i][0] * b[j][0] + b[i][1] * b[j][1] + b[i][2] * b[j][2];
}

// A B^T: (A B^T)_rc = sum_k A_rk B_ck.
__device__ __forceinline__ void svd_times_transpose(const float (&a)[3][3], const float (&b)[3][3],
                                                    float (&out)[3][3]) {
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) out[c][r] = a[0][r] * b[0][c] + a[1][r] * b[1][c] + a[2][r] * b[2][c];
}

// The Jacobi rotation in the (p, q) plane that zeroes S_pq of S = B^T B, applied to B's and V's
// columns (`jacobi` in src/sim/svd.rs): the smaller root t of t^2 + 2 theta t - 1 = 0, from d and
// 2 S_pq divided by the larger of them, so that no square underflows at rounding.
template <int p, int q>
__device__ __forceinline__ void svd_jacobi(float (&b)[3][3], float (&v)[3][3]) {
    const float s_pq = svd_dot(b, p, q);
    if (s_pq == 0.0f) return;
    const float d = svd_dot(b, q, q) - svd_dot(b, p, p);
    const float twice = 2.0f * s_pq;
    const float scale = fmaxf(fabsf(d), fabsf(twice));
    const float dn = d / scale, an = twice / scale;
    const float root = sqrtf(dn * dn + an * an);
    const float t = (d >= 0.0f ? an : -an) / (fabsf(dn) + root);
    const float c = 1.0f / sqrtf(1.0f + t * t);
    const float sn = t * c;
#pragma unroll
    for (int i = 0; i < 3; ++i) {
        const float bp = b[p][i], bq = b[q][i];
        b[p][i] = c * bp - sn * bq;
        b[q][i] = sn * bp + c * bq;
        const float vp = v[p][i], vq = v[q][i];
        v[p][i] = c * vp - sn * vq;
        v[q][i] = sn * vp + c * vq;
    }
}

// The longer of columns i < j of B first, V's columns moving with B's; the column moved back is
// negated, keeping det V = +1 and B = F V.
template <int i, int j>
__device__ __forceinline__ void svd_sort_pair(float (&b)[3][3], float (&v)[3][3], float (&rho)[3]) {
    if (rho[i] < rho[j]) {
        const float r = rho[i];
        rho[i] = rho[j];
        rho[j] = r;
#pragma unroll
        for (int k = 0; k < 3; ++k) {
            const float bi = b[i][k], vi = v[i][k];
            b[i][k] = b[j][k];
            b[j][k] = -bi;
            v[i][k] = v[j][k];
            v[j][k] = -vi;
        }
    }
}

// The Givens rotation in rows (p, q) that zeroes B_qk against B_pk, B <- G B and U <- U G^T
// (`givens` in src/sim/svd.rs): B_pk is left non-negative, so only sigma_2 can take det F's sign.
template <int p, int q, int k>
__device__ __forceinline__ void svd_givens(float (&b)[3][3], float (&u)[3][3]) {
    const float x = b[k][p], y = b[k][q];
    const float scale = fmaxf(fabsf(x), fabsf(y));
    if (scale == 0.0f) return;
    const float xn = x / scale, yn = y / scale;
    const float length = sqrtf(xn * xn + yn * yn);
    const float c = xn / length, sn = yn / length;
#pragma unroll
    for (int j = 0; j < 3; ++j) {
        const float bp = b[j][p], bq = b[j][q];
        b[j][p] = c * bp + sn * bq;
        b[j][q] = c * bq - sn * bp;
    }
    b[k][q] = 0.0f;
#pragma unroll
    for (int i = 0; i < 3; ++i) {
        const float up = u[p][i], uq = u[q][i];
        u[p][i] = c * up + sn * uq;
        u[q][i] = c * uq - sn * up;
    }
}

// F = U Sigma V^T (`svd3` in src/sim/svd.rs).
__device__ __forceinline__ void svd3(const float (&f)[3][3], float (&u)[3][3], float (&sigma)[3], float (&v)[3][3]) {
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) {
            u[c][r] = c == r ? 1.0f : 0.0f;
            v[c][r] = c == r ? 1.0f : 0.0f;
        }
    // Scaled by the power of two that brings the largest entry into [1, 2): exact, and no dot
    // product of a tiny or huge F underflows or overflows.
    float largest = 0.0f;
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) largest = fmaxf(largest, fabsf(f[c][r]));
    if (largest == 0.0f) {
        sigma[0] = sigma[1] = sigma[2] = 0.0f;
        return;
    }
    const int exponent = min(max((int)((__float_as_uint(largest) >> 23) & 0xffu) - 127, -126), 126);
    const float down = svd_power_of_two(-exponent), up = svd_power_of_two(exponent);
    float b[3][3];
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) b[c][r] = f[c][r] * down;

    // Not unrolled: one sweep's code, run four times, keeps the particle pass's instruction
    // footprint small; its three rotations' indices are constants, so B and V stay in registers.
#pragma unroll 1
    for (int sweep = 0; sweep < SVD_JACOBI_SWEEPS; ++sweep) {
        svd_jacobi<0, 1>(b, v);
        svd_jacobi<0, 2>(b, v);
        svd_jacobi<1, 2>(b, v);
    }

    float rho[3] = {svd_dot(b, 0, 0), svd_dot(b, 1, 1), svd_dot(b, 2, 2)};
    svd_sort_pair<0, 1>(b, v, rho);
    svd_sort_pair<0, 2>(b, v, rho);
    svd_sort_pair<1, 2>(b, v, rho);

    svd_givens<0, 1, 0>(b, u);
    svd_givens<0, 2, 0>(b, u);
    svd_givens<1, 2, 1>(b, u);
    sigma[0] = b[0][0] * up;
    sigma[1] = b[1][1] * up;
    sigma[2] = b[2][2] * up;
}

// The rotation of the polar decomposition F = R S, R = U V^T (`polar` in src/sim/svd.rs).
__device__ __forceinline__ void svd_polar(const float (&f)[3][3], float (&r)[3][3]) {
    float u[3][3], sigma[3], v[3][3];
    svd3(f, u, sigma, v);
    svd_times_transpose(u, v, r);
}
