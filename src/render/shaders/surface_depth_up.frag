// The depth smoothed at half resolution brought back to full resolution for the shading, aware of
// depth: of the four half-resolution pixels around this one, each weighs bilinearly and fades out
// as its smoothed depth leaves the narrow range around this pixel's own (unsmoothed) depth, so a
// silhouette's pixels never take the depth of the background or of a sheet behind. A pixel none of
// them matches keeps its own depth. The silhouettes therefore stay at full resolution; only the
// smoothing of the surface's interior is half as fine.
uniform sampler2D u_depth;     // full resolution, as the depth pass drew it
uniform sampler2D u_smoothed;  // half resolution, smoothed
uniform float u_range;         // half-width of the narrow range, m
out float o_depth;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    float z = texelFetch(u_depth, p, 0).r;
    if (z >= 0.5 * EMPTY_DEPTH) {
        o_depth = EMPTY_DEPTH;
        return;
    }
    ivec2 half_size = textureSize(u_smoothed, 0);
    // This pixel's centre in half-resolution pixels, whose centres sit at whole numbers.
    vec2 h = (vec2(p) + 0.5) * 0.5 - 0.5;
    ivec2 base = ivec2(floor(h));
    vec2 f = h - vec2(base);
    float sum = 0.0;
    float weights = 0.0;
    for (int k = 0; k < 4; ++k) {
        ivec2 o = ivec2(k & 1, k >> 1);
        float s = texelFetch(u_smoothed, clamp(base + o, ivec2(0), half_size - 1), 0).r;
        vec2 axis = mix(1.0 - f, f, vec2(o));
        float w = axis.x * axis.y * (1.0 - smoothstep(u_range, 2.0 * u_range, abs(s - z)));
        sum += w * s;
        weights += w;
    }
    o_depth = weights > 1e-4 ? sum / weights : z;
}
