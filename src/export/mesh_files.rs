//! Triangle-mesh files that Blender, ParaView and meshio open as they are: Wavefront OBJ (text),
//! binary little-endian PLY, and legacy VTK (binary unstructured grid of triangles). Each carries
//! per-vertex normals, and triangles wind counter-clockwise seen from outside (the normal is
//! `(b - a) x (c - a)`, pointing out of the water), which is what all three tools expect.

use anyhow::Result;
use std::io::Write;

/// A triangle mesh: shared vertices, their unit normals, and triangles as vertex indices.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SurfaceMesh {
    pub vertices: Vec<[f32; 3]>,
    /// One unit normal per vertex, pointing outward (out of the water, out of a body).
    pub normals: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

/// The file formats of `--surface-format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SurfaceFormat {
    /// Wavefront OBJ (text, with normals): Blender, meshio, most 3D tools; ParaView one file at a time.
    Obj,
    /// Binary little-endian PLY, a third of OBJ's size: Blender, ParaView (as a series), meshio.
    Ply,
    /// Legacy VTK, binary (an unstructured grid of triangles): ParaView (as a series), meshio.
    Vtk,
}

impl SurfaceFormat {
    pub const ALL: [SurfaceFormat; 3] = [SurfaceFormat::Obj, SurfaceFormat::Ply, SurfaceFormat::Vtk];

    pub fn extension(self) -> &'static str {
        match self {
            SurfaceFormat::Obj => "obj",
            SurfaceFormat::Ply => "ply",
            SurfaceFormat::Vtk => "vtk",
        }
    }

    /// Writes `mesh` with `comment` (one or more lines) in the file's header.
    pub fn write(self, out: impl Write, comment: &str, mesh: &SurfaceMesh) -> Result<()> {
        match self {
            SurfaceFormat::Obj => write_obj(out, comment, mesh),
            SurfaceFormat::Ply => write_ply(out, comment, mesh),
            SurfaceFormat::Vtk => write_vtk(out, comment, mesh),
        }
    }
}

pub fn write_obj(mut out: impl Write, comment: &str, mesh: &SurfaceMesh) -> Result<()> {
    write_comment(&mut out, comment)?;
    write_obj_mesh(&mut out, mesh, 0)?;
    out.flush()?;
    Ok(())
}

/// One OBJ of several meshes, each an object (`o NAME`) that Blender imports as an object of its own:
/// `objects` as (name, mesh).
pub fn write_obj_objects(
    mut out: impl Write,
    comment: &str,
    objects: &[(String, SurfaceMesh)],
) -> Result<()> {
    write_comment(&mut out, comment)?;
    let mut before = 0;
    for (name, mesh) in objects {
        writeln!(out, "o {name}")?;
        write_obj_mesh(&mut out, mesh, before)?;
        before += mesh.vertices.len() as u64;
    }
    out.flush()?;
    Ok(())
}

fn write_comment(out: &mut impl Write, comment: &str) -> Result<()> {
    for line in comment.lines() {
        writeln!(out, "# {line}")?;
    }
    Ok(())
}

/// `mesh`'s vertices, normals and faces, after `before` vertices (and normals) of the file.
fn write_obj_mesh(out: &mut impl Write, mesh: &SurfaceMesh, before: u64) -> Result<()> {
    writeln!(
        out,
        "# {} vertices, {} triangles",
        mesh.vertices.len(),
        mesh.triangles.len()
    )?;
    for [x, y, z] in &mesh.vertices {
        writeln!(out, "v {x} {y} {z}")?;
    }
    for [x, y, z] in &mesh.normals {
        writeln!(out, "vn {x} {y} {z}")?;
    }
    // OBJ counts from 1, through the whole file; each corner names its vertex and its normal (the
    // same index).
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| before + u64::from(i) + 1);
        writeln!(out, "f {a}//{a} {b}//{b} {c}//{c}")?;
    }
    Ok(())
}

pub fn write_ply(mut out: impl Write, comment: &str, mesh: &SurfaceMesh) -> Result<()> {
    writeln!(out, "ply\nformat binary_little_endian 1.0")?;
    for line in comment.lines() {
        writeln!(out, "comment {line}")?;
    }
    writeln!(out, "element vertex {}", mesh.vertices.len())?;
    for p in ["x", "y", "z", "nx", "ny", "nz"] {
        writeln!(out, "property float {p}")?;
    }
    writeln!(out, "element face {}", mesh.triangles.len())?;
    writeln!(out, "property list uchar uint vertex_indices\nend_header")?;
    for (v, n) in mesh.vertices.iter().zip(&mesh.normals) {
        for value in v.iter().chain(n) {
            out.write_all(&value.to_le_bytes())?;
        }
    }
    for t in &mesh.triangles {
        out.write_all(&[3])?;
        for i in t {
            out.write_all(&i.to_le_bytes())?;
        }
    }
    out.flush()?;
    Ok(())
}

/// Legacy VTK 3.0, binary (big-endian, as the format requires), an unstructured grid of triangles
/// (cell type 5) with the normals as point data: the dataset type every VTK reader and meshio read.
pub fn write_vtk(mut out: impl Write, comment: &str, mesh: &SurfaceMesh) -> Result<()> {
    // The title is one line of at most 255 characters.
    let title: String = comment
        .lines()
        .collect::<Vec<_>>()
        .join("; ")
        .chars()
        .take(255)
        .collect();
    writeln!(
        out,
        "# vtk DataFile Version 3.0\n{title}\nBINARY\nDATASET UNSTRUCTURED_GRID"
    )?;
    writeln!(out, "POINTS {} float", mesh.vertices.len())?;
    for value in mesh.vertices.iter().flatten() {
        out.write_all(&value.to_be_bytes())?;
    }
    let cells = mesh.triangles.len();
    writeln!(out, "\nCELLS {cells} {}", cells * 4)?;
    for t in &mesh.triangles {
        out.write_all(&3i32.to_be_bytes())?;
        for &i in t {
            out.write_all(&(i as i32).to_be_bytes())?;
        }
    }
    writeln!(out, "\nCELL_TYPES {cells}")?;
    const VTK_TRIANGLE: i32 = 5;
    for _ in 0..cells {
        out.write_all(&VTK_TRIANGLE.to_be_bytes())?;
    }
    // VECTORS, not NORMALS: meshio reads no NORMALS section; VTK and ParaView read both.
    writeln!(out, "\nPOINT_DATA {}\nVECTORS Normals float", mesh.vertices.len())?;
    for value in mesh.normals.iter().flatten() {
        out.write_all(&value.to_be_bytes())?;
    }
    writeln!(out)?;
    out.flush()?;
    Ok(())
}
