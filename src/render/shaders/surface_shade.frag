// The water: normals from the smoothed depth, Fresnel (Schlick) between a reflected sky and the
// refracted scene behind, that scene absorbed by the thickness (Beer-Lambert) and replaced by the
// water's own colour as it is absorbed, a sun highlight, and optionally whitewater from speed. Where
// there is no water, or the scene is in front of it, the scene shows as it is.
// Coloured by material with several liquids, each liquid has a surface of its own (the passes ran
// once per material row into the layers of u_layer_depth and u_layer_thickness); per pixel they are
// laid over the scene from the farthest to the nearest, each absorbing what is behind it in its own
// colour at its own rate.
in vec2 v_uv;
uniform sampler2D u_scene;           // colour of what is behind the water
uniform sampler2D u_scene_depth;     // its depth buffer
uniform sampler2D u_depth;           // smoothed water depth: view distance, m
uniform sampler2D u_thickness;       // reduced resolution: thickness (m), thickness x quantity
uniform int u_layers;                // > 1: one surface per material row, in the arrays below
uniform sampler2DArray u_layer_depth;     // per row: smoothed depth, as u_depth
uniform sampler2DArray u_layer_thickness; // per row: thickness (m) in .r, as u_thickness
uniform mat4 u_proj;
uniform mat3 u_view_to_world;
uniform vec3 u_sun_view;             // towards the sun, view space
uniform vec3 u_sun_world;
uniform vec3 u_absorption;           // 1/m per channel
uniform float u_absorption_scale;    // the panel's absorption (1: the defaults above)
uniform float u_scattering;          // 1/m: how fast the water's own colour replaces what is behind
uniform vec3 u_water_colour;
uniform float u_refraction;
uniform int u_tint;                  // 0 clear water, 1 whitewater from speed, 2 the colour scale,
                                     // 3 the materials' colours (the quantity: the material row)
uniform vec2 u_range;
out vec4 o_colour;

// A studio sky: a bright horizon, a blue zenith, a dark floor below, and the sun.
vec3 sky(vec3 d) {
    vec3 horizon = vec3(0.70, 0.76, 0.82);
    vec3 zenith = vec3(0.20, 0.40, 0.72);
    vec3 ground = vec3(0.08, 0.09, 0.10);
    vec3 c = d.y >= 0.0 ? mix(horizon, zenith, sqrt(d.y)) : mix(horizon * 0.6, ground, sqrt(-d.y));
    return c + vec3(1.0, 0.95, 0.85) * 6.0 * pow(max(dot(d, u_sun_world), 0.0), 600.0);
}

// View distance from a depth-buffer value, for this projection.
float view_distance(float depth_buffer) {
    float ndc = 2.0 * depth_buffer - 1.0;
    return u_proj[3][2] / (ndc + u_proj[2][2]);
}

vec3 view_position(ivec2 pixel, ivec2 size, float z) {
    vec2 ndc = (vec2(pixel) + 0.5) / vec2(size) * 2.0 - 1.0;
    return vec3(ndc.x * z / u_proj[0][0], ndc.y * z / u_proj[1][1], -z);
}

// The smoothed depth of the one surface (layer < 0) or of material row `layer`'s.
float depth_at(ivec2 pixel, ivec2 size, int layer) {
    pixel = clamp(pixel, ivec2(0), size - 1);
    return layer < 0 ? texelFetch(u_depth, pixel, 0).r : texelFetch(u_layer_depth, ivec3(pixel, layer), 0).r;
}

// The difference to the neighbour on the side whose depth changes less (a silhouette's other side
// belongs to another surface), in view space.
vec3 tangent(ivec2 pixel, ivec2 size, vec3 centre, ivec2 step, int layer) {
    float zf = depth_at(pixel + step, size, layer);
    float zb = depth_at(pixel - step, size, layer);
    vec3 forward = view_position(pixel + step, size, zf) - centre;
    vec3 backward = centre - view_position(pixel - step, size, zb);
    bool use_backward = zf >= 0.5 * EMPTY_DEPTH
        || (zb < 0.5 * EMPTY_DEPTH && abs(backward.z) < abs(forward.z));
    return use_backward ? backward : forward;
}

// The surface's normal at `position` (view space), facing the eye.
vec3 normal_at(ivec2 pixel, ivec2 size, vec3 position, int layer) {
    vec3 n = normalize(cross(tangent(pixel, size, position, ivec2(1, 0), layer),
                             tangent(pixel, size, position, ivec2(0, 1), layer)));
    return dot(n, -position) < 0.0 ? -n : n;
}

// Where the scene behind is seen through the surface: the bend grows with the thickness up to a few
// centimetres, then stays (a long path through the water, along a crease, must not throw the picture
// across the screen).
vec2 bent_uv(vec3 n, float thickness, float z) {
    return clamp(v_uv + n.xy * u_refraction * min(thickness, 0.05) / z, vec2(0.0), vec2(1.0));
}

// One surface over `behind`: Beer-Lambert absorption through `thickness`, the liquid's own colour
// `water` scattered in as it absorbs, Fresnel towards the sky's reflection; the sun's highlight comes
// back separately (whitewater dims it).
vec3 body_and_reflection(vec3 behind, vec3 n, vec3 v, float thickness, vec3 water, vec3 absorption,
                         float scattering) {
    float fresnel = 0.02 + 0.98 * pow(1.0 - max(dot(n, v), 0.0), 5.0);
    vec3 reflection = sky(normalize(u_view_to_world * reflect(-v, n)));
    vec3 transmitted = exp(-absorption * thickness);
    float scattered = 1.0 - exp(-scattering * thickness);
    float lit = max(dot(n, u_sun_view), 0.0);
    vec3 body = behind * transmitted + water * (0.6 + 0.4 * lit) * scattered;
    return mix(body, reflection, fresnel);
}

float highlight(vec3 n, vec3 v) {
    vec3 h = normalize(u_sun_view + v);
    return 1.5 * pow(max(dot(n, h), 0.0), 300.0);
}

// Several liquids, each its own surface: those in front of the scene, laid over it far to near.
void shade_layers(ivec2 pixel, ivec2 size, vec3 scene, float scene_z) {
    float z[8];
    int row[8];
    int n = 0;
    for (int k = 0; k < u_layers && k < 8; ++k) {
        float zk = depth_at(pixel, size, k);
        if (zk >= 0.5 * EMPTY_DEPTH || zk > scene_z) continue;
        // Insertion, farthest first.
        int i = n++;
        while (i > 0 && z[i - 1] < zk) {
            z[i] = z[i - 1];
            row[i] = row[i - 1];
            --i;
        }
        z[i] = zk;
        row[i] = k;
    }
    vec3 colour = scene;
    for (int i = 0; i < n; ++i) {
        vec3 position = view_position(pixel, size, z[i]);
        vec3 nrm = normal_at(pixel, size, position, row[i]);
        vec3 v = normalize(-position);
        float thickness = max(texture(u_layer_thickness, vec3(v_uv, float(row[i]))).r, 0.0);
        // The farthest liquid refracts the scene; a nearer one sees the liquids behind it unbent.
        vec3 behind = i == 0 ? texture(u_scene, bent_uv(nrm, thickness, z[i])).rgb : colour;
        colour = body_and_reflection(behind, nrm, v, thickness, material_colour(float(row[i])),
                                     u_absorption_scale * material_absorption(row[i]),
                                     u_scattering * material_absorption_factor(row[i]))
               + vec3(highlight(nrm, v));
    }
    o_colour = vec4(colour, 1.0);
}

void main() {
    ivec2 size = textureSize(u_depth, 0);
    ivec2 pixel = clamp(ivec2(v_uv * vec2(size)), ivec2(0), size - 1);
    vec3 scene = texture(u_scene, v_uv).rgb;
    float scene_z = view_distance(texture(u_scene_depth, v_uv).r);
    if (u_layers > 1) {
        shade_layers(pixel, size, scene, scene_z);
        return;
    }
    float z = texelFetch(u_depth, pixel, 0).r;
    if (z >= 0.5 * EMPTY_DEPTH || z > scene_z) {
        o_colour = vec4(scene, 1.0);
        return;
    }
    vec3 position = view_position(pixel, size, z);
    vec3 n = normal_at(pixel, size, position, -1);
    vec3 v = normalize(-position);

    vec2 th = texture(u_thickness, v_uv).rg;
    float thickness = max(th.x, 0.0);
    float quantity = th.x > 1e-6 ? th.y / th.x : (u_tint == 3 ? 0.0 : u_range.x);
    float t = (quantity - u_range.x) / max(u_range.y - u_range.x, 1e-6);

    vec3 behind = texture(u_scene, bent_uv(n, thickness, z)).rgb;
    // Coloured by material (one liquid here), the liquid absorbs the light its colour lacks.
    vec3 absorption = u_tint == 3 ? u_absorption_scale * material_absorption(int(quantity + 0.5)) : u_absorption;
    float scattering = u_tint == 3 ? u_scattering * material_absorption_factor(int(quantity + 0.5)) : u_scattering;
    vec3 water = u_tint == 2 ? scale_colour(t)
               : u_tint == 3 ? material_colour(quantity) : u_water_colour;
    vec3 colour = body_and_reflection(behind, n, v, thickness, water, absorption, scattering);
    float lit = max(dot(n, u_sun_view), 0.0);
    float specular = highlight(n, v);
    if (u_tint == 1) {
        float foam = foam_amount(t);
        colour = mix(colour, FOAM_COLOUR * (0.7 + 0.3 * lit), foam);
        specular *= 1.0 - foam;
    }
    o_colour = vec4(colour + vec3(specular), 1.0);
}
