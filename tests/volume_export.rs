//! `mpm run --export-volume`: the OpenVDB files read back with an independent reader (the `vdb-rs`
//! crate) hold exactly the writer's grids, leaf by leaf and voxel by voxel, inactive values and
//! tiles included; the level set of a resting block of water is a signed distance whose zero sits
//! within a voxel of the block's flat top, -band deep inside and +band outside; the density reads
//! about 1 inside; and every bad input is refused before the first step, naming the fix.
//! vdb-rs reads float grids only (its root node reads a 4-byte background): the velocity grid is
//! read back by OpenVDB itself in tests/volume_readers.rs.

mod common;

use mpm::export::surface::SurfaceOverrides;
use mpm::export::vdb::{self, Tree};
use mpm::export::volume::{self, VolumeExporter, VolumeFormat, VolumeJob, VolumeOverrides, VolumeSettings};
use mpm::sim::Scene;
use std::collections::HashMap;
use std::path::Path;
use vdb_rs::{MetadataValue, VdbReader};

/// A 6 cm deep layer of water filling the floor of a 20 cm box wall to wall (its fluid region is
/// [1, 18] cm, its top at y = 7 cm), 8 particles per 1 cm cell: 13,872 particles at rest.
const BLOCK: &str = "[[block]]\nmin = [0.01, 0.01, 0.01]\nmax = [0.18, 0.07, 0.18]\nparticles_per_cell = 8";
const TOP: f32 = 0.07;

fn block_scene() -> Scene {
    common::scene(&common::water_box(20, BLOCK))
}

fn settings(scene: &Scene, volume: VolumeOverrides) -> VolumeSettings {
    VolumeSettings::for_scene(scene, SurfaceOverrides::default(), volume, 2).unwrap()
}

/// A voxel's value in a grid vdb-rs read: from its leaf, or the tile of the deepest node that holds
/// it; `None` where no root child holds it (the background, which vdb-rs does not keep). The node
/// layout is the format's (x slowest, then y, then z), written out here again.
fn probe(grid: &vdb_rs::Grid<f32>, ijk: [i32; 3]) -> Option<(f32, bool)> {
    let origin = |log2: u32| ijk.map(|c| c & !((1 << log2) - 1));
    let slot = |total: u32, child: u32| {
        let m = (1 << total) - 1;
        let log2 = total - child;
        let s = |c: i32| ((c & m) >> child) as u32;
        (s(ijk[0]) << (2 * log2)) | (s(ijk[1]) << log2) | s(ijk[2])
    };
    let n5 = grid
        .tree
        .root_nodes
        .iter()
        .find(|n| n.origin.to_array() == origin(12))?;
    let s5 = slot(12, 7);
    let Some(n4) = n5.nodes.get(&s5) else {
        return Some((n5.data[s5 as usize], n5.value_mask[s5 as usize]));
    };
    let s4 = slot(7, 3);
    let Some(leaf) = n4.nodes.get(&s4) else {
        return Some((n4.data[s4 as usize], n4.value_mask[s4 as usize]));
    };
    let n = slot(3, 0);
    Some((leaf.buffer[n as usize], leaf.value_mask[n as usize]))
}

/// Opens a file with vdb-rs.
fn open(path: &Path) -> VdbReader<std::io::BufReader<std::fs::File>> {
    VdbReader::new(std::io::BufReader::new(std::fs::File::open(path).unwrap())).unwrap()
}

/// Every leaf of `tree` is in `read`, with the same values and active voxels, and `read` has no
/// other leaf; `half`: the written values rounded to half precision.
fn assert_same_leaves(read: &vdb_rs::Grid<f32>, tree: &Tree<f32>, half: bool, what: &str) {
    let mut leaves: HashMap<[i32; 3], (&Vec<f32>, Vec<bool>)> = HashMap::new();
    for n5 in &read.tree.root_nodes {
        for n4 in n5.nodes.values() {
            for leaf in n4.nodes.values() {
                let active = (0..512).map(|n| leaf.value_mask[n]).collect();
                leaves.insert(leaf.origin.to_array(), (&leaf.buffer, active));
            }
        }
    }
    assert_eq!(leaves.len(), tree.leaf_count(), "{what}: leaves");
    let round = |x: f32| if half { half::f16::from_f32(x).to_f32() } else { x };
    for (origin, leaf) in tree.leaves() {
        let (values, active) = leaves
            .get(origin)
            .unwrap_or_else(|| panic!("{what}: no leaf at {origin:?}"));
        for n in 0..512 {
            assert_eq!(
                values[n],
                round(leaf.values[n]),
                "{what}: leaf {origin:?} voxel {n}"
            );
            assert_eq!(
                active[n],
                leaf.is_active(n),
                "{what}: leaf {origin:?} voxel {n} active"
            );
        }
    }
}

fn string_meta<'a>(read: &'a VdbReader<std::io::BufReader<std::fs::File>>, grid: &str, key: &str) -> &'a str {
    match read.grid_descriptors[grid].meta_data.0.get(key) {
        Some(MetadataValue::String(s)) => s,
        other => panic!("{grid}: {key} is {other:?}"),
    }
}

/// The resting block, written by the exporter and read back by vdb-rs: the same voxels as the
/// writer's grids, and the level set of a flat-topped block of water.
#[test]
fn a_resting_block_reads_back_as_its_level_set_and_density() {
    let scene = block_scene();
    let settings = settings(&scene, VolumeOverrides::default());
    let h = settings.voxel_size;
    assert_eq!(h, 0.0025, "the default voxel is the particle radius");
    let positions = scene.spawn().x;
    let volumes = volume::build(&positions, None, &settings).unwrap();
    assert!(volumes.velocity.is_none());

    let dir = tempfile::tempdir().unwrap();
    let exporter = VolumeExporter::new(dir.path(), 1, VolumeFormat::Vdb, settings, false).unwrap();
    let job = VolumeJob {
        frame: 5,
        comment: "a test frame".into(),
        positions: positions.clone(),
        velocities: None,
    };
    let started = std::time::Instant::now();
    let done = exporter.export(&job).unwrap();
    println!(
        "exported {} ({} voxels in the band, {} in the liquid) in {:.3} s",
        done.path.display(),
        done.band,
        done.liquid,
        started.elapsed().as_secs_f64()
    );
    assert_eq!(done.path, dir.path().join("volume_000005.vdb"));

    let mut file = open(&done.path);
    assert_eq!(file.header.file_version, 224);
    let mut names = file.available_grids();
    names.sort();
    assert_eq!(names, ["density", "surface"]);
    assert_eq!(file.grid_descriptors["surface"].grid_type, "Tree_float_5_4_3");
    assert_eq!(string_meta(&file, "surface", "class"), "level set");
    assert_eq!(string_meta(&file, "density", "class"), "fog volume");
    let surface = file.read_grid::<f32>("surface").unwrap();
    let density = file.read_grid::<f32>("density").unwrap();
    match surface.transform {
        vdb_rs::Map::UniformScaleMap { voxel_size, .. } => {
            assert_eq!(voxel_size.to_array(), [f64::from(h); 3])
        }
        ref other => panic!("transform {other:?}"),
    }
    assert_same_leaves(&surface, &volumes.surface.tree, false, "surface");
    assert_same_leaves(&density, &volumes.density.tree, false, "density");

    // Every voxel of a box around the water: the reader's value is the writer's (tiles included).
    let band = settings.band_width();
    let (mut compared, mut tiles) = (0, 0);
    for i in (-8..90).step_by(3) {
        for j in -8..45 {
            for k in (-8..90).step_by(5) {
                let written = volumes.surface.tree.value([i, j, k]);
                match probe(&surface, [i, j, k]) {
                    Some(read) => {
                        assert_eq!(read, written, "surface at {:?}", [i, j, k]);
                        compared += 1;
                        tiles += usize::from(
                            volumes
                                .surface
                                .tree
                                .leaf(vdb::node_origin([i, j, k], 3))
                                .is_none(),
                        );
                    }
                    None => assert_eq!(written, (band, false), "surface at {:?}", [i, j, k]),
                }
            }
        }
    }
    assert!(
        compared > 10_000 && tiles > 1000,
        "{compared} voxels compared, {tiles} in tiles"
    );

    // The level set of the block: -band deep inside (a tile), +band far outside, and on every
    // column through the top, one crossing within a voxel of y = 7 cm with slope 1 above it.
    let centre = [38, 16, 38];
    assert_eq!(probe(&surface, centre), Some((-band, false)), "deep inside");
    assert_eq!(
        volumes.surface.tree.value([38, 60, 38]),
        (band, false),
        "far above"
    );
    let sdf = |i: i32, j: i32, k: i32| probe(&surface, [i, j, k]).map_or(band, |(v, _)| v);
    let mut crossings = Vec::new();
    for i in (20..56).step_by(3) {
        for k in (20..56).step_by(4) {
            let column: Vec<f32> = (16..40).map(|j| sdf(i, j, k)).collect();
            let below: Vec<usize> = (0..column.len() - 1)
                .filter(|&n| column[n] < 0.0 && column[n + 1] >= 0.0)
                .collect();
            assert_eq!(below.len(), 1, "column {i},{k}: {column:?}");
            let n = below[0];
            let y = (16 + n as i32) as f32 * h + column[n] / (column[n] - column[n + 1]) * h;
            crossings.push(y);
            // A signed distance: it grows by a voxel a voxel away from the flat top, in the band.
            for m in n.saturating_sub(1)..n + 3 {
                let step = column[m + 1] - column[m];
                assert!(
                    (step - h).abs() < 1e-3 * h,
                    "column {i},{k}: {step} m between voxels {m} and {}: {column:?}",
                    m + 1
                );
            }
        }
    }
    let (lo, hi) = crossings
        .iter()
        .fold((f32::MAX, f32::MIN), |(lo, hi), &y| (lo.min(y), hi.max(y)));
    println!(
        "the zero crossing over the block's top: y = {lo:.5} to {hi:.5} m ({} columns), the top {TOP} m, voxels of {h} m",
        crossings.len()
    );
    assert!(
        (lo - TOP).abs() < h && (hi - TOP).abs() < h,
        "{lo}..{hi} against {TOP}"
    );

    // The density: about 1 inside, 0 outside.
    let inside = probe(&density, centre).unwrap();
    assert!(
        inside.1 && (inside.0 - 1.0).abs() < 0.03,
        "density inside {inside:?}"
    );
    assert_eq!(volumes.density.tree.value([38, 60, 38]), (0.0, false));
}

/// With `--volume-half` the reader reads the writer's values rounded to half precision, the type
/// name and metadata say so, and the file is smaller.
#[test]
fn half_floats_read_back_rounded() {
    let scene = block_scene();
    let positions = scene.spawn().x;
    let dir = tempfile::tempdir().unwrap();
    let mut sizes = Vec::new();
    for half in [false, true] {
        let settings = settings(
            &scene,
            VolumeOverrides {
                half,
                ..VolumeOverrides::default()
            },
        );
        let sub = dir.path().join(if half { "half" } else { "float" });
        let exporter = VolumeExporter::new(&sub, 1, VolumeFormat::Vdb, settings, false).unwrap();
        let job = VolumeJob {
            frame: 0,
            comment: "half".into(),
            positions: positions.clone(),
            velocities: None,
        };
        let done = exporter.export(&job).unwrap();
        let volumes = volume::build(&positions, None, &settings).unwrap();
        let mut file = open(&done.path);
        let suffix = if half { "_HalfFloat" } else { "" };
        assert_eq!(
            file.grid_descriptors["surface"].grid_type,
            format!("Tree_float_5_4_3{suffix}")
        );
        assert_eq!(file.grid_descriptors["density"].meta_data.is_half_float(), half);
        for (name, tree) in [
            ("surface", &volumes.surface.tree),
            ("density", &volumes.density.tree),
        ] {
            assert_same_leaves(&file.read_grid::<f32>(name).unwrap(), tree, half, name);
        }
        sizes.push(std::fs::metadata(&done.path).unwrap().len());
    }
    println!("file sizes: float {} bytes, half {} bytes", sizes[0], sizes[1]);
    assert!(sizes[1] * 10 < sizes[0] * 6, "{sizes:?}");
}

/// No particles: the grids are empty, and the file still reads.
#[test]
fn an_empty_frame_writes_empty_grids() {
    let scene = block_scene();
    let settings = settings(&scene, VolumeOverrides::default());
    let dir = tempfile::tempdir().unwrap();
    let exporter = VolumeExporter::new(dir.path(), 1, VolumeFormat::Vdb, settings, false).unwrap();
    let job = VolumeJob {
        frame: 0,
        comment: "empty".into(),
        positions: vec![],
        velocities: None,
    };
    let done = exporter.export(&job).unwrap();
    let mut file = open(&done.path);
    let surface = file.read_grid::<f32>("surface").unwrap();
    assert!(surface.tree.root_nodes.is_empty());
}

// --- Through `mpm run`: files, the closing line, and every refusal before the first step. ---

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

fn run(dir: &Path, frames: &str, extra: &[&str]) -> std::process::Output {
    let scene = tiny_scene_file(dir);
    let mut args = vec![
        "run",
        "--backend",
        "cpu",
        "--frames",
        frames,
        "--scene",
        scene.as_str(),
    ];
    args.extend_from_slice(extra);
    common::mpm(&args)
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
fn mpm_run_writes_every_kth_frame() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("volumes");
    let o = out.to_str().unwrap();
    let result = run(
        dir.path(),
        "4",
        &[
            "--export-volume",
            o,
            "--every",
            "2",
            "--surface-threshold",
            "0.5",
            "--volume-band",
            "2",
        ],
    );
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(
        result.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&result.stderr)
    );
    assert_eq!(
        names(&out),
        ["volume_000000.vdb", "volume_000002.vdb", "volume_000004.vdb"]
    );
    assert!(
        stdout.contains("a band of 2 voxels") && stdout.contains("threshold 0.5 x rest density"),
        "{stdout}"
    );
    assert!(stdout.contains("volume: 3 volumes (vdb in "), "{stdout}");
    for name in names(&out) {
        let mut file = open(&out.join(name));
        let surface = file.read_grid::<f32>("surface").unwrap();
        assert!(!surface.tree.root_nodes.is_empty());
    }
    // Again: refused, the earlier run's files untouched; with --overwrite, replaced.
    let again = run(dir.path(), "0", &["--export-volume", o]);
    assert!(!again.status.success());
    let stderr = String::from_utf8_lossy(&again.stderr);
    assert!(
        stderr.contains("already holds 3 exported volumes") && stderr.contains("--overwrite"),
        "{stderr}"
    );
    std::fs::write(out.join("volume_000006.vdb.partial"), b"half a file").unwrap();
    let again = run(dir.path(), "0", &["--export-volume", o, "--overwrite"]);
    let stdout = String::from_utf8_lossy(&again.stdout);
    assert!(again.status.success(), "{stdout}");
    assert!(
        stdout.contains("removed 1 file that a killed run left unfinished"),
        "{stdout}"
    );
    assert_eq!(names(&out), ["volume_000000.vdb"]);
}

/// Runs with `args`, expects a refusal before the first step, and returns stderr.
fn refused(dir: &Path, args: &[&str]) -> String {
    let out = run(dir, "2", args);
    common::refused_before_stepping(out, args)
}

#[test]
fn bad_volume_options_are_refused_before_the_first_step() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("volumes");
    let o = out.to_str().unwrap();
    for (flag, value, words) in [
        ("--volume-band", "0", "0 is not a positive number"),
        ("--volume-band", "-1", "-1 is not a positive number"),
        ("--volume-band", "0.5", "give 1 or more"),
        ("--volume-voxel-size", "0", "0 is not a positive number"),
        ("--volume-voxel-size", "nan", "NaN is not a positive number"),
        ("--volume-format", "nvdb", "possible values: vdb"),
        // Thousands of times the machine's memory.
        ("--volume-voxel-size", "1e-6", "give a larger --volume-voxel-size"),
        // Past what a grid's coordinates hold.
        (
            "--volume-voxel-size",
            "1e-12",
            "give a larger --volume-voxel-size",
        ),
    ] {
        let text = refused(dir.path(), &["--export-volume", o, flag, value]);
        assert!(text.contains(words), "{flag} {value}: {text}");
    }
    assert!(!out.exists(), "a refused run made {}", out.display());
    // The volumes' flags without the volumes.
    for args in [
        &["--volume-band", "3"][..],
        &["--volume-velocity"][..],
        &["--volume-half"][..],
    ] {
        let text = refused(dir.path(), args);
        assert!(text.contains("--export-volume"), "{args:?}: {text}");
    }
    // A folder that cannot be made: a path through a file.
    let file = dir.path().join("a-file");
    std::fs::write(&file, b"").unwrap();
    let through = file.join("volumes");
    let text = refused(dir.path(), &["--export-volume", through.to_str().unwrap()]);
    assert!(text.contains(&through.display().to_string()), "{text}");
    let text = refused(dir.path(), &["--export-volume", file.to_str().unwrap()]);
    assert!(text.contains("is a file, not a directory"), "{text}");
}
