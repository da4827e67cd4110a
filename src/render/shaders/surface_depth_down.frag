// The particles' depth at half resolution, for smoothing there (a quarter of the pixels, and the
// filter half as wide in pixels): each half-resolution pixel takes the mean of its 2x2 block's depths
// that lie within the narrow range of the block's nearest, so a silhouette keeps the water in front
// rather than a mix with the empty background or a sheet behind.
uniform sampler2D u_depth;
uniform float u_range;  // half-width of the narrow range, m
out float o_depth;

void main() {
    ivec2 size = textureSize(u_depth, 0);
    ivec2 p = 2 * ivec2(gl_FragCoord.xy);
    float z[4];
    float nearest = EMPTY_DEPTH;
    for (int k = 0; k < 4; ++k) {
        z[k] = texelFetch(u_depth, min(p + ivec2(k & 1, k >> 1), size - 1), 0).r;
        nearest = min(nearest, z[k]);
    }
    if (nearest >= 0.5 * EMPTY_DEPTH) {
        o_depth = EMPTY_DEPTH;
        return;
    }
    float sum = 0.0;
    float n = 0.0;
    for (int k = 0; k < 4; ++k) {
        if (z[k] <= nearest + u_range) {
            sum += z[k];
            n += 1.0;
        }
    }
    o_depth = sum / n;
}
