// Water thickness along the view ray, added up over particles (blending ONE, ONE): each splat is the
// chord profile of a sphere, scaled so that it adds exactly its particle's volume (spacing^3), whatever
// its on-screen size. The second channel carries thickness times the colour quantity, so that
// (y / x) is the quantity averaged through the water.
in vec3 v_centre;
in float v_splat;
in float v_quantity;
uniform float u_particle_volume;     // m^3
out vec2 o_thickness;
void main() {
    vec2 p = gl_PointCoord * 2.0 - 1.0;
    float r2 = dot(p, p);
    if (r2 > 1.0) discard;
    float chord = 2.0 * v_splat * sqrt(1.0 - r2);
    float sphere_volume = 4.18879 * v_splat * v_splat * v_splat;
    float t = chord * u_particle_volume / sphere_volume;
    o_thickness = vec2(t, t * v_quantity);
}
