// particle_stats: the per-frame statistics of the state (the runner's line, the viewer's panel) as a
// device reduction, so the host reads STATS_BLOCKS partial records instead of every particle.
// A fixed grid of STATS_BLOCKS blocks of STATS_THREADS threads, each block reducing in a fixed tree
// order: the partials, and so the host's sum of them, are the same on every run.
#include "common.cuh"


__device__ __forceinline__ void combine(StatsPartial& a, const StatsPartial& b) {
    a.kinetic_energy += b.kinetic_energy;
    for (int k = 0; k < 3; ++k) a.position_sum[k] += b.position_sum[k];
    a.density_ratio_sum += b.density_ratio_sum;
    a.max_speed = fmaxf(a.max_speed, b.max_speed);
    a.density_ratio_min = fminf(a.density_ratio_min, b.density_ratio_min);
    a.density_ratio_max = fmaxf(a.density_ratio_max, b.density_ratio_max);
    a.count += b.count;
}

extern "C" __global__ void __launch_bounds__(STATS_THREADS) particle_stats(const KernelParams params,
                                                                          const float4* __restrict__ x,
                                                                          const float4* __restrict__ v,
                                                                          const float* __restrict__ rho,
                                                                          StatsPartial* __restrict__ partials) {
    __shared__ StatsPartial shared[STATS_THREADS];
    StatsPartial mine{0.0, {0.0, 0.0, 0.0}, 0.0, 0.0f, __int_as_float(0x7f800000), -__int_as_float(0x7f800000), 0u};
    FOR_EACH_INDEX(p, params.num_particles) {
        const float4 xp = x[p], vp = v[p];
        if (is_parked(xp)) continue;
        const float v2 = vp.x * vp.x + vp.y * vp.y + vp.z * vp.z;
        const Material& mat = material_table[material_index(params, vp)];
        const float ratio = rho[p] / mat.rest_density;
        mine.kinetic_energy += 0.5 * (double)mat.particle_mass * (double)v2;
        mine.position_sum[0] += (double)xp.x;
        mine.position_sum[1] += (double)xp.y;
        mine.position_sum[2] += (double)xp.z;
        mine.density_ratio_sum += (double)ratio;
        mine.max_speed = fmaxf(mine.max_speed, sqrtf(v2));
        mine.density_ratio_min = fminf(mine.density_ratio_min, ratio);
        mine.density_ratio_max = fmaxf(mine.density_ratio_max, ratio);
        // A NaN anywhere must show: fmaxf/fminf would drop it, the sums keep it.
        if (!(v2 == v2) || !(ratio == ratio)) mine.kinetic_energy += (double)__int_as_float(0x7fffffff);
        mine.count += 1u;
    }
    shared[threadIdx.x] = mine;
    __syncthreads();
    for (u32 half = STATS_THREADS / 2; half > 0; half >>= 1) {
        if (threadIdx.x < half) combine(shared[threadIdx.x], shared[threadIdx.x + half]);
        __syncthreads();
    }
    if (threadIdx.x == 0) partials[blockIdx.x] = shared[0];
}
