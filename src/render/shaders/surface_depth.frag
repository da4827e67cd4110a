// The nearest sphere surface per pixel, as view distance (m) into a float texture; the hardware depth
// test keeps the nearest.
in vec3 v_centre;
in float v_splat;
in float v_quantity;
uniform mat4 u_proj;
out float o_depth;
void main() {
    vec2 p = gl_PointCoord * 2.0 - 1.0;
    p.y = -p.y;
    float r2 = dot(p, p);
    if (r2 > 1.0) discard;
    vec3 position = v_centre + v_splat * vec3(p, sqrt(1.0 - r2));
    vec4 clip = u_proj * vec4(position, 1.0);
    gl_FragDepth = 0.5 * (clip.z / clip.w) + 0.5;
    o_depth = -position.z;
}
