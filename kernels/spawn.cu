// Particle spawn on the device, in exactly the order of Scene::spawn() (src/sim/scene/lattice.rs): bodies in
// order, each body's lattice points x fastest, skipping points an earlier body already covers.
//
// All bodies' visited lattice ranges are laid end to end as one list of "candidate" points. Two passes
// over it with the same block size: spawn_count counts the kept points of each block; the host turns
// the counts into exclusive offsets (a prefix sum: block order = list order); spawn_write recomputes
// each point's keep flag, ranks it inside its block with a ballot scan, and writes it at
// offset + rank. The order is the list order, which is the host order.
//
// The geometry is computed in double with explicit round-to-nearest intrinsics, so NVRTC cannot fuse a
// multiply-add that the host (Rust, no contraction) does not: the keep flags equal the host's bit for
// bit, and the positions are the same doubles rounded to float.
#include "common.cuh"


// Lattice::point: (j + 1/2) h.
__device__ __forceinline__ double lattice_coordinate(i64 j, double spacing) {
    return __dmul_rn(__dadd_rn((double)j, 0.5), spacing);
}

// Lattice::contains.
__device__ bool body_contains(const SpawnBody& body, const double p[3], double spacing) {
    if (body.kind == BODY_BLOCK) {
        for (int a = 0; a < 3; ++a) {
            const i64 j = (i64)round(__dadd_rn(__ddiv_rn(p[a], spacing), -0.5));
            if (j < body.range_lo[a] || j >= body.range_hi[a]) return false;
        }
        return true;
    }
    double sum = 0.0;  // (p - c) . (p - c), summed x, y, z like glam's length_squared
    for (int a = 0; a < 3; ++a) {
        const double d = __dadd_rn(p[a], -body.center[a]);
        sum = __dadd_rn(sum, __dmul_rn(d, d));
    }
    return sum <= body.radius_sq;
}

// Decodes candidate `t` into its body and lattice point; returns whether the point is kept.
__device__ bool candidate(const SpawnBody* bodies, u32 num_bodies, double spacing, u64 t, u32* body_out,
                          double p[3]) {
    u32 k = 0;
    while (k + 1 < num_bodies && t >= bodies[k + 1].first_candidate) ++k;
    const SpawnBody& body = bodies[k];
    const u64 local = t - body.first_candidate;
    const u64 nx = (u64)(body.range_hi[0] - body.range_lo[0]);
    const u64 ny = (u64)(body.range_hi[1] - body.range_lo[1]);
    const i64 j[3] = {body.range_lo[0] + (i64)(local % nx), body.range_lo[1] + (i64)((local / nx) % ny),
                      body.range_lo[2] + (i64)(local / (nx * ny))};
    for (int a = 0; a < 3; ++a) p[a] = lattice_coordinate(j[a], spacing);
    *body_out = k;
    if (!body_contains(body, p, spacing)) return false;
    for (u32 e = 0; e < k; ++e) {
        if (body_contains(bodies[e], p, spacing)) return false;
    }
    return true;
}

// One thread per candidate, one block of candidates per block; block_counts[blockIdx.x] = kept points.
extern "C" __global__ void spawn_count(const SpawnBody* __restrict__ bodies, u32 num_bodies, double spacing,
                                       u64 num_candidates, u32* __restrict__ block_counts) {
    const u64 t = (u64)blockIdx.x * blockDim.x + threadIdx.x;
    bool keep = false;
    if (t < num_candidates) {
        u32 k;
        double p[3];
        keep = candidate(bodies, num_bodies, spacing, t, &k, p);
    }
    const int kept = __syncthreads_count(keep);
    if (threadIdx.x == 0) block_counts[blockIdx.x] = (u32)kept;
}

// Same launch shape as spawn_count. block_offsets = exclusive prefix sum of its counts.
extern "C" __global__ void spawn_write(const SpawnBody* __restrict__ bodies, u32 num_bodies, double spacing,
                                       u64 num_candidates, const u32* __restrict__ block_offsets,
                                       u32 num_particles, float4* __restrict__ x,
                                       float4* __restrict__ v, float4* __restrict__ c,
                                       float* __restrict__ rho) {
    __shared__ u32 warp_totals[32];
    const u64 t = (u64)blockIdx.x * blockDim.x + threadIdx.x;
    bool keep = false;
    u32 k = 0;
    double p[3] = {0.0, 0.0, 0.0};
    if (t < num_candidates) keep = candidate(bodies, num_bodies, spacing, t, &k, p);

    // Rank inside the block: ballot within the warp, then the totals of the warps before.
    const u32 lane = threadIdx.x & 31u, warp = threadIdx.x >> 5;
    const u32 ballot = __ballot_sync(0xffffffffu, keep);
    const u32 rank_in_warp = __popc(ballot & ((1u << lane) - 1u));
    if (lane == 0) warp_totals[warp] = __popc(ballot);
    __syncthreads();
    u32 rank = rank_in_warp;
    for (u32 w = 0; w < warp; ++w) rank += warp_totals[w];

    if (keep) {
        const u32 out = block_offsets[blockIdx.x] + rank;
        if (out < num_particles) {  // the host checked the total; this only guards memory
            const SpawnBody& body = bodies[k];
            x[out] = make_float4(__double2float_rn(p[0]), __double2float_rn(p[1]), __double2float_rn(p[2]),
                                 0.0f);
            v[out] = make_float4(body.velocity[0], body.velocity[1], body.velocity[2], body.material_tag);
            const float4 zero = make_float4(0.0f, 0.0f, 0.0f, 0.0f);
            c[out] = zero;
            c[(size_t)num_particles + out] = zero;
            c[2 * (size_t)num_particles + out] = zero;
            rho[out] = body.rest_density;
        }
    }
}
