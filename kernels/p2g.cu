// p2g (fused, docs/physics.md step 2): gather the density from the grid mass, Tait pressure and viscous
// stress, then scatter momentum plus the stress impulse:
//   rho_p = sum w m_i / dx^3,  V_p = m_p / rho_p,  p = max(p_min, k ((rho_p/rho0)^gamma - 1)),
//   sigma = -p I + mu (C + C^T),  (mv)_i += w [m_p v_p + (m_p dx C - 4 dt V_p / dx sigma) d].
// Reads only the mass word of each accumulator while other threads add to its momentum words.
#include "common.cuh"

extern "C" __global__ void p2g(const Params params,
                               const float4* __restrict__ x,
                               const u32* __restrict__ order,  // particles sorted by cell
                               const float4* __restrict__ v,
                               const float4* __restrict__ c,  // 3 arrays of N: columns 0, 1, 2 of C
                               float* __restrict__ rho_out,
                               float4* grid_acc,          // .xyz momentum, .w mass (float scatter)
                               const u64* fixed_mass,     // fixed-point scatter
                               u64* fixed_momentum,       // 3 per node, interleaved
                               StepCounters* __restrict__ counters) {
    const Material mat = params.material;
    const float m_p = mat.particle_mass;
    const float dx = params.dx;
    const float inv_cell_volume = params.inv_dx * params.inv_dx * params.inv_dx;
    const bool fixed = params.scatter_mode == SCATTER_FIXED_POINT;
    const float inv_mass_scale = fixed ? 1.0f / params.fixed_mass_scale : 0.0f;
    const u32 n = params.num_particles;
    const float* grid_mass_words = reinterpret_cast<const float*>(grid_acc) + 3;  // stride 4
    float max_rho = 0.0f;

    // Converged loop: the float scatter aggregates per warp. Lanes past the end work on a copy of the
    // block's first particle, write nothing and scatter zeros.
    FOR_EACH_INDEX_CONVERGED(i, live, first, n) {
        const u32 p = order[live ? i : first];
        const Stencil s = make_stencil(x[p], params);
        float grid_mass = 0.0f;  // with the walls' image mass, which mirror_walls added after p2g_init
        FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
            const float m_i = fixed ? fixed_point_value(fixed_mass[node], inv_mass_scale)
                                    : grid_mass_words[4 * (size_t)node];
            grid_mass += w * m_i;
        })
        const float rho = grid_mass * inv_cell_volume;
        if (live) {
            rho_out[p] = rho;
            max_rho = fmaxf(max_rho, rho);
        }

        const float volume = m_p / rho;
        const float pressure = fmaxf(
            mat.eos_stiffness * (powf(rho / mat.rest_density, mat.eos_power) - 1.0f), mat.pressure_floor);
        // C as cm[column][row].
        const float4 c0 = c[p], c1 = c[n + p], c2 = c[2 * (size_t)n + p];
        const float cm[3][3] = {{c0.x, c0.y, c0.z}, {c1.x, c1.y, c1.z}, {c2.x, c2.y, c2.z}};
        // affine = m_p dx C - (4 dt V / dx) sigma, with sigma = -p I + mu (C + C^T).
        const float stress_factor = 4.0f * params.dt * volume / dx;
        float affine[3][3];
        for (int col = 0; col < 3; ++col) {
            for (int row = 0; row < 3; ++row) {
                float stress = (cm[col][row] + cm[row][col]) * mat.viscosity;
                if (row == col) stress += -pressure;
                affine[col][row] = cm[col][row] * (m_p * dx) - stress * stress_factor;
            }
        }
        const float4 vp = v[p];
        const float mv[3] = {vp.x * m_p, vp.y * m_p, vp.z * m_p};

        FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
            float impulse[3];
            for (int row = 0; row < 3; ++row) {
                const float ad = affine[0][row] * d0 + affine[1][row] * d1 + affine[2][row] * d2;
                impulse[row] = live ? w * (mv[row] + ad) : 0.0f;
            }
            if (fixed) {
                // Not aggregated: summing floats before rounding would tie the result to the warps.
                u64* acc = &fixed_momentum[3 * (size_t)node];
                for (int a = 0; a < 3; ++a) {
                    if (live) fixed_point_add(&acc[a], impulse[a] * params.fixed_momentum_scale, counters);
                }
            } else {
                const WarpGroup group = warp_group(node);
                warp_group_sum(group, impulse);
                if (group.leader && live) atomic_add_momentum(&grid_acc[node], impulse[0], impulse[1], impulse[2]);
            }
        })
    }
    atomic_max_nonnegative(&counters->max_density_bits, max_rho);
}
