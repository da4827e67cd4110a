//! The surface meshes as meshio reads them: every format of `mpm run --export-surface` opens as it
//! is, with the same points, triangles, volume and normals. Needs python3 with meshio (`.ci/run`
//! installs it into `.ci-cache/python`); where it is missing the test shows as ignored, with the
//! reason (tests/harness: `harness = false`). Blender and ParaView have scripts of their own beside
//! the meshio one in tests/mesh_tools/ (docs/export.md, "Surface meshes").

mod common;
mod harness;

use mpm::export::mesh_files::SurfaceFormat;
use mpm::export::surface::{reconstruct, SurfaceOverrides, SurfaceSettings};
use std::path::{Path, PathBuf};

fn main() -> std::process::ExitCode {
    harness::run(
        "meshio",
        meshio_available,
        harness::tests![meshio_reads_every_format_as_written],
    )
}

fn meshio_available() -> Result<(), String> {
    common::ci_python_imports("import meshio", "meshio")
}

fn meshio_reads_every_format_as_written() {
    let scene = common::scene(&common::water_box(
        16,
        "[[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.10, 0.08, 0.09]",
    ));
    let settings = SurfaceSettings::for_scene(&scene, SurfaceOverrides::default()).unwrap();
    let mesh = reconstruct(&scene.spawn().x, &settings).unwrap();
    let volume: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| glam::DVec3::from(glam::Vec3::from(mesh.vertices[i as usize])));
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    let dir = tempfile::tempdir().unwrap();
    let paths: Vec<PathBuf> = SurfaceFormat::ALL
        .iter()
        .map(|format| {
            let path = dir.path().join(format!("surface_000000.{}", format.extension()));
            let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
            format.write(file, "mpm frame 0\nsecond line", &mesh).unwrap();
            path
        })
        .collect();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mesh_tools/meshio_check.py");
    let out = common::ci_python().arg(script).args(&paths).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let read: Vec<serde_json::Value> = stdout.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(read.len(), 3, "{stdout}");
    let n = mesh.vertices.len();
    for (format, r) in SurfaceFormat::ALL.iter().zip(&read) {
        assert_eq!(r["points"], n, "{format:?}: {r}");
        assert_eq!(
            r["cell_types"],
            serde_json::json!(["triangle"]),
            "{format:?}: {r}"
        );
        assert_eq!(r["triangles"], mesh.triangles.len(), "{format:?}: {r}");
        let read_volume = r["signed_volume"].as_f64().unwrap();
        assert!(
            volume > 0.0 && (read_volume - volume).abs() < 1e-6 * volume,
            "{format:?}: meshio's volume {read_volume:e}, written {volume:e}"
        );
        // Each reader names the normals its own way; each has one per point.
        let normals = match format {
            SurfaceFormat::Obj => serde_json::json!({"obj:vn": [n, 3]}),
            SurfaceFormat::Ply => serde_json::json!({"nx": [n], "ny": [n], "nz": [n]}),
            SurfaceFormat::Vtk => serde_json::json!({"Normals": [n, 3]}),
        };
        assert_eq!(r["point_data"], normals, "{format:?}: {r}");
    }
}
