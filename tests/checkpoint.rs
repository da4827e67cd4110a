//! Checkpoint and restart on the CPU backends: a resumed run is byte for byte the uninterrupted one,
//! and a corrupt, truncated, foreign or newer file is refused with a clear error. The same identity on
//! the GPU is in tests/gpu_lifecycle.rs.

use mpm::backend::{self, BackendKind};
use mpm::checkpoint::{Checkpoint, CheckpointSeries, FORMAT_VERSION};
use mpm::sim::{ScatterMode, Scene, Simulation};
use std::path::Path;
use std::process::Output;

mod common;
use common::mpm;

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "mpm failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The statistics lines of a run's stdout, without the wall-clock timing.
fn frame_lines(stdout: &str) -> Vec<String> {
    stdout
        .lines()
        .filter(|l| l.starts_with("frame"))
        .map(|l| l.split("  step=").next().unwrap_or(l).to_string())
        .collect()
}

fn path(p: &Path) -> &str {
    p.to_str().expect("temp paths are UTF-8")
}

/// `mpm` with the run's options `run`, resumed from the checkpoint `from` for two more frames,
/// checkpointing into `into`: its stdout.
fn resume_for_two_frames(run: &[&str], from: &Path, into: &Path) -> String {
    let mut args = run.to_vec();
    args.extend([
        "--resume",
        path(from),
        "--frames",
        "2",
        "--checkpoint",
        path(into),
    ]);
    ok(&mpm(&args))
}

/// The dam break at 2.5 cm under the CFL policy: the substep follows the collapse's rising speeds, so
/// the time-step policy's memory matters to the frames after a resume.
fn run_and_resume(backend: &str) {
    let dir = tempfile::tempdir().unwrap();
    let (whole, resumed) = (dir.path().join("whole"), dir.path().join("resumed"));
    let common = [
        "run",
        "--backend",
        backend,
        "--scatter",
        "fixed-point",
        "--checkpoint-every",
        "3",
    ];
    let mut args = common.to_vec();
    args.extend([
        "--scene",
        "dam-break-coarse",
        "--frames",
        "10",
        "--checkpoint",
        path(&whole),
    ]);
    let uninterrupted = ok(&mpm(&args));
    for frame in [3, 6, 9, 10] {
        let file = whole.join(format!("checkpoint_{frame:06}.mpmck"));
        assert!(file.is_file(), "no checkpoint at frame {frame}:\n{uninterrupted}");
    }
    let start = whole.join("checkpoint_000003.mpmck");
    // At frame 3 the collapse is speeding up: the policy's memory of the rise shapes the next substeps,
    // so a resume that lost it would step differently (and this test would see it).
    let clock = Checkpoint::read(&start).unwrap().clock;
    assert!(
        clock.signal_rise > 0.0,
        "the test needs a rising signal speed at its start: {clock:?}"
    );
    let mut args = common.to_vec();
    args.extend([
        "--resume",
        path(&start),
        "--frames",
        "7",
        "--checkpoint",
        path(&resumed),
    ]);
    let continued = ok(&mpm(&args));
    assert!(continued.contains("resumed from"), "{continued}");

    let lines = frame_lines(&uninterrupted);
    assert_eq!(
        frame_lines(&continued),
        lines[3..],
        "the resumed run's frames differ from the uninterrupted run's"
    );
    for frame in [6, 9, 10] {
        let name = format!("checkpoint_{frame:06}.mpmck");
        let (a, b) = (
            std::fs::read(whole.join(&name)).unwrap(),
            std::fs::read(resumed.join(&name)).unwrap(),
        );
        assert!(
            a == b,
            "{name}: the resumed run's state is not byte-identical to the uninterrupted run's"
        );
    }
    assert!(
        !resumed.join("checkpoint_000003.mpmck").exists(),
        "the resumed run rewrote the frame it started from"
    );
}

#[test]
fn a_resumed_cpu_run_is_byte_identical_to_an_uninterrupted_one() {
    run_and_resume("cpu");
}

#[test]
fn a_resumed_cpu_parallel_run_is_byte_identical_to_an_uninterrupted_one() {
    run_and_resume("cpu-parallel");
}

fn small_sim(frames: u64) -> Simulation {
    let mut scene = Scene::load("dam-break-coarse").unwrap();
    scene.scatter = ScatterMode::FixedPoint;
    let solver = backend::create(BackendKind::Cpu, &scene).unwrap();
    let mut sim = Simulation::new(scene, solver);
    for _ in 0..frames {
        sim.advance_frame().unwrap();
    }
    sim
}

#[test]
fn a_checkpoint_reads_back_as_written_and_holds_the_whole_state() {
    let dir = tempfile::tempdir().unwrap();
    let mut sim = small_sim(3);
    sim.set_viscosity(0, 0.25).unwrap(); // a live change the scene text does not know
    let saved = Checkpoint::capture(&mut sim).unwrap();
    let file = dir.path().join("a.mpmck");
    saved.write_new(&file).unwrap();
    let read = Checkpoint::read(&file).unwrap();
    assert_eq!(read, saved);
    assert_eq!(read.clock.frame, 3);
    assert!(
        read.particles.c.iter().any(|c| *c != glam::Mat3::ZERO),
        "C was not saved"
    );
    assert_eq!(read.params.materials[0].viscosity, 0.25);
    let resumed = read.resume(read.scene().unwrap(), BackendKind::Cpu).unwrap();
    assert_eq!(resumed.params().materials[0].viscosity, 0.25);
    assert_eq!((resumed.frame(), resumed.time()), (3, saved.clock.time));
    // Nothing but the checkpoint was left in the directory (no temporary file).
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["a.mpmck"]);
}

/// Which nodes a GPU's grid holds (`KernelParams::box_lo`, `box_res`: a rank's slab) is no part of
/// the run: a checkpoint of parameters with a rank's box writes the bytes of one with the whole
/// grid's, and reads back with the whole grid's.
#[test]
fn a_checkpoint_holds_no_grid_box() {
    let dir = tempfile::tempdir().unwrap();
    let whole = Checkpoint::capture(&mut small_sim(1)).unwrap();
    assert_eq!(whole.params.box_res, whole.params.grid_res);
    let mut part = whole.clone();
    part.params.box_lo = [8, 0, 0];
    part.params.box_res = [16, whole.params.grid_res[1], whole.params.grid_res[2]];
    let (a, b) = (dir.path().join("whole.mpmck"), dir.path().join("part.mpmck"));
    whole.write_new(&a).unwrap();
    part.write_new(&b).unwrap();
    assert!(
        std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
        "the grid box reached the file"
    );
    assert_eq!(Checkpoint::read(&b).unwrap(), whole);
}

#[test]
fn an_existing_file_is_never_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("mine.mpmck");
    std::fs::write(&file, "a user's file").unwrap();
    let e = Checkpoint::capture(&mut small_sim(0))
        .unwrap()
        .write_new(&file)
        .unwrap_err();
    assert!(format!("{e:#}").contains("not overwriting"), "{e:#}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "a user's file");
}

/// A written checkpoint's bytes, for damaging.
fn checkpoint_bytes() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("c.mpmck");
    Checkpoint::capture(&mut small_sim(1))
        .unwrap()
        .write_new(&file)
        .unwrap();
    std::fs::read(file).unwrap()
}

fn refusal(bytes: &[u8]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("damaged.mpmck");
    std::fs::write(&file, bytes).unwrap();
    let e = Checkpoint::read(&file).expect_err("a damaged checkpoint was accepted");
    let text = format!("{e:#}");
    assert!(
        text.contains("damaged.mpmck"),
        "the error does not name the file: {text}"
    );
    text
}

#[test]
fn a_corrupt_checkpoint_is_refused() {
    let mut bytes = checkpoint_bytes();
    let middle = bytes.len() / 2; // inside the particles
    bytes[middle] ^= 0x10;
    let text = refusal(&bytes);
    assert!(text.contains("corrupt") && text.contains("checksum"), "{text}");
}

#[test]
fn a_truncated_checkpoint_is_refused() {
    let bytes = checkpoint_bytes();
    for cut in [bytes.len() - 1, bytes.len() / 2, 20] {
        let text = refusal(&bytes[..cut]);
        assert!(text.contains("truncated"), "cut at {cut}: {text}");
    }
    let mut longer = bytes.clone();
    longer.extend_from_slice(b"extra");
    assert!(refusal(&longer).contains("after its end"));
}

#[test]
fn a_foreign_file_is_refused() {
    for foreign in [
        b"name = \"dam-break\"\n".to_vec(),
        b"\x89PNG\r\n\x1a\n0000000000000000".to_vec(),
        Vec::new(),
    ] {
        let text = refusal(&foreign);
        assert!(text.contains("not an mpm checkpoint"), "{text}");
    }
}

#[test]
fn a_newer_format_is_refused_with_what_to_do() {
    let mut bytes = checkpoint_bytes();
    bytes[8..12].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
    let text = refusal(&bytes);
    assert!(text.contains("newer mpm"), "{text}");
}

#[test]
fn the_cli_refuses_a_bad_checkpoint_before_creating_anything() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.mpmck");
    std::fs::write(&bad, "not a checkpoint").unwrap();
    let out_dir = dir.path().join("out");
    let out = mpm(&["run", "--resume", path(&bad), "--checkpoint", path(&out_dir)]);
    assert!(!out.status.success());
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(text.contains("not an mpm checkpoint"), "{text}");
    assert!(
        !out_dir.exists(),
        "the checkpoint directory was created for a run that never started"
    );
}

#[test]
fn checkpoints_of_another_run_are_not_mixed_with_or_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let series = dir.path().join("series");
    ok(&common::cpu_run(
        "dam-break-coarse",
        "2",
        &["--checkpoint", path(&series), "--checkpoint-every", "1"],
    ));
    let first = std::fs::read(series.join("checkpoint_000002.mpmck")).unwrap();
    // A fresh run into the same directory is refused...
    let out = common::cpu_run("dam-break-coarse", "2", &["--checkpoint", path(&series)]);
    assert!(!out.status.success());
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(
        text.contains("already holds 2 checkpoints") && text.contains("--overwrite"),
        "{text}"
    );
    // ...and so is a resume at frame 1, which would replace frame 2...
    let at_1 = series.join("checkpoint_000001.mpmck");
    let out = mpm(&[
        "run",
        "--resume",
        path(&at_1),
        "--frames",
        "1",
        "--checkpoint",
        path(&series),
    ]);
    assert!(!out.status.success(), "{}", String::from_utf8_lossy(&out.stdout));
    assert_eq!(
        std::fs::read(series.join("checkpoint_000002.mpmck")).unwrap(),
        first
    );
    // ...while resuming the latest one goes on in the same directory.
    let at_2 = series.join("checkpoint_000002.mpmck");
    ok(&mpm(&[
        "run",
        "--resume",
        path(&at_2),
        "--frames",
        "1",
        "--checkpoint",
        path(&series),
    ]));
    assert!(series.join("checkpoint_000003.mpmck").is_file());
}

#[test]
fn a_series_writes_every_kth_frame_and_the_last() {
    let dir = tempfile::tempdir().unwrap();
    let series = CheckpointSeries::new(dir.path(), 3, None, false).unwrap();
    let wanted: Vec<u64> = (1..=7).filter(|&f| series.wants(f, f == 7)).collect();
    assert_eq!(wanted, [3, 6, 7]);
}

#[test]
fn a_scene_built_in_code_carries_a_text_that_loads_back_to_it() {
    let scene = mpm::bench::column_scene(4096, 40).unwrap();
    assert!(!scene.toml.is_empty(), "the spec did not serialise");
    let back = Scene::from_toml(&scene.toml, &scene.source).unwrap();
    assert_eq!(
        Scene {
            toml: scene.toml.clone(),
            ..back
        },
        scene
    );
}

#[test]
fn the_fountain_resumed_from_the_command_line_is_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    let (whole, resumed) = (dir.path().join("whole"), dir.path().join("resumed"));
    let run = ["run", "--backend", "cpu-parallel", "--checkpoint-every", "2"];
    let mut args = run.to_vec();
    args.extend([
        "--scene",
        "fountain",
        "--frames",
        "4",
        "--checkpoint",
        path(&whole),
    ]);
    let uninterrupted = ok(&mpm(&args));
    assert!(
        uninterrupted.contains("emitted=") && uninterrupted.contains("(capacity 60000)"),
        "{uninterrupted}"
    );
    let start = whole.join("checkpoint_000002.mpmck");
    let saved = Checkpoint::read(&start).unwrap();
    let flow = saved.flow.as_ref().expect("the fountain's lifecycle is saved");
    assert!(
        flow.counts.emitted > 0 && flow.counts.drained > 0,
        "{:?}",
        flow.counts
    );
    let continued = resume_for_two_frames(&run, &start, &resumed);
    assert_eq!(frame_lines(&continued), frame_lines(&uninterrupted)[2..]);
    let name = "checkpoint_000004.mpmck";
    assert!(
        std::fs::read(whole.join(name)).unwrap() == std::fs::read(resumed.join(name)).unwrap(),
        "the resumed fountain's state differs"
    );
}

/// A run resumed into a folder holding another scene's checkpoints is refused: it would mix the two
/// runs' files, though none of the other run's frames come after the one it resumes from; and the
/// refusal counts what it refuses for, in words that say which (issue 17, item 4).
#[test]
fn a_resumed_run_is_not_mixed_with_another_scenes_checkpoints() {
    let dir = tempfile::tempdir().unwrap();
    let (mixed, own) = (dir.path().join("mix"), dir.path().join("own"));
    ok(&common::cpu_run(
        "dam-break-coarse",
        "2",
        &["--checkpoint-every", "1", "--checkpoint", path(&mixed)],
    ));
    // Another scene: the same preset saved as a file (its source is the file, not the preset).
    let scene_file = dir.path().join("coarse.toml");
    std::fs::write(&scene_file, mpm::sim::presets::get("dam-break-coarse").unwrap()).unwrap();
    ok(&common::cpu_run(
        path(&scene_file),
        "3",
        &["--checkpoint-every", "3", "--checkpoint", path(&own)],
    ));
    let resume = own.join("checkpoint_000003.mpmck");
    let out = mpm(&[
        "run",
        "--resume",
        path(&resume),
        "--frames",
        "2",
        "--checkpoint",
        path(&mixed),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "mixed in:\n{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(
        stderr.contains("holds 2 checkpoints after frame 3 or of another scene"),
        "{stderr}"
    );
    assert!(!mixed.join("checkpoint_000004.mpmck").exists());
}

/// The bytes a version-1 mpm (before the material table) wrote for `cp`'s state, built from that
/// format's layout (docs/checkpoints.md): 28 words of parameters, one material of 8 of them, and no
/// material rows after the live flags. `cp` must be of a scene of one material.
fn version_1_bytes(cp: &Checkpoint) -> Vec<u8> {
    assert_eq!(cp.params.material_count, 1);
    let meta = serde_json::to_vec(&serde_json::json!({
        "written_by": "mpm 0.1.0",
        "scene_source": cp.scene_source,
        "scene_toml": cp.scene_toml,
        "backend": cp.backend,
        "pipeline": cp.pipeline,
        "scatter": cp.scatter,
        "particles": cp.particles.len() as u64,
        "emitters": cp.clock.emitter_phases.len() as u64,
        "flow": cp.flow.is_some(),
    }))
    .unwrap();
    let (p, m) = (&cp.params, &cp.params.materials[0]);
    let f = |x: f32| x.to_bits();
    let mut params = vec![
        f(m.rest_density),
        f(m.eos_stiffness),
        f(m.eos_power),
        f(m.viscosity),
        f(m.pressure_floor),
        f(m.particle_mass),
        0,
        0,
    ];
    params.extend(p.gravity.map(f));
    params.push(f(p.dt));
    params.extend(p.grid_res);
    params.extend([f(p.dx), f(p.inv_dx), p.boundary_band, f(p.soft_wall_tau)]);
    params.extend([p.num_particles, p.scatter_mode]);
    params.extend([f(p.fixed_mass_scale), f(p.fixed_momentum_scale), p.wall_mirror_lo]);
    params.extend(p.wall_mirror_hi);
    params.push(p.density_rule);
    assert_eq!(params.len(), 28);

    let mut body = Vec::new();
    body.extend((meta.len() as u64).to_le_bytes());
    body.extend(&meta);
    body.extend(params.iter().flat_map(|w| w.to_le_bytes()));
    let clock = &cp.clock;
    body.extend(clock.frame.to_le_bytes());
    body.extend(clock.time.to_bits().to_le_bytes());
    body.extend(clock.signal_speed.to_bits().to_le_bytes());
    body.extend(clock.signal_rise.to_bits().to_le_bytes());
    body.extend(clock.late_layers.to_le_bytes());
    for phase in &clock.emitter_phases {
        body.extend(phase.to_bits().to_le_bytes());
    }
    let q = &cp.particles;
    let floats =
        |values: &[f32], body: &mut Vec<u8>| body.extend(values.iter().flat_map(|v| v.to_le_bytes()));
    floats(bytemuck::cast_slice(&q.x), &mut body);
    floats(bytemuck::cast_slice(&q.v), &mut body);
    floats(bytemuck::cast_slice(&q.c), &mut body);
    floats(&q.rho, &mut body);
    body.extend(q.live.iter().map(|&l| u8::from(l)));
    assert!(cp.flow.is_none(), "this builder writes no lifecycle");

    checkpoint_file(1, body)
}

/// A checkpoint file of format `version` around `body`: the magic, the version, the reserved word,
/// the body's length, the body and the CRC-32 of all before it (docs/checkpoints.md).
fn checkpoint_file(version: u32, body: Vec<u8>) -> Vec<u8> {
    let mut file = b"MPMCKPT\0".to_vec();
    file.extend(version.to_le_bytes());
    file.extend(0u32.to_le_bytes());
    file.extend((body.len() as u64).to_le_bytes());
    file.extend(body);
    let crc = crc32fast::hash(&file);
    file.extend(crc.to_le_bytes());
    file
}

/// A checkpoint of format version 1, written before scenes had a material table, loads as a table of
/// one Newtonian liquid with every particle made of it, and resumes to the same bytes as the
/// uninterrupted run.
#[test]
fn a_version_1_checkpoint_loads_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let (whole, old, resumed) = (
        dir.path().join("whole"),
        dir.path().join("old"),
        dir.path().join("resumed"),
    );
    // The float scatter: a file before version 6 holds no flow speed, so a fixed-point run resumed
    // from one takes other momentum units for a stretch (docs/checkpoints.md) and other bytes; the
    // CPU reference's float sums are as reproducible.
    let run = ["run", "--backend", "cpu", "--scatter", "float"];
    let mut args = run.to_vec();
    args.extend([
        "--scene",
        "dam-break-coarse",
        "--frames",
        "5",
        "--checkpoint-every",
        "3",
        "--checkpoint",
        path(&whole),
    ]);
    let uninterrupted = ok(&mpm(&args));
    let current = Checkpoint::read(&whole.join("checkpoint_000003.mpmck")).unwrap();
    let bytes = version_1_bytes(&current);
    std::fs::create_dir(&old).unwrap();
    let start = old.join("checkpoint_000003.mpmck");
    std::fs::write(&start, &bytes).unwrap();

    let read = Checkpoint::read(&start).unwrap();
    let row = read.params.materials[0];
    assert_eq!(read.params.material_count, 1);
    assert_eq!(row.law, mpm::contract::LAW_NEWTONIAN);
    assert_eq!((row.flow_index, row.max_viscosity), (1.0, row.viscosity));
    assert_eq!(read.params.volume_density, 0);
    assert!(read.particles.material.iter().all(|&m| m == 0));
    // Everything else is the state the current format saved, bit for bit (the flow speed, which
    // version 6 added, as the signal speed): the converted row is the one loading the scene gives.
    assert_eq!(read, read_before_version_6(&current));

    let continued = resume_for_two_frames(&run, &start, &resumed);
    assert_eq!(frame_lines(&continued), frame_lines(&uninterrupted)[3..]);
    let last = "checkpoint_000005.mpmck";
    let resumed_last = std::fs::read(resumed.join(last)).unwrap();
    assert_eq!(
        u32::from_le_bytes(resumed_last[8..12].try_into().unwrap()),
        FORMAT_VERSION,
        "a resumed run writes the current format"
    );
    assert!(
        resumed_last == std::fs::read(whole.join(last)).unwrap(),
        "the run resumed from a version-1 file differs from the uninterrupted one"
    );
}

/// Water and oil side by side: two rest densities (the density gathered from the volume), two rows.
fn two_liquids() -> Scene {
    let mut scene = Scene::from_toml(
        r#"
[domain]
size = [0.2, 0.2, 0.2]
resolution = [20, 20, 20]

[[material]]
name = "water"
rest_density = 1000.0
sound_speed = 20.0

[[material]]
name = "oil"
rest_density = 800.0
sound_speed = 20.0
viscosity = 0.05
colour = [0.9, 0.6, 0.1]

[[block]]
min = [0.03, 0.03, 0.03]
max = [0.09, 0.12, 0.17]
material = "water"

[[block]]
min = [0.11, 0.03, 0.03]
max = [0.17, 0.12, 0.17]
material = "oil"
"#,
        "two-liquids.toml",
    )
    .unwrap();
    scene.scatter = ScatterMode::FixedPoint;
    scene
}

/// `scene` on the CPU reference after `frames` frames, and its checkpoint written to a file and read
/// back, which must be the state captured, bit for bit: (the run, the checkpoint read).
fn saved_after(scene: &Scene, frames: u64) -> (Simulation, Checkpoint) {
    let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, scene).unwrap());
    for _ in 0..frames {
        sim.advance_frame().unwrap();
    }
    let saved = Checkpoint::capture(&mut sim).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("saved.mpmck");
    saved.write_new(&file).unwrap();
    let read = Checkpoint::read(&file).unwrap();
    assert_eq!(
        read, saved,
        "the checkpoint read back differs from the state saved"
    );
    (sim, read)
}

/// Two more frames of the run `read` resumes and of `sim`, the run it was saved from: the same
/// state, bit for bit.
fn assert_resumes_as_uninterrupted(read: &Checkpoint, sim: &mut Simulation, what: &str) {
    let mut resumed = read.resume(read.scene().unwrap(), BackendKind::Cpu).unwrap();
    for _ in 0..2 {
        resumed.advance_frame().unwrap();
        sim.advance_frame().unwrap();
    }
    assert_eq!(
        Checkpoint::capture(&mut resumed).unwrap(),
        Checkpoint::capture(sim).unwrap(),
        "the resumed {what} run differs from the uninterrupted one"
    );
}

#[test]
fn a_checkpoint_of_several_materials_round_trips_them_and_resumes_exactly() {
    let scene = two_liquids();
    let (mut sim, read) = saved_after(&scene, 2);
    assert_eq!(read.params.material_count, 2);
    assert_eq!(read.params.volume_density, 1);
    for (row, named) in scene.materials.iter().enumerate() {
        assert_eq!(read.params.materials[row], named.law, "row {row}");
    }
    // Both liquids are there, each particle with its own row, where the spawn put them.
    let spawned = scene.spawn();
    assert_eq!(read.particles.material, spawned.material);
    for row in [0, 1] {
        assert!(read.particles.material.contains(&row), "no particle of row {row}");
    }
    assert_resumes_as_uninterrupted(&read, &mut sim, "two-liquid");
}

/// A material row past the table is damage, not a particle of some other liquid; a table of another
/// size than the scene's is an inconsistent file.
#[test]
fn a_material_row_past_the_table_or_a_table_unlike_the_scenes_is_refused() {
    let mut sim = Simulation::new(
        two_liquids(),
        backend::create(BackendKind::Cpu, &two_liquids()).unwrap(),
    );
    let mut cp = Checkpoint::capture(&mut sim).unwrap();
    cp.particles.material[7] = 2;
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("past.mpmck");
    cp.write_new(&file).unwrap();
    let text = format!("{:#}", Checkpoint::read(&file).unwrap_err());
    assert!(text.contains("slot 7 is made of material row 2"), "{text}");

    // A table of one row for a scene of two: every row is in range, but the scene disagrees.
    cp.particles.material.fill(0);
    cp.params.material_count = 1;
    let file = dir.path().join("one-row.mpmck");
    cp.write_new(&file).unwrap();
    let read = Checkpoint::read(&file).unwrap();
    let text = format!("{:#}", read.scene().unwrap_err());
    assert!(
        text.contains("1 materials, but its scene has") && text.contains("and 2 materials"),
        "{text}"
    );
}

/// The bytes a version-2 mpm (before the solids) wrote for `cp`'s state: the kernel parameters, then
/// the table's 8 rows of 16 words (the liquids' 13, then padding), and no deformation. `cp` must be
/// of a scene of liquids.
fn version_2_bytes(cp: &Checkpoint) -> Vec<u8> {
    assert!(cp.particles.deformation.is_empty());
    let dir = tempfile::tempdir().unwrap();
    cp.write_new(&dir.path().join("now.mpmck")).unwrap();
    let file = std::fs::read(dir.path().join("now.mpmck")).unwrap();
    let current = mpm::checkpoint::saved_params_words(&cp.params);
    let row_words = std::mem::size_of::<mpm::contract::Material>() / 4;
    let kernel_words = current.len() - row_words * mpm::contract::MAX_MATERIALS as usize;
    let mut old = current[..kernel_words].to_vec();
    for row in current[kernel_words..].chunks_exact(row_words) {
        old.extend(&row[..13]);
        old.extend([0u32; 3]);
    }
    assert_eq!(old.len(), 150);
    // The body: its JSON (whose `deformation: false` a version-2 reader never looked for; without the
    // keys added since), then the parameters, replaced, and the rest as it is.
    let meta_len = u64::from_le_bytes(file[24..32].try_into().unwrap()) as usize;
    let params_at = 32 + meta_len;
    let mut body = meta_before_the_scheme_was_kept(serde_json::from_slice(&file[32..params_at]).unwrap());
    body.extend(old.iter().flat_map(|w| w.to_le_bytes()));
    body.extend(without_flow_speed(
        &file[params_at + 4 * current.len()..file.len() - 4],
    ));
    checkpoint_file(2, body)
}

/// The bytes after the parameters as a format before version 6 wrote them: the clock without the flow
/// speeds (after the frame, the time, the signal speed and its rise).
fn without_flow_speed(after_params: &[u8]) -> Vec<u8> {
    let at = 8 + 8 + 4 + 4;
    [&after_params[..at], &after_params[at + 8..]].concat()
}

/// `cp` as a format before version 6 reads it back: the flow speeds taken as the signal speed.
fn read_before_version_6(cp: &Checkpoint) -> Checkpoint {
    let mut read = read_before_the_scheme_was_kept(cp);
    read.clock.flow_speeds = [read.clock.signal_speed; 2];
    read
}

/// A checkpoint's JSON as files written before the run's method and position-based counts were kept
/// have it (without those keys), after its length, as the body starts.
fn meta_before_the_scheme_was_kept(mut meta: serde_json::Value) -> Vec<u8> {
    for key in ["method", "pbmpm"] {
        meta.as_object_mut().unwrap().remove(key);
    }
    let meta = serde_json::to_vec(&meta).unwrap();
    let mut body = (meta.len() as u64).to_le_bytes().to_vec();
    body.extend(&meta);
    body
}

/// `cp` as a file written before checkpoints kept the run's method and position-based counts reads:
/// without them (its scene resumes with the file's).
fn read_before_the_scheme_was_kept(cp: &Checkpoint) -> Checkpoint {
    Checkpoint {
        method: None,
        pbmpm: None,
        ..cp.clone()
    }
}

/// A checkpoint of format version 2, written before the solids, loads with its table's rows as they
/// were (the solids' parameters zero) and its particles, the same state the current format saves.
#[test]
fn a_version_2_checkpoint_of_several_liquids_loads_as_it_was() {
    let scene = two_liquids();
    let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
    sim.advance_frame().unwrap();
    let current = Checkpoint::capture(&mut sim).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("v2.mpmck");
    std::fs::write(&file, version_2_bytes(&current)).unwrap();
    assert_eq!(Checkpoint::read(&file).unwrap(), read_before_version_6(&current));
}

/// The bytes an earlier format `version` wrote for `cp`'s state, where that format is today's
/// without the counts or flags `missing` in its JSON (each 0 or false in `cp`: nothing of theirs
/// follows), without the run's method and position-based counts (kept since, in version 7) and,
/// before version 6, without the clock's flow speed.
fn without_counts(cp: &Checkpoint, version: u32, missing: &[&str]) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let now = dir.path().join("now.mpmck");
    cp.write_new(&now).unwrap();
    let file = std::fs::read(&now).unwrap();
    let meta_len = u64::from_le_bytes(file[24..32].try_into().unwrap()) as usize;
    let mut meta: serde_json::Value = serde_json::from_slice(&file[32..32 + meta_len]).unwrap();
    for key in missing {
        assert!(meta[key] == 0 || meta[key] == false, "{key}: {}", meta[key]);
        meta.as_object_mut().unwrap().remove(*key);
    }
    let mut body = meta_before_the_scheme_was_kept(meta);
    let params_at = 32 + meta_len;
    let clock_at = params_at + 4 * mpm::checkpoint::saved_params_words(&cp.params).len();
    body.extend(&file[params_at..clock_at]);
    let after_params = &file[clock_at..file.len() - 4];
    if version < 6 {
        body.extend(without_flow_speed(after_params));
    } else {
        body.extend(after_params);
    }
    checkpoint_file(version, body)
}

/// A checkpoint of format version 3, written before checkpoints held rigid bodies (its JSON names no
/// body count, and nothing follows the lifecycle), loads as the same state without bodies.
#[test]
fn a_version_3_checkpoint_loads_as_one_without_bodies() {
    let mut sim = small_sim(1);
    let current = Checkpoint::capture(&mut sim).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let v3 = dir.path().join("v3.mpmck");
    std::fs::write(
        &v3,
        without_counts(&current, 3, &["bodies", "dropped", "volume_bias"]),
    )
    .unwrap();
    assert_eq!(Checkpoint::read(&v3).unwrap(), read_before_version_6(&current));
}

/// A checkpoint of format version 4, written before bodies could be dropped into a run (its JSON
/// names no dropped count, and nothing follows the rigid bodies), loads as the same state, its scene's
/// bodies and all, without dropped bodies.
#[test]
fn a_version_4_checkpoint_loads_as_one_without_dropped_bodies() {
    let scene = common::scene(&common::log_thrown_into_a_pool());
    let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
    sim.advance_frame().unwrap();
    let current = Checkpoint::capture(&mut sim).unwrap();
    assert_eq!(current.bodies.states.len(), 1);
    let dir = tempfile::tempdir().unwrap();
    let v4 = dir.path().join("v4.mpmck");
    std::fs::write(&v4, without_counts(&current, 4, &["dropped", "volume_bias"])).unwrap();
    let read = Checkpoint::read(&v4).unwrap();
    assert_eq!(read, read_before_version_6(&current));
    assert!(read.dropped.is_empty());
}

/// A checkpoint of format version 6, written before the position-based solver kept a volume bias (its
/// JSON names no such flag, and nothing follows the deformation), loads as the same state.
#[test]
fn a_version_6_checkpoint_loads_as_one_without_a_volume_bias() {
    let mut sim = small_sim(1);
    let current = Checkpoint::capture(&mut sim).unwrap();
    assert!(current.particles.volume_bias.is_empty());
    let dir = tempfile::tempdir().unwrap();
    let v6 = dir.path().join("v6.mpmck");
    std::fs::write(&v6, without_counts(&current, 6, &["volume_bias"])).unwrap();
    assert_eq!(
        Checkpoint::read(&v6).unwrap(),
        read_before_the_scheme_was_kept(&current)
    );
}

/// A pool under the position-based solver: the checkpoint carries its particles' volume bias (the
/// liquid's pressure memory), reads back as written, and the run resumed from it goes on as the
/// uninterrupted one, bit for bit.
#[test]
fn a_pbmpm_checkpoint_round_trips_the_volume_bias_and_resumes_exactly() {
    let scene = common::scene(
        "[domain]\nsize = [0.4, 0.2, 0.16]\nresolution = [20, 10, 8]\n\
         [material]\nrest_density = 1000.0\nviscosity = 1.0e-3\n\
         [solver]\nmethod = \"pbmpm\"\n\
         [[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.36, 0.12, 0.12]\n",
    );
    let (mut sim, read) = saved_after(&scene, 10);
    assert_eq!(read.particles.volume_bias.len(), read.particles.len());
    assert!(
        read.particles.volume_bias.iter().any(|&b| b > 0.0),
        "no particle remembers a load: a weak test of the volume bias"
    );
    assert_resumes_as_uninterrupted(&read, &mut sim, "pbmpm");
}

/// A scene with a jelly: the checkpoint carries each particle's deformation, reads back as written,
/// and the run resumed from it goes on as the uninterrupted one, bit for bit.
#[test]
fn a_checkpoint_of_solids_round_trips_their_deformation_and_resumes_exactly() {
    let scene = Scene::from_toml(
        r#"
[domain]
size = [0.2, 0.2, 0.2]
resolution = [20, 20, 20]

[[material]]
name = "water"
rest_density = 1000.0
sound_speed = 20.0

[[material]]
name = "jelly"
law = "snow"
rest_density = 400.0
youngs_modulus = 1.4e5
poisson_ratio = 0.2

[[block]]
min = [0.03, 0.03, 0.03]
max = [0.17, 0.08, 0.17]
material = "water"

[[sphere]]
center = [0.1, 0.13, 0.1]
radius = 0.04
velocity = [0.0, -2.0, 0.0]
material = "jelly"
"#,
        "snow-in-water.toml",
    )
    .unwrap();
    let (mut sim, read) = saved_after(&scene, 3);
    assert_eq!(read.particles.deformation.len(), read.particles.len());
    assert!(
        read.particles.deformation.iter().any(|d| d.plastic != 1.0),
        "the snow has not yielded: a weak test of its plastic state"
    );
    assert_resumes_as_uninterrupted(&read, &mut sim, "snow");
}

/// A steel log thrown into a pool ([`common::log_thrown_into_a_pool`]) through the command line: 6
/// frames straight, against 3 frames, a checkpoint and 3 more resumed from it. The checkpoint holds
/// the body's whole state and the impulse sums its next step takes (the backstop's pushes out of it
/// as it lands), and the resumed run's frame lines (the body's pose among them) and its last
/// checkpoint (every particle and the body, bit for bit) are the uninterrupted run's.
#[test]
fn a_run_with_a_rigid_body_resumes_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("log.toml");
    std::fs::write(&scene, common::log_thrown_into_a_pool()).unwrap();
    let (whole, resumed) = (dir.path().join("whole"), dir.path().join("resumed"));
    let run = ["run", "--backend", "cpu", "--checkpoint-every", "3"];
    let mut args = run.to_vec();
    args.extend([
        "--scene",
        path(&scene),
        "--frames",
        "6",
        "--checkpoint",
        path(&whole),
    ]);
    let uninterrupted = ok(&mpm(&args));
    assert!(
        uninterrupted.contains("collider[0]=") && uninterrupted.contains("backstop="),
        "{uninterrupted}"
    );
    let start = whole.join("checkpoint_000003.mpmck");
    let saved = Checkpoint::read(&start).unwrap();
    assert_eq!(saved.bodies.states.len(), 1);
    assert!(
        saved.bodies.impulses[0] != [0; 6],
        "no backstop push is pending at frame 3: a weak test of the impulse sums"
    );
    let mut args = run.to_vec();
    args.extend([
        "--resume",
        path(&start),
        "--frames",
        "3",
        "--checkpoint",
        path(&resumed),
    ]);
    let continued = ok(&mpm(&args));
    assert_eq!(frame_lines(&continued), frame_lines(&uninterrupted)[3..]);
    let name = "checkpoint_000006.mpmck";
    let (a, b) = (
        Checkpoint::read(&whole.join(name)).unwrap(),
        Checkpoint::read(&resumed.join(name)).unwrap(),
    );
    let bytes = |c: &Checkpoint| bytemuck::cast_slice::<_, u8>(&c.bodies.states).to_vec();
    assert!(
        bytes(&a) == bytes(&b) && a.bodies.impulses == b.bodies.impulses,
        "the resumed body differs: {:?}\nagainst {:?}",
        b.bodies,
        a.bodies
    );
    assert!(
        common::same_particles(&a.particles, &b.particles),
        "the resumed run's particles differ"
    );
    assert!(
        std::fs::read(whole.join(name)).unwrap() == std::fs::read(resumed.join(name)).unwrap(),
        "{name}: the resumed run's state is not byte-identical to the uninterrupted run's"
    );
}

/// A checkpoint whose rigid bodies are not its scene's (another count, or a body of another
/// collider) is refused with what is wrong, by the library and by `mpm run --resume` before it
/// creates anything.
#[test]
fn a_checkpoint_whose_bodies_are_not_its_scenes_is_refused() {
    let scene = common::scene(&common::log_thrown_into_a_pool());
    let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
    let cp = Checkpoint::capture(&mut sim).unwrap();
    assert_eq!(cp.bodies.states.len(), 1);
    let dir = tempfile::tempdir().unwrap();

    let mut none = cp.clone();
    none.bodies = mpm::sim::colliders::bodies::BodiesState::default();
    let file = dir.path().join("no-body.mpmck");
    none.write_new(&file).unwrap();
    let read = Checkpoint::read(&file).unwrap();
    let text = format!("{:#}", read.scene().unwrap_err());
    assert!(
        text.contains("holds 0 rigid bodies but its scene has 1") && text.contains("inconsistent"),
        "{text}"
    );
    let Err(e) = read.resume(scene.clone(), BackendKind::Cpu) else {
        panic!("a checkpoint without its scene's body resumed");
    };
    let text = format!("{e:#}");
    assert!(text.contains("holds 0 rigid bodies"), "{text}");
    let out_dir = dir.path().join("out");
    let out = mpm(&["run", "--resume", path(&file), "--checkpoint", path(&out_dir)]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("holds 0 rigid bodies"), "{stderr}");
    assert!(
        !out_dir.exists(),
        "an output was created for a run that never started"
    );

    let mut elsewhere = cp.clone();
    elsewhere.bodies.states[0].slot = 3;
    let file = dir.path().join("elsewhere.mpmck");
    elsewhere.write_new(&file).unwrap();
    let text = format!("{:#}", Checkpoint::read(&file).unwrap().scene().unwrap_err());
    assert!(
        text.contains("rigid body 0 is collider 3") && text.contains("makes it collider 0"),
        "{text}"
    );

    // A body dropped into the run without its state, and one that fits no tank.
    let ball = |x: f64| mpm::sim::dropped::DroppedBody {
        shape: mpm::sim::dropped::DropShape::Ball { radius: 0.015 },
        density: 2000.0,
        center: glam::DVec3::new(x, 0.17, 0.035),
    };
    let mut stateless = cp.clone();
    stateless.dropped = vec![ball(0.05)];
    let file = dir.path().join("stateless.mpmck");
    stateless.write_new(&file).unwrap();
    let text = format!("{:#}", Checkpoint::read(&file).unwrap().scene().unwrap_err());
    assert!(
        text.contains("holds 1 rigid body but its scene has 2")
            && text.contains("counting the 1 dropped into the run"),
        "{text}"
    );
    let mut outside = cp.clone();
    outside.dropped = vec![ball(0.21)];
    let file = dir.path().join("outside.mpmck");
    outside.write_new(&file).unwrap();
    let text = format!("{:#}", Checkpoint::read(&file).unwrap().scene().unwrap_err());
    assert!(
        text.contains("does not fit its scene") && text.contains("the walls hold the bodies"),
        "{text}"
    );
}

/// A ball and a box dropped into the steel-log pool ([`common::log_thrown_into_a_pool`]) after its
/// first frame, beside the log as it lands, then checkpointed two frames later: the checkpoint holds
/// the three bodies and the two drops and reads back as written; its scene, as the file gives it,
/// has the file's one collider and spawns its particle count (a restart has no dropped body); and
/// the run resumed from it, by the library and by `mpm run --resume`, ends two frames later on the
/// bytes of the uninterrupted run's checkpoint.
#[test]
fn a_run_with_dropped_bodies_resumes_byte_identical() {
    use glam::DVec3;
    use mpm::sim::dropped::{DropShape, DroppedBody};
    let scene = common::scene(&common::log_thrown_into_a_pool());
    let mut sim = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
    sim.advance_frame().unwrap();
    let drops = [
        DroppedBody {
            shape: DropShape::Ball { radius: 0.015 },
            density: 2000.0,
            center: DVec3::new(0.05, 0.17, 0.035),
        },
        DroppedBody {
            shape: DropShape::Box {
                size: DVec3::new(0.04, 0.04, 0.048),
            },
            density: 500.0,
            center: DVec3::new(0.19, 0.17, 0.035),
        },
    ];
    for body in drops {
        sim.drop_body(body).unwrap();
    }
    for _ in 0..2 {
        sim.advance_frame().unwrap();
    }
    let saved = Checkpoint::capture(&mut sim).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("dropped.mpmck");
    saved.write_new(&file).unwrap();
    let read = Checkpoint::read(&file).unwrap();
    assert_eq!(
        read, saved,
        "the checkpoint read back differs from the state saved"
    );
    assert_eq!(read.dropped, drops);
    assert_eq!(read.bodies.states.len(), 3);
    let restart = read.scene().unwrap();
    assert_eq!(restart.colliders.len(), 1, "the scene as its file gives it");
    assert_eq!(restart.num_particles, scene.num_particles);

    let mut resumed = read.resume(read.scene().unwrap(), BackendKind::Cpu).unwrap();
    assert_eq!(resumed.dropped(), &drops);
    assert_eq!(resumed.scene().colliders.len(), 3);
    for _ in 0..2 {
        resumed.advance_frame().unwrap();
        sim.advance_frame().unwrap();
    }
    let bytes = |sim: &mut Simulation, name: &str| {
        let path = dir.path().join(name);
        Checkpoint::capture(sim).unwrap().write_new(&path).unwrap();
        std::fs::read(path).unwrap()
    };
    let uninterrupted = bytes(&mut sim, "uninterrupted.mpmck");
    assert!(
        bytes(&mut resumed, "resumed.mpmck") == uninterrupted,
        "the resumed run's state is not byte-identical to the uninterrupted run's"
    );
    let out = dir.path().join("out");
    resume_for_two_frames(&["run"], &file, &out);
    assert!(
        std::fs::read(out.join("checkpoint_000005.mpmck")).unwrap() == uninterrupted,
        "the run resumed by `mpm run --resume` is not byte-identical to the uninterrupted run"
    );
    // `--export-bodies` takes the dropped bodies as bodies (the scene file has one; the run three):
    // a row each, colliders 0, 1 and 2, at the frame resumed from and the next.
    let posed = dir.path().join("bodies");
    ok(&mpm(&[
        "run",
        "--resume",
        path(&file),
        "--frames",
        "1",
        "--export-bodies",
        path(&posed),
    ]));
    let table = std::fs::read_to_string(posed.join("bodies.csv")).unwrap();
    let rows: Vec<(&str, &str)> = table
        .lines()
        .skip(1)
        .map(|row| {
            let mut columns = row.split(',');
            (columns.next().unwrap(), columns.nth(1).unwrap())
        })
        .collect();
    assert_eq!(
        rows,
        [
            ("3", "0"),
            ("3", "1"),
            ("3", "2"),
            ("4", "0"),
            ("4", "1"),
            ("4", "2")
        ],
        "{table}"
    );
}
