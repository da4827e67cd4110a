//! The volumes as OpenVDB itself reads them: `volume_NNNNNN.vdb` opened by OpenVDB's own library
//! (its Python bindings: Debian's `python3-openvdb`, which `.ci/run` installs; the module
//! `pyopenvdb`, or `openvdb` from OpenVDB 11 on) holds, voxel by voxel over a box around the
//! liquid, the values and active states the writer meant, in every grid (the velocity grid too,
//! which vdb-rs cannot read), as floats and as halves; each grid's class, type, background, voxel
//! size and metadata are what docs/export.md says; and OpenVDB's own mesher, run on the level set,
//! encloses the block's volume. Where no python3 imports the bindings the test shows as ignored,
//! with the reason (tests/harness: `harness = false`). tests/volume_tools/ also holds the Blender
//! scripts (docs/export.md, "Volumes").

mod common;
mod harness;

use mpm::export::surface::SurfaceOverrides;
use mpm::export::vdb::Value;
use mpm::export::volume::{self, VolumeExporter, VolumeFormat, VolumeJob, VolumeOverrides, VolumeSettings};
use std::path::Path;
use std::process::Command;
use std::sync::OnceLock;

fn main() -> std::process::ExitCode {
    harness::run(
        "OpenVDB",
        openvdb_available,
        harness::tests![openvdb_reads_every_grid_as_written],
    )
}

/// The python3 that imports OpenVDB's bindings: the one on PATH, or the system's (Debian's package
/// installs into /usr/bin/python3's path, which a pyenv or venv python3 on PATH does not see).
static PYTHON: OnceLock<String> = OnceLock::new();

fn openvdb_available() -> Result<(), String> {
    let mut why = Vec::new();
    for python in ["python3", "/usr/bin/python3"] {
        let probe = "try:\n import pyopenvdb as v\nexcept ImportError:\n import openvdb as v\nv.readAll";
        match Command::new(python).args(["-c", probe]).output() {
            Ok(out) if out.status.success() => {
                let _ = PYTHON.set(python.to_string());
                return Ok(());
            }
            Ok(out) => why.push(format!(
                "{python}: {}",
                String::from_utf8_lossy(&out.stderr)
                    .lines()
                    .last()
                    .unwrap_or_default()
            )),
            Err(e) => why.push(format!("{python}: {e}")),
        }
    }
    Err(format!(
        "no python3 imports OpenVDB's bindings (apt-get install python3-openvdb): {}",
        why.join("; ")
    ))
}

/// A block of water 4 cm on a side moving at `V`, 512 particles in a 12 cm box.
const V: [f32; 3] = [0.3, -0.2, 0.1];

/// A voxel value as the floats it is made of.
trait Floats: Value {
    fn floats(self) -> Vec<f32>;
}

impl Floats for f32 {
    fn floats(self) -> Vec<f32> {
        vec![self]
    }
}

impl Floats for [f32; 3] {
    fn floats(self) -> Vec<f32> {
        self.to_vec()
    }
}

/// Writes the expected values of `tree` over the box for the Python side: little-endian floats, x
/// slowest and z fastest, and a byte per voxel for the active state.
fn write_expected<T: Floats>(
    dir: &Path,
    name: &str,
    tree: &mpm::export::vdb::Tree<T>,
    lo: [i32; 3],
    shape: [i32; 3],
    half: bool,
) {
    let (mut values, mut active) = (Vec::new(), Vec::new());
    for i in 0..shape[0] {
        for j in 0..shape[1] {
            for k in 0..shape[2] {
                let (v, on) = tree.value([lo[0] + i, lo[1] + j, lo[2] + k]);
                let v = if half { v.to_half_precision() } else { v };
                for x in v.floats() {
                    values.extend_from_slice(&x.to_le_bytes());
                }
                active.push(u8::from(on));
            }
        }
    }
    std::fs::write(dir.join(format!("{name}.values")), values).unwrap();
    std::fs::write(dir.join(format!("{name}.active")), active).unwrap();
}

fn openvdb_reads_every_grid_as_written() {
    let scene = common::scene(&common::water_box(
        12,
        &format!(
            "[[block]]\nmin = [0.04, 0.04, 0.04]\nmax = [0.08, 0.08, 0.08]\nvelocity = [{}, {}, {}]",
            V[0], V[1], V[2]
        ),
    ));
    let particles = scene.spawn();
    let fluid_volume = 0.04f64.powi(3);
    let python = PYTHON.get().expect("the requirement found a python3");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/volume_tools/openvdb_check.py");
    let dir = tempfile::tempdir().unwrap();
    for half in [false, true] {
        let overrides = VolumeOverrides {
            velocity: true,
            half,
            ..VolumeOverrides::default()
        };
        let settings = VolumeSettings::for_scene(&scene, SurfaceOverrides::default(), overrides, 2).unwrap();
        let (h, band) = (settings.voxel_size, settings.band_width());
        let out = dir.path().join(if half { "half" } else { "float" });
        let exporter = VolumeExporter::new(&out, 1, VolumeFormat::Vdb, settings, false).unwrap();
        let job = VolumeJob {
            frame: 3,
            comment: "mpm frame 3 t=0.05 s scene=test".into(),
            positions: particles.x.clone(),
            velocities: Some(particles.v.clone()),
        };
        let done = exporter.export(&job).unwrap();
        let volumes = volume::build(&particles.x, Some(&particles.v), &settings).unwrap();
        let velocity = volumes.velocity.as_ref().unwrap();

        // The box: the density's active voxels, and 12 voxels more on every side (past the band).
        let (lo, hi) = volumes.density.tree.active_bbox().unwrap();
        let lo = lo.map(|c| c - 12);
        let shape: [i32; 3] = std::array::from_fn(|a| hi[a] + 12 - lo[a] + 1);
        let expected = dir.path().join(format!("expected-{half}"));
        std::fs::create_dir(&expected).unwrap();
        write_expected(&expected, "surface", &volumes.surface.tree, lo, shape, half);
        write_expected(&expected, "density", &volumes.density.tree, lo, shape, half);
        write_expected(&expected, "velocity", &velocity.tree, lo, shape, half);
        let json =
            serde_json::json!({"box_min": lo, "shape": shape, "grids": ["surface", "density", "velocity"]});
        std::fs::write(expected.join("expected.json"), json.to_string()).unwrap();

        let run = Command::new(python)
            .arg(&script)
            .arg(&done.path)
            .arg(&expected)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(
            run.status.success(),
            "{stdout}\n{}",
            String::from_utf8_lossy(&run.stderr)
        );
        println!("{stdout}");
        let lines: Vec<serde_json::Value> =
            stdout.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        let file = &lines[0];
        assert_eq!(file["file_metadata"]["mpm_frame"], 3, "{file}");
        assert!(file["file_metadata"]["mpm_comment"]
            .as_str()
            .unwrap()
            .starts_with("mpm frame 3"));
        let grid = |name: &str| {
            lines
                .iter()
                .find(|l| l["name"] == name && l.get("value_type").is_some())
                .unwrap_or_else(|| panic!("no grid {name} in {stdout}"))
        };
        let voxels = i64::from(shape[0] * shape[1] * shape[2]);
        for (name, value_type, class, count) in [
            (
                "surface",
                "float",
                "level set",
                volumes.surface.tree.active_voxel_count(),
            ),
            (
                "density",
                "float",
                "fog volume",
                volumes.density.tree.active_voxel_count(),
            ),
            ("velocity", "vec3s", "unknown", velocity.tree.active_voxel_count()),
        ] {
            let g = grid(name);
            assert_eq!(g["value_type"], value_type, "{g}");
            assert_eq!(g["class"], class, "{g}");
            assert_eq!(g["half"], half, "{g}");
            assert_eq!(g["active_voxels"], count, "{g}");
            assert_eq!(g["voxels_compared"], voxels, "{g}");
            assert_eq!(g["values_differing"], 0, "{g}");
            assert_eq!(g["active_differing"], 0, "{g}");
            let size = g["voxel_size"].as_array().unwrap();
            assert!(size.iter().all(|s| s.as_f64().unwrap() == f64::from(h)), "{g}");
        }
        let background = if half { band.to_half_precision() } else { band };
        assert_eq!(
            grid("surface")["background"].as_f64().unwrap(),
            f64::from(background)
        );
        assert_eq!(grid("velocity")["vector_type"], "contravariant relative");
        // The block moves as one: the velocity reads V on every active voxel, to rounding.
        let tolerance = if half { 1e-3 } else { 1e-5 };
        for (origin, leaf) in velocity.tree.leaves() {
            for n in (0..512).filter(|&n| leaf.is_active(n)) {
                let v = leaf.values[n];
                assert!(
                    (0..3).all(|a| (v[a] - V[a]).abs() < tolerance),
                    "velocity {v:?} at leaf {origin:?} voxel {n}"
                );
            }
        }
        // OpenVDB's own mesher on the level set encloses the block, to within a few per cent.
        let mesh = lines.iter().find(|l| l.get("mesh_volume").is_some()).unwrap();
        let enclosed = mesh["mesh_volume"].as_f64().unwrap();
        println!("OpenVDB's mesh of the level set encloses {enclosed:.4e} m^3 of {fluid_volume:.4e} m^3");
        assert!((enclosed / fluid_volume - 1.0).abs() < 0.05, "{mesh}");
    }
}
