//! Colliders in the viewer and `mpm render`: each is drawn as a solid, shaded triangle mesh in its
//! pose at the current simulated time (so a wave maker's paddle moves), and in the window a collider
//! can be dragged with Ctrl + left mouse button: it follows the cursor in the plane facing the camera
//! as a kinematic body, its velocity that of the drag, so the fluid it meets is pushed accordingly.

use super::camera::OrbitCamera;
use super::program::{gl_error, link, set_mat4};
use crate::sim::colliders::{ColliderFrame, ColliderState, Colliders, Shape, BOUNDARY_PIPE};
use crate::sim::{Simulation, FRAME_DT};
use anyhow::Result;
use glam::{DVec3, Mat4, Vec2, Vec3, Vec4};
use glow::HasContext;
use std::sync::Arc;

/// Segments around a sphere, capsule or cylinder.
const ROUND_SEGMENTS: usize = 32;
/// The fastest a dragged collider is moved, m/s: a flick of the mouse must not blow the fluid up.
pub const MAX_DRAG_SPEED: f64 = 5.0;

/// The triangles of a collider's shape in its own frame (the one `ColliderState` places), with the
/// outward normal of each vertex: position, normal.
pub fn shape_triangles(shape: &Shape) -> Vec<[Vec3; 2]> {
    let mut out = Vec::new();
    // A vertex of a round surface: its normal from a centre point.
    let mut tri = |a: [Vec3; 2], b: [Vec3; 2], c: [Vec3; 2]| out.extend([a, b, c]);
    match shape {
        Shape::Box { half_extents } => {
            let h = half_extents.as_vec3();
            for axis in 0..3 {
                for sign in [-1.0f32, 1.0] {
                    let mut n = Vec3::ZERO;
                    n[axis] = sign;
                    let (u, v) = (Vec3::AXES[(axis + 1) % 3], Vec3::AXES[(axis + 2) % 3]);
                    let corner = |s: f32, t: f32| [(n + u * s + v * t) * h, n];
                    // Counter-clockwise seen from outside.
                    let (a, b, c, d) = (
                        corner(-1.0, -1.0),
                        corner(1.0, -1.0),
                        corner(1.0, 1.0),
                        corner(-1.0, 1.0),
                    );
                    if sign > 0.0 {
                        tri(a, b, c);
                        tri(a, c, d);
                    } else {
                        tri(a, c, b);
                        tri(a, d, c);
                    }
                }
            }
        }
        Shape::Sphere { radius } => round(&mut tri, *radius as f32, 0.0, true),
        Shape::Capsule { radius, half_length } => round(&mut tri, *radius as f32, *half_length as f32, true),
        Shape::Cylinder { radius, half_length } => {
            round(&mut tri, *radius as f32, *half_length as f32, false)
        }
        Shape::Mesh(mesh) => {
            for t in &mesh.triangles {
                let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
                // Flat shading; the normal's sign follows the winding, so it is taken two-sided.
                let n = (b - a).cross(c - a).normalize_or_zero();
                tri([a, n], [b, n], [c, n]);
            }
        }
    }
    out
}

/// A sphere (`half_length` 0), a capsule (`caps`), or a cylinder along local y.
fn round(tri: &mut impl FnMut([Vec3; 2], [Vec3; 2], [Vec3; 2]), radius: f32, half_length: f32, caps: bool) {
    let n = ROUND_SEGMENTS;
    let ring = |k: usize| {
        let a = std::f32::consts::TAU * k as f32 / n as f32;
        Vec3::new(a.cos(), 0.0, a.sin())
    };
    if caps {
        // Two hemispheres of latitude rings, shifted by -+half_length, and the side band between
        // their equators (none for a sphere).
        let steps = (n / 4) as i32;
        let point = |i: i32, k: usize, shift: f32| {
            let phi = std::f32::consts::FRAC_PI_2 * i as f32 / steps as f32;
            let dir = ring(k) * phi.cos() + Vec3::Y * phi.sin();
            [dir * radius + Vec3::Y * shift, dir]
        };
        for i in -steps..steps {
            let shift = if i < 0 { -half_length } else { half_length };
            for k in 0..n {
                let (a, b) = (point(i, k, shift), point(i, k + 1, shift));
                let (c, d) = (point(i + 1, k + 1, shift), point(i + 1, k, shift));
                tri(a, c, b);
                tri(a, d, c);
            }
        }
        if half_length > 0.0 {
            for k in 0..n {
                let (a, b) = (point(0, k, -half_length), point(0, k + 1, -half_length));
                let (c, d) = (point(0, k + 1, half_length), point(0, k, half_length));
                tri(a, c, b);
                tri(a, d, c);
            }
        }
    } else {
        for k in 0..n {
            let (p, q) = (ring(k), ring(k + 1));
            let lo = |r: Vec3| [r * radius - Vec3::Y * half_length, r];
            let hi = |r: Vec3| [r * radius + Vec3::Y * half_length, r];
            tri(lo(p), hi(q), lo(q));
            tri(lo(p), hi(p), hi(q));
            let (top, bottom) = (Vec3::Y * half_length, -Vec3::Y * half_length);
            tri(
                [top, Vec3::Y],
                [q * radius + top, Vec3::Y],
                [p * radius + top, Vec3::Y],
            );
            tri(
                [bottom, -Vec3::Y],
                [p * radius + bottom, -Vec3::Y],
                [q * radius + bottom, -Vec3::Y],
            );
        }
    }
}

/// World-from-local of a collider state.
fn model_matrix(s: &ColliderState) -> Mat4 {
    let r = &s.rotation;
    Mat4::from_cols(
        Vec4::new(r[0], r[3], r[6], 0.0),
        Vec4::new(r[1], r[4], r[7], 0.0),
        Vec4::new(r[2], r[5], r[8], 0.0),
        Vec3::from(s.center).extend(1.0),
    )
}

const VS: &str = r#"
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
uniform mat4 u_view_proj;
uniform mat4 u_model;
uniform vec3 u_lo;
uniform vec3 u_hi;
out vec3 v_normal;
out float gl_ClipDistance[6];
void main() {
    v_normal = mat3(u_model) * a_normal;
    vec4 world = u_model * vec4(a_position, 1.0);
    // Cut away what reaches past the tank (a paddle or a slope through the walls).
    for (int a = 0; a < 3; ++a) {
        gl_ClipDistance[a] = world[a] - u_lo[a];
        gl_ClipDistance[a + 3] = u_hi[a] - world[a];
    }
    gl_Position = u_view_proj * world;
}
"#;

// Two-sided Lambert shading in a warm grey, so obstacles read apart from the coloured water.
const FS: &str = r#"
in vec3 v_normal;
out vec4 o_colour;
void main() {
    vec3 n = normalize(gl_FrontFacing ? v_normal : -v_normal);
    vec3 light = normalize(vec3(0.4, 0.7, 0.6));
    float diffuse = abs(dot(n, light));
    o_colour = vec4(vec3(0.62, 0.58, 0.52) * (0.35 + 0.65 * diffuse), 1.0);
}
"#;

struct GpuMesh {
    vao: glow::VertexArray,
    vbo: glow::Buffer,
    vertices: i32,
}

/// The colliders' meshes on the GPU, built once per scene.
pub struct ColliderRenderer {
    gl: Arc<glow::Context>,
    program: glow::Program,
    meshes: Vec<GpuMesh>,
}

impl ColliderRenderer {
    /// Uploads a mesh per collider (none for a scene without colliders).
    pub fn new(gl: Arc<glow::Context>, colliders: &Colliders) -> Result<ColliderRenderer> {
        // SAFETY: the caller's GL context is current on this thread; every object is created here.
        unsafe {
            let program = link(&gl, "colliders", &[VS], &[FS], "")?;
            let mut meshes = Vec::with_capacity(colliders.len());
            for collider in &colliders.list {
                let vertices = shape_triangles(&collider.shape);
                let vao = gl.create_vertex_array().map_err(gl_error("a vertex array"))?;
                let vbo = gl.create_buffer().map_err(gl_error("a buffer"))?;
                gl.bind_vertex_array(Some(vao));
                gl.bind_buffer(glow::ARRAY_BUFFER, Some(vbo));
                gl.buffer_data_u8_slice(
                    glow::ARRAY_BUFFER,
                    bytemuck::cast_slice(&vertices),
                    glow::STATIC_DRAW,
                );
                gl.enable_vertex_attrib_array(0);
                gl.vertex_attrib_pointer_f32(0, 3, glow::FLOAT, false, 24, 0);
                gl.enable_vertex_attrib_array(1);
                gl.vertex_attrib_pointer_f32(1, 3, glow::FLOAT, false, 24, 12);
                meshes.push(GpuMesh {
                    vao,
                    vbo,
                    vertices: vertices.len() as i32,
                });
            }
            gl.bind_vertex_array(None);
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
            Ok(ColliderRenderer { gl, program, meshes })
        }
    }

    /// Draws every collider in its pose of `frame` into the pass under way (its framebuffer and
    /// viewport), depth-tested, and cut off at the faces of the box `domain` (lo, hi).
    pub fn draw_in_pass(&self, view_proj: &Mat4, frame: &ColliderFrame, domain: (Vec3, Vec3)) {
        if self.meshes.is_empty() {
            return;
        }
        let gl = &self.gl;
        // SAFETY: our objects; the context is current.
        unsafe {
            gl.enable(glow::DEPTH_TEST);
            gl.depth_func(glow::LESS);
            gl.use_program(Some(self.program));
            set_mat4(gl, self.program, "u_view_proj", view_proj);
            for (name, corner) in [("u_lo", domain.0), ("u_hi", domain.1)] {
                let loc = gl.get_uniform_location(self.program, name);
                gl.uniform_3_f32(loc.as_ref(), corner.x, corner.y, corner.z);
            }
            for plane in 0..6 {
                gl.enable(glow::CLIP_DISTANCE0 + plane);
            }
            for (mesh, state) in self.meshes.iter().zip(&frame.states) {
                set_mat4(gl, self.program, "u_model", &model_matrix(state));
                gl.bind_vertex_array(Some(mesh.vao));
                gl.draw_arrays(glow::TRIANGLES, 0, mesh.vertices);
            }
            gl.bind_vertex_array(None);
            gl.use_program(None);
            for plane in 0..6 {
                gl.disable(glow::CLIP_DISTANCE0 + plane);
            }
        }
    }

    /// Deletes the GL objects (the context must be current).
    pub fn destroy(&mut self) {
        // SAFETY: our objects, deleted once.
        unsafe {
            for mesh in self.meshes.drain(..) {
                self.gl.delete_vertex_array(mesh.vao);
                self.gl.delete_buffer(mesh.vbo);
            }
            self.gl.delete_program(self.program);
        }
    }
}

/// The first collider a ray hits, and where: sphere tracing along the colliders' distance fields.
pub fn pick(
    frame: &ColliderFrame,
    origin: Vec3,
    direction: Vec3,
    max_distance: f32,
) -> Option<(usize, Vec3)> {
    let direction = direction.normalize_or_zero();
    let mut best: Option<(usize, f32)> = None;
    for (index, state) in frame.states.iter().enumerate() {
        if state.boundary == BOUNDARY_PIPE {
            continue; // a nozzle's pipe is the emitter's, not a body to drag
        }
        let mut t = 0.0f32;
        for _ in 0..256 {
            let (phi, _) = frame.distance(state, origin + direction * t);
            if phi < 1e-4 {
                if best.is_none_or(|(_, b)| t < b) {
                    best = Some((index, t));
                }
                break;
            }
            // A mesh is far (infinite) outside its sampled box: step to the box at a bounded pace.
            t += if phi.is_finite() { phi } else { 0.05 * max_distance };
            if t > max_distance {
                break;
            }
        }
    }
    best.map(|(index, t)| (index, origin + direction * t))
}

/// A collider held by the mouse: it moves in the plane through the grab point facing the camera.
#[derive(Debug, Clone, Copy)]
pub struct ColliderDrag {
    pub index: usize,
    plane_point: Vec3,
    plane_normal: Vec3,
    /// Collider centre minus grab point.
    offset: Vec3,
}

impl ColliderDrag {
    /// Starts a drag where the cursor's ray hits a collider, if it does.
    pub fn grab(
        sim: &Simulation,
        camera: &OrbitCamera,
        cursor: Vec2,
        viewport_size: Vec2,
    ) -> Option<ColliderDrag> {
        let frame = sim.collider_frame();
        let (origin, direction) = camera.ray(cursor, viewport_size);
        let (index, hit) = pick(&frame, origin, direction, 4.0 * camera.distance)?;
        Some(ColliderDrag {
            index,
            plane_point: hit,
            plane_normal: (camera.target - camera.eye()).normalize(),
            offset: Vec3::from(frame.states[index].center) - hit,
        })
    }

    /// Moves the held collider so that it reaches the cursor's point of the drag plane after `frames`
    /// 60 Hz frames, at a constant velocity (capped at [`MAX_DRAG_SPEED`]).
    pub fn follow(
        &self,
        sim: &mut Simulation,
        camera: &OrbitCamera,
        cursor: Vec2,
        viewport_size: Vec2,
        frames: u32,
    ) -> Result<()> {
        let (origin, direction) = camera.ray(cursor, viewport_size);
        let denominator = direction.dot(self.plane_normal);
        if denominator.abs() < 1e-6 {
            return Ok(()); // the ray runs along the plane: hold still
        }
        let t = (self.plane_point - origin).dot(self.plane_normal) / denominator;
        let target = (origin + direction * t + self.offset).as_dvec3();
        let center = DVec3::from(sim.collider_frame().states[self.index].center.map(f64::from));
        let span = f64::from(frames.max(1)) * f64::from(FRAME_DT);
        let velocity = ((target - center) / span).clamp_length_max(MAX_DRAG_SPEED);
        sim.drag_collider(self.index, center, velocity)
    }

    /// Lets go: the collider stays where it is, at rest.
    pub fn release(&self, sim: &mut Simulation) -> Result<()> {
        let center = DVec3::from(sim.collider_frame().states[self.index].center.map(f64::from));
        sim.drag_collider(self.index, center, DVec3::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every triangle's winding agrees with its vertex normals (outward), and the vertices lie on the
    /// shape's surface: the meshes drawn are the shapes the solver sees.
    #[test]
    fn shape_meshes_lie_on_the_surface_and_face_outward() {
        let shapes = [
            Shape::Box {
                half_extents: DVec3::new(0.1, 0.2, 0.3),
            },
            Shape::Sphere { radius: 0.2 },
            Shape::Capsule {
                radius: 0.1,
                half_length: 0.2,
            },
            Shape::Cylinder {
                radius: 0.1,
                half_length: 0.2,
            },
        ];
        for shape in shapes {
            let triangles = shape_triangles(&shape);
            assert!(!triangles.is_empty() && triangles.len() % 3 == 0);
            let colliders = Colliders::new(
                vec![crate::sim::colliders::Collider {
                    shape: shape.clone(),
                    boundary: crate::sim::colliders::Boundary::Slip,
                    center: DVec3::ZERO,
                    rotation: glam::DQuat::IDENTITY,
                    motion: crate::sim::colliders::Motion::Static,
                    body: None,
                }],
                0.01,
            );
            let frame = colliders.frame(0.0);
            for t in triangles.chunks_exact(3) {
                let face = (t[1][0] - t[0][0]).cross(t[2][0] - t[0][0]);
                let normal = t[0][1] + t[1][1] + t[2][1];
                if face.length() > 1e-9 {
                    assert!(
                        face.dot(normal) > 0.0,
                        "{}: a triangle faces inward",
                        shape.kind_name()
                    );
                }
                for [p, _] in t {
                    let (phi, _) = frame.distance(&frame.states[0], *p);
                    assert!(
                        phi.abs() < 1e-5,
                        "{}: vertex {p} is {phi} m off the surface",
                        shape.kind_name()
                    );
                }
            }
        }
    }

    #[test]
    fn a_ray_picks_the_nearest_collider() {
        let sphere = |x: f64| crate::sim::colliders::Collider {
            shape: Shape::Sphere { radius: 0.1 },
            boundary: crate::sim::colliders::Boundary::Slip,
            center: DVec3::new(x, 0.0, 0.0),
            rotation: glam::DQuat::IDENTITY,
            motion: crate::sim::colliders::Motion::Static,
            body: None,
        };
        let frame = Colliders::new(vec![sphere(1.0), sphere(0.5)], 0.01).frame(0.0);
        let (index, hit) = pick(&frame, Vec3::ZERO, Vec3::X, 10.0).expect("a hit");
        assert_eq!(index, 1);
        assert!((hit - Vec3::new(0.4, 0.0, 0.0)).length() < 1e-3, "{hit}");
        assert!(pick(&frame, Vec3::ZERO, Vec3::Y, 10.0).is_none());
    }
}
