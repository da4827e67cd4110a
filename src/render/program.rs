//! Small OpenGL helpers shared by the renderer's parts: compiling and linking GLSL programs, setting
//! uniforms by name, and turning glow's string errors into messages that say what was being made.
//!
//! Every `unsafe fn` here has one requirement: the context `gl` is current on this thread, and the
//! objects passed are its own.

use anyhow::{anyhow, Result};
use glam::{Mat3, Mat4};
use glow::HasContext;

/// The `#version` line for the context: GLSL 3.30 core runs on every GL 3.3+ core context (and the
/// 4.x ones this viewer asks for first).
const GLSL_HEADER: &str = "#version 330 core\n";

/// A triangle that covers the viewport, from gl_VertexID (no buffer): the vertex stage of every
/// full-screen pass. `v_uv` runs from 0 to 1 across the viewport.
pub const FULLSCREEN_VS: &str = r#"
out vec2 v_uv;
void main() {
    vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    v_uv = corner;
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
"#;

pub fn gl_error(what: &'static str) -> impl Fn(String) -> anyhow::Error {
    move |e| anyhow!("OpenGL could not create {what}: {e}")
}

pub unsafe fn set_mat4(gl: &glow::Context, program: glow::Program, name: &str, m: &Mat4) {
    unsafe {
        let loc = gl.get_uniform_location(program, name);
        gl.uniform_matrix_4_f32_slice(loc.as_ref(), false, &m.to_cols_array());
    }
}

pub unsafe fn set_mat3(gl: &glow::Context, program: glow::Program, name: &str, m: &Mat3) {
    unsafe {
        let loc = gl.get_uniform_location(program, name);
        gl.uniform_matrix_3_f32_slice(loc.as_ref(), false, &m.to_cols_array());
    }
}

pub unsafe fn set_f32(gl: &glow::Context, program: glow::Program, name: &str, value: f32) {
    unsafe {
        let loc = gl.get_uniform_location(program, name);
        gl.uniform_1_f32(loc.as_ref(), value);
    }
}

pub unsafe fn set_vec2(gl: &glow::Context, program: glow::Program, name: &str, v: [f32; 2]) {
    unsafe {
        let loc = gl.get_uniform_location(program, name);
        gl.uniform_2_f32(loc.as_ref(), v[0], v[1]);
    }
}

pub unsafe fn set_vec3(gl: &glow::Context, program: glow::Program, name: &str, v: [f32; 3]) {
    unsafe {
        let loc = gl.get_uniform_location(program, name);
        gl.uniform_3_f32(loc.as_ref(), v[0], v[1], v[2]);
    }
}

pub unsafe fn set_i32(gl: &glow::Context, program: glow::Program, name: &str, value: i32) {
    unsafe {
        let loc = gl.get_uniform_location(program, name);
        gl.uniform_1_i32(loc.as_ref(), value);
    }
}

/// Binds `texture` to texture unit `unit` and points the sampler uniform `name` at it.
pub unsafe fn bind_texture(
    gl: &glow::Context,
    program: glow::Program,
    name: &str,
    unit: u32,
    texture: glow::Texture,
) {
    unsafe { bind_texture_as(gl, program, name, unit, glow::TEXTURE_2D, Some(texture)) }
}

/// [`bind_texture`] for a texture of another `target` (`TEXTURE_2D_ARRAY`), or none.
pub unsafe fn bind_texture_as(
    gl: &glow::Context,
    program: glow::Program,
    name: &str,
    unit: u32,
    target: u32,
    texture: Option<glow::Texture>,
) {
    unsafe {
        gl.active_texture(glow::TEXTURE0 + unit);
        gl.bind_texture(target, texture);
        set_i32(gl, program, name, unit as i32);
    }
}

/// The bound `target` texture's sampling: `filter` both ways, clamped to its edges.
pub unsafe fn set_sampling(gl: &glow::Context, target: u32, filter: u32) {
    unsafe {
        for (parameter, value) in [
            (glow::TEXTURE_MIN_FILTER, filter),
            (glow::TEXTURE_MAG_FILTER, filter),
            (glow::TEXTURE_WRAP_S, glow::CLAMP_TO_EDGE),
            (glow::TEXTURE_WRAP_T, glow::CLAMP_TO_EDGE),
        ] {
            gl.tex_parameter_i32(target, parameter, value as i32);
        }
    }
}

/// Compiles and links one program; `prelude` (shared GLSL functions) follows the version line.
pub unsafe fn link(
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
