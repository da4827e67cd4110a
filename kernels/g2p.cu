// g2p (fused, docs/physics.md step 4): gather velocity and C = (4/dx) sum w v_i d^T, then the optional soft
// wall (nialltl), advection and the clamp to [1, R-2] dx that keeps every stencil inside the grid.
// Also the extremes the time step is chosen from: the largest speed, and the largest signal speed
// c(rho_p) + |v_p| of one particle (docs/physics.md's CFL check: the densest particles at an impact have
// just stopped, so pairing the largest density with the largest speed would overstate it).
#include "common.cuh"

extern "C" __global__ void g2p(const Params params,
                               float4* __restrict__ x,
                               float4* __restrict__ v,
                               float4* __restrict__ c,  // 3 arrays of N: columns 0, 1, 2 of C
                               const float4* __restrict__ grid_vel,
                               const float* __restrict__ rho,  // p2g's density estimate, this step
                               StepCounters* __restrict__ counters) {
    const float dx = params.dx, dt = params.dt, tau = params.soft_wall_tau;
    const u32 n = params.num_particles;
    const float res[3] = {(float)params.grid_res[0], (float)params.grid_res[1], (float)params.grid_res[2]};
    const float wall_lo = (float)(params.boundary_band + 1) * dx;
    const float wall_offset = (float)(params.boundary_band + 2);
    const Material mat = params.material;
    const float sound_speed = sqrtf(mat.eos_stiffness * mat.eos_power / mat.rest_density);
    const float sound_exponent = 0.5f * (mat.eos_power - 1.0f);
    float max_speed = 0.0f, max_signal = 0.0f;

    // Index order, not the sorted `order` of the scatters: this kernel writes 64 bytes per particle,
    // which in cell order land all over the particle arrays (measured at bench-655k after the column
    // collapses: 0.12 ms per step in cell order, 0.07 ms in index order); its grid reads are cached
    // gathers, which suffer less from the spawn order's decay than the scatters' atomics do.
    FOR_EACH_INDEX(p, n) {
        const float4 xp = x[p];
        const Stencil s = make_stencil(xp, params);
        float vel[3] = {0.0f, 0.0f, 0.0f};
        float b[3][3] = {{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}};  // b[column][row]
        FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
            const float4 vi = grid_vel[node];
            const float wv[3] = {w * vi.x, w * vi.y, w * vi.z};
            const float d[3] = {d0, d1, d2};
            for (int row = 0; row < 3; ++row) {
                vel[row] += wv[row];
                for (int col = 0; col < 3; ++col) b[col][row] += wv[row] * d[col];
            }
        })
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
        const float scale = 4.0f * params.inv_dx;
        for (int col = 0; col < 3; ++col) {
            c[(size_t)col * n + p] = make_float4(b[col][0] * scale, b[col][1] * scale, b[col][2] * scale, 0.0f);
        }
        v[p] = make_float4(vel[0], vel[1], vel[2], 0.0f);
        x[p] = make_float4(next[0], next[1], next[2], 0.0f);
        const float speed = sqrtf(speed_sq);
        const float ratio = fmaxf(rho[p] / mat.rest_density, 0.0f);
        max_speed = fmaxf(max_speed, speed);
        max_signal = fmaxf(max_signal, sound_speed * powf(ratio, sound_exponent) + speed);
    }
    atomic_max_nonnegative(&counters->max_speed_bits, max_speed);
    atomic_max_nonnegative(&counters->max_signal_bits, max_signal);
}
