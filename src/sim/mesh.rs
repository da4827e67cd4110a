//! Mesh colliders: a closed triangle mesh (OBJ through `tobj`, STL through `stl_io`), checked to be
//! closed, turned once at load into a signed distance field sampled on a lattice of the grid's
//! spacing around it, in the mesh's own frame (so a moving mesh collider carries its field along).
//!
//! Distance: to the nearest triangle (Ericson's closest point on a triangle). Sign: the generalized
//! winding number (the solid angles of all triangles summed, over 4 pi), which is 1 inside a closed
//! mesh and 0 outside whatever the triangles' orientation, and needs no ray casting. Both are a walk
//! over all triangles per sample, on every core: fine for the few thousand triangles and tens of
//! thousands of samples an obstacle in a scene has (a 1,280-triangle sphere on a 40^3 lattice takes
//! about a second on two cores).

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// A mesh collider's distance field and its triangles (for drawing), in the collider's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSdf {
    pub vertices: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Position of sample (0, 0, 0).
    pub origin: Vec3,
    pub spacing: f32,
    pub dims: [u32; 3],
    /// Signed distances, x fastest; negative inside.
    pub values: Vec<f32>,
    /// Radius of a ball about the local origin that holds the mesh.
    pub bounding_radius: f64,
}

/// Reads an OBJ or STL file's triangles (vertices scaled by `scale`), welded by position.
pub fn read_triangles(path: &Path, scale: f64) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot be opened: {e}"))?;
    parse_triangles(path, &bytes, scale)
}

/// The triangles of an OBJ or STL file's contents (`path`'s extension says which), welded by
/// position, vertices scaled by `scale`: a file read from disk, or one embedded with the presets.
pub fn parse_triangles(path: &Path, bytes: &[u8], scale: f64) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), String> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let (positions, triangles): (Vec<[f64; 3]>, Vec<[u32; 3]>) = match ext.as_str() {
        "obj" => {
            let options = tobj::LoadOptions {
                triangulate: true,
                ignore_points: true,
                ignore_lines: true,
                ..Default::default()
            };
            // Materials play no part in a collider: a `mtllib` line is skipped, not read.
            let (models, _materials) = tobj::load_obj_buf(&mut &bytes[..], &options, |_| {
                Err(tobj::LoadError::OpenFileFailed)
            })
            .map_err(|e| format!("cannot be read as OBJ: {e}"))?;
            let mut positions = Vec::new();
            let mut triangles = Vec::new();
            for model in models {
                let base = positions.len() as u32;
                let m = model.mesh;
                positions.extend(
                    m.positions
                        .chunks_exact(3)
                        .map(|p| [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]),
                );
                triangles.extend(
                    m.indices
                        .chunks_exact(3)
                        .map(|t| [base + t[0], base + t[1], base + t[2]]),
                );
            }
            (positions, triangles)
        }
        "stl" => {
            let mesh = stl_io::read_stl(&mut std::io::Cursor::new(bytes))
                .map_err(|e| format!("cannot be read as STL: {e}"))?;
            (
                mesh.vertices
                    .iter()
                    .map(|v| [f64::from(v.0[0]), f64::from(v.0[1]), f64::from(v.0[2])])
                    .collect(),
                mesh.faces.iter().map(|f| f.vertices.map(|i| i as u32)).collect(),
            )
        }
        _ => return Err("is neither an .obj nor an .stl file".into()),
    };
    if triangles.is_empty() {
        return Err("holds no triangles".into());
    }
    // Weld equal positions, so a mesh written with per-face vertices still shares its edges.
    let mut index_of: HashMap<[u64; 3], u32> = HashMap::new();
    let mut welded = Vec::new();
    let mut remap = Vec::with_capacity(positions.len());
    for p in &positions {
        if !p.iter().all(|c| c.is_finite()) {
            return Err("has a vertex that is not a finite number".into());
        }
        let key = p.map(f64::to_bits);
        let next = welded.len() as u32;
        let i = *index_of.entry(key).or_insert_with(|| {
            welded.push(DVec3::from(*p) * scale);
            next
        });
        remap.push(i);
    }
    let mut out = Vec::with_capacity(triangles.len());
    for t in triangles {
        if t.iter().any(|&i| i as usize >= remap.len()) {
            return Err("has a face that names a vertex it does not have".into());
        }
        let t = t.map(|i| remap[i as usize]);
        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
            out.push(t);
        }
    }
    Ok((welded, out))
}

/// Refuses a mesh that does not enclose a volume: every edge must be shared by exactly two triangles
/// that run along it in opposite directions.
pub fn check_closed(triangles: &[[u32; 3]]) -> Result<(), String> {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    let mut open = 0usize;
    let mut example = None;
    for (&(a, b), &count) in &directed {
        let back = directed.get(&(b, a)).copied().unwrap_or(0);
        if count != 1 || back != 1 {
            open += 1;
            example.get_or_insert((a, b, count, back));
        }
    }
    match example {
        None => Ok(()),
        Some((a, b, count, back)) => Err(format!(
            "is not a closed mesh: {open} edges are not shared by exactly two opposite triangles (e.g. the \
             edge between vertices {} and {} is used {count} time(s) one way and {back} the other, \
             counting vertices from 1 as OBJ does, once those at one position are merged); it has holes, \
             loose faces or flipped triangles",
            a + 1,
            b + 1
        )),
    }
}

/// Distance samples a mesh collider's field may hold at most: the kernels index them with 32 bits.
pub const MAX_SDF_SAMPLES: u64 = u32::MAX as u64;

/// The signed distance field of a closed mesh on a lattice of `spacing` that reaches `margin` past
/// its bounding box on every side, sampled only inside `clip` (a box in the mesh's own frame: the
/// part of space the collider can reach in the tank) where given. Refuses a field of more than
/// `max_bytes` (or [`MAX_SDF_SAMPLES`] samples), naming `name`; says how far it has come on stderr
/// when it takes more than a second (each sample visits every triangle).
pub fn build_sdf(
    name: &str,
    vertices: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    spacing: f64,
    margin: f64,
    clip: Option<(DVec3, DVec3)>,
    max_bytes: u64,
) -> Result<MeshSdf, String> {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for v in &vertices {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    let (mut lo, mut hi) = (lo - margin, hi + margin);
    if let Some((clip_lo, clip_hi)) = clip {
        (lo, hi) = (lo.max(clip_lo), hi.min(clip_hi));
        // A mesh wholly outside the tank still gets a (tiny) field: it never touches the fluid.
        hi = hi.max(lo);
    }
    let origin = lo;
    // In f64 and u64: a mesh far larger than the tank must be refused, not wrap around.
    let cells = ((hi - origin) / spacing).ceil() + 1.0;
    let samples = cells.x * cells.y * cells.z;
    let bytes = samples * 4.0;
    if samples > MAX_SDF_SAMPLES as f64 || bytes > max_bytes as f64 {
        let size = hi - origin;
        return Err(format!(
            "{name}: its distance field would hold {samples:.3e} samples ({:.1} GiB) for the {:.2} x \
             {:.2} x {:.2} m of it that can reach the tank, more than fits (at most {:.1} GiB of this \
             machine's memory and {MAX_SDF_SAMPLES} samples)",
            bytes / (1u64 << 30) as f64,
            size.x,
            size.y,
            size.z,
            max_bytes as f64 / (1u64 << 30) as f64
        ));
    }
    let dims = cells.as_uvec3();
    let tris: Vec<[DVec3; 3]> = triangles
        .iter()
        .map(|t| t.map(|i| vertices[i as usize]))
        .collect();
    let sample = |x: u32, y: u32, z: u32| {
        let p = origin + DVec3::new(f64::from(x), f64::from(y), f64::from(z)) * spacing;
        let mut nearest = f64::INFINITY;
        let mut solid_angle = 0.0;
        for t in &tris {
            nearest = nearest.min((closest_on_triangle(p, t) - p).length_squared());
            solid_angle += triangle_solid_angle(p, t);
        }
        let inside = (solid_angle / (4.0 * std::f64::consts::PI)).abs() > 0.5;
        let d = nearest.sqrt();
        (if inside { -d } else { d }) as f32
    };
    let started = std::time::Instant::now();
    let mut said = false;
    let mut values = Vec::with_capacity(samples as usize);
    for z in 0..dims.z {
        let plane: Vec<f32> = (0..dims.x * dims.y)
            .into_par_iter()
            .with_min_len(64)
            .map(|i| sample(i % dims.x, i / dims.x, z))
            .collect();
        values.extend(plane);
        if started.elapsed().as_secs_f64() > 1.0 {
            eprint!(
                "\rbuilding the distance field of {name}: {}% of {:.1e} samples",
                100 * (z + 1) / dims.z,
                samples
            );
            said = true;
        }
    }
    if said {
        eprintln!();
    }
    let bounding_radius = vertices.iter().map(|v| v.length()).fold(0.0, f64::max);
    Ok(MeshSdf {
        vertices: vertices.iter().map(|v| v.as_vec3()).collect(),
        triangles,
        origin: origin.as_vec3(),
        spacing: spacing as f32,
        dims: dims.to_array(),
        values,
        bounding_radius,
    })
}

/// Closest point of triangle t to p (Ericson, Real-Time Collision Detection, 5.1.5).
fn closest_on_triangle(p: DVec3, t: &[DVec3; 3]) -> DVec3 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// The signed solid angle triangle t subtends at p (Van Oosterom and Strackee).
fn triangle_solid_angle(p: DVec3, t: &[DVec3; 3]) -> f64 {
    let (a, b, c) = (t[0] - p, t[1] - p, t[2] - p);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let numerator = a.dot(b.cross(c));
    let denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * numerator.atan2(denominator)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A unit cube about the origin, its triangles outward (the colliders' tests build a mesh
    /// collider from it too).
    pub(crate) fn cube() -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let v: Vec<DVec3> = (0..8)
            .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64) - 0.5)
            .collect();
        // Outward-facing, counter-clockwise seen from outside.
        let t = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        (v, t)
    }

    #[test]
    fn a_cube_is_closed_and_its_field_is_the_box_distance() {
        let (v, t) = cube();
        check_closed(&t).unwrap();
        let sdf = build_sdf("cube", v, t, 0.1, 0.3, None, u64::MAX).unwrap();
        let at = |i: u32, j: u32, k: u32| {
            let d = sdf.dims;
            let p = sdf.origin + Vec3::new(i as f32, j as f32, k as f32) * sdf.spacing;
            (p, sdf.values[(i + d[0] * (j + d[1] * k)) as usize])
        };
        for (i, j, k) in [(0, 0, 0), (5, 5, 5), (8, 7, 6), (3, 8, 8), (10, 2, 7)] {
            let (p, phi) = at(i, j, k);
            let q = p.abs() - Vec3::splat(0.5);
            let exact = q.max(Vec3::ZERO).length() + q.max_element().min(0.0);
            assert!((phi - exact).abs() < 1e-5, "at {p}: {phi} vs {exact}");
        }
    }

    #[test]
    fn a_cube_missing_a_face_is_refused() {
        let (_, mut t) = cube();
        t.pop();
        let why = check_closed(&t).unwrap_err();
        assert!(why.contains("not a closed mesh"), "{why}");
    }
}
