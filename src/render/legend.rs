//! The colour bar at the right edge of the picture, with its end values, its middle value and its unit
//! drawn into the frame itself (so they are in screenshots, recordings and headless frames too).
//!
//! The numbers are rasterised on the CPU with ab_glyph from egui's own monospace font (Hack, through
//! `epaint_default_fonts`, both already in the build for the panel) into a small texture, only when
//! the text or its size changes; each frame draws a few textured quads.

use super::program::{bind_texture, gl_error, link, set_f32, set_i32, set_sampling, set_vec3};
use super::renderer::scale_colour;
use super::surface::{foam_amount, FOAM_COLOUR, WATER_COLOUR};
use super::Viewport;
use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
use anyhow::{anyhow, Result};
use glow::HasContext;
use std::sync::Arc;

/// What the bar shows.
#[derive(Debug, Clone, PartialEq)]
pub struct Scale {
    /// Water turning to whitewater (the surface coloured by speed), else the colour scale.
    pub whitewater: bool,
    pub range: [f32; 2],
    pub unit: &'static str,
}

impl Scale {
    /// The bar's colour at `t` in [0, 1] (the panel's copy of the legend draws with it).
    pub fn colour(&self, t: f32) -> [f32; 3] {
        if self.whitewater {
            let f = foam_amount(t);
            [0, 1, 2].map(|k| WATER_COLOUR[k] + (FOAM_COLOUR[k] - WATER_COLOUR[k]) * f)
        } else {
            scale_colour(t)
        }
    }
}

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
uniform bool u_whitewater;
uniform vec3 u_water_colour;
out vec4 o_colour;
void main() {
    vec3 c = u_whitewater ? mix(u_water_colour, FOAM_COLOUR, foam_amount(v_t)) : scale_colour(v_t);
    o_colour = vec4(c, 1.0);
}
"#;

const TEXT_VS: &str = r#"
layout(location = 0) in vec4 a_vertex; // xy in clip space, zw in the atlas
out vec2 v_uv;
void main() {
    v_uv = a_vertex.zw;
    gl_Position = vec4(a_vertex.xy, 0.0, 1.0);
}
"#;

const TEXT_FS: &str = r#"
in vec2 v_uv;
uniform sampler2D u_atlas;
uniform vec3 u_colour;
uniform float u_alpha;
out vec4 o_colour;
void main() { o_colour = vec4(u_colour, u_alpha * texture(u_atlas, v_uv).r); }
"#;

const TEXT_COLOUR: [f32; 3] = [0.90, 0.92, 0.95];

/// Labels rasterised into one texture: each a row of the atlas.
struct Atlas {
    texts: Vec<String>,
    px: u32,
    texture: glow::Texture,
    size: [u32; 2],
    /// (x, y, w, h) of each text in the atlas, pixels, y down.
    boxes: Vec<[u32; 4]>,
}

pub struct Legend {
    gl: Arc<glow::Context>,
    font: FontRef<'static>,
    bar: glow::Program,
    text: glow::Program,
    bar_vao: glow::VertexArray,
    text_vao: glow::VertexArray,
    text_vbo: glow::Buffer,
    atlas: Option<Atlas>,
}

/// Where a label goes: its reference point in viewport pixels (y up) and how it hangs from it.
struct Placement {
    x: i32,
    y: i32,
    /// The text's right edge at x (else its left edge).
    right_aligned: bool,
}

impl Legend {
    pub fn new(gl: Arc<glow::Context>, prelude: &str) -> Result<Legend> {
        let font = FontRef::try_from_slice(epaint_default_fonts::HACK_REGULAR)
            .map_err(|e| anyhow!("the legend's font does not load: {e}"))?;
        // SAFETY: the caller's context is current.
        unsafe {
            let bar = link(&gl, "colour bar", &[BAR_VS], &[BAR_FS], prelude)?;
            let text = link(&gl, "legend text", &[TEXT_VS], &[TEXT_FS], "")?;
            let bar_vao = gl.create_vertex_array().map_err(gl_error("a vertex array"))?;
            let text_vao = gl.create_vertex_array().map_err(gl_error("a vertex array"))?;
            let text_vbo = gl.create_buffer().map_err(gl_error("a buffer"))?;
            gl.bind_vertex_array(Some(text_vao));
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(text_vbo));
            gl.enable_vertex_attrib_array(0);
            gl.vertex_attrib_pointer_f32(0, 4, glow::FLOAT, false, 16, 0);
            gl.bind_vertex_array(None);
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
            Ok(Legend {
                gl,
                font,
                bar,
                text,
                bar_vao,
                text_vao,
                text_vbo,
                atlas: None,
            })
        }
    }

    /// Draws the bar and its labels into `viewport` of the bound framebuffer.
    pub fn draw(&mut self, viewport: Viewport, scale: &Scale) -> Result<()> {
        let (w, h) = (viewport.width.max(1) as i32, viewport.height.max(1) as i32);
        let bar_w = bar_width(w);
        let bar_h = h * 3 / 5;
        let bar_x = w - 2 * bar_w;
        let bar_y = (h - bar_h) / 2;
        // SAFETY: our objects; the context is current.
        unsafe {
            let gl = &self.gl;
            gl.disable(glow::DEPTH_TEST);
            gl.disable(glow::BLEND);
            gl.viewport(viewport.x + bar_x, viewport.y + bar_y, bar_w, bar_h);
            gl.use_program(Some(self.bar));
            set_i32(gl, self.bar, "u_whitewater", i32::from(scale.whitewater));
            set_vec3(gl, self.bar, "u_water_colour", WATER_COLOUR);
            gl.bind_vertex_array(Some(self.bar_vao));
            gl.draw_arrays(glow::TRIANGLE_STRIP, 0, 4);
        }

        // Numbers left of the bar, at its top, middle and bottom; the unit above it.
        let px = text_pixels(h);
        let [lo, hi] = scale.range;
        let decimals = decimals_for(hi - lo);
        let texts = vec![
            format!("{hi:.decimals$}"),
            format!("{:.decimals$}", 0.5 * (lo + hi)),
            format!("{lo:.decimals$}"),
            scale.unit.to_string(),
        ];
        let gap = bar_w / 2 + 2;
        let label_x = bar_x - gap;
        let placements = [
            Placement {
                x: label_x,
                y: bar_y + bar_h,
                right_aligned: true,
            },
            Placement {
                x: label_x,
                y: bar_y + bar_h / 2,
                right_aligned: true,
            },
            Placement {
                x: label_x,
                y: bar_y,
                right_aligned: true,
            },
            Placement {
                x: bar_x + bar_w,
                y: bar_y + bar_h + gap + px as i32 / 2,
                right_aligned: true,
            },
        ];
        self.ensure_atlas(texts, px)?;
        let atlas = self.atlas.as_ref().expect("just made");
        let mut vertices: Vec<[f32; 4]> = Vec::with_capacity(6 * placements.len());
        for (placement, b) in placements.iter().zip(&atlas.boxes) {
            let [ax, ay, bw, bh] = b.map(|v| v as i32);
            let left = if placement.right_aligned {
                placement.x - bw
            } else {
                placement.x
            };
            // Centred vertically on the reference point, kept inside the viewport.
            let bottom = (placement.y - bh / 2).clamp(0, (h - bh).max(0));
            let to_clip = |x: i32, y: i32| [2.0 * x as f32 / w as f32 - 1.0, 2.0 * y as f32 / h as f32 - 1.0];
            let to_atlas =
                |x: i32, y: i32| [x as f32 / atlas.size[0] as f32, y as f32 / atlas.size[1] as f32];
            // Atlas rows run top to bottom, the viewport's bottom to top.
            let corners = [
                (left, bottom, ax, ay + bh),
                (left + bw, bottom, ax + bw, ay + bh),
                (left + bw, bottom + bh, ax + bw, ay),
                (left, bottom + bh, ax, ay),
            ];
            for i in [0, 1, 2, 0, 2, 3] {
                let (x, y, u, v) = corners[i];
                let [cx, cy] = to_clip(x, y);
                let [tu, tv] = to_atlas(u, v);
                vertices.push([cx, cy, tu, tv]);
            }
        }
        // SAFETY: as above; the buffer is re-specified with exactly this data.
        unsafe {
            let gl = &self.gl;
            gl.viewport(viewport.x, viewport.y, w, h);
            gl.bind_vertex_array(Some(self.text_vao));
            // A dark shadow two pixels down and right, then the text: legible over light water too.
            let shadow = vertices
                .iter()
                .map(|v| [v[0] + 2.0 / w as f32, v[1] - 2.0 / h as f32, v[2], v[3]]);
            let both: Vec<[f32; 4]> = shadow.chain(vertices.iter().copied()).collect();
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.text_vbo));
            gl.buffer_data_u8_slice(glow::ARRAY_BUFFER, bytemuck::cast_slice(&both), glow::STREAM_DRAW);
            gl.use_program(Some(self.text));
            bind_texture(gl, self.text, "u_atlas", 0, atlas.texture);
            gl.enable(glow::BLEND);
            // Colour blends over the frame; the frame's alpha stays opaque (headless PNGs keep it).
            gl.blend_func_separate(glow::SRC_ALPHA, glow::ONE_MINUS_SRC_ALPHA, glow::ZERO, glow::ONE);
            let n = vertices.len() as i32;
            set_vec3(gl, self.text, "u_colour", [0.0; 3]);
            set_f32(gl, self.text, "u_alpha", 0.7);
            gl.draw_arrays(glow::TRIANGLES, 0, n);
            set_vec3(gl, self.text, "u_colour", TEXT_COLOUR);
            set_f32(gl, self.text, "u_alpha", 1.0);
            gl.draw_arrays(glow::TRIANGLES, n, n);
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
            gl.disable(glow::BLEND);
            gl.bind_vertex_array(None);
            gl.bind_texture(glow::TEXTURE_2D, None);
            gl.use_program(None);
        }
        Ok(())
    }

    /// Rasterises `texts` at `px` into the atlas, unless it holds exactly those already.
    fn ensure_atlas(&mut self, texts: Vec<String>, px: u32) -> Result<()> {
        if self
            .atlas
            .as_ref()
            .is_some_and(|a| a.px == px && a.texts == texts)
        {
            return Ok(());
        }
        let lines: Vec<(u32, u32, Vec<u8>)> = texts
            .iter()
            .map(|t| rasterise(&self.font, t, px as f32))
            .collect();
        let width = lines.iter().map(|l| l.0).max().unwrap_or(1).max(1);
        let height: u32 = lines.iter().map(|l| l.1 + 1).sum::<u32>().max(1);
        let mut pixels = vec![0u8; (width * height) as usize];
        let mut boxes = Vec::with_capacity(lines.len());
        let mut y = 0;
        for (lw, lh, coverage) in &lines {
            for row in 0..*lh {
                let src = (row * lw) as usize;
                let dst = ((y + row) * width) as usize;
                pixels[dst..dst + *lw as usize].copy_from_slice(&coverage[src..src + *lw as usize]);
            }
            boxes.push([0, y, *lw, *lh]);
            y += lh + 1;
        }
        let gl = &self.gl;
        // SAFETY: our texture (made here or replaced); the pixel data is width x height bytes.
        unsafe {
            let texture = match self.atlas.take() {
                Some(old) => old.texture,
                None => gl.create_texture().map_err(gl_error("a texture"))?,
            };
            gl.bind_texture(glow::TEXTURE_2D, Some(texture));
            gl.pixel_store_i32(glow::UNPACK_ALIGNMENT, 1);
            gl.tex_image_2d(
                glow::TEXTURE_2D,
                0,
                glow::R8 as i32,
                width as i32,
                height as i32,
                0,
                glow::RED,
                glow::UNSIGNED_BYTE,
                glow::PixelUnpackData::Slice(Some(&pixels)),
            );
            gl.pixel_store_i32(glow::UNPACK_ALIGNMENT, 4);
            set_sampling(gl, glow::TEXTURE_2D, glow::NEAREST);
            gl.bind_texture(glow::TEXTURE_2D, None);
            self.atlas = Some(Atlas {
                texts,
                px,
                texture,
                size: [width, height],
                boxes,
            });
        }
        Ok(())
    }

    pub fn destroy(&mut self) {
        // SAFETY: our objects, deleted once.
        unsafe {
            let gl = &self.gl;
            if let Some(atlas) = self.atlas.take() {
                gl.delete_texture(atlas.texture);
            }
            gl.delete_program(self.bar);
            gl.delete_program(self.text);
            gl.delete_vertex_array(self.bar_vao);
            gl.delete_vertex_array(self.text_vao);
            gl.delete_buffer(self.text_vbo);
        }
    }
}

/// The bar is 2% of the viewport wide (at least 6 px), the middle 60% of its height, one bar width
/// from the right edge.
fn bar_width(viewport_width: i32) -> i32 {
    (viewport_width / 50).max(6)
}

/// The labels' height in pixels.
fn text_pixels(viewport_height: i32) -> u32 {
    (viewport_height as f32 * 0.022).round().clamp(10.0, 40.0) as u32
}

/// Pixels at the right edge of `viewport` that the bar and its numbers take, for the camera to keep
/// the water out of: the bar, its margin, and labels of up to six glyphs (`1.234`, `kg/m³`) left of it.
pub fn clearance(viewport: Viewport) -> f32 {
    let bar_w = bar_width(viewport.width.max(1) as i32) as f32;
    let px = text_pixels(viewport.height.max(1) as i32) as f32;
    2.5 * bar_w + 2.0 + 6.0 * 0.6 * px
}

/// Decimals that tell the bar's three values apart: 0 to 3 m/s reads 0.0, 1.5, 3.0; 0.9 to 1.1
/// reads 0.90, 1.00, 1.10.
pub fn decimals_for(span: f32) -> usize {
    let half = (0.5 * span.abs()).max(1e-6);
    (1.0 - half.log10().floor()).clamp(0.0, 4.0) as usize
}

/// `text` as a coverage image (width, height, one byte per pixel, rows top to bottom).
fn rasterise(font: &FontRef, text: &str, px: f32) -> (u32, u32, Vec<u8>) {
    let scaled = font.as_scaled(PxScale::from(px));
    let ascent = scaled.ascent();
    let height = (ascent - scaled.descent()).ceil().max(1.0) as u32;
    let mut glyphs = Vec::new();
    let mut caret = 0.0f32;
    let mut previous = None;
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(previous) = previous {
            caret += scaled.kern(previous, id);
        }
        glyphs.push(id.with_scale_and_position(px, ab_glyph::point(caret, ascent)));
        caret += scaled.h_advance(id);
        previous = Some(id);
    }
    let width = caret.ceil().max(1.0) as u32;
    let mut coverage = vec![0u8; (width * height) as usize];
    for glyph in glyphs {
        let Some(outline) = font.outline_glyph(glyph) else {
            continue; // a space
        };
        let bounds = outline.px_bounds();
        outline.draw(|x, y, c| {
            let (x, y) = (bounds.min.x as i32 + x as i32, bounds.min.y as i32 + y as i32);
            if (0..width as i32).contains(&x) && (0..height as i32).contains(&y) {
                let i = (y as u32 * width + x as u32) as usize;
                coverage[i] = coverage[i].max((c.clamp(0.0, 1.0) * 255.0).round() as u8);
            }
        });
    }
    (width, height, coverage)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimals_tell_the_values_apart() {
        assert_eq!(decimals_for(3.0), 1);
        assert_eq!(decimals_for(0.2), 2);
        assert_eq!(decimals_for(100.0), 0);
    }

    #[test]
    fn labels_rasterise_with_ink() {
        let font = FontRef::try_from_slice(epaint_default_fonts::HACK_REGULAR).unwrap();
        for text in ["3.0", "m/s", "ρ/ρ0"] {
            let (w, h, coverage) = rasterise(&font, text, 16.0);
            assert!(w >= 3 * 8 && h >= 14, "{text}: {w}x{h}");
            let inked = coverage.iter().filter(|&&c| c > 128).count();
            assert!(inked > 20, "{text}: only {inked} pixels inked");
            // Every character has a glyph in the font (none falls back to the empty box).
            assert!(text.chars().all(|c| font.glyph_id(c).0 != 0), "{text}");
        }
    }
}
