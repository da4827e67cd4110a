//! `mpm run --export-surface`: the meshes of a resting block of water are closed, wound outward and
//! hold the fluid's volume, in every file format as read back from the file; and every bad input is
//! refused before the first step, with a message that names the problem and the fix.

mod common;

use mpm::backend::{self, BackendKind};
use mpm::export::mesh_files::{SurfaceFormat, SurfaceMesh};
use mpm::export::surface::{SurfaceExporter, SurfaceJob, SurfaceOverrides, SurfaceSettings};
use mpm::runner::{self, RunOptions};
use mpm::sim::{FrameStats, Scene, Simulation};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};
use std::collections::HashMap;
use std::path::Path;
use std::process::{Command, Output};

/// A 6 cm deep layer of water filling the floor of a 20 cm box wall to wall (its fluid region is
/// [1, 18] cm), 8 particles per 1 cm cell: 13,872 particles at rest.
const BLOCK: &str = "[[block]]\nmin = [0.01, 0.01, 0.01]\nmax = [0.18, 0.07, 0.18]\nparticles_per_cell = 8";

fn block_scene() -> Scene {
    common::scene(&common::water_box(20, BLOCK))
}

/// The fluid's volume: the particles' share of the spawn lattice.
fn fluid_volume(scene: &Scene) -> f64 {
    let spacing = f64::from(scene.dx) / f64::from(scene.particles_per_axis);
    scene.num_particles as f64 * spacing.powi(3)
}

/// A mesh read back from a file, independently of the writer.
struct Read {
    vertices: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    triangles: Vec<[usize; 3]>,
}

fn read_obj(path: &Path) -> Read {
    let text = std::fs::read_to_string(path).unwrap();
    let mut mesh = Read {
        vertices: vec![],
        normals: vec![],
        triangles: vec![],
    };
    let numbers = |rest: &str| -> [f64; 3] {
        let v: Vec<f64> = rest.split_whitespace().map(|x| x.parse().unwrap()).collect();
        [v[0], v[1], v[2]]
    };
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("v ") {
            mesh.vertices.push(numbers(rest));
        } else if let Some(rest) = line.strip_prefix("vn ") {
            mesh.normals.push(numbers(rest));
        } else if let Some(rest) = line.strip_prefix("f ") {
            let corners: Vec<usize> = rest
                .split_whitespace()
                .map(|c| {
                    let (v, n) = c.split_once("//").expect("f v//vn");
                    assert_eq!(v, n, "a corner's normal is its vertex's");
                    v.parse::<usize>().unwrap() - 1
                })
                .collect();
            mesh.triangles.push([corners[0], corners[1], corners[2]]);
        } else {
            assert!(line.starts_with('#'), "unexpected OBJ line {line:?}");
        }
    }
    mesh
}

fn read_ply(path: &Path) -> Read {
    let mut f = std::fs::File::open(path).unwrap();
    let ply = Parser::<DefaultElement>::new().read_ply(&mut f).unwrap();
    let float = |v: &DefaultElement, name: &str| match v[name] {
        Property::Float(x) => f64::from(x),
        ref other => panic!("{name} is {other:?}, not a float"),
    };
    let vertices = &ply.payload["vertex"];
    Read {
        vertices: vertices
            .iter()
            .map(|v| ["x", "y", "z"].map(|p| float(v, p)))
            .collect(),
        normals: vertices
            .iter()
            .map(|v| ["nx", "ny", "nz"].map(|p| float(v, p)))
            .collect(),
        triangles: ply.payload["face"]
            .iter()
            .map(|f| match &f["vertex_indices"] {
                Property::ListUInt(i) => {
                    assert_eq!(i.len(), 3);
                    [i[0] as usize, i[1] as usize, i[2] as usize]
                }
                other => panic!("vertex_indices is {other:?}"),
            })
            .collect(),
    }
}

/// Reads a legacy binary VTK file: header lines, then big-endian blocks, each followed by a newline.
struct VtkCursor {
    bytes: Vec<u8>,
    at: usize,
}

impl VtkCursor {
    fn line(&mut self) -> String {
        let end = self.at + self.bytes[self.at..].iter().position(|&b| b == b'\n').unwrap();
        let text = String::from_utf8(self.bytes[self.at..end].to_vec()).unwrap();
        self.at = end + 1;
        text
    }

    /// `count` big-endian 4-byte words, then the newline after them.
    fn words(&mut self, count: usize) -> Vec<[u8; 4]> {
        let words = (0..count)
            .map(|i| self.bytes[self.at + 4 * i..][..4].try_into().unwrap())
            .collect();
        self.at += 4 * count;
        assert_eq!(self.bytes[self.at], b'\n', "a newline after the block");
        self.at += 1;
        words
    }

    fn floats(&mut self, count: usize) -> Vec<[f64; 3]> {
        let words = self.words(3 * count);
        words
            .chunks(3)
            .map(|w| std::array::from_fn(|k| f64::from(f32::from_be_bytes(w[k]))))
            .collect()
    }
}

fn read_vtk(path: &Path) -> Read {
    let mut vtk = VtkCursor {
        bytes: std::fs::read(path).unwrap(),
        at: 0,
    };
    assert_eq!(vtk.line(), "# vtk DataFile Version 3.0");
    vtk.line();
    assert_eq!(vtk.line(), "BINARY");
    assert_eq!(vtk.line(), "DATASET UNSTRUCTURED_GRID");
    let points = vtk.line();
    let n: usize = points
        .strip_prefix("POINTS ")
        .and_then(|p| p.strip_suffix(" float"))
        .unwrap()
        .parse()
        .unwrap();
    let vertices = vtk.floats(n);
    let cells = vtk.line();
    let m: usize = cells.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert_eq!(cells, format!("CELLS {m} {}", 4 * m));
    let ints: Vec<i32> = vtk.words(4 * m).into_iter().map(i32::from_be_bytes).collect();
    let triangles = ints
        .chunks(4)
        .map(|c| {
            assert_eq!(c[0], 3, "a cell of three points");
            [c[1] as usize, c[2] as usize, c[3] as usize]
        })
        .collect();
    assert_eq!(vtk.line(), format!("CELL_TYPES {m}"));
    let types = vtk.words(m);
    assert!(
        types.into_iter().all(|t| i32::from_be_bytes(t) == 5),
        "every cell a VTK_TRIANGLE"
    );
    assert_eq!(vtk.line(), format!("POINT_DATA {n}"));
    assert_eq!(vtk.line(), "VECTORS Normals float");
    let normals = vtk.floats(n);
    assert_eq!(vtk.at, vtk.bytes.len(), "nothing after the normals");
    Read {
        vertices,
        normals,
        triangles,
    }
}

fn read(path: &Path) -> Read {
    match path.extension().and_then(|e| e.to_str()) {
        Some("obj") => read_obj(path),
        Some("ply") => read_ply(path),
        Some("vtk") => read_vtk(path),
        other => panic!("no reader for {other:?}"),
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Checks that the mesh is closed and consistently oriented (every directed edge once, its reverse
/// once: every edge shared by exactly two triangles that traverse it in opposite directions), that
/// it encloses `volume` within 10 % with a positive signed volume (wound outward), and that the
/// vertex normals point out of the water. Returns the enclosed volume.
fn check_closed_outward(mesh: &Read, volume: f64, what: &str) -> f64 {
    assert!(
        mesh.triangles.len() > 100,
        "{what}: {} triangles",
        mesh.triangles.len()
    );
    assert_eq!(
        mesh.normals.len(),
        mesh.vertices.len(),
        "{what}: a normal per vertex"
    );
    let mut directed: HashMap<(usize, usize), u32> = HashMap::new();
    for t in &mesh.triangles {
        assert!(
            t.iter().all(|&i| i < mesh.vertices.len()),
            "{what}: index out of range"
        );
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(
            n, 1,
            "{what}: edge {a}->{b} used by {n} triangles in one direction"
        );
        assert_eq!(
            directed.get(&(b, a)),
            Some(&1),
            "{what}: edge {a}-{b} has no triangle on the other side (a hole) or two on one"
        );
    }
    // Divergence theorem: the volume is the sum of the signed tetrahedra (origin, a, b, c).
    let signed: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices[i]);
            dot(a, cross(b, c)) / 6.0
        })
        .sum();
    assert!(
        signed > 0.0,
        "{what}: signed volume {signed:.3e} m^3: the triangles wind inward"
    );
    let error = (signed - volume).abs() / volume;
    assert!(
        error < 0.10,
        "{what}: encloses {signed:.4e} m^3, the fluid is {volume:.4e} m^3 ({:.1} % off)",
        error * 100.0
    );
    // Normals: unit length, on the outer side of their triangles, and away from the block's centre.
    let centre = mesh
        .vertices
        .iter()
        .fold([0.0; 3], |s, v| [s[0] + v[0], s[1] + v[1], s[2] + v[2]])
        .map(|s| s / mesh.vertices.len() as f64);
    for (i, (v, n)) in mesh.vertices.iter().zip(&mesh.normals).enumerate() {
        assert!(
            (dot(*n, *n).sqrt() - 1.0).abs() < 1e-4,
            "{what}: normal {i} is {n:?}"
        );
        assert!(
            dot(*n, sub(*v, centre)) > 0.0,
            "{what}: normal {i} {n:?} at {v:?} points inward"
        );
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.vertices[i]);
        let face = cross(sub(b, a), sub(c, a));
        let corners: f64 = t.iter().map(|&i| dot(face, mesh.normals[i])).sum();
        assert!(
            corners >= 0.0,
            "{what}: vertex normals disagree with the winding of {t:?}"
        );
    }
    signed
}

/// Runs `frames` frames on the CPU reference with the surface export; returns the frames'
/// statistics and what the run printed.
fn run_with_surface(
    scene: &Scene,
    dir: &Path,
    frames: u64,
    every: u64,
    format: SurfaceFormat,
) -> (Vec<FrameStats>, String) {
    let settings = SurfaceSettings::for_scene(scene, SurfaceOverrides::default()).unwrap();
    let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, scene).unwrap());
    let opts = RunOptions {
        surface: Some(SurfaceExporter::new(dir, every, format, settings, false).unwrap()),
        ..RunOptions::writing_nothing(frames, std::time::Instant::now())
    };
    let mut out = Vec::new();
    let stats = runner::run(&mut sim, opts, &mut out).unwrap();
    (stats, String::from_utf8(out).unwrap())
}

fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    names
}

#[test]
fn a_resting_block_exports_closed_outward_meshes_that_hold_its_volume() {
    let scene = block_scene();
    let volume = fluid_volume(&scene);
    assert!((volume - 0.17 * 0.06 * 0.17).abs() < 1e-9, "{volume}");
    let dir = tempfile::tempdir().unwrap();
    let (stats, out) = run_with_surface(&scene, dir.path(), 4, 2, SurfaceFormat::Obj);
    let fastest = stats.iter().map(|s| s.summary.max_speed).fold(0.0, f32::max);
    assert!(fastest < 0.05, "the block moves: {fastest} m/s");
    assert_eq!(
        names(dir.path()),
        ["surface_000000.obj", "surface_000002.obj", "surface_000004.obj"]
    );
    // The surface's summary, then the run's closing time line.
    let lines: Vec<&str> = out.lines().collect();
    let [.., summary, time] = lines[..] else {
        panic!("no closing lines in {out}");
    };
    assert!(time.starts_with("time: "), "{time}");
    assert!(
        summary.starts_with("surface: 3 meshes (obj in ") && summary.contains(" s per mesh"),
        "{summary}"
    );
    for name in names(dir.path()) {
        let enclosed = check_closed_outward(&read(&dir.path().join(&name)), volume, &name);
        println!("{name}: encloses {enclosed:.4e} m^3 of {volume:.4e} m^3");
    }
}

/// Every format: the writer's file reads back to exactly the mesh it was given, and the exporter's
/// file (its own reconstruction: the triangle order varies with the threads) is closed and outward.
#[test]
fn every_format_reads_back_to_the_same_mesh() {
    let scene = block_scene();
    let volume = fluid_volume(&scene);
    let settings = SurfaceSettings::for_scene(&scene, SurfaceOverrides::default()).unwrap();
    let positions = scene.spawn().x;
    let mesh: SurfaceMesh = mpm::export::surface::reconstruct(&positions, &settings).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for format in SurfaceFormat::ALL {
        let path = dir.path().join(format!("written.{}", format.extension()));
        let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        format.write(file, "a test frame\nline two", &mesh).unwrap();
        let back = read(&path);
        assert_eq!(back.triangles.len(), mesh.triangles.len(), "{format:?}");
        for (i, t) in back.triangles.iter().enumerate() {
            assert_eq!(t.map(|i| i as u32), mesh.triangles[i], "{format:?} triangle {i}");
        }
        // OBJ is text: Rust writes the shortest decimal that reads back to the same f32.
        for (i, (v, n)) in back.vertices.iter().zip(&back.normals).enumerate() {
            assert_eq!(v.map(|x| x as f32), mesh.vertices[i], "{format:?} vertex {i}");
            assert_eq!(n.map(|x| x as f32), mesh.normals[i], "{format:?} normal {i}");
        }
        check_closed_outward(&back, volume, &format!("{format:?} as written"));

        let sub_dir = dir.path().join(format.extension());
        let exporter = SurfaceExporter::new(&sub_dir, 1, format, settings, false).unwrap();
        let job = SurfaceJob {
            frame: 7,
            comment: "a test frame".into(),
            positions: positions.clone(),
        };
        let done = exporter.export(&job).unwrap();
        assert_eq!(
            done.path,
            sub_dir.join(format!("surface_000007.{}", format.extension()))
        );
        assert_eq!(
            names(&sub_dir),
            [format!("surface_000007.{}", format.extension())]
        );
        let exported = read(&done.path);
        assert_eq!(done.triangles, exported.triangles.len());
        check_closed_outward(&exported, volume, &format!("{format:?} exported"));
    }
}

/// A mesh that cannot be written (here its folder vanished after the checks; a full disk is the
/// same path) stops the run with the file's name and the reason, instead of being lost on a worker
/// thread; nothing is left under a mesh's name.
#[test]
fn a_failed_write_on_a_worker_stops_the_run() {
    let scene = block_scene();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("surface");
    let settings = SurfaceSettings::for_scene(&scene, SurfaceOverrides::default()).unwrap();
    let exporter = SurfaceExporter::new(&out, 1, SurfaceFormat::Ply, settings, false).unwrap();
    std::fs::remove_dir(&out).unwrap();
    let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
    let opts = RunOptions {
        surface: Some(exporter),
        ..RunOptions::writing_nothing(3, std::time::Instant::now())
    };
    let e = runner::run(&mut sim, opts, &mut std::io::sink()).unwrap_err();
    let text = format!("{e:#}");
    assert!(
        text.contains(&format!(
            "cannot write {}",
            out.join("surface_000000.ply").display()
        )) && text.contains("does not exist"),
        "{text}"
    );
    assert!(!out.exists());
}

// --- The command line: every refusal comes before the first step. ---

fn mpm(args: &[&str]) -> Output {
    Command::new(common::mpm_binary())
        .args(args)
        .output()
        .expect("running mpm")
}

fn tiny_scene_file(dir: &Path) -> String {
    let path = dir.join("tiny.toml");
    std::fs::write(
        &path,
        common::water_box(
            12,
            "[[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.06, 0.06, 0.06]",
        ),
    )
    .unwrap();
    path.to_str().unwrap().to_string()
}

/// `mpm run` of `scene` for `frames` frames on the CPU reference, then `extra`.
fn run_args<'a>(scene: &'a str, frames: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["run", "--backend", "cpu", "--frames", frames, "--scene", scene];
    args.extend_from_slice(extra);
    args
}

/// Runs `mpm run` with a tiny scene and `args`, expects a refusal before the first step, and returns
/// stderr.
fn refused(dir: &Path, args: &[&str]) -> String {
    let scene = tiny_scene_file(dir);
    let out = mpm(&run_args(&scene, "2", args));
    common::refused_before_stepping(out, args)
}

#[test]
fn bad_flag_values_are_refused_with_the_range() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("surface");
    // Each with `--export-surface DIR`: the flag, its value, and words the refusal must hold.
    for (flag, value, words) in [
        ("--every", "0", "0 is too small"),
        ("--every", "-3", "-3 is too small"),
        ("--every", "two", "not a whole number"),
        ("--surface-format", "stl", "possible values: obj, ply, vtk"),
        ("--surface-particle-radius", "0", "0 is not a positive number"),
        (
            "--surface-particle-radius",
            "-0.01",
            "-0.01 is not a positive number",
        ),
        (
            "--surface-smoothing-length",
            "nan",
            "NaN is not a positive number",
        ),
        ("--surface-threshold", "inf", "inf is not a positive number"),
        ("--surface-cube-size", "x", "`x` is not a number"),
        // A cell of 1e-6 radii: billions of cells per axis.
        ("--surface-cube-size", "1e-6", "larger --surface-cube-size"),
    ] {
        let args = ["--export-surface", out.to_str().unwrap(), flag, value];
        let text = refused(dir.path(), &args);
        assert!(text.contains(words), "{args:?}: {text}");
    }
    // The surface's flags without the surface, --every without an export.
    for (args, words) in [
        (&["--surface-format", "ply"][..], "--export-surface"),
        (&["--surface-threshold", "0.5"][..], "--export-surface"),
        (&["--every", "2"][..], "--export"),
    ] {
        let text = refused(dir.path(), args);
        assert!(text.contains(words), "{args:?}: {text}");
    }
    assert!(!out.exists() || names(&out).is_empty());
}

#[test]
fn existing_meshes_are_never_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("surface");
    std::fs::create_dir(&out).unwrap();
    // An earlier run's mesh, in another format than the new run's: the folder would mix two runs.
    std::fs::write(out.join("surface_000040.ply"), "saved by the user").unwrap();
    let text = refused(dir.path(), &["--export-surface", out.to_str().unwrap()]);
    assert!(
        text.contains("already holds 1 exported surface mesh")
            && text.contains("pick another --export-surface directory")
            && text.contains("--overwrite"),
        "{text}"
    );
    assert_eq!(names(&out), ["surface_000040.ply"]);
    assert_eq!(
        std::fs::read_to_string(out.join("surface_000040.ply")).unwrap(),
        "saved by the user"
    );
    // Other files in the folder are not the run's, and stay: only its own kind is refused or removed.
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let scene = tiny_scene_file(dir.path());
    let run = mpm(&run_args(
        &scene,
        "1",
        &["--export-surface", out.to_str().unwrap(), "--overwrite"],
    ));
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(
        stdout.contains("--overwrite: removed surface_000040.ply"),
        "{stdout}"
    );
    assert_eq!(
        names(&out),
        ["notes.txt", "surface_000000.obj", "surface_000001.obj"]
    );
}

#[test]
fn a_path_that_is_a_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("meshes");
    std::fs::write(&file, "a file").unwrap();
    let text = refused(dir.path(), &["--export-surface", file.to_str().unwrap()]);
    assert!(
        text.contains("--export-surface") && text.contains("is a file, not a directory"),
        "{text}"
    );
    let text = refused(
        dir.path(),
        &["--export-surface", file.join("below").to_str().unwrap()],
    );
    assert!(text.contains("cannot create the export directory"), "{text}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "a file");
}

/// A directory the user cannot write into is refused before the first step, naming it and the fix.
/// Root writes anywhere, so as root the run is made as `nobody` (through setpriv).
#[test]
fn a_read_only_directory_is_refused() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let dir = tempfile::tempdir().unwrap();
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    let scene = tiny_scene_file(dir.path());
    let args = run_args(&scene, "1", &["--export-surface", locked.to_str().unwrap()]);
    let as_root = std::fs::metadata("/proc/self")
        .map(|m| m.uid() == 0)
        .unwrap_or(false);
    let out = if as_root {
        let binary = common::mpm_binary();
        Command::new("setpriv")
            .args(["--reuid=65534", "--regid=65534", "--clear-groups", "--"])
            .arg(&binary)
            .args(&args)
            .output()
            .expect("as root, this test runs mpm as nobody through setpriv (util-linux)")
    } else {
        mpm(&args)
    };
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "wrote into a read-only directory: {text}");
    assert!(
        text.contains(&format!("cannot write into {}", locked.display())) && text.contains("not writable"),
        "{text}"
    );
    assert!(!String::from_utf8_lossy(&out.stdout).contains("frame "));
    assert!(names(&locked).is_empty());
}
