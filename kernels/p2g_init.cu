// p2g_init: scatter particle mass to the grid, m_i += w m_p (docs/physics.md step 1).
// One thread per particle, in cell order (kernels/bins.cu); float or fixed-point atomics per Params.scatter_mode.
#include "common.cuh"

extern "C" __global__ void p2g_init(const KernelParams params,
                                    const float4* __restrict__ x,
                                    const float4* __restrict__ v,     // .w: the material (several)
                                    const u32* __restrict__ order,    // particles sorted by cell
                                    float4* __restrict__ grid_acc,    // .w = mass (float scatter)
                                    u64* __restrict__ fixed_mass,     // fixed-point scatter
                                    StepCounters* __restrict__ counters) {
    const bool fixed = params.scatter_mode == SCATTER_FIXED_POINT;
    // Converged loop: the float scatter aggregates per warp. Lanes past the end take the stencil of
    // the block's first particle and add nothing.
    FOR_EACH_INDEX_CONVERGED(i, live, first, params.num_particles) {
        const u32 p = order[live ? i : first];
        const Stencil s = make_stencil(x[p], params);
        const float m_p = particle_mass_of(params, v, p);
        const WarpRun run = warp_run(s.base_index);
        FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
            const float mass = w * m_p;
            if (fixed) {
                // Each lane rounds its own contribution; the run sums integers, exactly.
                i64 units[1] = {live ? fixed_point_units(mass * params.fixed_mass_scale, counters) : 0};
                warp_run_sum(run, units);
                if (run.head && live && units[0] != 0) atomicAdd(&fixed_mass[node], (u64)units[0]);
            } else {
                float sum[1] = {live ? mass : 0.0f};
                warp_run_sum(run, sum);
                if (run.head && live) atomicAdd(&grid_acc[node].w, sum[0]);
            }
        })
    }
}
