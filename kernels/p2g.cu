// p2g (fused, docs/physics.md step 2): gather the density from the grid mass, Tait pressure and viscous
// stress, then scatter momentum plus the stress impulse:
//   rho_p = sum w m_i / dx^3,  V_p = m_p / rho_p,  p = max(p_min, k ((rho_p/rho0)^gamma - 1)),
//   sigma = -p I + mu (C + C^T),  (mv)_i += w [m_p v_p + (m_p dx C - 4 dt V_p / dx sigma) d].
// The report's pipeline: one thread per particle in cell order (kernels/bins.cu), global atomics per
// stencil node (warp-aggregated for floats). The binned pipeline's tiled version is p2g_tiled.cu.
// Reads only the mass word of each accumulator while other threads add to its momentum words.
#include "common.cuh"

extern "C" __global__ void p2g(const KernelParams params,
                               const float4* __restrict__ x,
                               const u32* __restrict__ order,  // particles sorted by cell
                               const float4* __restrict__ v,
                               const float4* __restrict__ c,  // 3 arrays of N: columns 0, 1, 2 of C
                               float* __restrict__ rho_out,
                               float4* grid_acc,          // .xyz momentum, .w mass (float scatter)
                               const u64* fixed_mass,     // fixed-point scatter
                               u64* fixed_momentum,       // 3 per node, interleaved
                               StepCounters* __restrict__ counters) {
    const bool fixed = params.scatter_mode == SCATTER_FIXED_POINT;
    const u32 n = params.num_particles;
    float max_rho = 0.0f;

    // Converged loop: the float scatter aggregates per warp. Lanes past the end work on a copy of the
    // block's first particle, write nothing and scatter zeros.
    FOR_EACH_INDEX_CONVERGED(i, live, first, n) {
        const u32 p = order[live ? i : first];
        const Stencil s = make_stencil(x[p], params);
        // volume_density: the density gathered from the grid's volume (several rest densities,
        // volume.cu), not from its mass.
        const float rho = params.volume_density ? rho_out[p] : gather_density(s, params, grid_acc, fixed_mass);
        if (live) {
            rho_out[p] = rho;
            max_rho = fmaxf(max_rho, reported_density(params, v[p], rho));
        }
        const float4 vp = v[p];
        const ParticleImpulse q = particle_impulse(params, rho, vp, c[p], c[n + p], c[2 * (size_t)n + p]);
        const WarpRun run = warp_run(s.base_index);
        FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
            float impulse[3];
            impulse_at(q, w, d0, d1, d2, impulse);
            if (!live) impulse[0] = impulse[1] = impulse[2] = 0.0f;
            if (fixed) {
                // Each lane rounds its own contribution; the run sums integers, exactly.
                i64 units[3];
                for (int a = 0; a < 3; ++a) units[a] = live ? fixed_point_units(impulse[a] * params.fixed_momentum_scale, counters) : 0;
                warp_run_sum(run, units);
                if (run.head && live) {
                    for (int a = 0; a < 3; ++a) {
                        if (units[a] != 0) atomicAdd(&fixed_momentum[3 * (size_t)node + a], (u64)units[a]);
                    }
                }
            } else {
                warp_run_sum(run, impulse);
                if (run.head && live) atomic_add_momentum(&grid_acc[node], impulse[0], impulse[1], impulse[2]);
            }
        })
    }
    atomic_max_nonnegative(&counters->max_density_bits, max_rho);
}
