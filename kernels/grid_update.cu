// grid_update (docs/physics.md step 3): momentum to velocity, gravity, free slip in the boundary band.
// It is also the grid clear: each accumulator has exactly one reader here (its node's thread), so the
// thread zeroes what it read (consume-and-zero) and the next step's scatter finds a clean grid.
// Writes every node's velocity (zero where there is no mass), so g2p never reads a stale one.
#include "common.cuh"

extern "C" __global__ void grid_update(const Params params,
                                       float4* __restrict__ grid_acc,     // in: momentum, mass; zeroed
                                       float4* __restrict__ grid_vel,     // out: .xyz velocity, .w mass
                                       u64* __restrict__ fixed_mass,      // in (fixed-point); zeroed
                                       u64* __restrict__ fixed_momentum,  // in (fixed-point); zeroed
                                       StepCounters* __restrict__ counters) {
    const u32 rx = params.grid_res[0], ry = params.grid_res[1], rz = params.grid_res[2];
    const u32 num_nodes = rx * ry * rz;
    const u32 band = params.boundary_band;
    const float gravity[3] = {params.gravity[0] * params.dt, params.gravity[1] * params.dt,
                              params.gravity[2] * params.dt};
    const bool fixed = params.scatter_mode == SCATTER_FIXED_POINT;

    FOR_EACH_INDEX(i, num_nodes) {
        float m, mv[3];
        if (fixed) {
            const u64 qm = fixed_mass[i];
            const u64 q[3] = {fixed_momentum[3 * (size_t)i], fixed_momentum[3 * (size_t)i + 1],
                              fixed_momentum[3 * (size_t)i + 2]};
            fixed_mass[i] = 0;
            fixed_momentum[3 * (size_t)i] = 0;
            fixed_momentum[3 * (size_t)i + 1] = 0;
            fixed_momentum[3 * (size_t)i + 2] = 0;
            bool out_of_range = (i64)qm >= FIXED_SUM_LIMIT || (i64)qm <= -FIXED_SUM_LIMIT;
            for (int a = 0; a < 3; ++a) {
                out_of_range |= (i64)q[a] >= FIXED_SUM_LIMIT || (i64)q[a] <= -FIXED_SUM_LIMIT;
            }
            if (out_of_range) atomicAdd(&counters->fixed_overflows, 1u);
            m = fixed_point_value(qm, 1.0f / params.fixed_mass_scale);
            const float inv_momentum_scale = 1.0f / params.fixed_momentum_scale;
            for (int a = 0; a < 3; ++a) mv[a] = fixed_point_value(q[a], inv_momentum_scale);
        } else {
            const float4 acc = grid_acc[i];
            grid_acc[i] = make_float4(0.0f, 0.0f, 0.0f, 0.0f);
            m = acc.w;
            mv[0] = acc.x;
            mv[1] = acc.y;
            mv[2] = acc.z;
        }

        float vel[3] = {0.0f, 0.0f, 0.0f};
        if (m > 0.0f) {
            const u32 node[3] = {i % rx, (i / rx) % ry, i / (rx * ry)};
            const u32 res[3] = {rx, ry, rz};
            for (int a = 0; a < 3; ++a) {
                vel[a] = mv[a] / m + gravity[a];
                if (node[a] < band || node[a] >= res[a] - band) vel[a] = 0.0f;
            }
        }
        grid_vel[i] = make_float4(vel[0], vel[1], vel[2], m);
    }
}
