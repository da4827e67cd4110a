//! The particle renderer, shared by the window and the headless path: particles as flat points (the
//! report's minimal mode) or as lit sphere impostors with true depth, the domain box as a wireframe,
//! and the colour scale as a bar at the right edge. It draws into whatever framebuffer is bound.

use super::camera::OrbitCamera;
use anyhow::{anyhow, Result};
use glam::{Mat4, Vec3};
use glow::HasContext;
use std::sync::Arc;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum DrawMode {
    /// Square points of a fixed pixel size, no lighting.
    Points,
    /// Lit spheres of the particle radius, with correct depth.
    #[default]
    Spheres,
}

/// How particles are coloured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Colouring {
    /// One colour for every particle.
    Solid,
    /// |v|, on the colour scale.
    #[default]
    Speed,
    /// rho / rho0, on the colour scale.
    Density,
}

impl Colouring {
    /// The quantity the render kernel writes (solid colouring ignores it).
    pub fn quantity(self) -> crate::sim::ColourBy {
        match self {
            Colouring::Density => crate::sim::ColourBy::Density,
            Colouring::Solid | Colouring::Speed => crate::sim::ColourBy::Speed,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    pub mode: DrawMode,
    pub colouring: Colouring,
    /// Point size in pixels (points mode).
    pub point_size: f32,
    /// Sphere radius, m (spheres mode).
    pub sphere_radius: f32,
    /// Values mapped to the two ends of the colour scale.
    pub scale_range: [f32; 2],
    pub show_box: bool,
}

impl RenderSettings {
    /// Defaults for a scene of grid spacing `dx`: spheres about the spacing of the particles.
    pub fn for_spacing(particle_spacing: f32) -> RenderSettings {
        RenderSettings {
            mode: DrawMode::Spheres,
            colouring: Colouring::Speed,
            point_size: 2.0,
            sphere_radius: 0.6 * particle_spacing,
            scale_range: [0.0, 3.0],
            show_box: true,
        }
    }

    /// A sensible scale for the colouring: 0..3 m/s for speed, 0.9..1.1 for density.
    pub fn default_range(colouring: Colouring) -> [f32; 2] {
        match colouring {
            Colouring::Density => [0.9, 1.1],
            Colouring::Solid | Colouring::Speed => [0.0, 3.0],
        }
    }
}

/// A rectangle of the framebuffer in GL's convention: pixels from the bottom-left corner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Viewport {
    pub x: i32,
    pub y: i32,
    pub width: u32,
    pub height: u32,
}

impl Viewport {
    /// The whole of a `size` framebuffer.
    pub fn full(size: [u32; 2]) -> Viewport {
        Viewport {
            x: 0,
            y: 0,
            width: size[0].max(1),
            height: size[1].max(1),
        }
    }
}

/// The colour scale, as stops from low to high (the GLSL `scale_colour` and the panel's legend share
/// this table).
pub const SCALE_STOPS: [[f32; 3]; 5] = [
    [0.05, 0.15, 0.55],
    [0.10, 0.55, 0.85],
    [0.30, 0.85, 0.55],
    [0.95, 0.80, 0.20],
    [0.90, 0.25, 0.15],
];
pub const SOLID_COLOUR: [f32; 3] = [0.25, 0.55, 0.95];
pub const BACKGROUND: [f32; 3] = [0.09, 0.10, 0.12];

/// The colour of `t` in [0, 1] on the scale.
pub fn scale_colour(t: f32) -> [f32; 3] {
    let x = t.clamp(0.0, 1.0) * (SCALE_STOPS.len() - 1) as f32;
    let i = (x.floor() as usize).min(SCALE_STOPS.len() - 2);
    let f = x - i as f32;
    let (a, b) = (SCALE_STOPS[i], SCALE_STOPS[i + 1]);
    [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * f)
}

fn glsl_scale() -> String {
    let stops: Vec<String> = SCALE_STOPS
        .iter()
        .map(|c| format!("vec3({:.3}, {:.3}, {:.3})", c[0], c[1], c[2]))
        .collect();
    format!(
        "vec3 scale_colour(float t) {{
    const vec3 stops[5] = vec3[5]({});
    float x = clamp(t, 0.0, 1.0) * 4.0;
    int i = min(int(floor(x)), 3);
    return mix(stops[i], stops[i + 1], x - float(i));
}}
",
        stops.join(", ")
    )
}

const PARTICLE_VS: &str = r#"
layout(location = 0) in vec4 a_particle; // xyz position, w the colour quantity
uniform mat4 u_view;
uniform mat4 u_proj;
uniform int u_spheres;
uniform float u_point_size;
uniform float u_radius;
uniform float u_pixels_per_metre_at_unit_depth;
uniform int u_solid;
uniform vec3 u_solid_colour;
uniform vec2 u_range;
out vec3 v_colour;
out vec3 v_centre;
void main() {
    vec4 view = u_view * vec4(a_particle.xyz, 1.0);
    gl_Position = u_proj * view;
    v_centre = view.xyz;
    if (u_spheres == 1) {
        gl_PointSize = max(2.0 * u_radius * u_pixels_per_metre_at_unit_depth / max(-view.z, 1e-4), 1.0);
    } else {
        gl_PointSize = u_point_size;
    }
    float t = (a_particle.w - u_range.x) / max(u_range.y - u_range.x, 1e-6);
    v_colour = u_solid == 1 ? u_solid_colour : scale_colour(t);
}
"#;

const POINTS_FS: &str = r#"
in vec3 v_colour;
in vec3 v_centre;
out vec4 o_colour;
void main() { o_colour = vec4(v_colour, 1.0); }
"#;

// The sprite is a disc; each fragment finds its point on the sphere's front half, shades it, and
// writes that point's depth, so spheres intersect each other and the box correctly.
const SPHERES_FS: &str = r#"
in vec3 v_colour;
in vec3 v_centre;
uniform mat4 u_proj;
uniform float u_radius;
out vec4 o_colour;
void main() {
    vec2 p = gl_PointCoord * 2.0 - 1.0;
    p.y = -p.y;
    float r2 = dot(p, p);
    if (r2 > 1.0) discard;
    vec3 n = vec3(p, sqrt(1.0 - r2));
    vec3 position = v_centre + n * u_radius;
    vec4 clip = u_proj * vec4(position, 1.0);
    gl_FragDepth = 0.5 * (clip.z / clip.w) + 0.5;
    vec3 light = normalize(vec3(0.4, 0.7, 0.6));
    float diffuse = max(dot(n, light), 0.0);
    vec3 h = normalize(light + vec3(0.0, 0.0, 1.0));
    float specular = pow(max(dot(n, h), 0.0), 40.0);
    o_colour = vec4(v_colour * (0.3 + 0.7 * diffuse) + vec3(0.25) * specular, 1.0);
}
"#;

const LINES_VS: &str = r#"
layout(location = 0) in vec3 a_position;
uniform mat4 u_view_proj;
void main() { gl_Position = u_view_proj * vec4(a_position, 1.0); }
"#;

const LINES_FS: &str = r#"
uniform vec3 u_colour;
out vec4 o_colour;
void main() { o_colour = vec4(u_colour, 1.0); }
"#;

// A quad from gl_VertexID (no buffer), drawn into a small viewport at the right edge.
const BAR_VS: &str = r#"
out float v_t;
void main() {
    vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1));
    v_t = corner.y;
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
"#;

const BAR_FS: &str = r#"
in float v_t;
out vec4 o_colour;
void main() { o_colour = vec4(scale_colour(v_t), 1.0); }
"#;

struct Programs {
    points: glow::Program,
    spheres: glow::Program,
    lines: glow::Program,
    bar: glow::Program,
}

pub struct Renderer {
    gl: Arc<glow::Context>,
    programs: Programs,
    particle_vao: glow::VertexArray,
    particle_vbo: glow::Buffer,
    /// Particles the VBO has room for.
    capacity: usize,
    box_vao: glow::VertexArray,
    box_vbo: glow::Buffer,
    bar_vao: glow::VertexArray,
}

/// The `#version` line for the context: GLSL 3.30 core runs on every GL 3.3+ core context (and the
/// 4.x ones this viewer asks for first).
const GLSL_HEADER: &str = "#version 330 core\n";

impl Renderer {
    pub fn new(gl: Arc<glow::Context>) -> Result<Renderer> {
        // SAFETY: the caller's GL context is current on this thread; every object is created here.
        unsafe {
            let scale = glsl_scale();
            let programs = Programs {
                points: link(&gl, "points", &[PARTICLE_VS], &[POINTS_FS], &scale)?,
                spheres: link(&gl, "spheres", &[PARTICLE_VS], &[SPHERES_FS], &scale)?,
                lines: link(&gl, "lines", &[LINES_VS], &[LINES_FS], "")?,
                bar: link(&gl, "colour bar", &[BAR_VS], &[BAR_FS], &scale)?,
            };
            let particle_vao = gl.create_vertex_array().map_err(gl_error("a vertex array"))?;
            let particle_vbo = gl.create_buffer().map_err(gl_error("a buffer"))?;
            gl.bind_vertex_array(Some(particle_vao));
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(particle_vbo));
            // Give the buffer storage now: CUDA can only register a buffer that has some.
            gl.buffer_data_size(glow::ARRAY_BUFFER, 16, glow::DYNAMIC_DRAW);
            gl.enable_vertex_attrib_array(0);
            gl.vertex_attrib_pointer_f32(0, 4, glow::FLOAT, false, 16, 0);

            let box_vao = gl.create_vertex_array().map_err(gl_error("a vertex array"))?;
            let box_vbo = gl.create_buffer().map_err(gl_error("a buffer"))?;
            gl.bind_vertex_array(Some(box_vao));
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(box_vbo));
            gl.buffer_data_size(glow::ARRAY_BUFFER, 24 * 12, glow::DYNAMIC_DRAW);
            gl.enable_vertex_attrib_array(0);
            gl.vertex_attrib_pointer_f32(0, 3, glow::FLOAT, false, 12, 0);

            let bar_vao = gl.create_vertex_array().map_err(gl_error("a vertex array"))?;
            gl.bind_vertex_array(None);
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
            Ok(Renderer {
                gl,
                programs,
                particle_vao,
                particle_vbo,
                capacity: 1,
                box_vao,
                box_vbo,
                bar_vao,
            })
        }
    }

    pub fn gl(&self) -> &Arc<glow::Context> {
        &self.gl
    }

    /// The GL name of the particle vertex buffer, for registering it with CUDA.
    pub fn particle_buffer_name(&self) -> u32 {
        self.particle_vbo.0.get()
    }

    /// Makes the particle buffer hold `particles` float4s. Returns true when it was reallocated: a
    /// CUDA registration of the old storage must then be dropped (before this call) and redone.
    pub fn ensure_capacity(&mut self, particles: usize) -> bool {
        if particles == self.capacity {
            return false;
        }
        // SAFETY: our buffer, our context (current).
        unsafe {
            self.gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.particle_vbo));
            self.gl.buffer_data_size(
                glow::ARRAY_BUFFER,
                (16 * particles.max(1)) as i32,
                glow::DYNAMIC_DRAW,
            );
            self.gl.bind_buffer(glow::ARRAY_BUFFER, None);
        }
        self.capacity = particles;
        true
    }

    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Uploads host particle attributes (the CPU backend and the host-copy path): glBufferSubData
    /// into the buffer `ensure_capacity` sized.
    pub fn upload(&mut self, particles: &[[f32; 4]]) {
        self.ensure_capacity(particles.len());
        // SAFETY: the buffer holds `capacity` float4 (just ensured).
        unsafe {
            self.gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.particle_vbo));
            self.gl
                .buffer_sub_data_u8_slice(glow::ARRAY_BUFFER, 0, bytemuck::cast_slice(particles));
            self.gl.bind_buffer(glow::ARRAY_BUFFER, None);
        }
    }

    /// Reads the first `count` vertices of the particle buffer back through GL (tests: what CUDA
    /// wrote through interop, as GL sees it).
    pub fn read_particle_buffer(&self, count: usize) -> Vec<[f32; 4]> {
        let count = count.min(self.capacity);
        let mut bytes = vec![0u8; 16 * count];
        // SAFETY: the buffer holds `capacity` >= count float4.
        unsafe {
            self.gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.particle_vbo));
            self.gl.get_buffer_sub_data(glow::ARRAY_BUFFER, 0, &mut bytes);
            self.gl.bind_buffer(glow::ARRAY_BUFFER, None);
        }
        bytes
            .chunks_exact(16)
            .map(|v| {
                std::array::from_fn(|k| {
                    f32::from_ne_bytes([v[4 * k], v[4 * k + 1], v[4 * k + 2], v[4 * k + 3]])
                })
            })
            .collect()
    }

    /// Clears the bound framebuffer and draws `count` particles, the box [lo, hi] and the colour bar
    /// into `viewport` of it (the window leaves room for the panel; headless uses all of it).
    pub fn draw(
        &self,
        viewport: Viewport,
        camera: &OrbitCamera,
        settings: &RenderSettings,
        count: usize,
        domain: (Vec3, Vec3),
    ) {
        let gl = &self.gl;
        let (x0, y0) = (viewport.x, viewport.y);
        let (w, h) = (viewport.width.max(1) as i32, viewport.height.max(1) as i32);
        let view = camera.view();
        let proj = camera.projection(w as f32 / h as f32);
        // SAFETY: every object used is this renderer's; the context is current.
        unsafe {
            gl.viewport(x0, y0, w, h);
            gl.clear_color(BACKGROUND[0], BACKGROUND[1], BACKGROUND[2], 1.0);
            gl.clear_depth_f32(1.0);
            gl.clear(glow::COLOR_BUFFER_BIT | glow::DEPTH_BUFFER_BIT);
            gl.enable(glow::DEPTH_TEST);
            gl.depth_func(glow::LESS);
            gl.disable(glow::BLEND);
            gl.disable(glow::CULL_FACE);
            gl.disable(glow::SCISSOR_TEST);

            if settings.show_box {
                self.draw_box(&(proj * view), domain);
            }

            let count = count.min(self.capacity);
            let program = match settings.mode {
                DrawMode::Points => self.programs.points,
                DrawMode::Spheres => self.programs.spheres,
            };
            gl.use_program(Some(program));
            gl.enable(glow::PROGRAM_POINT_SIZE);
            set_mat4(gl, program, "u_view", &view);
            set_mat4(gl, program, "u_proj", &proj);
            set_i32(
                gl,
                program,
                "u_spheres",
                i32::from(settings.mode == DrawMode::Spheres),
            );
            set_f32(gl, program, "u_point_size", settings.point_size);
            set_f32(gl, program, "u_radius", settings.sphere_radius);
            // proj[1][1] = 1 / tan(fov/2): pixels per metre at unit depth = h/2 * proj[1][1].
            set_f32(
                gl,
                program,
                "u_pixels_per_metre_at_unit_depth",
                0.5 * h as f32 * proj.y_axis.y,
            );
            set_i32(
                gl,
                program,
                "u_solid",
                i32::from(settings.colouring == Colouring::Solid),
            );
            let loc = gl.get_uniform_location(program, "u_solid_colour");
            gl.uniform_3_f32(loc.as_ref(), SOLID_COLOUR[0], SOLID_COLOUR[1], SOLID_COLOUR[2]);
            let loc = gl.get_uniform_location(program, "u_range");
            gl.uniform_2_f32(loc.as_ref(), settings.scale_range[0], settings.scale_range[1]);
            gl.bind_vertex_array(Some(self.particle_vao));
            gl.draw_arrays(glow::POINTS, 0, count as i32);
            gl.bind_vertex_array(None);

            if settings.colouring != Colouring::Solid {
                // A bar 2% wide, the middle 60% of the height, at the right edge.
                let bar_w = (w / 50).max(6);
                let bar_h = h * 3 / 5;
                gl.disable(glow::DEPTH_TEST);
                gl.viewport(x0 + w - 2 * bar_w, y0 + (h - bar_h) / 2, bar_w, bar_h);
                gl.use_program(Some(self.programs.bar));
                gl.bind_vertex_array(Some(self.bar_vao));
                gl.draw_arrays(glow::TRIANGLE_STRIP, 0, 4);
                gl.bind_vertex_array(None);
                gl.viewport(x0, y0, w, h);
            }
            gl.use_program(None);
            gl.disable(glow::PROGRAM_POINT_SIZE);
        }
    }

    unsafe fn draw_box(&self, view_proj: &Mat4, (lo, hi): (Vec3, Vec3)) {
        let gl = &self.gl;
        let corner = |i: usize| {
            Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        };
        // The 12 edges join corners that differ in one bit.
        let mut lines = Vec::with_capacity(24);
        for a in 0..8usize {
            for bit in [1, 2, 4] {
                if a & bit == 0 {
                    lines.push(corner(a).to_array());
                    lines.push(corner(a | bit).to_array());
                }
            }
        }
        unsafe {
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.box_vbo));
            gl.buffer_sub_data_u8_slice(glow::ARRAY_BUFFER, 0, bytemuck::cast_slice(&lines));
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
            gl.use_program(Some(self.programs.lines));
            set_mat4(gl, self.programs.lines, "u_view_proj", view_proj);
            let loc = gl.get_uniform_location(self.programs.lines, "u_colour");
            gl.uniform_3_f32(loc.as_ref(), 0.6, 0.62, 0.68);
            gl.bind_vertex_array(Some(self.box_vao));
            gl.draw_arrays(glow::LINES, 0, lines.len() as i32);
            gl.bind_vertex_array(None);
        }
    }

    /// Deletes the GL objects (the context must be current). Drop any CUDA registration first.
    pub fn destroy(&mut self) {
        // SAFETY: our objects, deleted once (the renderer is not used afterwards).
        unsafe {
            let gl = &self.gl;
            for program in [
                self.programs.points,
                self.programs.spheres,
                self.programs.lines,
                self.programs.bar,
            ] {
                gl.delete_program(program);
            }
            gl.delete_vertex_array(self.particle_vao);
            gl.delete_vertex_array(self.box_vao);
            gl.delete_vertex_array(self.bar_vao);
            gl.delete_buffer(self.particle_vbo);
            gl.delete_buffer(self.box_vbo);
        }
    }
}

pub(super) fn gl_error(what: &'static str) -> impl Fn(String) -> anyhow::Error {
    move |e| anyhow!("OpenGL could not create {what}: {e}")
}

pub(super) unsafe fn set_mat4(gl: &glow::Context, program: glow::Program, name: &str, m: &Mat4) {
    unsafe {
        let loc = gl.get_uniform_location(program, name);
        gl.uniform_matrix_4_f32_slice(loc.as_ref(), false, &m.to_cols_array());
    }
}

unsafe fn set_f32(gl: &glow::Context, program: glow::Program, name: &str, value: f32) {
    unsafe {
        let loc = gl.get_uniform_location(program, name);
        gl.uniform_1_f32(loc.as_ref(), value);
    }
}

unsafe fn set_i32(gl: &glow::Context, program: glow::Program, name: &str, value: i32) {
    unsafe {
        let loc = gl.get_uniform_location(program, name);
        gl.uniform_1_i32(loc.as_ref(), value);
    }
}

/// Compiles and links one program; `prelude` (shared GLSL functions) follows the version line.
pub(super) unsafe fn link(
    gl: &glow::Context,
    name: &str,
    vertex: &[&str],
    fragment: &[&str],
    prelude: &str,
) -> Result<glow::Program> {
    unsafe {
        let program = gl.create_program().map_err(gl_error("a program"))?;
        let mut shaders = Vec::new();
        for (kind, parts, stage) in [
            (glow::VERTEX_SHADER, vertex, "vertex"),
            (glow::FRAGMENT_SHADER, fragment, "fragment"),
        ] {
            let shader = gl.create_shader(kind).map_err(gl_error("a shader"))?;
            let source = format!("{GLSL_HEADER}{prelude}{}", parts.concat());
            gl.shader_source(shader, &source);
            gl.compile_shader(shader);
            if !gl.get_shader_compile_status(shader) {
                let log = gl.get_shader_info_log(shader);
                return Err(anyhow!("the {name} {stage} shader does not compile:\n{log}"));
            }
            gl.attach_shader(program, shader);
            shaders.push(shader);
        }
        gl.link_program(program);
        for shader in shaders {
            gl.detach_shader(program, shader);
            gl.delete_shader(shader);
        }
        if !gl.get_program_link_status(program) {
            return Err(anyhow!(
                "the {name} program does not link:\n{}",
                gl.get_program_info_log(program)
            ));
        }
        Ok(program)
    }
}
