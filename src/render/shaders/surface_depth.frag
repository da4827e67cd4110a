// The nearest sphere surface per pixel, as view distance (m) into a float texture; the hardware depth
// test keeps the nearest. The sprite arrives at its sphere's front depth (surface_particle.vert), so
// the depth written is never nearer than the rasterised one: with `depth_greater` the early depth
// test still rejects the fragments behind water already drawn, instead of shading every layer.
#ifdef GL_ARB_conservative_depth
layout(depth_greater) out float gl_FragDepth;
#endif
in vec3 v_centre;
in float v_splat;
in float v_quantity;
uniform mat4 u_proj;
out float o_depth;
void main() {
    vec2 p = gl_PointCoord * 2.0 - 1.0;
    float r2 = dot(p, p);
    if (r2 > 1.0) discard;
    // Only the depth along the view axis matters here; the sprite is the sphere seen head-on.
    float z = v_centre.z + v_splat * sqrt(1.0 - r2);
    // The projection's depth for view z (a perspective matrix: clip.w = -z).
    gl_FragDepth = 0.5 * (u_proj[2][2] * z + u_proj[3][2]) / -z + 0.5;
    o_depth = -z;
}
