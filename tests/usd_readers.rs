//! The `--export-usd` stage as Pixar's own USD library reads it (pxr, from PyPI's usd-core):
//! `tests/usd_tools/usd_check.py` opens the stage and prints what it finds at given frames, and
//! each test holds that against what the same run wrote in the formats checked elsewhere: its PLY
//! frames (particles, to the bit), its OBJ surface meshes, its pose table and body meshes, and the
//! scene's colliders. Needs python3 with pxr (`.ci/run` installs usd-core into `.ci-cache/python`);
//! where it is missing every test shows as ignored, with the reason (tests/harness).

mod common;
mod harness;

use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};
use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn main() -> std::process::ExitCode {
    harness::run(
        "usd-core",
        pxr_available,
        harness::tests![
            the_stage_holds_what_the_run_wrote,
            the_stage_holds_a_solids_deformation,
            an_interrupted_run_leaves_a_stage_of_whole_frames,
        ],
    )
}

fn pxr_available() -> Result<(), String> {
    common::ci_python_imports("from pxr import Usd, UsdGeom", "usd-core")
}

/// What pxr reads from `stage` at `frames`.
fn read_stage(stage: &Path, frames: &[u64]) -> Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/usd_tools/usd_check.py");
    let out = common::ci_python()
        .arg(script)
        .arg(stage)
        .args(frames.iter().map(u64::to_string))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "usd_check.py failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn p(path: &Path) -> String {
    path.to_str().unwrap().to_string()
}

fn ok(out: &std::process::Output) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "mpm failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// A PLY frame's vertices: each named property as f64 (the floats and the material row).
fn ply_vertices(path: &Path) -> Vec<std::collections::HashMap<String, f64>> {
    let mut f = std::fs::File::open(path).unwrap();
    let ply = Parser::<DefaultElement>::new().read_ply(&mut f).unwrap();
    ply.payload["vertex"]
        .iter()
        .map(|v| {
            v.iter()
                .map(|(name, value)| {
                    let x = match *value {
                        Property::Float(x) => f64::from(x),
                        Property::UChar(m) => f64::from(m),
                        ref other => panic!("{name} is {other:?}"),
                    };
                    (name.clone(), x)
                })
                .collect()
        })
        .collect()
}

/// An OBJ's vertices and triangles (0-based), objects run together.
fn obj_mesh(path: &Path) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let v: Vec<f32> = words.map(|w| w.parse().unwrap()).collect();
                vertices.push([v[0], v[1], v[2]]);
            }
            Some("f") => {
                let t: Vec<u32> = words
                    .map(|w| w.split('/').next().unwrap().parse::<u32>().unwrap() - 1)
                    .collect();
                triangles.push([t[0], t[1], t[2]]);
            }
            _ => {}
        }
    }
    (vertices, triangles)
}

fn f32s(value: &Value) -> Vec<f32> {
    value
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap() as f32)
        .collect()
}

fn vec3s(value: &Value) -> Vec<[f32; 3]> {
    value
        .as_array()
        .unwrap()
        .iter()
        .map(|v| {
            let v = f32s(v);
            [v[0], v[1], v[2]]
        })
        .collect()
}

/// Doubles the script wrote as text (a JSON reader's float may be a bit off).
fn exact(value: &Value) -> Vec<f64> {
    value
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap().parse().unwrap())
        .collect()
}

fn f64s(value: &Value) -> Vec<f64> {
    value
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// The steel log thrown into a pool, with a static sphere and a piston's paddle beside it: a rigid
/// body, a static collider and a moving one.
fn pool_scene() -> String {
    common::log_thrown_into_a_pool()
        + r#"
[[collider]]
shape = "sphere"
center = [0.2, 0.2, 0.04]
radius = 0.02

[[collider]]
shape = "box"
center = [0.02, 0.17, 0.04]
size = [0.02, 0.05, 0.06]
[collider.motion]
piston = { direction = [1.0, 0.0, 0.0], amplitude = 0.01, period = 0.5, phase = 0.0 }
"#
}

/// The log in the pool for 3 frames, every 2nd, through `mpm run` with every export at once. What
/// pxr reads at frames 0 and 2: the stage's metadata (y up, metres, 60 time codes a second, frames
/// 0 to 2); the particles' points, velocities, density and material equal to the PLY frame's to
/// the bit, a constant width of the spawn spacing, an extent around them; the surface mesh equal
/// to the OBJ of `--export-surface` (the same reconstruction); the log's translate and orient equal
/// to the pose table's numbers to the bit, its mesh placed by them where the body OBJ has it; the
/// static sphere where the scene puts it, not time-varying; the paddle where its motion puts it.
fn the_stage_holds_what_the_run_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let scene_path = dir.path().join("pool.toml");
    std::fs::write(&scene_path, pool_scene()).unwrap();
    let (ply, bodies, surface, stage) = (
        dir.path().join("ply"),
        dir.path().join("bodies"),
        dir.path().join("surface"),
        dir.path().join("pool.usda"),
    );
    let stdout = ok(&common::cpu_run(
        &p(&scene_path),
        "3",
        &[
            "--every",
            "2",
            "--export",
            &p(&ply),
            "--export-bodies",
            &p(&bodies),
            "--export-surface",
            &p(&surface),
            "--export-usd",
            &p(&stage),
        ],
    ));
    assert!(stdout.contains("usd: 2 frames in"), "{stdout}");
    let read = read_stage(&stage, &[0, 2]);
    assert_eq!(read["default_prim"], "/Sim");
    assert_eq!(read["up_axis"], "Y");
    assert_eq!(read["meters_per_unit"], 1.0);
    assert_eq!(read["time_codes_per_second"], 60.0);
    assert_eq!(read["frames_per_second"], 60.0);
    assert_eq!(
        (read["start"].as_f64(), read["end"].as_f64()),
        (Some(0.0), Some(2.0))
    );
    assert_eq!(f64s(&read["point_samples"]), [0.0, 2.0]);
    let scene = common::scene(&pool_scene());
    let spacing = scene.dx / scene.particles_per_axis as f32;
    assert_eq!(f32s(&read["widths"]), [spacing]);
    assert_eq!(read["widths_interpolation"], "constant");
    assert_eq!(
        read["primvars"],
        serde_json::json!([
            ["density", "vertex"],
            ["displayColor", "constant"],
            ["material", "vertex"]
        ])
    );
    assert_eq!(read["material_names"], serde_json::json!(["liquid"]));
    assert_eq!(read["has_surface"], true);

    let table = std::fs::read_to_string(bodies.join("bodies.csv")).unwrap();
    let rows: Vec<Vec<f64>> = table
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    for (frame, row) in [0u64, 2].into_iter().zip(&rows) {
        let f = &read["frames"][frame.to_string()];
        // The particles, to the bit.
        let vertices = ply_vertices(&ply.join(format!("frame_{frame:06}.ply")));
        let points = vec3s(&f["points"]);
        let velocities = vec3s(&f["velocities"]);
        let density = f32s(&f["density"]);
        let material = f32s(&f["material"]);
        assert_eq!(points.len(), vertices.len(), "frame {frame}");
        assert!(!points.is_empty());
        for (i, v) in vertices.iter().enumerate() {
            let want = |names: [&str; 3]| names.map(|n| v[n] as f32);
            assert_eq!(points[i], want(["x", "y", "z"]), "frame {frame}, particle {i}");
            assert_eq!(
                velocities[i],
                want(["vx", "vy", "vz"]),
                "frame {frame}, particle {i}"
            );
            assert_eq!(density[i], v["density"] as f32, "frame {frame}, particle {i}");
            assert_eq!(material[i], v["material"] as f32, "frame {frame}, particle {i}");
        }
        let extent = vec3s(&f["extent"]);
        for p in &points {
            for a in 0..3 {
                assert!(
                    extent[0][a] <= p[a] - spacing / 2.0 + 1e-6
                        && p[a] + spacing / 2.0 <= extent[1][a] + 1e-6
                );
            }
        }
        // The surface: the OBJ's mesh.
        let (vertices, triangles) = obj_mesh(&surface.join(format!("surface_{frame:06}.obj")));
        let s = &f["surface"];
        assert_eq!(vec3s(&s["points"]), vertices, "frame {frame}");
        assert_eq!(s["normals"], vertices.len());
        assert_eq!(s["faces"], triangles.len());
        assert_eq!(s["all_triangles"], true);
        assert_eq!(s["subdivision"], "none");
        let indices: Vec<u32> = s["indices"]
            .as_array()
            .unwrap()
            .iter()
            .map(|i| i.as_u64().unwrap() as u32)
            .collect();
        assert_eq!(indices, triangles.concat(), "frame {frame}");
        // The log: the pose table's numbers, to the bit, and its mesh where the body OBJ has it.
        let log = &f["colliders"]["collider_0"];
        assert_eq!(exact(&log["translate"]), row[3..6], "frame {frame}");
        assert_eq!(exact(&log["orient"]), row[6..10], "frame {frame}");
        assert_eq!(log["time_varying"], true);
        let (posed, _) = obj_mesh(&bodies.join(format!("bodies_{frame:06}.obj")));
        let world = vec3s(&log["world_points"]);
        assert_eq!(world.len(), posed.len());
        for (a, b) in world.iter().zip(&posed) {
            let d = glam::Vec3::from(*a) - glam::Vec3::from(*b);
            assert!(d.length() < 1e-6, "frame {frame}: {a:?} against the OBJ's {b:?}");
        }
        // The sphere stays where the scene puts it.
        let sphere = &f["colliders"]["collider_1"];
        assert_eq!(exact(&sphere["translate"]), [0.2, 0.2, 0.04]);
        assert_eq!(sphere["time_varying"], false);
        assert!(sphere["faces"].as_u64().unwrap() > 100);
        // The paddle where its motion has it at the frame's time.
        let paddle = &f["colliders"]["collider_2"];
        let pose = scene.colliders.list[2].pose(row[1]);
        assert_eq!(
            exact(&paddle["translate"]),
            pose.center.to_array(),
            "frame {frame}"
        );
        assert_eq!(paddle["time_varying"], true);
    }
    // The paddle moved between the frames, and the log fell.
    let at = |frame: &str, collider: &str| exact(&read["frames"][frame]["colliders"][collider]["translate"]);
    assert_ne!(at("0", "collider_2"), at("2", "collider_2"));
    assert!(at("2", "collider_0")[1] < at("0", "collider_0")[1]);
}

/// A jelly cube dropped into water: the stage's primvars `J` and `von_mises` are the PLY frame's
/// to the bit, as are the material rows of the two materials.
fn the_stage_holds_a_solids_deformation() {
    let dir = tempfile::tempdir().unwrap();
    let scene_path = dir.path().join("jelly.toml");
    std::fs::write(
        &scene_path,
        r#"
[domain]
size = [0.16, 0.16, 0.16]
resolution = [16, 16, 16]

[[material]]
name = "water"
rest_density = 1000.0
sound_speed = 20.0

[[material]]
name = "jelly"
law = "fixed-corotated"
rest_density = 500.0
youngs_modulus = 4.0e4
poisson_ratio = 0.3

[[block]]
min = [0.01, 0.01, 0.01]
max = [0.14, 0.05, 0.14]
material = "water"

[[block]]
min = [0.05, 0.08, 0.05]
max = [0.1, 0.13, 0.1]
material = "jelly"
velocity = [0.0, -1.0, 0.0]
"#,
    )
    .unwrap();
    let (ply, stage) = (dir.path().join("ply"), dir.path().join("jelly.usda"));
    ok(&common::cpu_run(
        &p(&scene_path),
        "2",
        &["--export", &p(&ply), "--export-usd", &p(&stage)],
    ));
    let read = read_stage(&stage, &[2]);
    assert_eq!(read["material_names"], serde_json::json!(["water", "jelly"]));
    let f = &read["frames"]["2"];
    let vertices = ply_vertices(&ply.join("frame_000002.ply"));
    let (j, von_mises, material) = (f32s(&f["J"]), f32s(&f["von_mises"]), f32s(&f["material"]));
    assert_eq!(j.len(), vertices.len());
    for (i, v) in vertices.iter().enumerate() {
        assert_eq!(j[i], v["J"] as f32, "particle {i}");
        assert_eq!(von_mises[i], v["von_mises"] as f32, "particle {i}");
        assert_eq!(material[i], v["material"] as f32, "particle {i}");
    }
    assert!(
        material.contains(&1.0) && von_mises.iter().any(|&s| s > 0.0),
        "the jelly is stressed"
    );
}

/// `mpm run --export-usd` stopped by Ctrl-C (SIGINT) after a few frames: no `*.partial` file is
/// left, and the stage opens, its frames exactly the particle layers whose names it holds, each a
/// whole layer.
fn an_interrupted_run_leaves_a_stage_of_whole_frames() {
    let dir = tempfile::tempdir().unwrap();
    let stage = dir.path().join("dam.usda");
    let mut child = Command::new(common::mpm_binary())
        .args([
            "run",
            "--backend",
            "cpu",
            "--scene",
            "dam-break-coarse",
            "--frames",
            "10000",
        ])
        .arg("--export-usd")
        .arg(&stage)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    {
        use std::io::BufRead;
        let lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
        for line in lines {
            if line.unwrap().starts_with("frame     4") {
                break;
            }
        }
    }
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let clips = dir.path().join("dam_clips");
    let mut names: Vec<String> = std::fs::read_dir(&clips)
        .unwrap()
        .chain(std::fs::read_dir(dir.path()).unwrap())
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert!(names.iter().all(|n| !n.ends_with(".partial")), "{names:?}");
    let layers: Vec<u64> = names
        .iter()
        .filter_map(|n| n.strip_prefix("particles_")?.strip_suffix(".usda")?.parse().ok())
        .collect();
    let read = read_stage(&stage, &[]);
    let samples: Vec<u64> = f64s(&read["point_samples"]).iter().map(|&t| t as u64).collect();
    assert!(samples.len() >= 4, "{samples:?}");
    assert_eq!(samples, (0..samples.len() as u64).collect::<Vec<_>>());
    // A layer written as the signal came may not be named yet; every one named is there.
    assert!(
        samples.iter().all(|s| layers.contains(s)),
        "{samples:?} {layers:?}"
    );
    let last = *samples.last().unwrap();
    let read = read_stage(&stage, &[last]);
    assert_eq!(
        read["frames"][last.to_string()]["points"]
            .as_array()
            .unwrap()
            .len(),
        10368
    );
}
