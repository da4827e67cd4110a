// Position-based MPM (docs/physics.md, "Position-based MPM"): the substep of `solver.method =
// "pbmpm"` on the GPU, the CPU reference src/sim/pbmpm.rs operation for operation where it can. A
// substep: pbmpm_begin (the warm start, the mass, viscosity and volume scatters), the walls' mirror
// of those sums (mirror_walls.cu), pbmpm_volume_targets (each liquid particle's volume target); then
// `iterations` times pbmpm_scatter (the gather of the last iteration's node displacements, the
// constraints, the scatter of the displacements) and pbmpm_grid (the node displacements held by the
// walls; pbmpm_diffuse for the liquids' viscosity); pbmpm_integrate gathers once more and integrates.
//
// Every grid sum is fixed point (integers of rounded contributions, which commute): a run writes the
// same bytes whatever order threads arrive in. The particles are binned by 4x4x4-node block every
// substep (kernels/bins.cu) and gathered into that order in memory (bin_order.cu; in place where
// memory is short or MPM_BIN_ORDER=0, read through `order`); pbmpm_begin and pbmpm_scatter walk the
// bins' chunks, a CUDA block each, summing into the bin's shared tile (tiles.cuh; two words a sum,
// PB_TILE_LOW_BITS).
#include "tiles.cuh"

// pbmpm_begin's and pbmpm_scatter's blocks per multiprocessor (their register cap): the fixed-point
// one_pass's.
#define PBMPM_TILED_MIN_BLOCKS 5
// pbmpm_scatter's tile holds each contribution's global units whole, as two 32-bit words: its high
// bits (units >> TILE_UNIT_SHIFT, signed; channels 0 to 2, the displacement's xyz) and its low
// TILE_UNIT_SHIFT bits (0 to 8191; channels 3 to 5), so that the flush adds to the grid the same
// 64-bit sum as the contributions' own global atomics would. Rounded to tile units instead (one
// word), a slow liquid's displacement kept ~3e-6 of a node's sum, not a float's 6e-8, and the GPU
// left the CPU reference four to twenty times further (BENCHMARKS.md M22).
#define PB_TILE_CHANNELS 6
#define PB_TILE_LOW_BITS ((1 << TILE_UNIT_SHIFT) - 1)
// pbmpm_begin's sums in its tile, two words each as above: mass, viscosity, fill, liquid mass,
// volume error.
#define PB_BEGIN_SUMS 5

// Adds a contribution's units to sum `sum` of tile node k, as its high and low words (channels `sum`
// and SUMS + `sum`).
template <int SUMS>
__device__ __forceinline__ void pb_tile_add(int* tile, u32 k, int sum, i64 units) {
    atomicAdd(&tile[sum * TILE_NODES + k], (int)(units >> TILE_UNIT_SHIFT));
    atomicAdd(&tile[(SUMS + sum) * TILE_NODES + k], (int)(units & PB_TILE_LOW_BITS));
}

// Sum `sum` of a flushed tile node in global units: its high words' sum (read as unsigned where the
// sum is never negative, up to 2^32) and its low words'.
template <int SUMS>
__device__ __forceinline__ i64 pb_tile_sum(const int (&sums)[2 * SUMS], int sum, bool non_negative) {
    const i64 high = non_negative ? (i64)(u32)sums[sum] : (i64)sums[sum];
    return high * (1 << TILE_UNIT_SHIFT) + (i64)(u32)sums[SUMS + sum];
}

// A particle's scatter of SUMS sums (those `adds` names) to each stencil node: `units(w, d0, d1, d2,
// sum)` the contribution's global units, into its bin's tile where the tile takes it (`first` its
// base's tile node), through `to_grid(node, sum, units)` otherwise. `units` runs in both branches and
// a particle's integers must not depend on which one added them, so it rounds as written.
// `added_high` gains the high words each sum added to the tile (the wrap checks' balance).
template <int SUMS, typename Units, typename ToGrid>
__device__ __forceinline__ void pb_scatter(const Stencil& s, const KernelParams& params, u32 first, bool taken,
                                           int* tile, const bool (&adds)[SUMS], i64 (&added_high)[SUMS],
                                           Units units, ToGrid to_grid) {
    if (taken) {
        FOR_EACH_TILE_STENCIL_NODE_STAGGERED(s, first, k, w, d0, d1, d2, {
            for (int sum = 0; sum < SUMS; ++sum) {
                if (!adds[sum]) continue;
                const i64 u = units(w, d0, d1, d2, sum);
                added_high[sum] += u >> TILE_UNIT_SHIFT;
                pb_tile_add<SUMS>(tile, k, sum, u);
            }
        })
    } else {
        FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
            for (int sum = 0; sum < SUMS; ++sum) {
                if (!adds[sum]) continue;
                if (const i64 u = units(w, d0, d1, d2, sum)) to_grid(node, sum, u);
            }
        })
    }
}

// Matrices as m[column][row], as the deformation and C are stored (common.cuh).
struct Mat {
    float m[3][3];
};

__device__ __forceinline__ Mat pb_identity() {
    Mat a;
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) a.m[c][r] = c == r ? 1.0f : 0.0f;
    return a;
}

__device__ __forceinline__ Mat pb_mul(const Mat& a, const Mat& b) {
    Mat p;
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) p.m[c][r] = a.m[0][r] * b.m[c][0] + a.m[1][r] * b.m[c][1] + a.m[2][r] * b.m[c][2];
    return p;
}

__device__ __forceinline__ Mat pb_lerp_add(const Mat& a, const Mat& b, float s) {  // a + b s
    Mat p;
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) p.m[c][r] = a.m[c][r] + b.m[c][r] * s;
    return p;
}

__device__ __forceinline__ float pb_trace(const Mat& a) { return a.m[0][0] + a.m[1][1] + a.m[2][2]; }

__device__ __forceinline__ float pb_det(const Mat& a) {
    const float(&m)[3][3] = a.m;
    return m[0][0] * (m[1][1] * m[2][2] - m[2][1] * m[1][2]) - m[1][0] * (m[0][1] * m[2][2] - m[2][1] * m[0][2]) +
           m[2][0] * (m[0][1] * m[1][2] - m[1][1] * m[0][2]);
}

// A^-T = cof(A) / det A.
__device__ __forceinline__ Mat pb_inverse_transpose(const Mat& a, float det) {
    const float(&m)[3][3] = a.m;
    const float inv = 1.0f / det;
    Mat t;
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) {
            const int c1 = (c + 1) % 3, c2 = (c + 2) % 3, r1 = (r + 1) % 3, r2 = (r + 2) % 3;
            t.m[c][r] = (m[c1][r1] * m[c2][r2] - m[c2][r1] * m[c1][r2]) * inv;
        }
    return t;
}

__device__ __forceinline__ Mat pb_inverse(const Mat& a) {
    const Mat t = pb_inverse_transpose(a, pb_det(a));
    Mat i;
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) i.m[c][r] = t.m[r][c];
    return i;
}

__device__ __forceinline__ float pb_largest(const Mat& a) {
    float largest = 0.0f;
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) largest = fmaxf(largest, fabsf(a.m[c][r]));
    return largest;
}

// The rotation of F = R S by Newton's iteration R <- (R + R^-T) / 2 (`polar_rotation`); the SVD's
// where det F is not safely positive. Out of line: only solids and elastoviscoplastic liquids call it.
__device__ __noinline__ Mat pb_polar_rotation(const Mat f) {
    const float scale = pb_largest(f);
    const float det = pb_det(f);
    const bool nan = f.m[0][0] != f.m[0][0] || scale != scale;
    if (nan || scale <= 0.0f || det <= 1e-6f * scale * scale * scale) {
        Mat r;
        svd_polar(f.m, r.m);
        return r;
    }
    Mat r = f;
    for (int k = 0; k < 20; ++k) {
        const Mat t = pb_inverse_transpose(r, pb_det(r));
        float change = 0.0f;
#pragma unroll
        for (int c = 0; c < 3; ++c)
#pragma unroll
            for (int q = 0; q < 3; ++q) {
                const float next = (r.m[c][q] + t.m[c][q]) * 0.5f;
                change = fmaxf(change, fabsf(next - r.m[c][q]));
                r.m[c][q] = next;
            }
        if (change <= 1e-6f) break;
    }
    return r;
}

// k / (1 + k), k = (c dt / dx)^2 (`stiffness_weight`).
__device__ __forceinline__ float pb_stiffness_weight(const KernelParams& params, float speed) {
    const float k = speed * params.dt * params.inv_dx;
    return (k * k) / (1.0f + k * k);
}

// 2 mu / (2 mu + lambda) (`elasticity_ratio`).
__device__ __forceinline__ float pb_elasticity_ratio(const Material& mat) {
    const float mu = mat.shear_modulus, lambda = fmaxf(mat.lame_lambda, 0.0f);
    if (mu + lambda <= 0.0f) return 1.0f;
    return 2.0f * mu / (2.0f * mu + lambda);
}

// One particle's constraint on its affine displacement D (`project` in src/sim/pbmpm.rs, which says
// what each material's target is). `f`, `f_inverse`: its deformation and F^-1, where it carries one;
// `liquid_relaxation`: `liquid_relaxation` there (none at one iteration).
__device__ __noinline__ Mat pb_project(const KernelParams params, u32 row, Mat affine, float rho, bool deformed,
                                       const Mat f, float plastic, const Mat f_inverse, float target,
                                       float liquid_relaxation) {
    const Material& mat = material_table[row];
    if (!solid_is_solid(mat.law)) {
        const float j = fmaxf(mat.rest_density / rho, MIN_LIQUID_VOLUME);
        const float a = ((1.0f + target) / j - 1.0f - pb_trace(affine)) / 3.0f;
#pragma unroll
        for (int c = 0; c < 3; ++c) affine.m[c][c] += liquid_relaxation * a;
        if (deformed && mat.law == LAW_HERSCHEL_BULKLEY && mat.shear_modulus > 0.0f) {
            const Mat f_trial = pb_mul(pb_lerp_add(pb_identity(), affine, 1.0f), f);
            Mat goal = pb_mul(pb_polar_rotation(f_trial), f_inverse);
#pragma unroll
            for (int c = 0; c < 3; ++c) goal.m[c][c] -= 1.0f;
            const float speed = sqrtf(mat.shear_modulus / mat.rest_density);
            const float weight = SOLID_RELAXATION * pb_stiffness_weight(params, speed);
            Mat change = pb_lerp_add(goal, affine, -1.0f);
            const float third = pb_trace(change) / 3.0f;
#pragma unroll
            for (int c = 0; c < 3; ++c) change.m[c][c] -= third;
            affine = pb_lerp_add(affine, change, weight);
        }
        return affine;
    }
    if (!deformed) return affine;
    const Mat f_trial = pb_mul(pb_lerp_add(pb_identity(), affine, 1.0f), f);
    const float ratio = pb_elasticity_ratio(mat);
    const float det = pb_det(f_trial);
    // Sand restores a lost volume only; an elastic solid its volume either way.
    const float volume = fminf(fmaxf(fabsf(det), 0.1f), mat.law == LAW_SAND ? 1.0f : 1000.0f);
    const float sign = det < 0.0f ? -1.0f : 1.0f;
    const float shape = sign / cbrtf(volume);
    const Mat rotation = pb_polar_rotation(f_trial);
    Mat blend;
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) blend.m[c][r] = rotation.m[c][r] * ratio + f_trial.m[c][r] * shape * (1.0f - ratio);
    Mat goal = pb_mul(blend, f_inverse);
#pragma unroll
    for (int c = 0; c < 3; ++c) goal.m[c][c] -= 1.0f;
    const float weight = SOLID_RELAXATION * pb_stiffness_weight(params, solid_wave_speed(mat, plastic));
    return pb_lerp_add(affine, pb_lerp_add(goal, affine, -1.0f), weight);
}

// F with its singular values held within [PBMPM_MIN_STRETCH, PBMPM_MAX_STRETCH] (`clamp_stretch`).
__device__ __noinline__ void pb_clamp_stretch(float (&f)[3][3]) {
    float u[3][3], sigma[3], v[3][3];
    svd3(f, u, sigma, v);
    float held[3];
    bool same = true;
#pragma unroll
    for (int k = 0; k < 3; ++k) {
        held[k] = fminf(fmaxf(fabsf(sigma[k]), PBMPM_MIN_STRETCH), PBMPM_MAX_STRETCH);
        same &= held[k] == sigma[k];
    }
    if (same) return;
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
        for (int r = 0; r < 3; ++r) f[c][r] = u[0][r] * held[0] * v[0][c] + u[1][r] * held[1] * v[1][c] + u[2][r] * held[2] * v[2][c];
}

// The pass's state of a particle between iterations: d (xyz) and its liquid volume target (w); D as
// three float4 columns of n; F^-1 likewise where the scene carries deformations.
__device__ __forceinline__ Mat pb_load_mat(const float4* columns, u32 n, u32 p) {
    Mat a;
#pragma unroll
    for (int c = 0; c < 3; ++c) {
        const float4 col = columns[(size_t)c * n + p];
        a.m[c][0] = col.x, a.m[c][1] = col.y, a.m[c][2] = col.z;
    }
    return a;
}

__device__ __forceinline__ void pb_store_mat(float4* columns, u32 n, u32 p, const Mat& a) {
#pragma unroll
    for (int c = 0; c < 3; ++c) columns[(size_t)c * n + p] = make_float4(a.m[c][0], a.m[c][1], a.m[c][2], 0.0f);
}

__device__ __forceinline__ i64 pb_units(float value, float scale, StepCounters* counters) {
    return fixed_point_units(value * scale, counters);
}

// The warm start and the substep's scalar scatters (`begin_substep`, the scatter half of
// `liquid_volumes`), over the listed bin chunks as pbmpm_scatter: d = v dt + g dt^2 and D = C dt into
// the pass state, F^-1; the mass, the liquids' mass-weighted kinematic viscosity (where `viscous`),
// and where `volumes` the rest volume (solids' m / rho), the liquids' mass and their mass-weighted
// volume error m (1 - J): PB_BEGIN_SUMS sums in the chunk's tile, two words each. A particle goes to
// the tile where its stencil fits and its viscosity and volume error are at most its mass in units
// (kinematic viscosity up to 1 m^2/s, a volume ratio up to 2), so that those sums stay within the
// mass's bound; the mass itself, and the fill (a lighter material's volume outweighs its mass in
// units), are checked by the units each thread added against those flushed (tile_count_mass_wraps).
extern "C" __global__ void __launch_bounds__(TILE_THREADS, PBMPM_TILED_MIN_BLOCKS)
    pbmpm_begin(const KernelParams params, const float volume_scale, const u32 viscous, const u32 volumes,
                const BinEntry* __restrict__ bins, const u32* __restrict__ work_counts, const u32* __restrict__ order,
                const float4* __restrict__ x, const float4* __restrict__ v, const float4* __restrict__ c,
                const float* __restrict__ rho, const float4* __restrict__ deformation, u64* __restrict__ mass,
                u64* __restrict__ viscosity, u64* __restrict__ fill, u64* __restrict__ liquid_mass,
                u64* __restrict__ volume_error, float4* __restrict__ pass_d, float4* __restrict__ pass_affine,
                float4* __restrict__ f_inverse, StepCounters* __restrict__ counters) {
    __shared__ u32 tile_marks[TILE_SPAN_BLOCKS];  // cleared with the tile; this pass lists no node blocks
    const u32 n = params.num_particles;
    const float dt = params.dt;
    const NodeBlocks blocks = node_blocks(params);
    const float mass_tile_scale = params.fixed_mass_scale / (float)(1 << TILE_UNIT_SHIFT);
    const float volume_tile_scale = volume_scale / (float)(1 << TILE_UNIT_SHIFT);
    u64* const targets[PB_BEGIN_SUMS] = {mass, viscosity, fill, liquid_mass, volume_error};
    i64 mass_balance = 0, fill_balance = 0;  // high words added to the tiles less those flushed
    u32 misses = 0, overflows = 0;
    bool far = false;

    const u32 listed = work_counts[WORK_BINS];
    int* tile = tile_clear<2 * PB_BEGIN_SUMS>(tile_marks, listed);
    for (u32 entry = blockIdx.x; entry < listed; entry += gridDim.x) {
        const BinEntry bin = bins[entry];
        const Tile t = make_tile(blocks, bin.bin);
        for (u32 j = threadIdx.x; j < bin.count; j += blockDim.x) {
            const u32 p = order[bin.start + j];
            const float4 xp = x[p], vp = v[p];
            if (is_parked(xp)) continue;
            const Material& mat = material_table[material_index(params, vp)];
            const bool solid = solid_is_solid(mat.law);
            pass_d[p] = make_float4(vp.x * dt + params.gravity[0] * (dt * dt), vp.y * dt + params.gravity[1] * (dt * dt),
                                    vp.z * dt + params.gravity[2] * (dt * dt), 0.0f);
            Mat affine;
#pragma unroll
            for (int col = 0; col < 3; ++col) {
                const float4 cc = c[(size_t)col * n + p];
                affine.m[col][0] = cc.x * dt, affine.m[col][1] = cc.y * dt, affine.m[col][2] = cc.z * dt;
            }
            pb_store_mat(pass_affine, n, p, affine);
            if (f_inverse) {
                Mat f = pb_identity();
                if (material_carries_deformation(mat)) {
                    const Deformation d = load_deformation(deformation, n, p);
#pragma unroll
                    for (int col = 0; col < 3; ++col)
#pragma unroll
                        for (int r = 0; r < 3; ++r) f.m[col][r] = d.f[col][r];
                    f = pb_inverse(f);
                }
                pb_store_mat(f_inverse, n, p, f);
            }
            // A liquid's viscosity at its strain rate over the last substep, C.
            float nu = 0.0f;
            if (viscous && !solid) {
                float cm[3][3];
#pragma unroll
                for (int col = 0; col < 3; ++col) {
                    const float4 cc = c[(size_t)col * n + p];
                    cm[col][0] = cc.x, cm[col][1] = cc.y, cm[col][2] = cc.z;
                }
                const float mu = mat.law == LAW_NEWTONIAN
                                     ? mat.viscosity
                                     : material_law_viscosity(mat.law, mat.viscosity, mat.flow_index,
                                                              mat.shear_modulus > 0.0f ? 0.0f : mat.yield_stress,
                                                              mat.min_viscosity, mat.max_viscosity,
                                                              mat.relaxation_time, mat.transition_exponent,
                                                              material_shear_rate(cm));
                nu = mu / mat.rest_density;
            }
            const float m_p = mat.particle_mass;
            const float volume = solid ? m_p / rho[p] : m_p / mat.rest_density;
            const float error = solid ? 0.0f : m_p * (1.0f - mat.rest_density / rho[p]);

            const Stencil s = make_stencil(xp, params);
            u32 first = 0;
            const bool in_tile = tile_stencil(t, s, first, far);
            misses += !in_tile;
            const float unit_m = m_p * mass_tile_scale;
            const bool taken = in_tile && tile_takes(s, fmaxf(nu, fabsf(error) / m_p) * unit_m, unit_m) &&
                               volume * volume_tile_scale <= TILE_UNIT_MASS_LIMIT;
            // Which sums the particle adds to; each one's units, rounded as written.
            const bool adds[PB_BEGIN_SUMS] = {true, viscous != 0, volumes != 0, volumes && !solid, volumes && !solid};
            auto units = [&](float w, float, float, float, int sum) -> i64 {
                switch (sum) {
                    case 0: return pb_units(__fmul_rn(w, m_p), params.fixed_mass_scale, counters);
                    case 1: return pb_units(__fmul_rn(__fmul_rn(w, m_p), nu), params.fixed_mass_scale, counters);
                    case 2: return pb_units(__fmul_rn(w, volume), volume_scale, counters);
                    case 3: return pb_units(__fmul_rn(w, m_p), params.fixed_mass_scale, counters);
                    default: return pb_units(__fmul_rn(w, error), params.fixed_mass_scale, counters);
                }
            };
            i64 added_high[PB_BEGIN_SUMS] = {};
            pb_scatter<PB_BEGIN_SUMS>(s, params, first, taken, tile, adds, added_high, units,
                                      [&](u32 node, int sum, i64 u) { atomicAdd(&targets[sum][node], (u64)u); });
            mass_balance += added_high[0];
            fill_balance += added_high[2];
        }
        // The viscosity, liquid mass and volume error are at most the mass's units plus one a
        // particle (taken), the mass and fill never negative.
        const u32 mass_limit = tile_mass_limit(bin.count);
        FOR_EACH_TILE_NODE_FLUSHED(2 * PB_BEGIN_SUMS, tile, t, params, k, node, sums, {
            mass_balance -= (u32)sums[0];
            fill_balance -= (u32)sums[2];
            overflows += (u32)sums[0] >= mass_limit;
            for (int sum = 0; sum < PB_BEGIN_SUMS; ++sum)
                if (const i64 total = pb_tile_sum<PB_BEGIN_SUMS>(sums, sum, sum != 4))
                    atomicAdd(&targets[sum][node], (u64)total);
        })
        __syncthreads();
    }
    tile_count_mass_wraps(mass_balance, counters);
    __syncthreads();  // its warps' shared sums are read before the second count writes them
    tile_count_mass_wraps(fill_balance, counters);
    if (overflows) atomicAdd(&counters->fixed_overflows, overflows);
    if (misses) atomicAdd(&counters->tile_misses, misses);
    if (far) counters->rebin_needed = 1u;
}

// Each liquid particle's volume target for the substep, with its memory and drift correction (the
// gather half of `liquid_volumes`): the fill about it moves its J towards the grid's measure where
// every stencil node is full, its volume bias gains its smoothed volume error, and the target (the
// pass state's w) is the bias plus the error's proportional part.
extern "C" __global__ void pbmpm_volume_targets(const KernelParams params, const u32* __restrict__ order,
                                                const float4* __restrict__ x, const float4* __restrict__ v,
                                                float* __restrict__ rho, const u64* __restrict__ fill,
                                                const u64* __restrict__ liquid_mass,
                                                const u64* __restrict__ volume_error, float* __restrict__ volume_bias,
                                                float4* __restrict__ pass_d) {
    // A node's fill as the fraction of its cell: pbmpm_begin's volume_scale maps one cell's volume
    // to PBMPM_CELL_VOLUME_UNITS.
    const float inv_cell_units = 1.0f / PBMPM_CELL_VOLUME_UNITS;
    const float inv_mass_scale = 1.0f / params.fixed_mass_scale;
    // In bin order: a warp's particles share stencil nodes, whose sums it then reads once. In slot
    // order, once the flow has mixed the particles, each read its own 27 nodes' lines (pbmpm-1m 10 s
    // in: 580 us a substep against 68 at the start, BENCHMARKS.md M25).
    FOR_EACH_INDEX(i, params.num_particles) {
        const u32 p = order[i];
        const float4 vp = v[p];
        const Material& mat = material_table[material_index(params, vp)];
        if (solid_is_solid(mat.law)) continue;
        const Stencil s = make_stencil(x[p], params);
        float phi = 0.0f, least = 3.4e38f, e = 0.0f;
        FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
            const float node_fill = fixed_point_value(fill[node], inv_cell_units);
            const float m = fixed_point_value(liquid_mass[node], inv_mass_scale);
            float error = fixed_point_value(volume_error[node], inv_mass_scale);
            if (m > 0.0f) error /= m;
            phi += w * node_fill;
            e += w * error;
            least = fminf(least, node_fill + fmaxf(1.0f - w / FULL_NODE_WEIGHT, 0.0f));
        })
        const float full = fminf(fmaxf((least - FULL_NODE_FILL) / FULL_NODE_FILL_RAMP + 0.5f, 0.0f), 1.0f);
        if (full > 0.0f) {
            float j = mat.rest_density / rho[p];
            j = j + GRID_VOLUME_RATE * full * (1.0f / phi - j);
            rho[p] = mat.rest_density / fmaxf(j, MIN_LIQUID_VOLUME);
        }
        const float bias = fminf(fmaxf(volume_bias[p] + VOLUME_MEMORY_GAIN * e, 0.0f), MAX_VOLUME_BIAS);
        volume_bias[p] = bias;
        pass_d[p].w = bias + VOLUME_ERROR_GAIN * fmaxf(e, 0.0f);
    }
}

// A particle's displacement d and affine displacement D for its constraints: gathered from the node
// displacements of the iteration before (`gather`), or as the pass state holds them (the warm start,
// or the first pass of a substep). d's w (the volume target) is the pass state's either way.
__device__ __forceinline__ void pb_displacement(const KernelParams& params, bool gather, const Stencil& s,
                                                const float4* __restrict__ node_d, const float4* __restrict__ pass_d,
                                                const float4* __restrict__ pass_affine, u32 n, u32 p, float4& dp,
                                                Mat& affine) {
    dp = pass_d[p];
    if (!gather) {
        affine = pb_load_mat(pass_affine, n, p);
        return;
    }
    float3 d = make_float3(0.0f, 0.0f, 0.0f);
    Mat b;
#pragma unroll
    for (int col = 0; col < 3; ++col)
#pragma unroll
        for (int r = 0; r < 3; ++r) b.m[col][r] = 0.0f;
    // Rounded as written, the sums of products fused (as NVRTC fused them when this gather was the
    // warp runs' pass's own code): the same bits in both of the kernels that call it.
    FOR_EACH_STENCIL_NODE(s, params, node, w, d0, d1, d2, {
        const float4 g = node_d[node];
        const float wd[3] = {__fmul_rn(w, g.x), __fmul_rn(w, g.y), __fmul_rn(w, g.z)};
        const float offset[3] = {d0, d1, d2};
        d.x = __fadd_rn(d.x, wd[0]), d.y = __fadd_rn(d.y, wd[1]), d.z = __fadd_rn(d.z, wd[2]);
        for (int col = 0; col < 3; ++col)
            for (int r = 0; r < 3; ++r) b.m[col][r] = __fmaf_rn(wd[r], offset[col], b.m[col][r]);
    })
    dp.x = d.x, dp.y = d.y, dp.z = d.z;
#pragma unroll
    for (int col = 0; col < 3; ++col)
#pragma unroll
        for (int r = 0; r < 3; ++r) affine.m[col][r] = b.m[col][r] * (4.0f * params.inv_dx);
}

// The most tile units a particle's displacement contributions can have per unit weight: |x_i - x_p|
// <= 1.5 dx per axis. NaN where its state is not finite (as tile_reach).
__device__ __forceinline__ float pb_tile_reach(const KernelParams& params, float4 dp, const Mat& affine,
                                               float unit_displacement) {
    const float d[3] = {dp.x, dp.y, dp.z};
    float reach = 0.0f, poison = 0.0f;
#pragma unroll
    for (int row = 0; row < 3; ++row) {
        const float spread = fabsf(affine.m[0][row]) + fabsf(affine.m[1][row]) + fabsf(affine.m[2][row]);
        const float bound = fabsf(d[row]) + 1.5f * params.dx * spread;
        reach = fmaxf(reach, bound);
        poison += 0.0f * bound;
    }
    return (reach + poison) * unit_displacement;
}

// The iteration loop's particle pass (`gather`, `project_all` and `scatter`), over the listed bin
// chunks (tiles.cuh): each particle's d and D (pb_displacement), its constraint (pb_project), then
// w m_p (d + D (x_i - x_p)) in units of `displacement_scale` per kg m, each contribution rounded on its
// own, into its chunk's tile (PB_TILE_CHANNELS words a node), flushed once per node with 64-bit
// atomics. A particle the tile does not take (its stencil outside, or a displacement past the high
// word's reach) adds the same integers to the grid directly, so the sums do not depend on which
// particles a tile held. The bins are rebuilt every substep (the particles do not move between its
// passes), so a stencil leaves its tile only where a position is not finite. Against the warp runs'
// 64-bit atomics it replaced: BENCHMARKS.md M22.
extern "C" __global__ void __launch_bounds__(TILE_THREADS, PBMPM_TILED_MIN_BLOCKS)
    pbmpm_scatter(const KernelParams params, const u32 gather, const float displacement_scale,
                  const float liquid_relaxation,
                  const BinEntry* __restrict__ bins, const u32* __restrict__ work_counts, const u32* __restrict__ order,
                  const float4* __restrict__ x, const float4* __restrict__ v, const float* __restrict__ rho,
                  const float4* __restrict__ deformation, const float4* __restrict__ node_d,
                  const u64* __restrict__ mass, u64* __restrict__ displacement, float4* __restrict__ pass_d,
                  float4* __restrict__ pass_affine, const float4* __restrict__ f_inverse,
                  StepCounters* __restrict__ counters) {
    __shared__ u32 tile_marks[TILE_SPAN_BLOCKS];  // cleared with the tile; this pass lists no node blocks
    const u32 n = params.num_particles;
    const NodeBlocks blocks = node_blocks(params);
    const float unit = 1.0f / (float)(1 << TILE_UNIT_SHIFT);
    const float mass_tile_scale = params.fixed_mass_scale * unit;
    const float displacement_tile_scale = displacement_scale * unit;
    const float unit_mass = heaviest_particle_mass(params) * mass_tile_scale;
    u32 misses = 0, overflows = 0;
    bool far = false;

    const u32 listed = work_counts[WORK_BINS];
    int* tile = tile_clear<PB_TILE_CHANNELS>(tile_marks, listed);
    for (u32 entry = blockIdx.x; entry < listed; entry += gridDim.x) {
        const BinEntry bin = bins[entry];
        const Tile t = make_tile(blocks, bin.bin);
        for (u32 j = threadIdx.x; j < bin.count; j += blockDim.x) {
            const u32 p = order[bin.start + j];
            const float4 xp = x[p];
            if (is_parked(xp)) continue;
            const u32 row = material_index(params, v[p]);
            const Material& mat = material_table[row];
            const Stencil s = make_stencil(xp, params);
            float4 dp;
            Mat affine;
            pb_displacement(params, gather, s, node_d, pass_d, pass_affine, n, p, dp, affine);
            const bool deformed = deformation != nullptr && material_carries_deformation(mat);
            Mat f = pb_identity(), fi = f;
            float plastic = 0.0f;
            if (deformed) {
                const Deformation def = load_deformation(deformation, n, p);
#pragma unroll
                for (int col = 0; col < 3; ++col)
#pragma unroll
                    for (int r = 0; r < 3; ++r) f.m[col][r] = def.f[col][r];
                fi = pb_load_mat(f_inverse, n, p);
                plastic = def.plastic;
            }
            if (deformed || !solid_is_solid(mat.law)) affine = pb_project(params, row, affine, rho[p], deformed, f, plastic, fi, dp.w, liquid_relaxation);
            pass_d[p] = dp;
            pb_store_mat(pass_affine, n, p, affine);

            u32 first = 0;
            const bool in_tile = tile_stencil(t, s, first, far);
            misses += !in_tile;
            const float m_p = mat.particle_mass;
            const bool taken = in_tile && tile_takes(s, pb_tile_reach(params, dp, affine, m_p * displacement_tile_scale),
                                                     m_p * mass_tile_scale);
            const float d[3] = {dp.x, dp.y, dp.z};
            const float scale = m_p * displacement_scale;
            // w m_p (d + D dx (x_i - x_p) / dx) in global units, rounded as written (left to itself,
            // NVRTC may contract one of pb_scatter's loops into fused multiply-adds and not the
            // other): as the warp runs' pass before the tile rounded it, so that a run writes the
            // bytes it wrote (BENCHMARKS.md M22).
            auto units = [&](float w, float d0, float d1, float d2, int a) -> i64 {
                const float offset = __fadd_rn(__fadd_rn(__fmul_rn(affine.m[0][a], d0), __fmul_rn(affine.m[1][a], d1)),
                                               __fmul_rn(affine.m[2][a], d2));
                return fixed_point_units(__fmul_rn(__fmul_rn(w, scale), __fmaf_rn(offset, params.dx, d[a])), counters);
            };
            const bool adds[3] = {true, true, true};
            i64 added_high[3] = {};  // unused: the node's mass bounds the sums (below)
            pb_scatter<3>(s, params, first, taken, tile, adds, added_high, units, [&](u32 node, int a, i64 u) {
                atomicAdd(&displacement[3 * (size_t)node + a], (u64)u);
            });
        }
        // A node's high words over the chunk are at most its mass's tile units plus one a particle
        // (tile_takes); where a chunk could pass 32 bits, the node's whole mass (this chunk's and
        // more) bounds them. The low words stay under 2^13 a particle.
        const bool may_wrap = tile_chunk_may_wrap(bin.count, unit_mass);
        const u32 mass_limit = tile_mass_limit(bin.count);
        FOR_EACH_TILE_NODE_FLUSHED(PB_TILE_CHANNELS, tile, t, params, k, node, sums, {
            i64 sum[3];
            bool any = false;
            for (int a = 0; a < 3; ++a) {
                sum[a] = pb_tile_sum<3>(sums, a, false);
                any |= sum[a] != 0;
            }
            if (!any) continue;
            if (may_wrap) overflows += (mass[node] >> TILE_UNIT_SHIFT) >= (u64)mass_limit;
            for (int a = 0; a < 3; ++a)
                if (sum[a] != 0) atomicAdd(&displacement[3 * (size_t)node + a], (u64)sum[a]);
        })
        __syncthreads();
    }
    if (overflows) atomicAdd(&counters->fixed_overflows, overflows);
    if (misses) atomicAdd(&counters->tile_misses, misses);
    if (far) counters->rebin_needed = 1u;
}

// The substep's last particle pass (`gather` and `integrate_all`): d and D gathered from the last
// iteration's node displacements; x += d within the fluid region; F and a liquid's J; v = d / dt,
// C = D / dt; then the colliders' backstop.
extern "C" __global__ void pbmpm_integrate(const KernelParams params, const float lo, const float hi0, const float hi1,
                                           const float hi2, float4* __restrict__ x, float4* __restrict__ v,
                                           float4* __restrict__ c, float* __restrict__ rho,
                                           float4* __restrict__ deformation, const u32* __restrict__ order,
                                           const float4* __restrict__ node_d, const float4* __restrict__ pass_d,
                                           const float4* __restrict__ pass_affine,
                                           const ColliderState* __restrict__ collider_states, const u32 num_colliders,
                                           const float* __restrict__ collider_sdf, u64* __restrict__ body_impulses,
                                           StepCounters* __restrict__ counters) {
    const u32 n = params.num_particles;
    const Colliders colliders{collider_states, num_colliders, collider_sdf, body_impulses};
    float max_speed = 0.0f, max_density = 0.0f;
    u32 pushes = 0;
    FOR_EACH_INDEX(i, n) {
        const u32 p = order[i];
        const float4 xp = x[p], vp = v[p];
        if (is_parked(xp)) continue;
        const Material& mat = material_table[material_index(params, vp)];
        const Stencil s = make_stencil(xp, params);
        float4 dp;
        Mat affine;
        pb_displacement(params, true, s, node_d, pass_d, pass_affine, n, p, dp, affine);
        float4 xn = make_float4(fminf(fmaxf(xp.x + dp.x, lo), hi0), fminf(fmaxf(xp.y + dp.y, lo), hi1),
                                fminf(fmaxf(xp.z + dp.z, lo), hi2), xp.w);
        float r = rho[p];
        if (deformation != nullptr && material_carries_deformation(mat)) {
            Deformation def = load_deformation(deformation, n, p);
            const Mat f = {{{def.f[0][0], def.f[0][1], def.f[0][2]},
                            {def.f[1][0], def.f[1][1], def.f[1][2]},
                            {def.f[2][0], def.f[2][1], def.f[2][2]}}};
            const Mat trial = pb_mul(pb_lerp_add(pb_identity(), affine, 1.0f), f);
#pragma unroll
            for (int col = 0; col < 3; ++col)
#pragma unroll
                for (int q = 0; q < 3; ++q) def.f[col][q] = trial.m[col][q];
            float tau[3][3];
            def.plastic = solid_plastic_return(mat, def.f, def.plastic, tau);
            if (!(mat.law == LAW_HERSCHEL_BULKLEY && !solid_is_solid(mat.law))) pb_clamp_stretch(def.f);
            store_deformation(deformation, n, p, def);
            if (solid_is_solid(mat.law)) r = mat.rest_density / fmaxf(fabsf(solid_determinant(def.f)), 1e-6f);
        }
        if (!solid_is_solid(mat.law)) {
            const float j = mat.rest_density / r * (1.0f + pb_trace(affine));
            r = mat.rest_density / fmaxf(j, MIN_LIQUID_VOLUME);
        }
        const float inv_dt = 1.0f / params.dt;
        float4 vn = make_float4(dp.x * inv_dt, dp.y * inv_dt, dp.z * inv_dt, vp.w);
        float held[3] = {xn.x, xn.y, xn.z}, vel[3] = {vn.x, vn.y, vn.z};
        if (collider_backstop(colliders, 0.0f, held, vel)) {
            xn = make_float4(fminf(fmaxf(held[0], lo), hi0), fminf(fmaxf(held[1], lo), hi1),
                             fminf(fmaxf(held[2], lo), hi2), xp.w);
            vn = make_float4(vel[0], vel[1], vel[2], vp.w);
            ++pushes;
        }
        x[p] = xn;
        v[p] = vn;
#pragma unroll
        for (int col = 0; col < 3; ++col)
            c[(size_t)col * n + p] = make_float4(affine.m[col][0] * inv_dt, affine.m[col][1] * inv_dt,
                                                 affine.m[col][2] * inv_dt, 0.0f);
        rho[p] = r;
        max_speed = fmaxf(max_speed, sqrtf(vn.x * vn.x + vn.y * vn.y + vn.z * vn.z));
        max_density = fmaxf(max_density, reported_density(params, vn, r));
    }
    atomic_max_nonnegative(&counters->max_speed_bits, max_speed);
    atomic_max_nonnegative(&counters->max_density_bits, max_density);
    if (pushes) atomicAdd(&counters->backstop_pushes, pushes);
}

// `wall_displacement`'s Coulomb friction: shortens the part of d tangential to an `axis` wall by `cut`.
__device__ __forceinline__ void pb_grip(float (&d)[3], int axis, float cut) {
    if (cut <= 0.0f) return;
    float t[3] = {d[0], d[1], d[2]};
    t[axis] = 0.0f;
    const float length = sqrtf(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    if (length > 0.0f) {
        const float kept = fmaxf(length - cut, 0.0f) / length;
#pragma unroll
        for (int b = 0; b < 3; ++b)
            if (b != axis) d[b] *= kept;
    }
}

// A node's displacement after the tank's walls (`wall_displacement`; with `own` the particles' own
// displacement where the mirror's images joined d, `wall_displacement_with_images`).
__device__ __forceinline__ void pb_walls(float (&d)[3], const float (&x)[3], const float (&lo)[3], const float (&hi)[3],
                                         float friction, const float* own) {
#pragma unroll
    for (int a = 0; a < 3; ++a) {
        const float least = fminf(lo[a] - x[a], 0.0f), most = fmaxf(hi[a] - x[a], 0.0f);
        const float held = fminf(fmaxf(d[a], least), most);
        const float taken = own ? fabsf(fminf(fmaxf(own[a], least), most) - own[a]) : fabsf(held - d[a]);
        d[a] = held;
        pb_grip(d, a, friction * taken);
    }
}

// The node displacements (`grid_update`): the displacement sum over the mass, held by the colliders
// (collider_hold_displacement), then the walls;
// the sums are zeroed for the next pass's scatter. `node_d`: d xyz, and in w the node's vote in the
// viscosity's sweep, m / (m + FADING_NODE_MASS of a cell's mass), 0 where it holds no mass.
// `own_mass`, `own_displacement`: the sums before the walls' images joined them, where the walls grip
// (friction) under the mirror (`own_mass` also where a liquid is viscous); null otherwise.
extern "C" __global__ void pbmpm_grid(const KernelParams params, const float displacement_scale, const float friction,
                                      const float lo, const float hi0, const float hi1, const float hi2,
                                      const u64* __restrict__ mass, const u64* __restrict__ own_mass,
                                      u64* __restrict__ displacement, const u64* __restrict__ own_displacement,
                                      float4* __restrict__ node_d,
                                      const ColliderState* __restrict__ collider_states, const u32 num_colliders,
                                      const float* __restrict__ collider_sdf, u64* __restrict__ body_impulses) {
    const Colliders colliders{collider_states, num_colliders, collider_sdf, body_impulses};
    const u32 rx = params.grid_res[0], ry = params.grid_res[1];
    const u32 nodes = rx * ry * params.grid_res[2];
    const float inv_mass_scale = 1.0f / params.fixed_mass_scale, inv_scale = 1.0f / displacement_scale;
    // A cell's mass of the densest material is PBMPM_CELL_VOLUME_UNITS (2^40) units of the mass scale.
    const float fading_units = FADING_NODE_MASS * PBMPM_CELL_VOLUME_UNITS;
    const float low[3] = {lo, lo, lo}, high[3] = {hi0, hi1, hi2};
    FOR_EACH_INDEX(i, nodes) {
        const u64 q = mass[i];
        u64 sums[3];
#pragma unroll
        for (int a = 0; a < 3; ++a) {
            sums[a] = displacement[3 * (size_t)i + a];
            displacement[3 * (size_t)i + a] = 0;
        }
        if (q == 0) {
            node_d[i] = make_float4(0.0f, 0.0f, 0.0f, 0.0f);
            continue;
        }
        const float m = fixed_point_value(q, inv_mass_scale);
        float d[3];
#pragma unroll
        for (int a = 0; a < 3; ++a) d[a] = fixed_point_value(sums[a], inv_scale) / m;
        const float xn[3] = {(float)(i % rx) * params.dx, (float)((i / rx) % ry) * params.dx,
                             (float)(i / (rx * ry)) * params.dx};
        collider_hold_displacement(colliders, v3(xn[0], xn[1], xn[2]), params.dt, d);
        if (own_displacement) {
            const u64 own_q = own_mass[i];
            if (own_q != 0) {
                const float own_m = fixed_point_value(own_q, inv_mass_scale);
                const float own[3] = {fixed_point_value(own_displacement[3 * (size_t)i], inv_scale) / own_m,
                                      fixed_point_value(own_displacement[3 * (size_t)i + 1], inv_scale) / own_m,
                                      fixed_point_value(own_displacement[3 * (size_t)i + 2], inv_scale) / own_m};
                pb_walls(d, xn, low, high, friction, own);
            } else {
                // A node that only images reach has no fluid of its own to grip.
                pb_walls(d, xn, low, high, 0.0f, nullptr);
            }
        } else {
            pb_walls(d, xn, low, high, friction, nullptr);
        }
        const float units = (float)(i64)q;
        node_d[i] = make_float4(d[0], d[1], d[2], units / (units + fading_units));
    }
}

// The liquids' viscosity (`diffuse`): one Jacobi sweep d_i <- (d_i + a sum_j t_j d_j) / (1 + a sum_j
// t_j) over the face neighbours j, each by its vote t_j (pbmpm_grid), a = nu_i `diffusion` with nu_i
// the particles' own viscosity over their own mass (before the walls' images joined it); then the
// colliders and the walls again. From `node_d` into `diffused`.
extern "C" __global__ void pbmpm_diffuse(const KernelParams params, const float friction, const float diffusion,
                                         const float lo, const float hi0, const float hi1, const float hi2,
                                         const u64* __restrict__ mass, const u64* __restrict__ own_mass,
                                         const u64* __restrict__ viscosity, const float4* __restrict__ node_d,
                                         float4* __restrict__ diffused,
                                         const ColliderState* __restrict__ collider_states, const u32 num_colliders,
                                         const float* __restrict__ collider_sdf, u64* __restrict__ body_impulses) {
    const Colliders colliders{collider_states, num_colliders, collider_sdf, body_impulses};
    const u32 res[3] = {params.grid_res[0], params.grid_res[1], params.grid_res[2]};
    const u32 nodes = res[0] * res[1] * res[2];
    const u32 stride[3] = {1u, res[0], res[0] * res[1]};
    const float inv_mass_scale = 1.0f / params.fixed_mass_scale;
    const float low[3] = {lo, lo, lo}, high[3] = {hi0, hi1, hi2};
    FOR_EACH_INDEX(i, nodes) {
        const float4 own = node_d[i];
        const u64 own_q = own_mass ? own_mass[i] : mass[i];
        float a = 0.0f;
        if (mass[i] != 0 && own_q != 0)
            a = fixed_point_value(viscosity[i], inv_mass_scale) / fixed_point_value(own_q, inv_mass_scale) * diffusion;
        if (a <= 0.0f) {
            diffused[i] = own;
            continue;
        }
        const u32 c[3] = {i % res[0], (i / res[0]) % res[1], i / (res[0] * res[1])};
        float sum[3] = {0.0f, 0.0f, 0.0f}, count = 0.0f;
#pragma unroll
        for (int axis = 0; axis < 3; ++axis) {
#pragma unroll
            for (int side = 0; side < 2; ++side) {
                if (side == 0 ? c[axis] == 0 : c[axis] + 1 >= res[axis]) continue;
                const float4 g = node_d[side == 0 ? i - stride[axis] : i + stride[axis]];
                sum[0] += g.x * g.w, sum[1] += g.y * g.w, sum[2] += g.z * g.w;
                count += g.w;
            }
        }
        const float denominator = 1.0f + a * count;
        float d[3] = {(own.x + sum[0] * a) / denominator, (own.y + sum[1] * a) / denominator,
                      (own.z + sum[2] * a) / denominator};
        const float xn[3] = {(float)c[0] * params.dx, (float)c[1] * params.dx, (float)c[2] * params.dx};
        collider_hold_displacement(colliders, v3(xn[0], xn[1], xn[2]), params.dt, d);
        pb_walls(d, xn, low, high, friction, nullptr);
        diffused[i] = make_float4(d[0], d[1], d[2], own.w);
    }
}
