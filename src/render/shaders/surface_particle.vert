// Sphere impostors for the surface's depth and thickness passes: a point sprite per particle, its
// size the sphere's projection (or at least u_min_splat_px in radius, for the thickness splats).
layout(location = 0) in vec4 a_particle; // xyz position, w the colour quantity
uniform mat4 u_view;
uniform mat4 u_proj;
uniform float u_radius;              // the sphere's radius, m
uniform float u_pixels_per_metre;    // pixels per metre at unit depth, in this pass's target
uniform float u_min_splat_px;        // smallest splat radius, pixels
uniform int u_only_row;              // >= 0: only the particles of this material row (w, coloured
                                     // by material), the others clipped away
layout(location = 1) in float a_row; // the slot's material row, where the buffer holds the rows
uniform int u_solid_rows;            // bit r: row r is a solid's, drawn as spheres by the renderer
                                     // and part of no surface (0: none; a_row then goes unread)
out vec3 v_centre;                   // view space, m
out float v_splat;                   // the splat's radius, m (>= u_radius)
out float v_quantity;
void main() {
    bool solid = u_solid_rows != 0 && ((u_solid_rows >> clamp(int(a_row + 0.5), 0, 31)) & 1) != 0;
    if ((u_only_row >= 0 && int(a_particle.w + 0.5) != u_only_row) || solid) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        gl_PointSize = 1.0;
        return;
    }
    vec4 view = u_view * vec4(a_particle.xyz, 1.0);
    gl_Position = u_proj * view;
    float depth = max(-view.z, 1e-4);
    float splat_px = max(u_radius * u_pixels_per_metre / depth, u_min_splat_px);
    gl_PointSize = 2.0 * splat_px;
    v_splat = splat_px * depth / u_pixels_per_metre;
    v_centre = view.xyz;
    v_quantity = a_particle.w;
#ifdef SPHERE_FRONT_DEPTH
    // The whole sprite is rasterised at the depth of the sphere's front (its nearest point), with its
    // place on screen unchanged: every depth the fragment shader writes is then at or behind the
    // rasterised one, which is what `depth_greater` promises the early depth test. A front in front
    // of the near plane is put just behind it (nearer than any depth written there).
    vec4 front = u_proj * vec4(view.xy, min(view.z + v_splat, -1e-4), 1.0);
    gl_Position.z = max(front.z / front.w, -0.99999) * gl_Position.w;
#endif
}
