//! `--export-bodies DIR`: the rigid bodies of each exported frame, for Blender and for plots.
//!
//! - `bodies_NNNNNN.obj`: every body's shape posed in world coordinates (m), one OBJ object a body
//!   named `collider_K` by its index among the scene's colliders, so Blender imports each as an
//!   object of its own. The triangles are the ones the viewer draws the collider with
//!   ([`shape_triangles`]: a box's faces, a sphere's, capsule's or cylinder's 32 segments, a mesh
//!   collider's own triangles), the corners they share merged, with outward normals (a mesh
//!   collider's as its file winds its triangles).
//! - `bodies.csv`: the pose table, a row a body a frame ([`POSE_TABLE_HEADER`]): the collider's
//!   centre (the body's frame, m), its orientation as a unit quaternion (x, y, z, w), the velocity
//!   of its centre of mass (m/s) and its angular velocity (rad/s, world frame), each number as the
//!   shortest decimal that reads back to the very f64 the solver holds.
//!
//! The meshes go through [`FrameDir`]: an earlier run's files (its meshes and its table) are
//! refused, or with `--overwrite` removed, before the first step, and each mesh is written to a
//! temporary name and renamed. The table grows a frame at a time; a write that fails is cut back to
//! the last whole frame, so no row is ever left half written.

use super::mesh_files::{write_obj_objects, SurfaceMesh};
use super::{check_every, FrameDir, FrameKind};
use crate::render::colliders::shape_triangles;
use crate::sim::colliders::bodies::RigidBody;
use crate::sim::Scene;
use crate::text::io_reason;
use anyhow::{anyhow, bail, Result};
use glam::{DMat3, DQuat, DVec3};
use std::collections::HashMap;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The pose table's file name, in the `--export-bodies` directory.
pub const POSE_TABLE: &str = "bodies.csv";

/// The pose table's first line: its columns.
pub const POSE_TABLE_HEADER: &str =
    "frame,time_s,collider,center_x,center_y,center_z,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz";

/// The body meshes and the pose table of `--export-bodies`.
pub const BODY_FRAMES: FrameKind = FrameKind {
    flag: "--export-bodies",
    prefix: "bodies_",
    extensions: &["obj"],
    companions: &[POSE_TABLE],
    noun: ("body file", "body files"),
};

/// Refuses `--export-bodies` for a scene without rigid bodies: there would be nothing to write.
pub fn check_scene(scene: &Scene) -> Result<()> {
    if scene.colliders.num_bodies() == 0 {
        bail!(
            "--export-bodies: scene {} has no rigid bodies (colliders with a density or a mass) to \
             export; drop --export-bodies, or give a collider a `density` or `mass` \
             (docs/scenes.md, \"Rigid bodies\")",
            scene.source
        );
    }
    Ok(())
}

/// Writes the bodies of exported frames into one directory.
pub struct BodyExporter {
    frames: FrameDir,
    every: u64,
    /// Each body's collider index and its mesh in the body's frame, in the order of the bodies.
    shapes: Vec<(u32, SurfaceMesh)>,
    table: PoseTable,
}

impl BodyExporter {
    /// Opens `dir` as [`FrameDir::open`] says (refusing an earlier run's meshes and table unless
    /// `overwrite`) for the bodies of `scene`, which must have some ([`check_scene`]); `every` is
    /// `--every`.
    pub fn new(dir: &Path, every: u64, scene: &Scene, overwrite: bool) -> Result<BodyExporter> {
        check_scene(scene)?;
        check_every(every)?;
        let shapes = scene
            .colliders
            .list
            .iter()
            .enumerate()
            .filter(|(_, c)| c.body.is_some())
            .map(|(index, c)| (index as u32, shape_mesh(&shape_triangles(&c.shape))))
            .collect();
        let frames = FrameDir::open(dir, BODY_FRAMES, "obj", overwrite)?;
        Ok(BodyExporter {
            table: PoseTable::new(dir.join(POSE_TABLE)),
            frames,
            every,
            shapes,
        })
    }

    pub fn wants(&self, frame: u64) -> bool {
        frame % self.every == 0
    }

    pub fn dir(&self) -> &Path {
        self.frames.dir()
    }

    pub fn path_of(&self, frame: u64) -> PathBuf {
        self.frames.path_of(frame)
    }

    /// One line for the user about what `--overwrite` removed, or `None`.
    pub fn removed_note(&self) -> Option<String> {
        self.frames.removed_note()
    }

    /// Writes frame `frame` (at `time` s): the bodies' posed meshes, with `comment` in the file's
    /// header, and their rows of the pose table. `bodies` are the simulation's, in the order of the
    /// colliders that are bodies.
    pub fn write(&mut self, frame: u64, time: f64, comment: &str, bodies: &[RigidBody]) -> Result<PathBuf> {
        if bodies.len() != self.shapes.len() {
            bail!(
                "--export-bodies: the simulation has {} but its scene {}",
                crate::text::count(bodies.len(), "rigid body", "rigid bodies"),
                self.shapes.len()
            );
        }
        let objects: Vec<(String, SurfaceMesh)> = self
            .shapes
            .iter()
            .zip(bodies)
            .map(|((collider, shape), body)| (format!("collider_{collider}"), posed(shape, body)))
            .collect();
        let comment = format!(
            "{comment}\nrigid bodies: one object a body, named collider_K by its collider index; \
             world coordinates, m"
        );
        let path = self
            .frames
            .write(frame, |out| write_obj_objects(out, &comment, &objects))?;
        self.table.append(&pose_rows(frame, time, bodies))?;
        Ok(path)
    }
}

/// The pose table's rows of one frame: [`POSE_TABLE_HEADER`]'s columns, a line a body.
pub fn pose_rows(frame: u64, time: f64, bodies: &[RigidBody]) -> String {
    let mut rows = String::new();
    for b in bodies {
        let numbers = [
            &b.center[..],
            &b.orientation[..],
            &b.velocity[..],
            &b.angular_velocity[..],
        ]
        .concat();
        let numbers: Vec<String> = numbers.iter().map(f64::to_string).collect();
        rows += &format!("{frame},{time},{},{}\n", b.slot, numbers.join(","));
    }
    rows
}

/// An indexed mesh of triangles given corner by corner (position and normal, as
/// [`shape_triangles`] gives them): corners with the same position and normal become one vertex.
pub fn shape_mesh(corners: &[[glam::Vec3; 2]]) -> SurfaceMesh {
    let mut mesh = SurfaceMesh::default();
    let mut index: HashMap<[u32; 6], u32> = HashMap::new();
    let ids: Vec<u32> = corners
        .iter()
        .map(|&[p, n]| {
            let key = [p.x, p.y, p.z, n.x, n.y, n.z].map(f32::to_bits);
            *index.entry(key).or_insert_with(|| {
                mesh.vertices.push(p.to_array());
                mesh.normals.push(n.to_array());
                mesh.vertices.len() as u32 - 1
            })
        })
        .collect();
    mesh.triangles = ids.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    mesh
}

/// `shape` (in the body's frame) where `body` is: each vertex at centre + R vertex, each normal
/// turned by R.
pub fn posed(shape: &SurfaceMesh, body: &RigidBody) -> SurfaceMesh {
    let r = DMat3::from_quat(DQuat::from_array(body.orientation));
    let center = DVec3::from_array(body.center);
    let place = |p: &[f32; 3], shift: DVec3| {
        (r * glam::Vec3::from_array(*p).as_dvec3() + shift)
            .as_vec3()
            .to_array()
    };
    SurfaceMesh {
        vertices: shape.vertices.iter().map(|p| place(p, center)).collect(),
        normals: shape.normals.iter().map(|n| place(n, DVec3::ZERO)).collect(),
        triangles: shape.triangles.clone(),
    }
}

/// The pose table: created with its header at its first rows (a run that stops before its first
/// frame leaves none behind), then appended a frame at a time.
struct PoseTable {
    path: PathBuf,
    file: Option<File>,
    /// Bytes of whole frames written: where a failed write is cut back to.
    written: u64,
}

impl PoseTable {
    fn new(path: PathBuf) -> PoseTable {
        PoseTable {
            path,
            file: None,
            written: 0,
        }
    }

    fn append(&mut self, rows: &str) -> Result<()> {
        let fail =
            |path: &Path, e: std::io::Error| anyhow!("cannot write {}: {}", path.display(), io_reason(&e));
        let (file, text) = match &mut self.file {
            Some(file) => (file, rows.to_string()),
            None => {
                // A new file: FrameDir::open removed an earlier run's, or refused the directory; one
                // that appeared since is not replaced.
                let file = OpenOptions::new()
                    .append(true)
                    .create_new(true)
                    .open(&self.path)
                    .map_err(|e| fail(&self.path, e))?;
                (self.file.insert(file), format!("{POSE_TABLE_HEADER}\n{rows}"))
            }
        };
        // One write a frame; where it fails, the frame's part is cut off again (appending, the next
        // write would go to the new end).
        if let Err(e) = file.write_all(text.as_bytes()) {
            let _ = file.set_len(self.written);
            return Err(fail(&self.path, e));
        }
        self.written += text.len() as u64;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::colliders::Shape;

    /// Every shape's mesh keeps the viewer's triangles corner for corner (position and normal) with
    /// the shared corners merged, and posing it puts each vertex at centre + R vertex.
    #[test]
    fn shape_meshes_keep_the_drawn_triangles_and_follow_the_pose() {
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
        let rotation = DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1);
        let body = RigidBody {
            center: [0.4, 0.25, -0.1],
            orientation: rotation.to_array(),
            ..RigidBody::default()
        };
        for shape in shapes {
            let corners = shape_triangles(&shape);
            let mesh = shape_mesh(&corners);
            let name = shape.kind_name();
            assert_eq!(mesh.triangles.len() * 3, corners.len(), "{name}");
            assert!(mesh.vertices.len() < corners.len(), "{name}: no corner merged");
            for (triangle, drawn) in mesh.triangles.iter().zip(corners.chunks_exact(3)) {
                for (&i, [p, n]) in triangle.iter().zip(drawn) {
                    assert_eq!(mesh.vertices[i as usize], p.to_array(), "{name}");
                    assert_eq!(mesh.normals[i as usize], n.to_array(), "{name}");
                }
            }
            let placed = posed(&mesh, &body);
            for (v, p) in placed.vertices.iter().zip(&mesh.vertices) {
                let want = DVec3::from_array(body.center) + rotation * glam::Vec3::from(*p).as_dvec3();
                assert!(
                    (glam::Vec3::from(*v).as_dvec3() - want).length() < 1e-6,
                    "{name}: {v:?} against {want}"
                );
            }
        }
    }
}
