//! The `surface` draw mode: screen-space fluid rendering. The particles are never shown as such; the
//! water's surface is rebuilt per pixel each frame from them:
//!
//! 1. **scene**: the floor, the domain box, the colliders and the solids' particles (as spheres)
//!    into a colour and a depth texture (what the water refracts), drawn by the renderer into
//!    [`Surface::bind_scene`]; the passes below leave the solids out ([`SurfaceFrame::solid_rows`]);
//! 2. **depth**: every particle as a sphere impostor; the nearest sphere's view distance per pixel;
//! 3. **thickness**: additive splats at a fraction of the resolution (a quarter per axis by
//!    default): how much water each pixel looks through, and the colour quantity averaged along the
//!    way. Where the particles come from CUDA through interop, CUDA sums the splats
//!    (src/cuda/thickness.rs) and GL fills the texture from a pixel buffer: the same texels for a
//!    fraction of the time GL's blending takes;
//! 4. **smoothing**: the narrow-range filter (`shaders/surface_smooth.frag` says why that filter)
//!    flattens the spheres into one surface, horizontally then vertically;
//! 5. **shading**: normals from the smoothed depth, Fresnel reflection of a sky, refraction of the
//!    scene absorbed by the thickness, a highlight, whitewater; into the caller's framebuffer.
//!
//! The textures follow the viewport's size: reallocated when it changes (a window resize), never per
//! frame. Nothing is read back to the CPU.

use super::program::{
    bind_texture, bind_texture_as, gl_error, link, set_f32, set_i32, set_mat3, set_mat4, set_sampling,
    set_vec2, set_vec3, FULLSCREEN_VS,
};
use super::timer::{GpuTimer, Pass};
use crate::contract::SplatCamera;
use crate::cuda::thickness::{CudaThickness, TEXEL_BYTES};
use anyhow::{bail, Result};
use cudarc::driver::{sys::CUdeviceptr, CudaContext, CudaStream};
use glam::{Mat3, Mat4, Vec3};
use glow::HasContext;
use std::sync::Arc;

/// The depth texture's value where there is no water (farther than anything drawn).
pub const EMPTY_DEPTH: f32 = 1.0e20;

/// Whitewater at the quantity's place `t` on the scale: none at the low end, little below the middle,
/// `FOAM_MAX` of the colour at the high end. The shaders run the same formula ([`glsl_constants`]).
pub fn foam_amount(t: f32) -> f32 {
    FOAM_MAX * t.clamp(0.0, 1.0).powi(3)
}

const FOAM_MAX: f32 = 0.75;

/// The GLSL constants and functions the surface's shaders share with the colour bar.
pub fn glsl_constants() -> String {
    format!(
        "const float EMPTY_DEPTH = {EMPTY_DEPTH:e};\n\
         const vec3 FOAM_COLOUR = vec3({:.3}, {:.3}, {:.3});\n\
         float foam_amount(float t) {{ t = clamp(t, 0.0, 1.0); return {FOAM_MAX:.3} * t * t * t; }}\n",
        FOAM_COLOUR[0], FOAM_COLOUR[1], FOAM_COLOUR[2]
    )
}

pub const FOAM_COLOUR: [f32; 3] = [0.92, 0.95, 1.0];
/// The colour water takes on as it absorbs what is behind it.
pub const WATER_COLOUR: [f32; 3] = [0.12, 0.42, 0.68];
/// Absorption per metre of water per channel at `absorption = 1` (red goes first, as in real water,
/// but far faster, so that a tank of tens of centimetres shows its depth).
const ABSORPTION: [f32; 3] = [6.0, 2.5, 1.5];
/// Per metre at `absorption = 1`: how fast the water's own colour (light scattered in it) replaces
/// the scene behind.
const SCATTERING: f32 = 2.5;
/// The direction towards the sun, world space (up and to the side of the default camera).
pub const SUN: [f32; 3] = [0.35, 0.85, 0.40];

/// What shapes the surface; the panel adjusts these.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceSettings {
    /// The spheres splatted per particle, m.
    pub radius: f32,
    /// The smoothing filter's radius, in particle radii (at the pixel's depth).
    pub smoothing: f32,
    /// Horizontal-then-vertical passes of the filter.
    pub iterations: u32,
    /// Multiplies the absorption per metre: more is deeper-looking water.
    pub absorption: f32,
    /// How far the scene behind is displaced by the surface's slope and the water's thickness.
    pub refraction: f32,
    /// Speed against quality: the filter's radius in pixels never exceeds this, whatever the zoom.
    pub max_filter_px: u32,
    /// Speed against quality: the thickness is splatted at 1/this of the resolution per axis.
    pub thickness_downsample: u32,
    /// Speed against quality: the smallest thickness splat's radius, in pixels of its texture (a
    /// smaller splat is cheaper but noisier; its mass is kept on average either way).
    pub thickness_min_splat_px: f32,
    /// Speed against quality: smooth the depth at half resolution (a quarter of the pixels, the
    /// filter half as wide in pixels) and bring it back with a depth-aware upsample; silhouettes
    /// stay at full resolution.
    pub half_res_smoothing: bool,
}

impl SurfaceSettings {
    /// For particles `spacing` apart: spheres a little larger than half the spacing, so neighbours
    /// overlap and the filter has a connected surface to smooth.
    pub fn for_spacing(spacing: f32) -> SurfaceSettings {
        SurfaceSettings {
            radius: 0.75 * spacing,
            smoothing: 5.0,
            iterations: 2,
            absorption: 1.0,
            refraction: 0.6,
            max_filter_px: 24,
            thickness_downsample: 4,
            thickness_min_splat_px: 1.0,
            half_res_smoothing: true,
        }
    }
}

/// How the colour quantity tints the water (the shading's `u_tint`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tint {
    /// Clear water (solid colouring).
    Clear = 0,
    /// Whitewater where the speed nears the top of the scale.
    Whitewater = 1,
    /// The water takes the colour scale's colour of the quantity (density).
    Scale = 2,
    /// The water takes its material's colour: the quantity is the material row, averaged through
    /// the water, so where two liquids lie along one view ray their colours blend by thickness.
    Material = 3,
}

/// What the passes need to know about the view and the particles.
pub struct SurfaceFrame<'a> {
    pub view: Mat4,
    pub proj: Mat4,
    /// Pixels per metre at unit depth at full resolution.
    pub pixels_per_metre: f32,
    pub particles: glow::VertexArray,
    pub count: usize,
    pub particle_volume: f32,
    pub settings: &'a SurfaceSettings,
    pub tint: Tint,
    /// The material table's colours ([`Tint::Material`]).
    pub materials: super::renderer::MaterialColours,
    pub range: [f32; 2],
    /// The material rows left out of every surface (bit `row`): the solids', which the renderer
    /// draws as spheres into the scene. Non-zero only where the particles' buffer holds their rows
    /// (`Renderer::ensure_layout`).
    pub solid_rows: u32,
}

impl SurfaceFrame<'_> {
    /// How many surfaces the frame draws, one per liquid, where it is coloured by material and
    /// the table has several liquids; 1 otherwise (the one surface of every liquid particle).
    pub fn liquid_surfaces(&self) -> u32 {
        if self.tint == Tint::Material {
            let solids = (0..self.materials.count)
                .filter(|&row| self.drawn_as_solid(row))
                .count();
            (self.materials.count - solids as u32).max(1)
        } else {
            1
        }
    }

    /// Whether material row `row` is left out of the surfaces ([`SurfaceFrame::solid_rows`]).
    pub fn drawn_as_solid(&self, row: u32) -> bool {
        self.solid_rows.checked_shr(row).is_some_and(|bits| bits & 1 != 0)
    }
}

struct Programs {
    depth: glow::Program,
    thickness: glow::Program,
    smooth: glow::Program,
    depth_down: glow::Program,
    depth_up: glow::Program,
    shade: glow::Program,
}

/// The off-screen textures for one viewport size and thickness resolution.
struct Targets {
    size: [u32; 2],
    thickness_downsample: u32,
    scene_fbo: glow::Framebuffer,
    scene_colour: glow::Texture,
    scene_depth: glow::Texture,
    /// Ping-pong pair for the depth and its smoothing; [0] has the depth buffer of the depth pass.
    depth_fbos: [glow::Framebuffer; 2],
    depth: [glow::Texture; 2],
    depth_test: glow::Renderbuffer,
    thickness_fbo: glow::Framebuffer,
    thickness: glow::Texture,
    /// The pixel buffer the CUDA splats' texels arrive in, to fill `thickness` from.
    thickness_pixels: glow::Buffer,
    /// Half resolution: the ping-pong pair the smoothing runs in when `half_res_smoothing` is on.
    half_size: (i32, i32),
    half_fbos: [glow::Framebuffer; 2],
    half: [glow::Texture; 2],
}

/// Several liquids' surfaces ([`SurfaceFrame::liquid_surfaces`]): a layer per material row of the
/// smoothed depth and of the thickness, each the size of the one surface's texture.
struct LayerTargets {
    size: [u32; 2],
    thickness_downsample: u32,
    count: u32,
    /// R32F layers, as `Targets::depth`.
    depth: glow::Texture,
    /// RG16F layers, as `Targets::thickness` (the quantity's channel unused).
    thickness: glow::Texture,
    /// A layer of `depth` attached at a time, with the depth test's buffer of `Targets`.
    depth_fbo: glow::Framebuffer,
    /// A layer of `thickness` attached at a time.
    thickness_fbo: glow::Framebuffer,
}

impl LayerTargets {
    /// Attaches layer `row` of `texture` to `fbo` as its colour.
    unsafe fn attach(&self, gl: &glow::Context, fbo: glow::Framebuffer, texture: glow::Texture, row: u32) {
        // SAFETY: as the caller vouches: our objects, on the current context.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(fbo));
            gl.framebuffer_texture_layer(
                glow::FRAMEBUFFER,
                glow::COLOR_ATTACHMENT0,
                Some(texture),
                0,
                row as i32,
            );
        }
    }
}

pub struct Surface {
    gl: Arc<glow::Context>,
    programs: Programs,
    empty_vao: glow::VertexArray,
    targets: Option<Targets>,
    /// Made when several liquids are first drawn each as its own surface.
    layers: Option<LayerTargets>,
    /// The indices `len - 1` down to 0, to draw the particles last to first (see [`Surface::draw`]).
    reversed: glow::Buffer,
    reversed_len: usize,
    /// The thickness splats by CUDA, once the feed has given it particles.
    cuda: Option<CudaThickness>,
    /// Whether `cuda` holds the particles of the frame about to be drawn.
    cuda_fed: bool,
    /// Why the CUDA splats are off, where they failed: GL splats from then on.
    cuda_refused: Option<String>,
    /// Whether CUDA summed the last frame's thickness.
    last_by_cuda: bool,
}

impl Surface {
    /// `prelude`: the shared GLSL (the colour scale and [`glsl_constants`]).
    pub fn new(gl: Arc<glow::Context>, prelude: &str) -> Result<Surface> {
        const PARTICLE_VS: &str = include_str!("shaders/surface_particle.vert");
        // The depth pass rasterises each sprite at its sphere's front and promises the fragment
        // depth is never nearer (conservative depth, core in GL 4.2, an extension to GLSL 3.30), so
        // the early depth test keeps rejecting hidden fragments although the shader writes depth.
        let depth_prelude =
            format!("#extension GL_ARB_conservative_depth : enable\n#define SPHERE_FRONT_DEPTH\n{prelude}");
        // SAFETY: the caller's context is current.
        unsafe {
            let programs = Programs {
                depth: link(
                    &gl,
                    "surface depth",
                    &[PARTICLE_VS],
                    &[include_str!("shaders/surface_depth.frag")],
                    &depth_prelude,
                )?,
                thickness: link(
                    &gl,
                    "surface thickness",
                    &[PARTICLE_VS],
                    &[include_str!("shaders/surface_thickness.frag")],
                    prelude,
                )?,
                smooth: link(
                    &gl,
                    "surface smoothing",
                    &[FULLSCREEN_VS],
                    &[include_str!("shaders/surface_smooth.frag")],
                    prelude,
                )?,
                depth_down: link(
                    &gl,
                    "surface depth to half resolution",
                    &[FULLSCREEN_VS],
                    &[include_str!("shaders/surface_depth_down.frag")],
                    prelude,
                )?,
                depth_up: link(
                    &gl,
                    "surface depth to full resolution",
                    &[FULLSCREEN_VS],
                    &[include_str!("shaders/surface_depth_up.frag")],
                    prelude,
                )?,
                shade: link(
                    &gl,
                    "surface shading",
                    &[FULLSCREEN_VS],
                    &[include_str!("shaders/surface_shade.frag")],
                    prelude,
                )?,
            };
            let empty_vao = gl.create_vertex_array().map_err(gl_error("a vertex array"))?;
            let reversed = gl.create_buffer().map_err(gl_error("a buffer"))?;
            Ok(Surface {
                gl,
                programs,
                empty_vao,
                targets: None,
                layers: None,
                reversed,
                reversed_len: 0,
                cuda: None,
                cuda_fed: false,
                cuda_refused: None,
                last_by_cuda: false,
            })
        }
    }

    /// Makes the textures `size`, the thickness 1/`thickness_downsample` of it (reallocating only
    /// when either changed) and binds the scene's framebuffer for drawing, with a viewport of that size.
    pub fn bind_scene(&mut self, size: [u32; 2], thickness_downsample: u32) -> Result<()> {
        let downsample = thickness_downsample.clamp(1, MAX_THICKNESS_DOWNSAMPLE);
        if self.targets.as_ref().map(|t| (t.size, t.thickness_downsample)) != Some((size, downsample)) {
            if let Some(old) = self.targets.take() {
                self.release_cuda_target();
                // SAFETY: our objects, not used after this.
                unsafe { self.delete_targets(&old) };
            }
            // SAFETY: the context is current.
            self.targets = Some(unsafe { self.create_targets(size, downsample)? });
        }
        self.rebind_scene();
        Ok(())
    }

    /// Binds the scene's framebuffer again, with a viewport of its size (after
    /// [`bind_scene`](Self::bind_scene) made it).
    pub fn rebind_scene(&self) {
        if let Some(targets) = &self.targets {
            // SAFETY: our framebuffer.
            unsafe {
                self.gl
                    .bind_framebuffer(glow::FRAMEBUFFER, Some(targets.scene_fbo));
                self.gl
                    .viewport(0, 0, targets.size[0] as i32, targets.size[1] as i32);
            }
        }
    }

    /// Gives the thickness splats the frame's particles: `count` float4 at `particles`, in `ctx`,
    /// written by the work queued on `stream` (the feed, through interop). Without this call before
    /// a frame, or with fewer than [`CUDA_THICKNESS_MIN_PARTICLES`], GL splats the thickness.
    ///
    /// # Safety
    /// `particles` must be a device allocation of `ctx` holding `count` float4, live until the work
    /// queued on `stream` so far is done.
    pub unsafe fn take_cuda_particles(
        &mut self,
        ctx: &Arc<CudaContext>,
        particles: CUdeviceptr,
        count: usize,
        stream: &Arc<CudaStream>,
    ) {
        if self.cuda_refused.is_some() || count < CUDA_THICKNESS_MIN_PARTICLES {
            return;
        }
        if self.cuda.as_ref().is_some_and(|c| !c.serves(ctx)) {
            self.release_cuda_target();
            self.cuda = None;
        }
        let taken = match &mut self.cuda {
            Some(cuda) => Ok(cuda),
            None => CudaThickness::new(ctx).map(|made| self.cuda.insert(made)),
        }
        // SAFETY: the caller vouches for `particles`.
        .and_then(|cuda| unsafe { cuda.take_particles(particles, count, stream) });
        match taken {
            Ok(()) => self.cuda_fed = true,
            Err(why) => self.refuse_cuda(why),
        }
    }

    fn refuse_cuda(&mut self, why: anyhow::Error) {
        let why = format!("{why:#}");
        eprintln!(
            "note: the surface's thickness splats by CUDA failed ({why}); OpenGL splats them from now on"
        );
        self.release_cuda_target();
        self.cuda = None;
        self.cuda_fed = false;
        self.cuda_refused = Some(why);
    }

    /// The last frame's thickness texture, texel rows from the bottom, (thickness m, thickness times
    /// the quantity) each (tests: CUDA's splats against GL's). None before the first surface frame.
    pub fn read_thickness(&self) -> Option<([u32; 2], Vec<[f32; 2]>)> {
        let t = self.targets.as_ref()?;
        let (w, h) = downsampled(t.size, t.thickness_downsample);
        let mut bytes = vec![0u8; 8 * (w * h) as usize];
        // SAFETY: our framebuffer; `bytes` holds w x h RG floats.
        unsafe {
            // Bound back afterwards: the next draw goes where the caller's last one went.
            let (draw, read) = (
                self.gl.get_parameter_framebuffer(glow::DRAW_FRAMEBUFFER_BINDING),
                self.gl.get_parameter_framebuffer(glow::READ_FRAMEBUFFER_BINDING),
            );
            self.gl.bind_framebuffer(glow::FRAMEBUFFER, Some(t.thickness_fbo));
            self.gl.pixel_store_i32(glow::PACK_ALIGNMENT, 4);
            self.gl.read_pixels(
                0,
                0,
                w,
                h,
                glow::RG,
                glow::FLOAT,
                glow::PixelPackData::Slice(Some(&mut bytes)),
            );
            self.gl.bind_framebuffer(glow::DRAW_FRAMEBUFFER, draw);
            self.gl.bind_framebuffer(glow::READ_FRAMEBUFFER, read);
        }
        let texels = bytemuck::pod_collect_to_vec::<u8, [f32; 2]>(&bytes);
        Some(([w as u32, h as u32], texels))
    }

    /// Whether CUDA summed the last frame's thickness.
    pub fn thickness_by_cuda(&self) -> bool {
        self.last_by_cuda
    }

    /// Drops CUDA's registration of the thickness pixel buffer (before GL deletes it).
    fn release_cuda_target(&mut self) {
        if let Some(cuda) = &mut self.cuda {
            cuda.release_target();
        }
    }

    /// The thickness pass by CUDA, where the feed gave it this frame's particles: before the frame's
    /// other GL work, so that handing the pixel buffer to CUDA waits for nothing of this frame (in
    /// the middle of the frame the hand-over held GL's passes up by about 0.9 ms on an H100, for
    /// kernels of 0.05 ms). Otherwise [`draw`](Self::draw) has GL splat it. After
    /// [`bind_scene`](Self::bind_scene); leaves no framebuffer bound.
    pub fn splat_thickness_by_cuda(&mut self, frame: &SurfaceFrame, timer: &mut GpuTimer) {
        self.last_by_cuda = false;
        let fed = std::mem::take(&mut self.cuda_fed);
        let (Some(targets), Some(cuda)) = (&self.targets, &mut self.cuda) else {
            return;
        };
        // Several liquids' thicknesses are a layer each, which GL splats; CUDA's splats would count
        // the solids in, which GL's leave out.
        if !fed || cuda.count() < frame.count || frame.liquid_surfaces() > 1 || frame.solid_rows != 0 {
            return;
        }
        let (thick_w, thick_h) = downsampled(targets.size, targets.thickness_downsample);
        let (pixels_per_metre, min_splat_px) = thickness_splat_size(frame, targets.thickness_downsample);
        let camera = SplatCamera {
            view: rows(&frame.view, 3).try_into().expect("three rows"),
            projection: rows(&frame.proj, 4).try_into().expect("four rows"),
            radius: frame.settings.radius,
            pixels_per_metre,
            min_splat_px,
            particle_volume: frame.particle_volume,
            width: thick_w as u32,
            height: thick_h as u32,
        };
        timer.begin(Pass::Thickness);
        if let Err(why) = cuda.splat(&camera, frame.count, targets.thickness_pixels.0.get()) {
            timer.end();
            self.refuse_cuda(why);
            return;
        }
        let gl = &self.gl;
        // SAFETY: our buffer and texture, on the current context; CUDA has unmapped the buffer.
        unsafe {
            gl.bind_buffer(glow::PIXEL_UNPACK_BUFFER, Some(targets.thickness_pixels));
            gl.bind_texture(glow::TEXTURE_2D, Some(targets.thickness));
            gl.tex_sub_image_2d(
                glow::TEXTURE_2D,
                0,
                0,
                0,
                thick_w,
                thick_h,
                glow::RG,
                glow::HALF_FLOAT,
                glow::PixelUnpackData::BufferOffset(0),
            );
            gl.bind_texture(glow::TEXTURE_2D, None);
            gl.bind_buffer(glow::PIXEL_UNPACK_BUFFER, None);
        }
        timer.end();
        self.last_by_cuda = true;
    }

    /// The depth, thickness (unless CUDA summed it, [`splat_thickness_by_cuda`](Self::splat_thickness_by_cuda))
    /// and smoothing passes (after [`bind_scene`](Self::bind_scene) and the scene), each timed; then
    /// the shading into `target` at `viewport` (x, y, w, h). Coloured by material with several
    /// liquids, the passes run once per material row, each liquid a surface of its own
    /// ([`SurfaceFrame::liquid_surfaces`]).
    pub fn draw(
        &mut self,
        frame: &SurfaceFrame,
        timer: &mut GpuTimer,
        target: Option<glow::Framebuffer>,
        viewport: [i32; 4],
    ) -> Result<()> {
        let Some(size) = self.targets.as_ref().map(|t| t.size) else {
            return Ok(());
        };
        let back_first = draws_back_first(&frame.view);
        if back_first {
            // SAFETY: our buffer, on the current context.
            unsafe { self.ensure_reversed(frame.count) };
        }
        let liquids = frame.liquid_surfaces();
        if liquids > 1 {
            // A layer per row, a solid's left empty: the shading finds a liquid's layer by its row.
            // SAFETY: the context is current.
            unsafe { self.ensure_layers(size, frame.materials.count)? };
        }
        let Some(targets) = &self.targets else {
            return Ok(());
        };
        let gl = &self.gl;
        let layers = self.layers.as_ref().filter(|_| liquids > 1);
        // SAFETY: every object is ours or the caller's (the VAO, the target), on the current context.
        unsafe {
            gl.disable(glow::BLEND);
            gl.disable(glow::SCISSOR_TEST);
            gl.disable(glow::CULL_FACE);
            gl.enable(glow::PROGRAM_POINT_SIZE);
            let smoothed = match layers {
                Some(layers) => {
                    self.layered_passes(targets, layers, frame, timer, back_first);
                    None
                }
                _ => {
                    timer.begin(Pass::Depth);
                    self.depth_pass(targets, frame, back_first, -1, targets.depth_fbos[0]);
                    if !self.last_by_cuda {
                        timer.begin(Pass::Thickness);
                        self.thickness_pass(targets, frame, -1, targets.thickness_fbo);
                    }
                    gl.disable(glow::PROGRAM_POINT_SIZE);
                    timer.begin(Pass::Smoothing);
                    Some(self.smoothing_pass(targets, frame))
                }
            };

            timer.begin(Pass::Shading);
            gl.bind_framebuffer(glow::FRAMEBUFFER, target);
            gl.viewport(viewport[0], viewport[1], viewport[2], viewport[3]);
            gl.bind_vertex_array(Some(self.empty_vao));
            let p = self.programs.shade;
            gl.use_program(Some(p));
            bind_texture(gl, p, "u_scene", 0, targets.scene_colour);
            bind_texture(gl, p, "u_scene_depth", 1, targets.scene_depth);
            bind_texture(gl, p, "u_depth", 2, smoothed.unwrap_or(targets.depth[0]));
            bind_texture(gl, p, "u_thickness", 3, targets.thickness);
            // The arrays' samplers always name units of their own: two samplers of different types
            // on one unit fail the draw, whether the shader reads them or not.
            let array = glow::TEXTURE_2D_ARRAY;
            bind_texture_as(gl, p, "u_layer_depth", 4, array, layers.map(|l| l.depth));
            bind_texture_as(gl, p, "u_layer_thickness", 5, array, layers.map(|l| l.thickness));
            set_i32(gl, p, "u_layers", layers.map_or(0, |l| l.count as i32));
            set_mat4(gl, p, "u_proj", &frame.proj);
            let view_to_world = Mat3::from_mat4(frame.view).transpose();
            set_mat3(gl, p, "u_view_to_world", &view_to_world);
            let sun = Vec3::from(SUN).normalize();
            set_vec3(gl, p, "u_sun_world", sun.to_array());
            set_vec3(
                gl,
                p,
                "u_sun_view",
                (Mat3::from_mat4(frame.view) * sun).to_array(),
            );
            let s = frame.settings;
            set_vec3(gl, p, "u_absorption", ABSORPTION.map(|k| k * s.absorption));
            set_f32(gl, p, "u_scattering", SCATTERING * s.absorption);
            set_f32(gl, p, "u_absorption_scale", s.absorption);
            set_vec3(gl, p, "u_water_colour", WATER_COLOUR);
            set_f32(gl, p, "u_refraction", s.refraction);
            set_i32(gl, p, "u_tint", frame.tint as i32);
            set_vec2(gl, p, "u_range", frame.range);
            frame.materials.set(gl, p);
            gl.draw_arrays(glow::TRIANGLES, 0, 3);
            timer.end();

            gl.bind_vertex_array(None);
            gl.use_program(None);
            for unit in [5, 4] {
                gl.active_texture(glow::TEXTURE0 + unit);
                gl.bind_texture(glow::TEXTURE_2D_ARRAY, None);
            }
            gl.active_texture(glow::TEXTURE0);
            gl.bind_texture(glow::TEXTURE_2D, None);
        }
        Ok(())
    }

    /// Several liquids: each pass for every material row in turn (so that each pass is timed once,
    /// over all of them), into the rows' layers: the depth, the thickness, then the smoothing, which
    /// runs in the one surface's textures and is copied back.
    unsafe fn layered_passes(
        &self,
        targets: &Targets,
        layers: &LayerTargets,
        frame: &SurfaceFrame,
        timer: &mut GpuTimer,
        back_first: bool,
    ) {
        let gl = &self.gl;
        let [w, h] = targets.size.map(|s| s as i32);
        // SAFETY: as the caller vouches: our objects, on the current context.
        unsafe {
            // A solid's layer stays empty (no depth, so the shading never reads its thickness).
            let liquid = |row: &u32| !frame.drawn_as_solid(*row);
            timer.begin(Pass::Depth);
            for row in 0..layers.count {
                layers.attach(gl, layers.depth_fbo, layers.depth, row);
                if liquid(&row) {
                    self.depth_pass(targets, frame, back_first, row as i32, layers.depth_fbo);
                } else {
                    gl.viewport(0, 0, w, h);
                    gl.clear_color(EMPTY_DEPTH, 0.0, 0.0, 0.0);
                    gl.clear(glow::COLOR_BUFFER_BIT);
                }
            }
            timer.begin(Pass::Thickness);
            for row in (0..layers.count).filter(liquid) {
                layers.attach(gl, layers.thickness_fbo, layers.thickness, row);
                self.thickness_pass(targets, frame, row as i32, layers.thickness_fbo);
            }
            gl.disable(glow::PROGRAM_POINT_SIZE);
            timer.begin(Pass::Smoothing);
            for row in (0..layers.count).filter(liquid) {
                layers.attach(gl, layers.depth_fbo, layers.depth, row);
                blit(gl, layers.depth_fbo, targets.depth_fbos[0], (w, h));
                let smoothed = self.smoothing_pass(targets, frame);
                let from = if smoothed == targets.depth[0] {
                    targets.depth_fbos[0]
                } else {
                    targets.depth_fbos[1]
                };
                blit(gl, from, layers.depth_fbo, (w, h));
            }
        }
    }

    /// The nearest sphere's view distance per pixel into `fbo` (the depth texture and the depth test's
    /// buffer attached), of the particles of material row `only_row` (every particle where it is -1).
    unsafe fn depth_pass(
        &self,
        targets: &Targets,
        frame: &SurfaceFrame,
        back_first: bool,
        only_row: i32,
        fbo: glow::Framebuffer,
    ) {
        let gl = &self.gl;
        let [w, h] = targets.size.map(|s| s as i32);
        let count = frame.count as i32;
        // SAFETY: as the caller vouches.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(fbo));
            gl.viewport(0, 0, w, h);
            gl.clear_color(EMPTY_DEPTH, 0.0, 0.0, 0.0);
            gl.clear_depth_f32(1.0);
            gl.clear(glow::COLOR_BUFFER_BIT | glow::DEPTH_BUFFER_BIT);
            gl.enable(glow::DEPTH_TEST);
            gl.depth_func(glow::LESS);
            let p = self.programs.depth;
            gl.use_program(Some(p));
            set_particle_uniforms(gl, p, frame, frame.pixels_per_metre, 0.5, only_row);
            gl.bind_vertex_array(Some(frame.particles));
            if back_first {
                // The last `count` of the indices: count - 1 down to 0.
                gl.bind_buffer(glow::ELEMENT_ARRAY_BUFFER, Some(self.reversed));
                let first = (self.reversed_len - frame.count) * std::mem::size_of::<u32>();
                gl.draw_elements(glow::POINTS, count, glow::UNSIGNED_INT, first as i32);
                // The element buffer is the VAO's state: the other draws of these particles use none.
                gl.bind_buffer(glow::ELEMENT_ARRAY_BUFFER, None);
            } else {
                gl.draw_arrays(glow::POINTS, 0, count);
            }
            gl.disable(glow::DEPTH_TEST);
            gl.bind_vertex_array(None);
        }
    }

    /// The thickness splats, blended, into `fbo` (a thickness texture attached), of the particles of
    /// material row `only_row` (every particle where it is -1).
    unsafe fn thickness_pass(
        &self,
        targets: &Targets,
        frame: &SurfaceFrame,
        only_row: i32,
        fbo: glow::Framebuffer,
    ) {
        let gl = &self.gl;
        let downsample = targets.thickness_downsample;
        let (thick_w, thick_h) = downsampled(targets.size, downsample);
        let (pixels_per_metre, min_splat_px) = thickness_splat_size(frame, downsample);
        // SAFETY: as the caller vouches.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(fbo));
            gl.viewport(0, 0, thick_w, thick_h);
            gl.clear_color(0.0, 0.0, 0.0, 0.0);
            gl.clear(glow::COLOR_BUFFER_BIT);
            gl.enable(glow::BLEND);
            gl.blend_equation(glow::FUNC_ADD);
            gl.blend_func(glow::ONE, glow::ONE);
            let p = self.programs.thickness;
            gl.use_program(Some(p));
            set_particle_uniforms(gl, p, frame, pixels_per_metre, min_splat_px, only_row);
            set_f32(gl, p, "u_particle_volume", frame.particle_volume);
            gl.bind_vertex_array(Some(frame.particles));
            gl.draw_arrays(glow::POINTS, 0, frame.count as i32);
            gl.disable(glow::BLEND);
            gl.bind_vertex_array(None);
        }
    }

    /// The narrow-range filter over `depth[0]`; returns the texture holding the smoothed depth at
    /// full resolution: `depth[0]` (smoothed in place), or `depth[1]` from the half-resolution
    /// result and the unsmoothed `depth[0]`.
    unsafe fn smoothing_pass(&self, targets: &Targets, frame: &SurfaceFrame) -> glow::Texture {
        let gl = &self.gl;
        let [w, h] = targets.size.map(|s| s as i32);
        let s = frame.settings;
        // SAFETY: as the caller vouches.
        unsafe {
            gl.bind_vertex_array(Some(self.empty_vao));
            // Depths within a few particle radii of each other belong to one surface.
            let range = 4.0 * s.radius;
            // The smoothing's ping-pong pair, its size and pixels per metre: full resolution, or half
            // with the depth brought down first.
            let (fbos, textures, (sw, sh), scale) = if s.half_res_smoothing {
                let p = self.programs.depth_down;
                gl.use_program(Some(p));
                gl.bind_framebuffer(glow::FRAMEBUFFER, Some(targets.half_fbos[0]));
                gl.viewport(0, 0, targets.half_size.0, targets.half_size.1);
                bind_texture(gl, p, "u_depth", 0, targets.depth[0]);
                set_f32(gl, p, "u_range", range);
                gl.draw_arrays(glow::TRIANGLES, 0, 3);
                (targets.half_fbos, targets.half, targets.half_size, 0.5)
            } else {
                (targets.depth_fbos, targets.depth, (w, h), 1.0)
            };
            let p = self.programs.smooth;
            gl.use_program(Some(p));
            gl.viewport(0, 0, sw, sh);
            set_f32(gl, p, "u_radius", s.radius);
            set_f32(gl, p, "u_pixels_per_metre", frame.pixels_per_metre * scale);
            set_f32(gl, p, "u_filter_radii", s.smoothing);
            let max_px = (s.max_filter_px.max(1) as f32 * scale).ceil() as i32;
            set_i32(gl, p, "u_max_filter_px", max_px);
            set_f32(gl, p, "u_range", range);
            for _ in 0..s.iterations {
                for (from, to, direction) in [(0, 1, (1, 0)), (1, 0, (0, 1))] {
                    gl.bind_framebuffer(glow::FRAMEBUFFER, Some(fbos[to]));
                    bind_texture(gl, p, "u_depth", 0, textures[from]);
                    let loc = gl.get_uniform_location(p, "u_direction");
                    gl.uniform_2_i32(loc.as_ref(), direction.0, direction.1);
                    gl.draw_arrays(glow::TRIANGLES, 0, 3);
                }
            }
            let smoothed = if s.half_res_smoothing {
                let p = self.programs.depth_up;
                gl.use_program(Some(p));
                gl.bind_framebuffer(glow::FRAMEBUFFER, Some(targets.depth_fbos[1]));
                gl.viewport(0, 0, w, h);
                bind_texture(gl, p, "u_depth", 0, targets.depth[0]);
                bind_texture(gl, p, "u_smoothed", 1, targets.half[0]);
                set_f32(gl, p, "u_range", range);
                gl.draw_arrays(glow::TRIANGLES, 0, 3);
                targets.depth[1]
            } else {
                targets.depth[0]
            };
            gl.bind_vertex_array(None);
            smoothed
        }
    }

    /// Makes the layers for `count` liquids at the targets' sizes (reallocating only when either
    /// changed).
    unsafe fn ensure_layers(&mut self, size: [u32; 2], count: u32) -> Result<()> {
        let Some(targets) = &self.targets else {
            return Ok(());
        };
        let downsample = targets.thickness_downsample;
        let wanted = (size, downsample, count);
        if self
            .layers
            .as_ref()
            .is_some_and(|l| (l.size, l.thickness_downsample, l.count) == wanted)
        {
            return Ok(());
        }
        let gl = &self.gl;
        // SAFETY: as the caller vouches: the context is current; the old layers are ours, deleted once.
        unsafe {
            if let Some(old) = self.layers.take() {
                delete_layers(gl, &old);
            }
            let array = |internal: u32, (w, h): (i32, i32)| -> Result<glow::Texture> {
                let t = gl.create_texture().map_err(gl_error("a texture array"))?;
                gl.bind_texture(glow::TEXTURE_2D_ARRAY, Some(t));
                gl.tex_storage_3d(glow::TEXTURE_2D_ARRAY, 1, internal, w, h, count as i32);
                set_sampling(gl, glow::TEXTURE_2D_ARRAY, glow::LINEAR);
                gl.bind_texture(glow::TEXTURE_2D_ARRAY, None);
                Ok(t)
            };
            let full = (size[0] as i32, size[1] as i32);
            let layers = LayerTargets {
                size,
                thickness_downsample: downsample,
                count,
                depth: array(glow::R32F, full)?,
                thickness: array(glow::RG16F, downsampled(size, downsample))?,
                depth_fbo: gl.create_framebuffer().map_err(gl_error("a framebuffer"))?,
                thickness_fbo: gl.create_framebuffer().map_err(gl_error("a framebuffer"))?,
            };
            layers.attach(gl, layers.depth_fbo, layers.depth, 0);
            gl.framebuffer_renderbuffer(
                glow::FRAMEBUFFER,
                glow::DEPTH_ATTACHMENT,
                glow::RENDERBUFFER,
                Some(targets.depth_test),
            );
            layers.attach(gl, layers.thickness_fbo, layers.thickness, 0);
            for (name, fbo) in [("depth", layers.depth_fbo), ("thickness", layers.thickness_fbo)] {
                gl.bind_framebuffer(glow::FRAMEBUFFER, Some(fbo));
                let status = gl.check_framebuffer_status(glow::FRAMEBUFFER);
                if status != glow::FRAMEBUFFER_COMPLETE {
                    delete_layers(gl, &layers);
                    gl.bind_framebuffer(glow::FRAMEBUFFER, None);
                    bail!(
                        "the surface's per-liquid {name} framebuffer is incomplete (status {status:#x}): this \
                         OpenGL cannot render into texture arrays; colour by speed or density, or draw \
                         with --draw spheres"
                    );
                }
            }
            gl.bind_framebuffer(glow::FRAMEBUFFER, None);
            self.layers = Some(layers);
        }
        Ok(())
    }

    /// Makes the reversed indices cover at least `count` particles (grown by doubling: an emitter's
    /// growing count reallocates a few times, not every frame).
    unsafe fn ensure_reversed(&mut self, count: usize) {
        if count <= self.reversed_len {
            return;
        }
        let len = count.max(2 * self.reversed_len);
        let indices: Vec<u32> = (0..len as u32).rev().collect();
        unsafe {
            self.gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.reversed));
            self.gl.buffer_data_u8_slice(
                glow::ARRAY_BUFFER,
                bytemuck::cast_slice(&indices),
                glow::STATIC_DRAW,
            );
            self.gl.bind_buffer(glow::ARRAY_BUFFER, None);
        }
        self.reversed_len = len;
    }

    unsafe fn create_targets(&self, size: [u32; 2], thickness_downsample: u32) -> Result<Targets> {
        let gl = &self.gl;
        let [w, h] = size.map(|s| s as i32);
        let (thick_w, thick_h) = downsampled(size, thickness_downsample);
        unsafe {
            let texture = |internal: u32,
                           format: u32,
                           kind: u32,
                           w: i32,
                           h: i32,
                           filter: u32|
             -> Result<glow::Texture> {
                let t = gl.create_texture().map_err(gl_error("a texture"))?;
                gl.bind_texture(glow::TEXTURE_2D, Some(t));
                gl.tex_image_2d(
                    glow::TEXTURE_2D,
                    0,
                    internal as i32,
                    w,
                    h,
                    0,
                    format,
                    kind,
                    glow::PixelUnpackData::Slice(None),
                );
                set_sampling(gl, glow::TEXTURE_2D, filter);
                Ok(t)
            };
            let scene_colour = texture(glow::RGBA8, glow::RGBA, glow::UNSIGNED_BYTE, w, h, glow::LINEAR)?;
            let scene_depth = texture(
                glow::DEPTH_COMPONENT24,
                glow::DEPTH_COMPONENT,
                glow::UNSIGNED_INT,
                w,
                h,
                glow::NEAREST,
            )?;
            // Linear: the smoothing reads two pixels per fetch (shaders/surface_smooth.frag); the
            // other passes read single pixels with texelFetch, which ignores the filter.
            let depth = [
                texture(glow::R32F, glow::RED, glow::FLOAT, w, h, glow::LINEAR)?,
                texture(glow::R32F, glow::RED, glow::FLOAT, w, h, glow::LINEAR)?,
            ];
            // Half floats: blended at full rate where 32-bit floats blend at a fraction of it; 11 bits
            // of mantissa are plenty for a thickness that only tints and absorbs.
            let thickness = texture(glow::RG16F, glow::RG, glow::FLOAT, thick_w, thick_h, glow::LINEAR)?;
            let thickness_pixels = gl.create_buffer().map_err(gl_error("a pixel buffer"))?;
            gl.bind_buffer(glow::PIXEL_UNPACK_BUFFER, Some(thickness_pixels));
            gl.buffer_data_size(
                glow::PIXEL_UNPACK_BUFFER,
                (TEXEL_BYTES * thick_w as usize * thick_h as usize) as i32,
                glow::STREAM_COPY,
            );
            gl.bind_buffer(glow::PIXEL_UNPACK_BUFFER, None);
            let half_size = downsampled(size, 2);
            let (half_w, half_h) = half_size;
            let half_texture = || texture(glow::R32F, glow::RED, glow::FLOAT, half_w, half_h, glow::LINEAR);
            let half = [half_texture()?, half_texture()?];
            gl.bind_texture(glow::TEXTURE_2D, None);
            let depth_test = gl.create_renderbuffer().map_err(gl_error("a renderbuffer"))?;
            gl.bind_renderbuffer(glow::RENDERBUFFER, Some(depth_test));
            gl.renderbuffer_storage(glow::RENDERBUFFER, glow::DEPTH_COMPONENT24, w, h);
            gl.bind_renderbuffer(glow::RENDERBUFFER, None);

            let framebuffer =
                |colour: glow::Texture, depth: Option<glow::Texture>| -> Result<glow::Framebuffer> {
                    let f = gl.create_framebuffer().map_err(gl_error("a framebuffer"))?;
                    gl.bind_framebuffer(glow::FRAMEBUFFER, Some(f));
                    gl.framebuffer_texture_2d(
                        glow::FRAMEBUFFER,
                        glow::COLOR_ATTACHMENT0,
                        glow::TEXTURE_2D,
                        Some(colour),
                        0,
                    );
                    if let Some(depth) = depth {
                        gl.framebuffer_texture_2d(
                            glow::FRAMEBUFFER,
                            glow::DEPTH_ATTACHMENT,
                            glow::TEXTURE_2D,
                            Some(depth),
                            0,
                        );
                    }
                    Ok(f)
                };
            let scene_fbo = framebuffer(scene_colour, Some(scene_depth))?;
            let depth_fbos = [framebuffer(depth[0], None)?, framebuffer(depth[1], None)?];
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(depth_fbos[0]));
            gl.framebuffer_renderbuffer(
                glow::FRAMEBUFFER,
                glow::DEPTH_ATTACHMENT,
                glow::RENDERBUFFER,
                Some(depth_test),
            );
            let thickness_fbo = framebuffer(thickness, None)?;
            let half_fbos = [framebuffer(half[0], None)?, framebuffer(half[1], None)?];
            let targets = Targets {
                size,
                thickness_downsample,
                scene_fbo,
                scene_colour,
                scene_depth,
                depth_fbos,
                depth,
                depth_test,
                thickness_fbo,
                thickness,
                thickness_pixels,
                half_size,
                half_fbos,
                half,
            };
            for (name, fbo) in [
                ("scene", scene_fbo),
                ("depth", depth_fbos[0]),
                ("smoothing", depth_fbos[1]),
                ("thickness", thickness_fbo),
                ("half-resolution smoothing", half_fbos[0]),
                ("half-resolution smoothing", half_fbos[1]),
            ] {
                gl.bind_framebuffer(glow::FRAMEBUFFER, Some(fbo));
                let status = gl.check_framebuffer_status(glow::FRAMEBUFFER);
                if status != glow::FRAMEBUFFER_COMPLETE {
                    self.delete_targets(&targets);
                    bail!(
                        "the surface's {name} framebuffer ({w}x{h}) is incomplete (status {status:#x}): this \
                         OpenGL lacks float render targets; draw with --draw spheres instead"
                    );
                }
            }
            Ok(targets)
        }
    }

    unsafe fn delete_targets(&self, t: &Targets) {
        let gl = &self.gl;
        unsafe {
            for f in [
                t.scene_fbo,
                t.depth_fbos[0],
                t.depth_fbos[1],
                t.thickness_fbo,
                t.half_fbos[0],
                t.half_fbos[1],
            ] {
                gl.delete_framebuffer(f);
            }
            for tex in [
                t.scene_colour,
                t.scene_depth,
                t.depth[0],
                t.depth[1],
                t.thickness,
                t.half[0],
                t.half[1],
            ] {
                gl.delete_texture(tex);
            }
            gl.delete_renderbuffer(t.depth_test);
            gl.delete_buffer(t.thickness_pixels);
        }
    }

    pub fn destroy(&mut self) {
        self.release_cuda_target();
        self.cuda = None;
        if let Some(layers) = self.layers.take() {
            // SAFETY: our objects, deleted once.
            unsafe { delete_layers(&self.gl, &layers) };
        }
        if let Some(t) = self.targets.take() {
            // SAFETY: our objects, deleted once.
            unsafe { self.delete_targets(&t) };
        }
        // SAFETY: as above.
        unsafe {
            let p = &self.programs;
            for program in [p.depth, p.thickness, p.smooth, p.depth_down, p.depth_up, p.shade] {
                self.gl.delete_program(program);
            }
            self.gl.delete_vertex_array(self.empty_vao);
            self.gl.delete_buffer(self.reversed);
        }
    }
}

/// Whether the particles' buffer order runs from the back of this view to its front, so that the
/// depth pass should draw it last to first.
///
/// The early depth test (see `shaders/surface_depth.frag`) only saves work for fragments behind water
/// already drawn: drawn back to front, every layer of a pixel is shaded. The buffer holds the
/// particles in slot order, which is spawn order, each body's lattice x fastest, then y, then z
/// (`Scene::spawn`; kernels/render.cu writes each particle at its slot, whatever order a solver
/// stores them in), and they stay roughly where they started. So the order runs mainly along +z,
/// then +y, then +x; this compares that with the direction towards the camera and draws in reverse
/// where they agree. No sorting per frame: a wrong guess (a scene mixed through) costs time, never a
/// different picture.
fn draws_back_first(view: &Mat4) -> bool {
    // The view's +z axis in world space points from the scene towards the eye.
    let towards_eye = view.row(2).truncate();
    towards_eye.dot(Vec3::new(0.01, 0.1, 1.0)) > 0.0
}

/// The thickness splats' texels per metre at unit depth and their smallest radius, texels: fewer
/// texels per metre at the lower resolution, and a smallest radius so that a far particle still lands
/// on texels rather than between them.
fn thickness_splat_size(frame: &SurfaceFrame, downsample: u32) -> (f32, f32) {
    (
        frame.pixels_per_metre / downsample as f32,
        frame.settings.thickness_min_splat_px.max(0.5),
    )
}

/// The first `n` rows of `m`, row-major (a kernel's matrix: glam stores columns).
fn rows(m: &Mat4, n: usize) -> Vec<f32> {
    (0..n).flat_map(|i| m.row(i).to_array()).collect()
}

/// Fewer particles than this are splatted by GL even where CUDA could sum them: handing the pixel
/// buffer to CUDA and back costs about 0.33 ms a frame on an H100, where GL's blending costs about
/// 2.6 ns a particle, so GL is cheaper below about 127,000 (the fountain's 20,000 to 60,000: GL
/// 0.09 ms, CUDA 0.36; the dam break's 451,200: GL 1.30, CUDA 0.43 to 0.48; BENCHMARKS.md 0s).
pub const CUDA_THICKNESS_MIN_PARTICLES: usize = 131_072;

/// The largest thickness downsampling the targets accept (the panel's slider stops there).
pub const MAX_THICKNESS_DOWNSAMPLE: u32 = 8;

/// The thickness texture's size: 1/`factor` of `size`, rounded up, at least 1.
fn downsampled(size: [u32; 2], factor: u32) -> (i32, i32) {
    (
        size[0].div_ceil(factor).max(1) as i32,
        size[1].div_ceil(factor).max(1) as i32,
    )
}

unsafe fn delete_layers(gl: &glow::Context, layers: &LayerTargets) {
    // SAFETY: as the caller vouches: its objects, on the current context.
    unsafe {
        gl.delete_framebuffer(layers.depth_fbo);
        gl.delete_framebuffer(layers.thickness_fbo);
        gl.delete_texture(layers.depth);
        gl.delete_texture(layers.thickness);
    }
}

/// Copies the colour of framebuffer `from` into `to`, both `(w, h)`.
unsafe fn blit(gl: &glow::Context, from: glow::Framebuffer, to: glow::Framebuffer, (w, h): (i32, i32)) {
    // SAFETY: as the caller vouches.
    unsafe {
        gl.bind_framebuffer(glow::READ_FRAMEBUFFER, Some(from));
        gl.bind_framebuffer(glow::DRAW_FRAMEBUFFER, Some(to));
        gl.blit_framebuffer(0, 0, w, h, 0, 0, w, h, glow::COLOR_BUFFER_BIT, glow::NEAREST);
        gl.bind_framebuffer(glow::FRAMEBUFFER, None);
    }
}

unsafe fn set_particle_uniforms(
    gl: &glow::Context,
    program: glow::Program,
    frame: &SurfaceFrame,
    pixels_per_metre: f32,
    min_splat_px: f32,
    only_row: i32,
) {
    unsafe {
        set_i32(gl, program, "u_only_row", only_row);
        set_i32(gl, program, "u_solid_rows", frame.solid_rows as i32);
        set_mat4(gl, program, "u_view", &frame.view);
        set_mat4(gl, program, "u_proj", &frame.proj);
        set_f32(gl, program, "u_radius", frame.settings.radius);
        set_f32(gl, program, "u_pixels_per_metre", pixels_per_metre);
        set_f32(gl, program, "u_min_splat_px", min_splat_px);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::camera::OrbitCamera;

    #[test]
    fn depth_pass_draws_the_spawn_order_from_the_front() {
        let size = glam::Vec2::new(1600.0, 900.0);
        let mut camera = OrbitCamera::framing(Vec3::ZERO, Vec3::new(1.0, 0.5, 0.3), size, 0.0);
        // The default view looks from +z (and above, and +x) at the tank: the last spawned particles
        // (highest z) are the nearest, so the buffer runs back to front.
        assert!(draws_back_first(&camera.view()));
        // Turned round to look from -z, the buffer's own order is front to back.
        camera.yaw += std::f32::consts::PI;
        assert!(!draws_back_first(&camera.view()));
    }

    #[test]
    fn thickness_targets_round_up_and_never_vanish() {
        assert_eq!(downsampled([1920, 1080], 4), (480, 270));
        assert_eq!(downsampled([1921, 1081], 4), (481, 271));
        assert_eq!(downsampled([3, 1], 8), (1, 1));
    }
}
