// One direction of the narrow-range filter (Truong & Yuksel 2018, "A Narrow-Range Filter for
// Screen-Space Fluid Rendering"), run horizontally then vertically.
//
// A Gaussian over the depth, except that it only averages depths within a narrow range around the
// pixel's own: a sample farther than the range (the background, or a sheet of water behind) is left
// out, together with its mirror sample so the kernel stays symmetric; a sample nearer than the range
// (a sheet in front) counts as lying at the range's near end (clamped), so it cannot drag the
// silhouette forward. Samples inside the range widen it, so the filter follows a surface seen at a
// grazing angle. The radius is a fixed number of particle radii in pixels at the pixel's depth,
// capped at u_max_filter_px: the cost per pixel is bounded.
//
// The samples are read in pairs of neighbouring pixels, one bilinear fetch per pair placed between
// the two so that the hardware's interpolation weights them as the Gaussian does (the depth textures
// filter linearly): half the fetches and half the range tests of one read per pixel, the same
// result wherever both pixels of a pair lie on one surface. A pair that straddles a silhouette reads
// a depth far behind (the mean with the empty background) and is left out with its mirror, as a
// far sample is; every pixel still contributes, so there is none of the aliasing (noise along the
// particles' bumps) that reading only every second pixel would give.
//
// Why this filter and not a bilateral one with a depth cut-off: a bilateral filter either blurs
// across silhouettes (a wide range pulls the background in and rounds the edges off) or, with a
// narrow range, leaves the spheres' bumps (the particle lattice) wherever the surface is tilted. The
// narrow-range filter keeps silhouettes sharp with a narrow range and still smooths tilted surfaces,
// at the cost of a Gaussian: the same samples, a few comparisons more.
in vec2 v_uv;
uniform sampler2D u_depth;
uniform ivec2 u_direction;
uniform float u_radius;              // particle radius, m
uniform float u_pixels_per_metre;    // at unit depth
uniform float u_filter_radii;        // filter radius in particle radii
uniform int u_max_filter_px;
uniform float u_range;               // half-width of the narrow range, m
out float o_depth;

// Each sample's part is continuous in its depth: a sample that crosses the range's far end fades out
// over one range width (with its mirror), and one in front is clamped to the range's near end, so
// that no pixel's result jumps where a neighbour's depth crosses a threshold (such jumps draw lines
// at a fixed distance inside every silhouette).
void narrow(inout float depth, inout float weight, inout float mirror_weight,
            inout float upper, inout float lower) {
    if (depth > upper) {
        float keep = 1.0 - smoothstep(upper, upper + u_range, depth);
        weight *= keep;
        mirror_weight *= keep;
    } else if (depth < lower) {
        depth = lower;
    } else {
        upper = max(upper, depth + u_range);
        lower = min(lower, depth - u_range);
    }
}

void main() {
    ivec2 size = textureSize(u_depth, 0);
    ivec2 p = ivec2(gl_FragCoord.xy);
    float z = texelFetch(u_depth, p, 0).r;
    if (z >= 0.5 * EMPTY_DEPTH) {
        o_depth = EMPTY_DEPTH;
        return;
    }
    // The kernel's width follows the depth continuously (a width that jumped from one whole pixel
    // count to the next would draw the jump as a line along each depth contour): a Gaussian cut at
    // `reach` pixels, its value there subtracted so that the weights fall to zero at the cut.
    float reach = min(float(u_max_filter_px), u_filter_radii * u_radius * u_pixels_per_metre / z);
    int n = int(ceil(reach));
    vec2 texel = 1.0 / vec2(size);
    vec2 centre = (vec2(p) + 0.5) * texel;
    vec2 step = vec2(u_direction) * texel;
    float sigma = max(reach / 2.5, 0.5);
    float two_sigma2 = 2.0 * sigma * sigma;
    float tail = exp(-reach * reach / two_sigma2);
    float upper = z + u_range;
    float lower = z - u_range;
    float sum = z;
    float weights = 1.0;
    for (int i = 1; i <= n; i += 2) {
        // Pixels i and i + 1 (the latter of weight 0 past the cut), read at their weighted mean.
        float w1 = max(exp(-float(i * i) / two_sigma2) - tail, 0.0);
        float w2 = max(exp(-float((i + 1) * (i + 1)) / two_sigma2) - tail, 0.0);
        float w = w1 + w2;
        float offset = float(i) + w2 / max(w, 1e-30);
        float a = texture(u_depth, centre + offset * step).r;
        float b = texture(u_depth, centre - offset * step).r;
        float wa = w;
        float wb = w;
        narrow(a, wa, wb, upper, lower);
        narrow(b, wb, wa, upper, lower);
        sum += a * wa + b * wb;
        weights += wa + wb;
    }
    o_depth = sum / weights;
}
