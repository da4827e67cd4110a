//! The particle renderer, shared by the window and the headless path: the fluid as a screen-space
//! water surface (the default; [`super::surface`]), as flat points (the report's minimal mode) or as
//! lit sphere impostors with true depth; the domain box as a wireframe (and, under the water, a tiled
//! floor); the colour scale as a bar with its numbers at the right edge ([`super::legend`]). A solid
//! material's particles are no part of the surface: it draws them as lit spheres of their colour into
//! the scene the liquid refracts. It draws into whatever framebuffer is bound, and times each pass
//! on the GPU ([`super::timer`]).

use super::camera::OrbitCamera;
use super::colliders::ColliderRenderer;
use super::flow::{outline, OUTLINE_COLOUR};
use super::legend::{Legend, Scale};
use super::program::{gl_error, link, set_f32, set_i32, set_mat4};
use super::surface::{Surface, SurfaceFrame, SurfaceSettings, Tint};
use super::timer::{GpuTimer, Pass, PassTimes};
use crate::sim::colliders::{ColliderFrame, Colliders};
use crate::sim::flow::Flow;
use crate::sim::ColourBy;
use anyhow::{anyhow, Result};
use glam::{Mat4, Vec3};
use glow::HasContext;
use std::sync::Arc;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum DrawMode {
    /// Square points of a fixed pixel size, no lighting: every particle, cheapest.
    Points,
    /// Lit spheres of the particle radius, with correct depth: the particles as they are.
    Spheres,
    /// The water's surface, rebuilt on screen from the particles: refracting, reflecting, absorbing.
    #[default]
    Surface,
}

impl DrawMode {
    /// The next mode for the M key.
    pub fn next(self) -> DrawMode {
        match self {
            DrawMode::Points => DrawMode::Spheres,
            DrawMode::Spheres => DrawMode::Surface,
            DrawMode::Surface => DrawMode::Points,
        }
    }
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
    /// Each particle in its material's colour (the scene's `colour`); the default in a scene of
    /// several materials.
    Material,
}

impl Colouring {
    /// The quantity the render kernel writes (solid colouring ignores it).
    pub fn quantity(self) -> ColourBy {
        match self {
            Colouring::Density => ColourBy::Density,
            Colouring::Material => ColourBy::Material,
            Colouring::Solid | Colouring::Speed => ColourBy::Speed,
        }
    }

    /// The unit of the quantity, for the legend.
    pub fn unit(self) -> &'static str {
        match self {
            Colouring::Density => "ρ/ρ0",
            Colouring::Material => "",
            Colouring::Solid | Colouring::Speed => "m/s",
        }
    }

    /// The colouring `scene` starts with where none is asked for: by material where it has several,
    /// else by speed.
    pub fn default_for(scene: &crate::sim::Scene) -> Colouring {
        if scene.materials.len() > 1 {
            Colouring::Material
        } else {
            Colouring::Speed
        }
    }

    /// The next colouring for the C key: solid, speed, density, material, solid, ...
    pub fn next(self) -> Colouring {
        match self {
            Colouring::Solid => Colouring::Speed,
            Colouring::Speed => Colouring::Density,
            Colouring::Density => Colouring::Material,
            Colouring::Material => Colouring::Solid,
        }
    }
}

/// The material table's colours as the shaders take them: a row per material (linear RGB), unused
/// rows black.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaterialColours {
    pub colours: [[f32; 3]; crate::contract::MAX_MATERIALS as usize],
    /// The surface's absorption per row, a multiple of what the colour gives (`NamedMaterial::absorption`).
    pub absorptions: [f32; crate::contract::MAX_MATERIALS as usize],
    /// Rows in use (at least 1).
    pub count: u32,
    /// Bit `row` set where that row is a solid's: the surface draws those particles as lit spheres
    /// of their colour, in no liquid's surface. 0 in a scene of liquids alone.
    pub solid_rows: u32,
}

impl MaterialColours {
    pub fn of(materials: &[crate::sim::material::NamedMaterial]) -> MaterialColours {
        let mut colours = [[0.0; 3]; crate::contract::MAX_MATERIALS as usize];
        let mut absorptions = [1.0; crate::contract::MAX_MATERIALS as usize];
        let mut solid_rows = 0;
        for (row, m) in materials.iter().enumerate().take(colours.len()) {
            colours[row] = m.colour;
            absorptions[row] = m.absorption;
            if m.law.is_solid() {
                solid_rows |= 1 << row;
            }
        }
        MaterialColours {
            colours,
            absorptions,
            count: (materials.len() as u32).clamp(1, crate::contract::MAX_MATERIALS),
            solid_rows,
        }
    }

    /// Whether every row is a solid's: the surface then shows no liquid for a scale to tint.
    pub fn all_solid(&self) -> bool {
        self.solid_rows != 0 && self.solid_rows.count_ones() >= self.count
    }

    /// Sets `u_material_colours`, `u_material_absorptions` and `u_material_count` of `program` (the
    /// prelude's `material_colour` and `material_absorption`).
    ///
    /// # Safety
    /// `gl` is current on this thread and `program` is its own, in use.
    pub unsafe fn set(&self, gl: &glow::Context, program: glow::Program) {
        let flat: Vec<f32> = self.colours.iter().flatten().copied().collect();
        // SAFETY: as the caller vouches.
        unsafe {
            let loc = gl.get_uniform_location(program, "u_material_colours");
            gl.uniform_3_f32_slice(loc.as_ref(), &flat);
            let loc = gl.get_uniform_location(program, "u_material_absorptions");
            gl.uniform_1_f32_slice(loc.as_ref(), &self.absorptions);
            set_i32(gl, program, "u_material_count", self.count as i32);
        }
    }
}

impl Default for MaterialColours {
    /// One material, water's default colour.
    fn default() -> MaterialColours {
        let mut colours = [[0.0; 3]; crate::contract::MAX_MATERIALS as usize];
        colours[0] = crate::sim::material::default_colour(0);
        MaterialColours {
            colours,
            absorptions: [1.0; crate::contract::MAX_MATERIALS as usize],
            count: 1,
            solid_rows: 0,
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
    /// The surface mode's spheres, filter and water.
    pub surface: SurfaceSettings,
    /// The distance between neighbouring particles at rest, m (the scene's dx over the particles per
    /// axis of a cell): each particle stands for spacing^3 of water.
    pub spacing: f32,
    /// Values mapped to the two ends of the colour scale.
    pub scale_range: [f32; 2],
    pub show_box: bool,
    /// The scene's materials' colours, for colouring by material.
    pub materials: MaterialColours,
}

impl RenderSettings {
    /// Defaults for particles `particle_spacing` apart: spheres about the spacing of the particles.
    pub fn for_spacing(particle_spacing: f32) -> RenderSettings {
        RenderSettings {
            mode: DrawMode::default(),
            colouring: Colouring::Speed,
            point_size: 2.0,
            sphere_radius: 0.6 * particle_spacing,
            surface: SurfaceSettings::for_spacing(particle_spacing),
            spacing: particle_spacing,
            scale_range: [0.0, 3.0],
            show_box: true,
            materials: MaterialColours::default(),
        }
    }

    /// The settings `mpm view` and `mpm render` start `scene` with. `particle_radius` (the
    /// `--particle-radius` flag) replaces the radius derived from the scene, for spheres and surface;
    /// it must be positive and smaller than the domain.
    pub fn for_scene(
        scene: &crate::sim::Scene,
        mode: DrawMode,
        colouring: Colouring,
        particle_radius: Option<f32>,
    ) -> Result<RenderSettings> {
        let mut settings = RenderSettings::for_spacing(scene.lattice().spacing as f32);
        settings.mode = mode;
        settings.colouring = colouring;
        settings.scale_range = RenderSettings::default_range(colouring);
        settings.materials = MaterialColours::of(&scene.materials);
        if let Some(radius) = particle_radius {
            let (lo, hi) = scene.fluid_region();
            let extent = (hi - lo).max_element() as f32;
            anyhow::ensure!(
                radius.is_finite() && radius > 0.0 && radius < extent,
                "--particle-radius {radius}: give a radius in metres above 0 and below the domain's \
                 {extent} m (the scene's particle spacing is {:.4} m)",
                settings.spacing
            );
            settings.sphere_radius = radius;
            settings.surface.radius = radius;
        }
        Ok(settings)
    }

    /// What the colour bar shows, if anything: the scale of the colouring, or for the surface coloured
    /// by speed, water turning to whitewater. Solid and material colouring have no scale (the
    /// panel lists the materials' colours), nor has the surface of a scene of solids alone (they
    /// keep their own colours).
    pub fn legend(&self) -> Option<Scale> {
        let whitewater = match (self.mode, self.colouring) {
            (_, Colouring::Solid | Colouring::Material) => return None,
            (DrawMode::Surface, _) if self.materials.all_solid() => return None,
            (DrawMode::Surface, Colouring::Speed) => true,
            _ => false,
        };
        Some(Scale {
            whitewater,
            range: self.scale_range,
            unit: self.colouring.unit(),
        })
    }

    /// The camera that frames the box [lo, hi] in `viewport`, keeping the water clear of the colour
    /// bar when there is one.
    pub fn framing(&self, lo: Vec3, hi: Vec3, viewport: Viewport) -> OrbitCamera {
        let clear = match self.legend() {
            Some(_) => super::legend::clearance(viewport),
            None => 0.0,
        };
        let size = glam::Vec2::new(viewport.width as f32, viewport.height as f32);
        OrbitCamera::framing(lo, hi, size, clear)
    }

    /// A sensible scale for the colouring: 0..3 m/s for speed, 0.9..1.1 for density (material
    /// colouring has none; it keeps speed's).
    pub fn default_range(colouring: Colouring) -> [f32; 2] {
        match colouring {
            Colouring::Density => [0.9, 1.1],
            Colouring::Solid | Colouring::Speed | Colouring::Material => [0.0, 3.0],
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

/// The material table's colours and their lookup, shared by the particles' and the surface's shaders:
/// `material_colour(row)` for a particle's row, or for a row averaged through the water (the surface),
/// blended between the two rows it lies between; `material_absorption(row)`, the surface's light
/// absorbed per metre of the liquid of `row`, from its colour (what the colour lacks goes first, at
/// most about water's red per metre) times its own factor.
const GLSL_MATERIALS: &str = "
uniform vec3 u_material_colours[8];
uniform float u_material_absorptions[8];
uniform int u_material_count;
// The row's own factor (`absorption` in the scene), which also scales how fast its colour
// replaces what is behind it.
float material_absorption_factor(int row) {
    return u_material_absorptions[clamp(row, 0, max(u_material_count - 1, 0))];
}
vec3 material_absorption(int row) {
    int r = clamp(row, 0, max(u_material_count - 1, 0));
    return material_absorption_factor(r) * (1.0 + 6.0 * (1.0 - u_material_colours[r]));
}
vec3 material_colour(float row) {
    float r = clamp(row, 0.0, float(max(u_material_count - 1, 0)));
    int i = int(floor(r));
    int j = min(i + 1, max(u_material_count - 1, 0));
    return mix(u_material_colours[i], u_material_colours[j], r - float(i));
}
";

const PARTICLE_VS: &str = r#"
layout(location = 0) in vec4 a_particle; // xyz position, w the colour quantity
#ifdef SOLIDS_ONLY
// The surface's solids: whatever the colouring, each solid particle in its material's colour, found
// by its row in the buffer's rows section (Renderer::ensure_layout); the liquids' are clipped.
layout(location = 1) in float a_row;
uniform int u_solid_rows;
#endif
uniform mat4 u_view;
uniform mat4 u_proj;
uniform int u_spheres;
uniform float u_point_size;
uniform float u_radius;
uniform float u_pixels_per_metre_at_unit_depth;
uniform int u_solid;
uniform int u_by_material;
uniform vec3 u_solid_colour;
uniform vec2 u_range;
out vec3 v_colour;
out vec3 v_centre;
void main() {
    vec4 view = u_view * vec4(a_particle.xyz, 1.0);
    gl_Position = u_proj * view;
    // A parked particle slot (sim::flow) arrives as NaN: put it behind the far plane, where it is clipped.
    if (isnan(a_particle.x)) gl_Position = vec4(0.0, 0.0, 2.0, 1.0);
    v_centre = view.xyz;
    if (u_spheres == 1) {
        gl_PointSize = max(2.0 * u_radius * u_pixels_per_metre_at_unit_depth / max(-view.z, 1e-4), 1.0);
    } else {
        gl_PointSize = u_point_size;
    }
#ifdef SOLIDS_ONLY
    int row = clamp(int(a_row + 0.5), 0, 31);
    if (isnan(a_particle.x) || ((u_solid_rows >> row) & 1) == 0) gl_Position = vec4(0.0, 0.0, 2.0, 1.0);
    v_colour = material_colour(float(row));
#else
    float t = (a_particle.w - u_range.x) / max(u_range.y - u_range.x, 1e-6);
    v_colour = u_solid == 1 ? u_solid_colour
             : u_by_material == 1 ? material_colour(a_particle.w) : scale_colour(t);
#endif
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

// The tank's floor under the water (surface mode): tiles, so refraction has something to bend.
const FLOOR_VS: &str = r#"
layout(location = 0) in vec3 a_position;
uniform mat4 u_view_proj;
out vec3 v_world;
void main() {
    v_world = a_position;
    gl_Position = u_view_proj * vec4(a_position, 1.0);
}
"#;

const FLOOR_FS: &str = r#"
in vec3 v_world;
uniform float u_tile;
out vec4 o_colour;
void main() {
    ivec2 cell = ivec2(floor(v_world.xz / u_tile));
    float odd = float((cell.x + cell.y) & 1);
    o_colour = vec4(mix(vec3(0.22, 0.23, 0.25), vec3(0.34, 0.35, 0.38), odd), 1.0);
}
"#;

struct Programs {
    points: glow::Program,
    spheres: glow::Program,
    /// The surface's solids as spheres ([`PARTICLE_VS`] with `SOLIDS_ONLY`).
    solids: glow::Program,
    lines: glow::Program,
    floor: glow::Program,
}

/// The box's 12 edges as 24 line vertices, then the floor as 2 triangles.
const BOX_VERTICES: usize = 24;
const FLOOR_VERTICES: usize = 6;

pub struct Renderer {
    gl: Arc<glow::Context>,
    programs: Programs,
    particle_vao: glow::VertexArray,
    particle_vbo: glow::Buffer,
    /// Particles the VBO has room for.
    capacity: usize,
    /// Whether the VBO holds, after the particles' float4s, as many again whose w is each slot's
    /// material row: the surface needs the row, whatever the colouring, to leave the solids out of
    /// the liquid and draw them itself. Fed only for scenes with solids.
    material_rows: bool,
    stage_vao: glow::VertexArray,
    stage_vbo: glow::Buffer,
    surface: Surface,
    legend: Legend,
    timer: GpuTimer,
    /// The scene's colliders, drawn solid into the scene pass (so the water refracts them and they
    /// hide the water behind them), in the pose last set.
    colliders: Option<ColliderRenderer>,
    collider_frame: ColliderFrame,
    /// The scene's emitters and sinks outlined ([`super::flow`]): line vertices, set per scene.
    flow_vao: glow::VertexArray,
    flow_vbo: glow::Buffer,
    flow_vertices: i32,
    /// Whether the last frame was drawn as a surface (and so wants the particles for CUDA's
    /// thickness splats); true before the first, as the copy costs little.
    surface_last: bool,
}

impl Renderer {
    pub fn new(gl: Arc<glow::Context>) -> Result<Renderer> {
        // SAFETY: the caller's GL context is current on this thread; every object is created here.
        unsafe {
            let prelude = format!(
                "{}{GLSL_MATERIALS}{}",
                glsl_scale(),
                super::surface::glsl_constants()
            );
            let programs = Programs {
                points: link(&gl, "points", &[PARTICLE_VS], &[POINTS_FS], &prelude)?,
                spheres: link(&gl, "spheres", &[PARTICLE_VS], &[SPHERES_FS], &prelude)?,
                solids: link(
                    &gl,
                    "solids",
                    &[PARTICLE_VS],
                    &[SPHERES_FS],
                    &format!("#define SOLIDS_ONLY\n{prelude}"),
                )?,
                lines: link(&gl, "lines", &[LINES_VS], &[LINES_FS], "")?,
                floor: link(&gl, "floor", &[FLOOR_VS], &[FLOOR_FS], "")?,
            };
            let particle_vao = gl.create_vertex_array().map_err(gl_error("a vertex array"))?;
            let particle_vbo = gl.create_buffer().map_err(gl_error("a buffer"))?;
            gl.bind_vertex_array(Some(particle_vao));
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(particle_vbo));
            // Give the buffer storage now: CUDA can only register a buffer that has some.
            gl.buffer_data_size(glow::ARRAY_BUFFER, 16, glow::DYNAMIC_DRAW);
            gl.enable_vertex_attrib_array(0);
            gl.vertex_attrib_pointer_f32(0, 4, glow::FLOAT, false, 16, 0);

            let stage_vao = gl.create_vertex_array().map_err(gl_error("a vertex array"))?;
            let stage_vbo = gl.create_buffer().map_err(gl_error("a buffer"))?;
            gl.bind_vertex_array(Some(stage_vao));
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(stage_vbo));
            gl.buffer_data_size(
                glow::ARRAY_BUFFER,
                ((BOX_VERTICES + FLOOR_VERTICES) * 12) as i32,
                glow::DYNAMIC_DRAW,
            );
            gl.enable_vertex_attrib_array(0);
            gl.vertex_attrib_pointer_f32(0, 3, glow::FLOAT, false, 12, 0);

            let flow_vao = gl.create_vertex_array().map_err(gl_error("a vertex array"))?;
            let flow_vbo = gl.create_buffer().map_err(gl_error("a buffer"))?;
            gl.bind_vertex_array(Some(flow_vao));
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(flow_vbo));
            gl.enable_vertex_attrib_array(0);
            gl.vertex_attrib_pointer_f32(0, 3, glow::FLOAT, false, 12, 0);
            gl.bind_vertex_array(None);
            gl.bind_buffer(glow::ARRAY_BUFFER, None);

            let surface = Surface::new(gl.clone(), &prelude)?;
            let legend = Legend::new(gl.clone(), &prelude)?;
            let timer = GpuTimer::new(gl.clone())
                .map_err(|e| anyhow!("OpenGL could not create a timer query: {e}"))?;
            Ok(Renderer {
                gl,
                programs,
                particle_vao,
                particle_vbo,
                capacity: 1,
                material_rows: false,
                stage_vao,
                stage_vbo,
                surface,
                legend,
                timer,
                colliders: None,
                collider_frame: ColliderFrame::default(),
                flow_vao,
                flow_vbo,
                flow_vertices: 0,
                surface_last: true,
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

    /// Makes the particle buffer hold `particles` float4s, keeping its material rows section if it
    /// has one ([`ensure_layout`](Self::ensure_layout)). Returns true when it was reallocated: a
    /// CUDA registration of the old storage must then be dropped (before this call) and redone.
    pub fn ensure_capacity(&mut self, particles: usize) -> bool {
        self.ensure_layout(particles, self.material_rows)
    }

    /// Makes the particle buffer hold `particles` float4s and, where `material_rows`, as many again
    /// after them, at byte [`material_rows_offset`](Self::material_rows_offset): each slot's
    /// `ColourBy::Material` attributes, whose w the surface reads as the slot's row. Returns true
    /// when it was reallocated, as [`ensure_capacity`](Self::ensure_capacity).
    pub fn ensure_layout(&mut self, particles: usize, material_rows: bool) -> bool {
        if (particles, material_rows) == (self.capacity, self.material_rows) {
            return false;
        }
        let sections = if material_rows { 2 } else { 1 };
        // SAFETY: our buffer and vertex array, our context (current).
        unsafe {
            let gl = &self.gl;
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.particle_vbo));
            gl.buffer_data_size(
                glow::ARRAY_BUFFER,
                (16 * sections * particles.max(1)) as i32,
                glow::DYNAMIC_DRAW,
            );
            gl.bind_vertex_array(Some(self.particle_vao));
            if material_rows {
                // Only the rows' w: the row, as a float.
                gl.vertex_attrib_pointer_f32(1, 1, glow::FLOAT, false, 16, (16 * particles + 12) as i32);
                gl.enable_vertex_attrib_array(1);
            } else {
                gl.disable_vertex_attrib_array(1);
            }
            gl.bind_vertex_array(None);
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
        }
        self.capacity = particles;
        self.material_rows = material_rows;
        true
    }

    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Whether the particle buffer has a material rows section ([`ensure_layout`](Self::ensure_layout)).
    pub fn holds_material_rows(&self) -> bool {
        self.material_rows
    }

    /// Where the material rows section starts in the particle buffer, bytes.
    pub fn material_rows_offset(&self) -> usize {
        16 * self.capacity
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

    /// The slots' material rows (each slot's `ColourBy::Material` attributes, the buffer's
    /// `particles.len()` float4s of [`upload`](Self::upload)) into the rows section; nothing where the
    /// buffer has none or is not that size.
    pub fn upload_material_rows(&mut self, rows: &[[f32; 4]]) {
        debug_assert!(self.material_rows && rows.len() == self.capacity);
        if !self.material_rows || rows.len() != self.capacity {
            return;
        }
        // SAFETY: the buffer holds two sections of `capacity` float4 (checked above).
        unsafe {
            self.gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.particle_vbo));
            self.gl.buffer_sub_data_u8_slice(
                glow::ARRAY_BUFFER,
                self.material_rows_offset() as i32,
                bytemuck::cast_slice(rows),
            );
            self.gl.bind_buffer(glow::ARRAY_BUFFER, None);
        }
    }

    /// Reads the first `count` vertices of the particle buffer back through GL (tests: what CUDA
    /// wrote through interop, as GL sees it).
    pub fn read_particle_buffer(&self, count: usize) -> Vec<[f32; 4]> {
        self.read_particle_section(0, count)
    }

    /// Reads the first `count` float4s of the material rows section back through GL (tests); none
    /// where the buffer has no such section.
    pub fn read_material_rows(&self, count: usize) -> Vec<[f32; 4]> {
        if !self.material_rows {
            return Vec::new();
        }
        self.read_particle_section(self.material_rows_offset(), count)
    }

    fn read_particle_section(&self, offset: usize, count: usize) -> Vec<[f32; 4]> {
        let count = count.min(self.capacity);
        let mut bytes = vec![0u8; 16 * count];
        // SAFETY: the section at `offset` holds `capacity` >= count float4.
        unsafe {
            self.gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.particle_vbo));
            self.gl
                .get_buffer_sub_data(glow::ARRAY_BUFFER, offset as i32, &mut bytes);
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

    /// The particles the feed just wrote through interop (`count` float4 at `particles`, in `ctx`, by
    /// the work queued on `stream`), for the surface's thickness splats by CUDA: the next frame's
    /// thickness is summed by CUDA from them where it is drawn as a surface, else GL splats it.
    ///
    /// # Safety
    /// `particles` must be a device allocation of `ctx` holding `count` float4, live until the work
    /// queued on `stream` so far is done.
    pub unsafe fn take_cuda_particles(
        &mut self,
        ctx: &Arc<cudarc::driver::CudaContext>,
        particles: cudarc::driver::sys::CUdeviceptr,
        count: usize,
        stream: &Arc<cudarc::driver::CudaStream>,
    ) {
        if self.surface_last {
            // SAFETY: the caller vouches for `particles`.
            unsafe { self.surface.take_cuda_particles(ctx, particles, count, stream) };
        }
    }

    /// The last surface frame's thickness texture (tests; see [`Surface::read_thickness`]).
    pub fn read_thickness(&self) -> Option<([u32; 2], Vec<[f32; 2]>)> {
        self.surface.read_thickness()
    }

    /// Whether CUDA summed the last surface frame's thickness (else GL blended it).
    pub fn thickness_by_cuda(&self) -> bool {
        self.surface.thickness_by_cuda()
    }

    /// GPU milliseconds per pass of the newest frame whose timer queries have arrived (a few frames
    /// old: reading them never waits for the GPU).
    pub fn pass_times(&self) -> Option<PassTimes> {
        self.timer.latest()
    }

    /// The timer itself: `mpm render` reads it after glFinish and averages over its frames.
    pub fn timer_mut(&mut self) -> &mut GpuTimer {
        &mut self.timer
    }

    /// Draws the particles of the buffer's first `slots` slots (a parked slot is clipped), the box
    /// [lo, hi] and the colour bar into `viewport` of the bound framebuffer, replacing what was there
    /// (the window leaves room for the panel; headless uses all of it). Fails only where the
    /// surface's float render targets cannot be made.
    pub fn draw(
        &mut self,
        viewport: Viewport,
        camera: &OrbitCamera,
        settings: &RenderSettings,
        slots: usize,
        domain: (Vec3, Vec3),
    ) -> Result<()> {
        let count = slots.min(self.capacity);
        // SAFETY: a query of the current context.
        let target = unsafe { self.gl.get_parameter_framebuffer(glow::DRAW_FRAMEBUFFER_BINDING) };
        self.timer.begin_frame();
        self.surface_last = settings.mode == DrawMode::Surface;
        let drawn = match settings.mode {
            DrawMode::Surface => self.draw_surface(target, viewport, camera, settings, count, domain),
            DrawMode::Points | DrawMode::Spheres => {
                self.draw_particles(viewport, camera, settings, count, domain);
                Ok(())
            }
        };
        let legend = match (&drawn, settings.legend()) {
            (Ok(()), Some(scale)) => {
                self.timer.begin(Pass::Legend);
                self.legend.draw(viewport, &scale)
            }
            _ => Ok(()),
        };
        self.timer.end_frame();
        drawn.and(legend)
    }

    fn draw_particles(
        &mut self,
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
        self.timer.begin(Pass::Scene);
        // SAFETY: every object used is this renderer's; the context is current.
        unsafe {
            gl.viewport(x0, y0, w, h);
            self.clear_scene();

            if settings.show_box {
                self.draw_stage(&(proj * view), domain, false, true);
            }
            self.draw_scene_objects(&(proj * view), domain);
        }
        self.timer.begin(Pass::Particles);
        // SAFETY: as above.
        unsafe {
            let program = match settings.mode {
                DrawMode::Points => self.programs.points,
                _ => self.programs.spheres,
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
            set_f32(
                gl,
                program,
                "u_pixels_per_metre_at_unit_depth",
                pixels_per_metre(&proj, h),
            );
            set_i32(
                gl,
                program,
                "u_solid",
                i32::from(settings.colouring == Colouring::Solid),
            );
            set_i32(
                gl,
                program,
                "u_by_material",
                i32::from(settings.colouring == Colouring::Material),
            );
            settings.materials.set(gl, program);
            let loc = gl.get_uniform_location(program, "u_solid_colour");
            gl.uniform_3_f32(loc.as_ref(), SOLID_COLOUR[0], SOLID_COLOUR[1], SOLID_COLOUR[2]);
            let loc = gl.get_uniform_location(program, "u_range");
            gl.uniform_2_f32(loc.as_ref(), settings.scale_range[0], settings.scale_range[1]);
            gl.bind_vertex_array(Some(self.particle_vao));
            gl.draw_arrays(glow::POINTS, 0, count as i32);
            gl.bind_vertex_array(None);
            gl.use_program(None);
            gl.disable(glow::PROGRAM_POINT_SIZE);
        }
        self.timer.end();
    }

    fn draw_surface(
        &mut self,
        target: Option<glow::Framebuffer>,
        viewport: Viewport,
        camera: &OrbitCamera,
        settings: &RenderSettings,
        count: usize,
        domain: (Vec3, Vec3),
    ) -> Result<()> {
        let (w, h) = (viewport.width.max(1), viewport.height.max(1));
        let view = camera.view();
        let proj = camera.projection(w as f32 / h as f32);
        let bound = self
            .surface
            .bind_scene([w, h], settings.surface.thickness_downsample);
        if bound.is_err() {
            // SAFETY: the caller's framebuffer, bound back.
            unsafe { self.gl.bind_framebuffer(glow::FRAMEBUFFER, target) };
            return bound;
        }
        let tint = match settings.colouring {
            Colouring::Solid => Tint::Clear,
            Colouring::Speed => Tint::Whitewater,
            Colouring::Density => Tint::Scale,
            Colouring::Material => Tint::Material,
        };
        let frame = SurfaceFrame {
            view,
            proj,
            pixels_per_metre: pixels_per_metre(&proj, h as i32),
            particles: self.particle_vao,
            count,
            particle_volume: settings.spacing.powi(3),
            settings: &settings.surface,
            tint,
            range: settings.scale_range,
            materials: settings.materials,
            solid_rows: self.solid_rows(settings),
        };
        self.surface.splat_thickness_by_cuda(&frame, &mut self.timer);
        self.timer.begin(Pass::Scene);
        self.surface.rebind_scene();
        // SAFETY: the surface's scene framebuffer is bound; every object is ours.
        unsafe {
            self.clear_scene();
            // The floor stays without the box: the water refracts it.
            self.draw_stage(&(proj * view), domain, true, settings.show_box);
            self.draw_scene_objects(&(proj * view), domain);
            if frame.solid_rows != 0 {
                self.timer.begin(Pass::Solids);
                self.draw_solids(&frame, settings, h as i32);
            }
        }
        self.surface.draw(
            &frame,
            &mut self.timer,
            target,
            [viewport.x, viewport.y, w as i32, h as i32],
        )
    }

    /// The material rows the surface draws as solids: the scene's solids', where the particle buffer
    /// holds the slots' rows (the feed gives them for a scene with solids); else none.
    fn solid_rows(&self, settings: &RenderSettings) -> u32 {
        if self.material_rows {
            settings.materials.solid_rows
        } else {
            0
        }
    }

    /// The solids' particles as lit spheres of their materials' colours into the surface's scene
    /// (bound, `height` pixels high), which the liquid then refracts and covers where it lies in front,
    /// as it does the colliders. The surface's particle radius: at its default, 0.75 of the spacing,
    /// the spheres of a lattice face overlap even seen head-on (that takes 1/sqrt(2)), so a solid
    /// body shows no gaps, and it is the radius the panel offers in this mode.
    unsafe fn draw_solids(&self, frame: &SurfaceFrame, settings: &RenderSettings, height: i32) {
        let gl = &self.gl;
        let p = self.programs.solids;
        // SAFETY: as the caller vouches: the scene pass is bound, every object is ours.
        unsafe {
            gl.use_program(Some(p));
            gl.enable(glow::PROGRAM_POINT_SIZE);
            set_mat4(gl, p, "u_view", &frame.view);
            set_mat4(gl, p, "u_proj", &frame.proj);
            set_i32(gl, p, "u_spheres", 1);
            set_f32(gl, p, "u_radius", settings.surface.radius);
            set_f32(
                gl,
                p,
                "u_pixels_per_metre_at_unit_depth",
                pixels_per_metre(&frame.proj, height),
            );
            settings.materials.set(gl, p);
            set_i32(gl, p, "u_solid_rows", frame.solid_rows as i32);
            gl.bind_vertex_array(Some(self.particle_vao));
            gl.draw_arrays(glow::POINTS, 0, frame.count as i32);
            gl.bind_vertex_array(None);
            gl.use_program(None);
            gl.disable(glow::PROGRAM_POINT_SIZE);
        }
    }

    /// The tiled floor at the box's bottom and the box's edges, each where asked.
    unsafe fn draw_stage(&self, view_proj: &Mat4, (lo, hi): (Vec3, Vec3), floor: bool, edges: bool) {
        let gl = &self.gl;
        let corner = |i: usize| {
            Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        };
        // The 12 edges join corners that differ in one bit; the floor is corners 0, 1, 4, 5.
        let mut vertices = Vec::with_capacity(BOX_VERTICES + FLOOR_VERTICES);
        for a in 0..8usize {
            for bit in [1, 2, 4] {
                if a & bit == 0 {
                    vertices.push(corner(a).to_array());
                    vertices.push(corner(a | bit).to_array());
                }
            }
        }
        for i in [0, 1, 5, 0, 5, 4] {
            vertices.push(corner(i).to_array());
        }
        unsafe {
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.stage_vbo));
            gl.buffer_sub_data_u8_slice(glow::ARRAY_BUFFER, 0, bytemuck::cast_slice(&vertices));
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
            gl.bind_vertex_array(Some(self.stage_vao));
            if floor {
                let p = self.programs.floor;
                gl.use_program(Some(p));
                set_mat4(gl, p, "u_view_proj", view_proj);
                // About 16 tiles along the longest side.
                set_f32(gl, p, "u_tile", (hi - lo).max_element() / 16.0);
                gl.draw_arrays(glow::TRIANGLES, BOX_VERTICES as i32, FLOOR_VERTICES as i32);
            }
            if edges {
                let p = self.programs.lines;
                gl.use_program(Some(p));
                set_mat4(gl, p, "u_view_proj", view_proj);
                let loc = gl.get_uniform_location(p, "u_colour");
                gl.uniform_3_f32(loc.as_ref(), 0.6, 0.62, 0.68);
                gl.draw_arrays(glow::LINES, 0, BOX_VERTICES as i32);
            }
            gl.bind_vertex_array(None);
            gl.use_program(None);
        }
    }

    /// Clears the bound framebuffer to the background and sets the scene pass's state (opaque,
    /// depth-tested), for every draw mode.
    unsafe fn clear_scene(&self) {
        let gl = &self.gl;
        // SAFETY: the caller's framebuffer is bound and the context current.
        unsafe {
            gl.clear_color(BACKGROUND[0], BACKGROUND[1], BACKGROUND[2], 1.0);
            gl.clear_depth_f32(1.0);
            gl.clear(glow::COLOR_BUFFER_BIT | glow::DEPTH_BUFFER_BIT);
            gl.enable(glow::DEPTH_TEST);
            gl.depth_func(glow::LESS);
            gl.disable(glow::BLEND);
            gl.disable(glow::CULL_FACE);
            gl.disable(glow::SCISSOR_TEST);
        }
    }

    /// What stands in the tank besides the fluid, drawn into the scene pass of every draw mode: the
    /// colliders (solid) and the emitters' and sinks' outlines.
    unsafe fn draw_scene_objects(&self, view_proj: &Mat4, domain: (Vec3, Vec3)) {
        if let Some(colliders) = &self.colliders {
            colliders.draw_in_pass(view_proj, &self.collider_frame, domain);
        }
        // SAFETY: the caller's pass is bound and the context current.
        unsafe { self.draw_flow(view_proj) };
    }

    /// The emitters' and sinks' outlines, depth-tested (a sink in the floor shows on it, not under).
    unsafe fn draw_flow(&self, view_proj: &Mat4) {
        if self.flow_vertices == 0 {
            return;
        }
        let gl = &self.gl;
        let p = self.programs.lines;
        unsafe {
            gl.depth_func(glow::LEQUAL);
            gl.use_program(Some(p));
            set_mat4(gl, p, "u_view_proj", view_proj);
            let loc = gl.get_uniform_location(p, "u_colour");
            let [r, g, b] = OUTLINE_COLOUR;
            gl.uniform_3_f32(loc.as_ref(), r, g, b);
            gl.bind_vertex_array(Some(self.flow_vao));
            gl.draw_arrays(glow::LINES, 0, self.flow_vertices);
            gl.bind_vertex_array(None);
            gl.use_program(None);
            gl.depth_func(glow::LESS);
        }
    }

    /// The emitters and sinks of a new scene, outlined in every draw mode; sinks are cut to the box
    /// `domain` (lo, hi) the draws show.
    pub fn set_flow(&mut self, flow: &Flow, domain: (Vec3, Vec3)) {
        let lines = outline(flow, domain);
        // SAFETY: our buffer, our context (current).
        unsafe {
            self.gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.flow_vbo));
            self.gl.buffer_data_u8_slice(
                glow::ARRAY_BUFFER,
                bytemuck::cast_slice(&lines),
                glow::STATIC_DRAW,
            );
            self.gl.bind_buffer(glow::ARRAY_BUFFER, None);
        }
        self.flow_vertices = 2 * lines.len() as i32;
    }

    /// The colliders of a new scene (their meshes are built once per scene).
    pub fn set_colliders(&mut self, colliders: &Colliders) -> Result<()> {
        if let Some(mut old) = self.colliders.take() {
            old.destroy();
        }
        self.colliders = (!colliders.is_empty())
            .then(|| ColliderRenderer::new(self.gl.clone(), colliders))
            .transpose()?;
        self.collider_frame = ColliderFrame::default();
        Ok(())
    }

    /// The colliders' pose the next draws show.
    pub fn set_collider_frame(&mut self, frame: ColliderFrame) {
        self.collider_frame = frame;
    }

    /// Deletes the GL objects (the context must be current). Drop any CUDA registration first.
    pub fn destroy(&mut self) {
        if let Some(mut colliders) = self.colliders.take() {
            colliders.destroy();
        }
        self.surface.destroy();
        self.legend.destroy();
        self.timer.destroy();
        // SAFETY: our objects, deleted once (the renderer is not used afterwards).
        unsafe {
            let gl = &self.gl;
            for program in [
                self.programs.points,
                self.programs.spheres,
                self.programs.solids,
                self.programs.lines,
                self.programs.floor,
            ] {
                gl.delete_program(program);
            }
            gl.delete_vertex_array(self.particle_vao);
            gl.delete_vertex_array(self.stage_vao);
            gl.delete_vertex_array(self.flow_vao);
            gl.delete_buffer(self.particle_vbo);
            gl.delete_buffer(self.stage_vbo);
            gl.delete_buffer(self.flow_vbo);
        }
    }
}

/// Pixels per metre at unit depth in a viewport `height` pixels high: proj[1][1] = 1 / tan(fov/2),
/// so it is height / 2 * proj[1][1].
fn pixels_per_metre(proj: &Mat4, height: i32) -> f32 {
    0.5 * height as f32 * proj.y_axis.y
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::Scene;

    #[test]
    fn particle_radius_follows_the_scene_or_the_flag() {
        let scene = Scene::load("dam-break").unwrap();
        let spacing = scene.lattice().spacing as f32;
        let derived = RenderSettings::for_scene(&scene, DrawMode::Surface, Colouring::Speed, None).unwrap();
        assert_eq!(derived.spacing, spacing);
        assert!(derived.surface.radius > 0.5 * spacing && derived.surface.radius < spacing);
        assert_eq!(derived.mode, DrawMode::Surface);
        let given =
            RenderSettings::for_scene(&scene, DrawMode::Spheres, Colouring::Speed, Some(0.004)).unwrap();
        assert_eq!((given.sphere_radius, given.surface.radius), (0.004, 0.004));
    }

    #[test]
    fn a_bad_particle_radius_is_refused_with_the_range() {
        let scene = Scene::load("dam-break").unwrap();
        for radius in [0.0, -0.01, f32::NAN, f32::INFINITY, 5.0] {
            let error = RenderSettings::for_scene(&scene, DrawMode::Surface, Colouring::Speed, Some(radius))
                .unwrap_err()
                .to_string();
            assert!(
                error.contains("--particle-radius") && error.contains("above 0 and below"),
                "{radius}: {error}"
            );
        }
    }

    #[test]
    fn m_cycles_through_every_mode() {
        let mut mode = DrawMode::default();
        assert_eq!(mode, DrawMode::Surface);
        let mut seen = Vec::new();
        for _ in 0..3 {
            mode = mode.next();
            seen.push(mode);
        }
        assert_eq!(seen, [DrawMode::Points, DrawMode::Spheres, DrawMode::Surface]);
    }

    #[test]
    fn the_legend_says_what_the_colour_means() {
        let mut settings = RenderSettings::for_spacing(0.005);
        settings.colouring = Colouring::Solid;
        assert_eq!(settings.legend(), None);
        settings.colouring = Colouring::Speed;
        assert_eq!(
            settings.legend().map(|s| (s.whitewater, s.unit)),
            Some((true, "m/s"))
        );
        settings.mode = DrawMode::Spheres;
        assert_eq!(
            settings.legend().map(|s| (s.whitewater, s.unit)),
            Some((false, "m/s"))
        );
        settings.colouring = Colouring::Density;
        assert_eq!(settings.legend().map(|s| s.unit), Some("ρ/ρ0"));
        settings.colouring = Colouring::Material;
        assert_eq!(settings.legend(), None, "the panel keys the materials; no scale");
    }

    #[test]
    fn the_solid_rows_are_marked_and_a_surface_of_solids_has_no_scale() {
        let jelly = Scene::load("jelly-drop").unwrap();
        let colours = MaterialColours::of(&jelly.materials);
        assert_eq!(colours.solid_rows, 0b110, "water, then two jellies");
        assert!(!colours.all_solid());
        assert_eq!(
            MaterialColours::of(&Scene::load("dam-break").unwrap().materials).solid_rows,
            0
        );
        let sand = Scene::load("sand-column").unwrap();
        let surface = RenderSettings::for_scene(&sand, DrawMode::Surface, Colouring::Speed, None).unwrap();
        assert!(surface.materials.all_solid());
        assert_eq!(surface.legend(), None, "no liquid to turn to whitewater");
        let spheres = RenderSettings::for_scene(&sand, DrawMode::Spheres, Colouring::Speed, None).unwrap();
        assert!(spheres.legend().is_some(), "spheres take the scale, solids too");
        let with_water =
            RenderSettings::for_scene(&jelly, DrawMode::Surface, Colouring::Speed, None).unwrap();
        assert!(with_water.legend().is_some_and(|scale| scale.whitewater));
    }

    #[test]
    fn several_materials_are_coloured_by_material_unless_asked_otherwise() {
        let one = Scene::load("drop").unwrap();
        assert_eq!(Colouring::default_for(&one), Colouring::Speed);
        let two = Scene::from_toml(
            "[domain]\nsize = [0.2, 0.2, 0.2]\nresolution = [20, 20, 20]\n\
             [[material]]\nname = \"water\"\nrest_density = 1000.0\nsound_speed = 20.0\n\
             [[material]]\nname = \"oil\"\nrest_density = 900.0\nsound_speed = 20.0\n\
             colour = [0.9, 0.6, 0.1]\n\
             [[block]]\nmin = [0.03, 0.03, 0.03]\nmax = [0.08, 0.08, 0.08]\nmaterial = \"oil\"\n",
            "two.toml",
        )
        .unwrap();
        assert_eq!(Colouring::default_for(&two), Colouring::Material);
        let settings = RenderSettings::for_scene(&two, DrawMode::Spheres, Colouring::Material, None).unwrap();
        assert_eq!(settings.materials.count, 2);
        assert_eq!(settings.materials.colours[1], [0.9, 0.6, 0.1]);
        assert_eq!(settings.materials.colours[0], two.materials[0].colour);
        // The C key reaches every colouring and comes back.
        let mut c = Colouring::Solid;
        let mut seen = Vec::new();
        for _ in 0..4 {
            c = c.next();
            seen.push(c);
        }
        assert_eq!(
            seen,
            [
                Colouring::Speed,
                Colouring::Density,
                Colouring::Material,
                Colouring::Solid
            ]
        );
    }
}
