//! The mass properties of a collider's shape: what a rigid body made of it weighs and how it turns
//! (issue 42's floating bodies take their mass and inertia from here).
//!
//! Everything is per unit density, in the shape's own frame: a body of density rho has mass rho
//! `volume` and inertia tensor rho `inertia` about its centroid. The primitives have closed forms;
//! a closed mesh is split into tetrahedra from the origin (the divergence theorem: each signed
//! tetrahedron adds its volume and second moments, and those outside the mesh cancel), after Blow
//! and Binstock's and Tonon's formulas for a tetrahedron's covariance.

use super::Shape;
use glam::{DMat3, DVec3};

/// A shape's volume, centroid and inertia about the centroid, per unit density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProperties {
    /// m^3.
    pub volume: f64,
    /// m, in the shape's frame (the origin for every primitive).
    pub centroid: DVec3,
    /// m^5: the inertia tensor about the centroid, axes of the shape's frame, per kg/m^3.
    pub inertia: DMat3,
}

impl Shape {
    /// The shape's [`MassProperties`] (module docs).
    pub fn mass_properties(&self) -> MassProperties {
        use std::f64::consts::PI;
        let at_origin = |volume: f64, diagonal: DVec3| MassProperties {
            volume,
            centroid: DVec3::ZERO,
            inertia: DMat3::from_diagonal(diagonal),
        };
        match self {
            Shape::Box { half_extents: h } => {
                let volume = 8.0 * h.x * h.y * h.z;
                let sq = *h * *h;
                at_origin(
                    volume,
                    volume / 3.0 * DVec3::new(sq.y + sq.z, sq.x + sq.z, sq.x + sq.y),
                )
            }
            Shape::Sphere { radius: r } => {
                let volume = 4.0 / 3.0 * PI * r.powi(3);
                at_origin(volume, DVec3::splat(0.4 * volume * r * r))
            }
            Shape::Cylinder {
                radius: r,
                half_length: h,
            } => {
                let volume = PI * r * r * 2.0 * h;
                let across = volume * (3.0 * r * r + 4.0 * h * h) / 12.0;
                at_origin(volume, DVec3::new(across, 0.5 * volume * r * r, across))
            }
            Shape::Capsule {
                radius: r,
                half_length: h,
            } => {
                // The cylinder between the caps, and two hemispheres whose flat faces sit at +-h: a
                // hemisphere of volume v has 2/5 v r^2 about any diameter of its face, and its
                // centroid 3r/8 past the face, which the parallel-axis theorem moves to the centre.
                let cylinder = PI * r * r * 2.0 * h;
                let cap = 2.0 / 3.0 * PI * r.powi(3);
                let along = 0.5 * cylinder * r * r + 2.0 * 0.4 * cap * r * r;
                let across = cylinder * (3.0 * r * r + 4.0 * h * h) / 12.0
                    + 2.0 * (0.4 * cap * r * r + cap * (h * h + 0.75 * h * r));
                at_origin(cylinder + 2.0 * cap, DVec3::new(across, along, across))
            }
            Shape::Mesh(mesh) => {
                let vertices: Vec<DVec3> = mesh.vertices.iter().map(|v| v.as_dvec3()).collect();
                triangles_mass_properties(&vertices, &mesh.triangles)
            }
        }
    }
}

impl Shape {
    /// The shape's surface area, m^2.
    pub fn surface_area(&self) -> f64 {
        use std::f64::consts::PI;
        match self {
            Shape::Box { half_extents: h } => 8.0 * (h.x * h.y + h.y * h.z + h.x * h.z),
            Shape::Sphere { radius: r } => 4.0 * PI * r * r,
            Shape::Cylinder {
                radius: r,
                half_length: h,
            } => 2.0 * PI * r * (2.0 * h + r),
            Shape::Capsule {
                radius: r,
                half_length: h,
            } => 2.0 * PI * r * (2.0 * h + 2.0 * r),
            Shape::Mesh(mesh) => mesh
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| mesh.vertices[i as usize].as_dvec3());
                    0.5 * (b - a).cross(c - a).length()
                })
                .sum(),
        }
    }
}

/// The [`MassProperties`] of the solid a closed triangle mesh bounds. Its triangles may wind either
/// way round, all the same way (the mesh loader checks closure, not winding): wound clockwise
/// seen from outside, every tetrahedron's sign flips, and so the sums are negated back.
pub fn triangles_mass_properties(vertices: &[DVec3], triangles: &[[u32; 3]]) -> MassProperties {
    // The canonical tetrahedron's covariance (second moments about the origin of the unit
    // tetrahedron (0, e_x, e_y, e_z), per unit of its determinant): 1/60 on the diagonal, 1/120 off.
    let canonical = DMat3::from_cols_array(&[
        2.0, 1.0, 1.0, //
        1.0, 2.0, 1.0, //
        1.0, 1.0, 2.0,
    ]) * (1.0 / 120.0);
    let (mut volume, mut first, mut covariance) = (0.0, DVec3::ZERO, DMat3::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        let frame = DMat3::from_cols(a, b, c);
        let det = frame.determinant();
        volume += det / 6.0;
        first += det / 24.0 * (a + b + c);
        covariance += frame * canonical * frame.transpose() * det;
    }
    if volume < 0.0 {
        (volume, first, covariance) = (-volume, -first, -covariance);
    }
    from_moments(volume, first, covariance)
}

/// The [`MassProperties`] of a solid from its moments about the origin: its volume, first moment
/// (the integral of x) and covariance (the integral of x x^T).
fn from_moments(volume: f64, first: DVec3, covariance: DMat3) -> MassProperties {
    let centroid = first / volume;
    // Moved to the centroid: C_c = C - V c c^T; the inertia is tr(C) I - C.
    let about_centroid = covariance - outer(centroid, centroid) * volume;
    let trace = about_centroid.x_axis.x + about_centroid.y_axis.y + about_centroid.z_axis.z;
    MassProperties {
        volume,
        centroid,
        inertia: DMat3::from_diagonal(DVec3::splat(trace)) - about_centroid,
    }
}

fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn largest(m: DMat3) -> f64 {
        m.to_cols_array().iter().fold(0.0f64, |a, x| a.max(x.abs()))
    }

    /// A box's 12 triangles, counter-clockwise from outside, offset by `shift`.
    fn box_mesh(h: DVec3, shift: DVec3) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let vertices = (0..8)
            .map(|i| {
                let s = DVec3::new(
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                );
                s * h + shift
            })
            .collect();
        let faces = [
            [0, 2, 3, 1], // -z
            [4, 5, 7, 6], // +z
            [0, 1, 5, 4], // -y
            [2, 6, 7, 3], // +y
            [0, 4, 6, 2], // -x
            [1, 3, 7, 5], // +x
        ];
        let triangles = faces
            .iter()
            .flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
            .collect();
        (vertices, triangles)
    }

    /// Mass properties by summing a fine lattice of points inside `inside` (midpoints of cells of
    /// edge `step` over the cube of half-width `reach`).
    fn sampled(inside: impl Fn(DVec3) -> bool, reach: f64, step: f64) -> MassProperties {
        let n = (2.0 * reach / step).round() as i32;
        let cell = step.powi(3);
        let (mut volume, mut first, mut second) = (0.0, DVec3::ZERO, DMat3::ZERO);
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let p = DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * step - reach;
                    if inside(p) {
                        volume += cell;
                        first += p * cell;
                        second += outer(p, p) * cell;
                    }
                }
            }
        }
        from_moments(volume, first, second)
    }

    #[test]
    fn a_box_mesh_has_the_box_s_mass_properties_wherever_it_is_and_however_it_winds() {
        let h = DVec3::new(0.3, 0.1, 0.2);
        let exact = Shape::Box { half_extents: h }.mass_properties();
        assert!((exact.volume - 0.048).abs() < 1e-15);
        for (shift, inside_out) in [
            (DVec3::ZERO, false),
            (DVec3::new(1.5, -2.0, 0.7), false),
            (DVec3::ZERO, true),
        ] {
            let (v, mut t) = box_mesh(h, shift);
            if inside_out {
                t.iter_mut().for_each(|tri| tri.swap(1, 2));
            }
            let mesh = triangles_mass_properties(&v, &t);
            assert!(
                (mesh.volume - exact.volume).abs() < 1e-12 * exact.volume,
                "{mesh:?}"
            );
            assert!((mesh.centroid - shift).length() < 1e-12, "{mesh:?}");
            assert!(
                largest(mesh.inertia - exact.inertia) < 1e-12 * largest(exact.inertia),
                "{mesh:?}"
            );
        }
    }

    #[test]
    fn a_rotated_box_mesh_turns_its_inertia_with_it() {
        let h = DVec3::new(0.3, 0.1, 0.2);
        let turn = glam::DQuat::from_axis_angle(DVec3::new(1.0, 2.0, -0.5).normalize(), 0.7);
        let (v, t) = box_mesh(h, DVec3::ZERO);
        let v: Vec<DVec3> = v.iter().map(|p| turn * *p).collect();
        let mesh = triangles_mass_properties(&v, &t);
        let r = DMat3::from_quat(turn);
        let expected = r * Shape::Box { half_extents: h }.mass_properties().inertia * r.transpose();
        assert!(
            largest(mesh.inertia - expected) < 1e-12 * largest(expected),
            "{mesh:?}"
        );
    }

    /// The primitives' closed forms against a lattice sum over the same solid, to the lattice's
    /// accuracy (a cell of 1/200 of the size: about 1 % for the volume at the surface).
    #[test]
    fn the_primitives_closed_forms_match_a_sum_over_their_volume() {
        let (r, h) = (0.1f64, 0.15f64);
        type Inside = Box<dyn Fn(DVec3) -> bool>;
        let cases: Vec<(Shape, Inside)> = vec![
            (
                Shape::Sphere { radius: r },
                Box::new(move |p: DVec3| p.length() <= r),
            ),
            (
                Shape::Cylinder {
                    radius: r,
                    half_length: h,
                },
                Box::new(move |p: DVec3| p.x * p.x + p.z * p.z <= r * r && p.y.abs() <= h),
            ),
            (
                Shape::Capsule {
                    radius: r,
                    half_length: h,
                },
                Box::new(move |p: DVec3| {
                    let axis = DVec3::new(0.0, p.y.clamp(-h, h), 0.0);
                    (p - axis).length() <= r
                }),
            ),
        ];
        for (shape, inside) in cases {
            let exact = shape.mass_properties();
            let sum = sampled(inside, h + r, (h + r) / 100.0);
            let volume_error = (sum.volume / exact.volume - 1.0).abs();
            let inertia_error = largest(sum.inertia - exact.inertia) / largest(exact.inertia);
            assert!(
                volume_error < 0.01 && inertia_error < 0.02 && sum.centroid.length() < 1e-3 * r,
                "{}: volume {volume_error:.2e}, inertia {inertia_error:.2e} apart",
                shape.kind_name()
            );
        }
    }
}
