//! The runner's outputs: PLY frames that an independent reader gives back exactly, JSON-lines stats,
//! and refusals that protect what a user saved.

mod common;

use mpm::backend::{self, BackendKind};
use mpm::export::{PlyExporter, PLY_MATERIAL_PROPERTY, PLY_PROPERTIES};
use mpm::runner::{self, RunOptions, StatsFile};
use mpm::sim::material::NamedMaterial;
use mpm::sim::{Particles, Simulation};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};

fn small_scene() -> mpm::sim::Scene {
    common::scene(&common::water_box(
        16,
        "[[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.08, 0.1, 0.08]\nvelocity = [0.5, 0.0, -0.25]",
    ))
}

fn read_back(path: &std::path::Path) -> Vec<[f32; 7]> {
    read_back_all(path)
        .0
        .into_iter()
        .map(|(floats, _)| floats)
        .collect()
}

/// Each vertex's floats and material row, and the header's comments.
fn read_back_all(path: &std::path::Path) -> (Vec<([f32; 7], u8)>, Vec<String>) {
    let mut f = std::fs::File::open(path).unwrap();
    let ply = Parser::<DefaultElement>::new().read_ply(&mut f).unwrap();
    let names: Vec<&String> = ply.header.elements["vertex"].properties.keys().collect();
    let mut expected: Vec<&str> = PLY_PROPERTIES.to_vec();
    expected.push(PLY_MATERIAL_PROPERTY);
    assert_eq!(names, expected, "the vertex properties or their order changed");
    let vertices = ply.payload["vertex"]
        .iter()
        .map(|v| {
            let floats = PLY_PROPERTIES.map(|name| match v[name] {
                Property::Float(x) => x,
                ref other => panic!("{name} is {other:?}, not a float"),
            });
            let material = match v[PLY_MATERIAL_PROPERTY] {
                Property::UChar(m) => m,
                ref other => panic!("material is {other:?}, not a uchar"),
            };
            (floats, material)
        })
        .collect();
    (vertices, ply.header.comments.clone())
}

#[test]
fn exported_ply_reads_back_to_the_same_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let p = common::random_particles(500, 0.0, 1.0, 3.0, 1.0, 7);
    let p = Particles {
        rho: (0..500).map(|i| 900.0 + i as f32).collect(),
        material: (0..500).map(|i| (i % 3) as u8).collect(),
        ..p
    };
    let table = ["water", "olive oil", "honey"].map(|name| NamedMaterial {
        absorption: 1.0,
        name: name.to_string(),
        colour: [0.25, 0.5, 1.0],
        law: Default::default(),
    });
    let exporter = PlyExporter::new(dir.path(), 1, false).unwrap();
    let path = exporter.write(3, "a test frame", &p, &table).unwrap();
    assert_eq!(path.file_name().unwrap(), "frame_000003.ply");
    let (back, comments) = read_back_all(&path);
    assert_eq!(back.len(), 500);
    for (i, (r, material)) in back.iter().enumerate() {
        let expected = [
            p.x[i].x, p.x[i].y, p.x[i].z, p.v[i].x, p.v[i].y, p.v[i].z, p.rho[i],
        ];
        assert_eq!(r, &expected, "particle {i}");
        assert_eq!(*material, p.material[i], "particle {i}'s material");
    }
    assert_eq!(
        comments,
        [
            "a test frame",
            "material 0 water 0.250 0.500 1.000",
            "material 1 olive oil 0.250 0.500 1.000",
            "material 2 honey 0.250 0.500 1.000",
        ]
    );
}

#[test]
fn a_run_writes_sorted_frames_and_stats_lines_and_refuses_to_overwrite_them() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    let stats = dir.path().join("stats.jsonl");
    let scene = small_scene();
    let run = |overwrite: bool| -> anyhow::Result<Vec<mpm::sim::FrameStats>> {
        let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene)?);
        let opts = RunOptions {
            export: Some(PlyExporter::new(&frames, 2, overwrite)?),
            stats: Some(StatsFile::create(&stats, overwrite)?),
            ..RunOptions::writing_nothing(4, std::time::Instant::now())
        };
        runner::run(&mut sim, opts, &mut std::io::sink())
    };
    let lines = run(false).unwrap();
    let mut names: Vec<String> = std::fs::read_dir(&frames)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["frame_000000.ply", "frame_000002.ply", "frame_000004.ply"]
    );
    assert_eq!(
        read_back(&frames.join("frame_000000.ply")).len(),
        scene.num_particles
    );
    // Frame 0 is the spawned state: the body's initial velocity, rest density.
    assert!(read_back(&frames.join("frame_000000.ply"))
        .iter()
        .all(|r| r[3] == 0.5 && r[6] == 1000.0));

    let text = std::fs::read_to_string(&stats).unwrap();
    let parsed: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(parsed.len(), 4);
    assert_eq!(parsed[3]["frame"], 4);
    assert_eq!(parsed[3]["particles"], scene.num_particles);
    assert_eq!(parsed[3]["substeps"], lines[3].substeps);
    for key in [
        "time",
        "max_speed",
        "density_ratio_min",
        "max_cfl",
        "kinetic_energy",
        "centre_of_mass",
    ] {
        assert!(
            !parsed[3][key].is_null(),
            "{key} missing from {}",
            text.lines().last().unwrap()
        );
    }

    let refused = run(false).unwrap_err().to_string();
    assert!(
        refused.contains("already") && refused.contains("--overwrite"),
        "{refused}"
    );
    assert!(run(true).is_ok());
}

#[test]
fn an_unwritable_export_directory_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "not a directory").unwrap();
    let e = PlyExporter::new(&file.join("frames"), 1, false).err().unwrap();
    assert!(
        format!("{e:#}").contains("cannot create the export directory"),
        "{e:#}"
    );
    assert!(
        PlyExporter::new(dir.path(), 0, false).is_err(),
        "--every 0 is refused"
    );
}

/// `--overwrite` into a folder from a longer earlier run: the earlier run's frames are removed (and
/// named), so the folder holds the new run only.
#[test]
fn overwrite_leaves_one_run_in_the_folder() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    let scene = small_scene();
    let run = |count: u64, overwrite: bool| -> anyhow::Result<Option<String>> {
        let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene)?);
        let exporter = PlyExporter::new(&frames, 1, overwrite)?;
        let note = exporter.removed_note();
        let opts = RunOptions {
            export: Some(exporter),
            ..RunOptions::writing_nothing(count, std::time::Instant::now())
        };
        runner::run(&mut sim, opts, &mut std::io::sink())?;
        Ok(note)
    };
    assert_eq!(run(5, false).unwrap(), None);
    let note = run(2, true).unwrap().expect("the earlier frames are reported");
    assert!(
        note.contains("removed 6 frames") && note.contains("frame_000000.ply .. frame_000005.ply"),
        "{note}"
    );
    let mut names: Vec<String> = std::fs::read_dir(&frames)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["frame_000000.ply", "frame_000001.ply", "frame_000002.ply"]
    );
}

/// `--export` onto a file says it is a file; a refused permission is not called a full disk.
#[test]
fn export_errors_name_the_real_problem() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "not a directory").unwrap();
    let e = PlyExporter::new(&file, 1, false).err().unwrap();
    assert!(format!("{e:#}").contains("is a file, not a directory"), "{e:#}");

    use std::io::{Error, ErrorKind};
    let denied = mpm::text::io_reason(&Error::from(ErrorKind::PermissionDenied));
    assert!(
        denied.contains("not writable") && !denied.contains("space"),
        "{denied}"
    );
    let full = mpm::text::io_reason(&Error::from(ErrorKind::StorageFull));
    assert!(full.contains("free some space"), "{full}");
}

/// A huge --frames is a long run, not an abort: nothing is reserved up front for it.
#[test]
fn a_huge_frame_count_does_not_abort() {
    let scene = small_scene();
    let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
    // The runner stops at the first error; a closed output is one, after the first frame.
    struct Closed;
    impl std::io::Write for Closed {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(std::io::ErrorKind::BrokenPipe.into())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let opts = RunOptions::writing_nothing(99_999_999_999, std::time::Instant::now());
    let e = runner::run(&mut sim, opts, &mut Closed).unwrap_err();
    assert!(format!("{e:#}").to_lowercase().contains("pipe"), "{e:#}");
}

/// A run of two liquids writes each particle's row, and the header names and colours the rows as the
/// scene does.
#[test]
fn a_run_of_two_liquids_exports_each_particles_material() {
    let scene = common::scene(
        r#"
[domain]
size = [0.16, 0.16, 0.16]
resolution = [16, 16, 16]

[[material]]
name = "water"
rest_density = 1000.0
sound_speed = 20.0

[[material]]
name = "syrup"
rest_density = 1300.0
sound_speed = 20.0
viscosity = 0.5
colour = [0.6, 0.3, 0.05]

[[block]]
min = [0.03, 0.03, 0.03]
max = [0.07, 0.08, 0.13]
material = "syrup"

[[block]]
min = [0.09, 0.03, 0.03]
max = [0.13, 0.08, 0.13]
material = "water"
"#,
    );
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
    let opts = RunOptions {
        export: Some(PlyExporter::new(&frames, 1, false).unwrap()),
        ..RunOptions::writing_nothing(1, std::time::Instant::now())
    };
    runner::run(&mut sim, opts, &mut std::io::sink()).unwrap();
    let (vertices, comments) = read_back_all(&frames.join("frame_000000.ply"));
    assert!(
        comments.contains(&"material 0 water 0.100 0.350 0.800".to_string())
            && comments.contains(&"material 1 syrup 0.600 0.300 0.050".to_string()),
        "{comments:?}"
    );
    // The syrup (row 1) block is left of x = 0.08 m, the water (row 0) right of it.
    for (floats, material) in &vertices {
        assert_eq!(
            *material,
            u8::from(floats[0] < 0.08),
            "particle at x = {}",
            floats[0]
        );
    }
    let (after, _) = read_back_all(&frames.join("frame_000001.ply"));
    let count = |rows: &[([f32; 7], u8)], row: u8| rows.iter().filter(|(_, m)| *m == row).count();
    assert!(count(&vertices, 0) > 0 && count(&vertices, 1) > 0);
    assert_eq!(
        (count(&after, 0), count(&after, 1)),
        (count(&vertices, 0), count(&vertices, 1)),
        "a liquid changed its particle count"
    );
}

fn ok(out: &std::process::Output) -> String {
    assert!(
        out.status.success(),
        "mpm failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn names_in(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    names
}

/// An OBJ's objects: each one's name and its vertices (world coordinates), in file order.
fn obj_objects(path: &std::path::Path) -> Vec<(String, Vec<glam::DVec3>)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut objects: Vec<(String, Vec<glam::DVec3>)> = Vec::new();
    let mut vertices = 0;
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("o") => objects.push((words.next().unwrap().to_string(), Vec::new())),
            Some("v") => {
                let p: Vec<f64> = words.map(|w| w.parse().unwrap()).collect();
                objects
                    .last_mut()
                    .expect("a vertex before any object")
                    .1
                    .push(glam::DVec3::new(p[0], p[1], p[2]));
                vertices += 1;
            }
            Some("f") => {
                for corner in words {
                    let index: usize = corner.split("//").next().unwrap().parse().unwrap();
                    assert!((1..=vertices).contains(&index), "{line}: no vertex {index} yet");
                }
            }
            _ => {}
        }
    }
    objects
}

/// `--export-bodies` through `mpm run`: the steel log thrown into a pool
/// ([`common::log_thrown_into_a_pool`]) for 3 frames, every 2nd. The directory holds the pose table
/// and the meshes of frames 0 and 2; the table's rows are the simulation's poses, to the bit (frame
/// 2's those of the same run in this process, frame 0's the scene's start); each mesh is one object a body, named by its collider, whose 24
/// vertices (a box: 4 a face, each with its face's normal) sit at the pose's corners, centre +
/// R (+-half extents).
#[test]
fn export_bodies_writes_each_body_posed_and_a_pose_table() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("log.toml");
    std::fs::write(&scene, common::log_thrown_into_a_pool()).unwrap();
    let out = dir.path().join("bodies");
    let p = |path: &std::path::Path| path.to_str().unwrap().to_string();
    let run = ["--export-bodies", &p(&out), "--every", "2"];
    let stdout = ok(&common::cpu_run(&p(&scene), "3", &run));
    assert!(
        stdout.contains("exported the rigid bodies of 2 frames into"),
        "{stdout}"
    );
    assert_eq!(
        names_in(&out),
        ["bodies.csv", "bodies_000000.obj", "bodies_000002.obj"]
    );

    let table = std::fs::read_to_string(out.join("bodies.csv")).unwrap();
    let mut lines = table.lines();
    assert_eq!(lines.next(), Some(mpm::export::bodies::POSE_TABLE_HEADER));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 2, "{table}");
    assert!(rows.iter().all(|r| r.len() == 16), "{table}");
    assert_eq!((rows[0][0], rows[1][0]), (0.0, 2.0), "the frames");
    assert!(rows.iter().all(|r| r[2] == 0.0), "the collider index");
    // Frame 0: where the scene starts the log, turned 10 degrees about z, thrown down at 4 m/s.
    let start = glam::DQuat::from_rotation_z(10f64.to_radians());
    assert_eq!(rows[0][1], 0.0);
    assert_eq!(&rows[0][3..6], [0.12, 0.15, 0.035]);
    assert!((glam::DQuat::from_slice(&rows[0][6..10]).dot(start) - 1.0).abs() < 1e-12);
    assert_eq!(&rows[0][10..16], [0.0, -4.0, 0.0, 0.0, 0.0, 0.0]);
    // Frame 2: the pose of the same run here, to the bit.
    let scene = common::scene(&common::log_thrown_into_a_pool());
    let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
    for _ in 0..2 {
        sim.advance_frame().unwrap();
    }
    let b = sim.bodies()[0];
    let pose = [b.center, b.velocity, b.angular_velocity];
    assert_eq!(rows[1][1].to_bits(), sim.time().to_bits());
    assert_eq!(rows[1][3..6], pose[0]);
    assert_eq!(rows[1][6..10], b.orientation);
    assert_eq!(rows[1][10..13], pose[1]);
    assert_eq!(rows[1][13..16], pose[2]);
    assert!(rows[1][4] < 0.1, "the log has not fallen: {:?}", rows[1]);

    let half = glam::DVec3::new(0.03, 0.02, 0.024);
    for (row, frame) in rows.iter().zip([0, 2]) {
        let objects = obj_objects(&out.join(format!("bodies_{frame:06}.obj")));
        assert_eq!(objects.len(), 1, "frame {frame}");
        let (name, vertices) = &objects[0];
        assert_eq!(name, "collider_0");
        assert_eq!(vertices.len(), 24, "frame {frame}: a box's faces, 4 corners each");
        let center = glam::DVec3::from_slice(&row[3..6]);
        let rotation = glam::DQuat::from_slice(&row[6..10]);
        let mut corners = std::collections::BTreeSet::new();
        for v in vertices {
            let local = rotation.inverse() * (*v - center);
            let sign = (local / half).round();
            assert!(
                sign.abs() == glam::DVec3::ONE && (local - sign * half).length() < 1e-6,
                "frame {frame}: vertex {v} is not a corner of the posed box (local {local})"
            );
            corners.insert(sign.to_array().map(|s| s as i32));
        }
        assert_eq!(corners.len(), 8, "frame {frame}: not every corner is there");
    }
}

/// `--export-bodies` is refused before any work for a scene without rigid bodies, and for a
/// directory holding an earlier run's body files or a pose table a user saved there (left as they
/// were); `--overwrite` replaces them, saying so.
#[test]
fn export_bodies_refuses_a_scene_without_bodies_and_existing_files() {
    let dir = tempfile::tempdir().unwrap();
    let p = |path: &std::path::Path| path.to_str().unwrap().to_string();
    let out = dir.path().join("bodies");
    let refused = common::cpu_run("dam-break-coarse", "1", &["--export-bodies", &p(&out)]);
    assert!(!refused.status.success());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        stderr.contains("has no rigid bodies") && stderr.contains("drop --export-bodies"),
        "{stderr}"
    );
    assert!(!out.exists(), "the directory was created for a refused run");

    let scene = dir.path().join("log.toml");
    std::fs::write(&scene, common::log_thrown_into_a_pool()).unwrap();
    let first = common::cpu_run(&p(&scene), "0", &["--export-bodies", &p(&out)]);
    ok(&first);
    assert_eq!(names_in(&out), ["bodies.csv", "bodies_000000.obj"]);
    let table = std::fs::read(out.join("bodies.csv")).unwrap();
    let again = common::cpu_run(&p(&scene), "0", &["--export-bodies", &p(&out)]);
    assert!(!again.status.success());
    let stderr = String::from_utf8_lossy(&again.stderr);
    assert!(
        stderr.contains("already holds 2 exported body files") && stderr.contains("--overwrite"),
        "{stderr}"
    );
    assert_eq!(std::fs::read(out.join("bodies.csv")).unwrap(), table);
    let replaced = ok(&common::cpu_run(
        &p(&scene),
        "0",
        &["--export-bodies", &p(&out), "--overwrite"],
    ));
    assert!(
        replaced.contains("--overwrite: removed 2 body files of an earlier run"),
        "{replaced}"
    );

    // A pose table alone (a user's, say) is an earlier run's file too.
    let mine = dir.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("bodies.csv"), "my notes").unwrap();
    let kept = common::cpu_run(&p(&scene), "0", &["--export-bodies", &p(&mine)]);
    assert!(!kept.status.success());
    assert_eq!(
        std::fs::read_to_string(mine.join("bodies.csv")).unwrap(),
        "my notes"
    );
}

/// `--export-usd` is checked before any work: a name that is not `.usda`/`.usd`, a missing folder
/// and an earlier run's stage (left as it was, no clip folder made) are refused with the fix;
/// `--overwrite` replaces the stage, saying so; `--usd-surface` needs `--export-usd`. The files
/// written: the root layer, and in `NAME_clips/` the manifest and a layer a frame (what the stage
/// holds is checked through USD's own library in tests/usd_readers.rs).
#[test]
fn export_usd_refuses_bad_paths_and_earlier_stages_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let p = |path: &std::path::Path| path.to_str().unwrap().to_string();
    let stderr = |out: &std::process::Output| String::from_utf8_lossy(&out.stderr).into_owned();
    let binary = common::cpu_run(
        "dam-break-coarse",
        "0",
        &["--export-usd", &p(&dir.path().join("a.usdc"))],
    );
    assert!(!binary.status.success());
    assert!(
        stderr(&binary).contains("name a .usda file"),
        "{}",
        stderr(&binary)
    );
    let missing = dir.path().join("no/such/folder/a.usda");
    let out = common::cpu_run("dam-break-coarse", "0", &["--export-usd", &p(&missing)]);
    assert!(
        stderr(&out).contains("does not exist; create it"),
        "{}",
        stderr(&out)
    );
    let out = common::cpu_run("dam-break-coarse", "0", &["--usd-surface"]);
    assert!(
        !out.status.success() && stderr(&out).contains("--export-usd"),
        "{}",
        stderr(&out)
    );
    assert_eq!(
        names_in(dir.path()),
        Vec::<String>::new(),
        "nothing is left behind"
    );

    let stage = dir.path().join("dam.usda");
    let stdout = ok(&common::cpu_run(
        "dam-break-coarse",
        "2",
        &["--export-usd", &p(&stage), "--every", "2"],
    ));
    assert!(stdout.contains("usd: 2 frames in"), "{stdout}");
    assert_eq!(names_in(dir.path()), ["dam.usda", "dam_clips"]);
    assert_eq!(
        names_in(&dir.path().join("dam_clips")),
        [
            "particles.manifest.usda",
            "particles_000000.usda",
            "particles_000002.usda"
        ]
    );
    let written = std::fs::read(&stage).unwrap();
    let again = common::cpu_run("dam-break-coarse", "1", &["--export-usd", &p(&stage)]);
    assert!(!again.status.success());
    assert!(
        stderr(&again).contains("exists; pass --overwrite to replace it"),
        "{}",
        stderr(&again)
    );
    assert_eq!(
        std::fs::read(&stage).unwrap(),
        written,
        "the earlier stage is untouched"
    );
    let replaced = ok(&common::cpu_run(
        "dam-break-coarse",
        "1",
        &["--export-usd", &p(&stage), "--overwrite"],
    ));
    assert!(
        replaced.contains("--overwrite: removed the earlier")
            && replaced.contains("removed 3 USD particle layers"),
        "{replaced}"
    );
    assert_eq!(
        names_in(&dir.path().join("dam_clips")),
        [
            "particles.manifest.usda",
            "particles_000000.usda",
            "particles_000001.usda"
        ]
    );
}
