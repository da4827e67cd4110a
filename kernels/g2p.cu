// g2p (fused, docs/physics.md step 4): gather velocity and C = (4/dx) sum w v_i d^T, then the optional soft
// wall (nialltl), advection and the clamp to [1, R-2] dx that keeps every stencil inside the grid
// (g2p_particle in common.cuh, shared with the binned pipeline's g2p2g.cu).
// Also the extremes the time step is chosen from: the largest speed, and the largest signal speed
// c(rho_p) + |v_p| of one particle (the CFL check: the densest particles at an impact have just
// stopped, so pairing the largest density with the largest speed would overstate it).
#include "common.cuh"

extern "C" __global__ void g2p(const KernelParams params,
                               float4* __restrict__ x,
                               float4* __restrict__ v,
                               float4* __restrict__ c,  // 3 arrays of N: columns 0, 1, 2 of C
                               const float4* __restrict__ grid_vel,
                               const float* __restrict__ rho,  // p2g's density estimate
                               StepCounters* __restrict__ counters) {
    const u32 n = params.num_particles;
    float max_speed = 0.0f, max_signal = 0.0f;

    // Index order, not the sorted `order` of the scatters: this kernel writes 64 bytes per particle,
    // which in cell order land all over the particle arrays (measured at bench-655k after the column
    // collapses: 0.12 ms per step in cell order, 0.07 ms in index order); its grid reads are cached
    // gathers, which suffer less from the spawn order's decay than the scatters' atomics do.
    FOR_EACH_INDEX(p, n) {
        const G2pResult r = g2p_particle(params, x[p], particle_material_tag(params, v, p), rho[p], grid_vel);
        for (int col = 0; col < 3; ++col) c[(size_t)col * n + p] = r.c[col];
        v[p] = r.v;
        x[p] = r.x;
        max_speed = fmaxf(max_speed, r.speed);
        max_signal = fmaxf(max_signal, r.signal);
    }
    atomic_max_nonnegative(&counters->max_speed_bits, max_speed);
    atomic_max_nonnegative(&counters->max_signal_bits, max_signal);
}
