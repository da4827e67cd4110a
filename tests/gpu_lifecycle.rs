//! The particle state's life on the CUDA backend: a fixed-point run resumed from a checkpoint is byte
//! for byte the uninterrupted one, in both pipelines; emitters and sinks follow the CPU reference,
//! keep exact books, stay deterministic and resume exactly; a run whose frames are stepped on other
//! threads (as the viewer steps on a worker while it draws) is the run stepped on one; the export's
//! asynchronous snapshots are the particles of the frame they were taken at. Where no CUDA
//! device and driver are usable, every test is reported as ignored, with the reason (tests/harness:
//! `harness = false`).
//!
//! What this guards: the CUDA solver keeps state between substeps that a checkpoint does not hold
//! (the particle bins, rebuilt every few substeps or on a flag; the binned pipeline's grid mass of the
//! next substep, scattered by g2p2g; a rigid body's collider slot, which step_bodies writes). A
//! resumed solver rebuilds them from the particles and the bodies on its first substep; the
//! fixed-point scatter must then give the very integers the uninterrupted run had.

use mpm::backend::BackendKind;
use mpm::checkpoint::Checkpoint;
use mpm::cuda::{CudaOptions, CudaSolver};
use mpm::sim::params::{Pipeline, ScatterMode};
use mpm::sim::{ParticleSnapshot, Scene, Simulation};

mod common;
mod harness;

fn main() -> std::process::ExitCode {
    harness::run(
        "GPU",
        harness::cuda_device,
        harness::tests![
            a_resumed_fixed_point_run_is_byte_identical,
            a_resumed_run_with_a_rigid_body_is_byte_identical,
            resumed_plastic_solids_are_byte_identical,
            a_gpu_checkpoint_resumes_on_the_cpu,
            gpu_emission_and_draining_follow_the_cpu,
            gpu_flow_runs_are_byte_identical_and_resume_exactly,
            gpu_flow_runs_in_bin_order_are_the_runs_in_place,
            gpu_capacity_exhaustion_is_counted,
            the_report_pipeline_refuses_emitters,
            a_pipe_holds_its_rope_on_the_gpu_as_on_the_cpu,
            a_run_stepped_on_other_threads_is_byte_identical,
            export_snapshots_are_the_particles_of_their_frame,
            snapshots_between_overlapped_frames_are_those_frames,
        ],
    )
}

fn scene(pipeline: Pipeline) -> Scene {
    let mut scene = Scene::load("dam-break-coarse").expect("a preset loads");
    scene.pipeline = pipeline;
    scene.scatter = ScatterMode::FixedPoint;
    scene
}

fn cuda_sim(scene: &Scene) -> Simulation {
    let solver = mpm::backend::create(BackendKind::Cuda, scene).expect("a CUDA solver");
    Simulation::new(scene.clone(), solver)
}

fn frames(sim: &mut Simulation, n: u64) {
    for _ in 0..n {
        sim.advance_frame().expect("a frame");
    }
}

/// Through a file, as `mpm run --resume` does.
fn save_and_read(sim: &mut Simulation, dir: &std::path::Path) -> Checkpoint {
    let file = dir.join(format!("frame-{}.mpmck", sim.frame()));
    Checkpoint::capture(sim).unwrap().write_new(&file).unwrap();
    Checkpoint::read(&file).unwrap()
}

fn a_resumed_fixed_point_run_is_byte_identical() {
    // 29 substeps a frame or so: the checkpoints fall between two of the 8-substep rebinnings.
    const BEFORE: u64 = 3;
    const AFTER: u64 = 7;
    for pipeline in Pipeline::ALL {
        // A folder per pipeline: both checkpoint the same frame, and files are never overwritten.
        let dir = tempfile::tempdir().unwrap();
        let scene = scene(pipeline);
        let mut whole = cuda_sim(&scene);
        frames(&mut whole, BEFORE + AFTER);
        let expected = whole.solver_mut().read_particles().unwrap();

        let mut first = cuda_sim(&scene);
        frames(&mut first, BEFORE);
        let checkpoint = save_and_read(&mut first, dir.path());
        drop(first);
        let mut resumed = checkpoint
            .resume(checkpoint.scene().unwrap(), checkpoint.backend_kind().unwrap())
            .unwrap();
        assert_eq!(resumed.backend(), "cuda");
        frames(&mut resumed, AFTER);
        assert_eq!(resumed.frame(), whole.frame());
        assert_eq!(
            resumed.time().to_bits(),
            whole.time().to_bits(),
            "{pipeline:?}: times differ"
        );
        let got = resumed.solver_mut().read_particles().unwrap();
        let (a, b) = (common::particle_bits(&expected), common::particle_bits(&got));
        let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        let n = expected.len();
        let in_field = |range: std::ops::Range<usize>| range.filter(|&i| a[i] != b[i]).count();
        println!(
            "{pipeline:?}: {differing} of {} words differ after the resume (x {}, v {}, C {}, rho {})",
            a.len(),
            in_field(0..3 * n),
            in_field(3 * n..6 * n),
            in_field(6 * n..15 * n),
            in_field(15 * n..16 * n)
        );
        assert!(
            differing == 0,
            "{pipeline:?}: the resumed fixed-point run differs from the uninterrupted one in {differing} words"
        );
    }
}

/// Snow, sand and a yield-stress liquid with a shear modulus (the `snowball`, `sand-column` and
/// `mud-dam-break` presets, fixed point): their fused pass hands the scatter the stress of its
/// return mapping, which a resumed run's first scatter computes anew from the stored deformation;
/// the frame's last substep scatters as that first one does, so 2 frames, a checkpoint and 2 more
/// give the uninterrupted run's bits, deformations included.
fn resumed_plastic_solids_are_byte_identical() {
    for name in ["snowball", "sand-column", "mud-dam-break"] {
        let dir = tempfile::tempdir().unwrap();
        let mut scene = Scene::load(name).expect("a preset loads");
        scene.scatter = ScatterMode::FixedPoint;
        assert!(scene.has_deformation(), "{name} carries no deformation");
        let mut whole = cuda_sim(&scene);
        frames(&mut whole, 4);
        let expected = whole.solver_mut().read_particles().unwrap();
        let mut first = cuda_sim(&scene);
        frames(&mut first, 2);
        let checkpoint = save_and_read(&mut first, dir.path());
        drop(first);
        let mut resumed = checkpoint
            .resume(checkpoint.scene().unwrap(), BackendKind::Cuda)
            .unwrap();
        frames(&mut resumed, 2);
        let got = resumed.solver_mut().read_particles().unwrap();
        let (a, b) = (common::particle_bits(&expected), common::particle_bits(&got));
        let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        println!("{name}: {differing} of {} words differ after the resume", a.len());
        assert!(
            !got.deformation.is_empty() && differing == 0,
            "{name}: the resumed run differs from the uninterrupted one in {differing} words"
        );
    }
}

/// A steel log thrown into a pool ([`common::log_thrown_into_a_pool`], fused pipeline, fixed point):
/// 6 frames straight against 3, a checkpoint, and 3 more resumed from it. The device's between-frame
/// state of a body is its row and its pending impulse sums, which the checkpoint holds, and its
/// collider slot, which the resumed solver's first upload places as step_bodies does (the same
/// unfused operations): the particles and the body must come out bit for bit the same.
fn a_resumed_run_with_a_rigid_body_is_byte_identical() {
    const BEFORE: u64 = 3;
    const AFTER: u64 = 3;
    let dir = tempfile::tempdir().unwrap();
    let scene = common::scene(&common::log_thrown_into_a_pool());
    let mut whole = cuda_sim(&scene);
    frames(&mut whole, BEFORE + AFTER);

    let mut first = cuda_sim(&scene);
    frames(&mut first, BEFORE);
    let checkpoint = save_and_read(&mut first, dir.path());
    drop(first);
    println!(
        "pending impulse sums at frame {BEFORE}: {:?}",
        checkpoint.bodies.impulses
    );
    let mut resumed = checkpoint
        .resume(checkpoint.scene().unwrap(), BackendKind::Cuda)
        .unwrap();
    frames(&mut resumed, AFTER);
    let (a, b) = (
        Checkpoint::capture(&mut whole).unwrap(),
        Checkpoint::capture(&mut resumed).unwrap(),
    );
    let bytes = |c: &Checkpoint| bytemuck::cast_slice::<_, u8>(&c.bodies.states).to_vec();
    assert!(
        bytes(&a) == bytes(&b) && a.bodies.impulses == b.bodies.impulses,
        "the resumed body differs: {:?}\nagainst {:?}",
        b.bodies,
        a.bodies
    );
    let (pa, pb) = (
        common::particle_bits(&a.particles),
        common::particle_bits(&b.particles),
    );
    let differing = pa.iter().zip(&pb).filter(|(x, y)| x != y).count();
    assert!(
        differing == 0,
        "the resumed run's particles differ from the uninterrupted run's in {differing} words"
    );
}

fn a_gpu_checkpoint_resumes_on_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let mut sim = cuda_sim(&scene(Pipeline::Binned));
    frames(&mut sim, 2);
    let checkpoint = save_and_read(&mut sim, dir.path());
    let mut on_cpu = checkpoint
        .resume(checkpoint.scene().unwrap(), BackendKind::Cpu)
        .unwrap();
    let stats = on_cpu.advance_frame().unwrap();
    assert_eq!(stats.frame, 3);
    assert!(stats.summary.is_finite());
    assert_eq!(stats.summary.particles, checkpoint.particles.len());
}

// ---------------------------------------------------------------------------------------------
// Emitters and sinks on the GPU (the binned pipeline), against the CPU reference.

fn flow_scene(capacity: u64, extra: &str) -> Scene {
    let mut scene = common::scene(&common::jet_tank(capacity, extra));
    scene.scatter = ScatterMode::FixedPoint;
    scene
}

fn flow_sim(scene: &Scene, backend: BackendKind) -> Simulation {
    let solver = mpm::backend::create(backend, scene).expect("a solver");
    Simulation::new(scene.clone(), solver)
}

fn gpu_emission_and_draining_follow_the_cpu() {
    let scene = flow_scene(40_000, common::JET_TANK_DRAIN);
    let (mut cpu, mut gpu) = (
        flow_sim(&scene, BackendKind::Cpu),
        flow_sim(&scene, BackendKind::Cuda),
    );
    let start = scene.num_particles as u64;
    for _ in 0..30 {
        let a = cpu.advance_frame().unwrap();
        let b = gpu.advance_frame().unwrap();
        let (fa, fb) = (a.flow.unwrap(), b.flow.unwrap());
        println!(
            "frame {}: cpu emitted {} drained {} blocked {}, gpu emitted {} drained {} blocked {}",
            a.frame, fa.emitted, fa.drained, fa.blocked, fb.emitted, fb.drained, fb.blocked
        );
        // The schedule is the host's, the same for both: every layer is emitted unless blocked.
        assert_eq!(
            fa.emitted + fa.blocked,
            fb.emitted + fb.blocked,
            "frame {}",
            a.frame
        );
        assert!(
            fa.emitted.abs_diff(fb.emitted) <= 16,
            "frame {}: emitted {fa:?} vs {fb:?}",
            a.frame
        );
        // Rounding moves a particle across a sink's face now and then.
        let tolerance = 8 + fa.drained / 20;
        assert!(
            fa.drained.abs_diff(fb.drained) <= tolerance,
            "frame {}: {fa:?} vs {fb:?}",
            a.frame
        );
        // Exact bookkeeping on the device.
        assert_eq!(fb.live, start + fb.emitted - fb.drained, "frame {}", b.frame);
        assert_eq!(
            b.summary.particles as u64, fb.live,
            "the statistics count parked slots"
        );
        assert_eq!(fb.exhausted, 0);
    }
    let p = gpu.solver_mut().read_particles().unwrap();
    let counts = gpu.solver_mut().flow_counts().unwrap().unwrap();
    assert_eq!(p.num_live() as u64, counts.live);
    assert!(counts.drained > 0 && counts.emitted > 500, "{counts:?}");
    let sinks = &scene.flow.sinks;
    assert!(
        (0..p.len()).all(|i| !p.live[i] || !sinks.iter().any(|s| s.contains(p.x[i]))),
        "a live particle sits in the drain"
    );
    let attributes =
        mpm::render::feed::read_attributes(gpu.solver_mut(), mpm::render::ColourBy::Speed, 1000.0).unwrap();
    assert_eq!(attributes.iter().filter(|a| !a[0].is_nan()).count(), p.num_live());
}

/// The emitter's pipe (the grid update's BOUNDARY_PIPE, kernels/colliders.cuh) in both pipelines:
/// the liquid inside it at the nozzle's speed, the rope below as the CPU reference has it
/// (tests/flow.rs holds the CPU to the physics).
fn a_pipe_holds_its_rope_on_the_gpu_as_on_the_cpu() {
    use common::{piped_rope, rope, ROPE_PIPE, ROPE_SPEED};
    let scene = common::scene(&piped_rope(ROPE_PIPE));
    let run = |backend: BackendKind, pipeline: Pipeline| {
        let mut scene = scene.clone();
        scene.pipeline = pipeline;
        let mut sim = flow_sim(&scene, backend);
        frames(&mut sim, 45);
        rope(&sim.solver_mut().read_particles().unwrap())
    };
    let cpu = run(BackendKind::CpuParallel, Pipeline::Fused);
    println!("cpu-parallel: {cpu:?}");
    for pipeline in [Pipeline::Fused, Pipeline::Binned] {
        let gpu = run(BackendKind::Cuda, pipeline);
        println!("{pipeline:?}: {gpu:?}");
        assert!(
            gpu.inside == cpu.inside && gpu.worst_inside < 1e-3 * ROPE_SPEED,
            "{pipeline:?}: {gpu:?}"
        );
        assert!(
            (gpu.fastest / cpu.fastest - 1.0).abs() < 0.02,
            "{pipeline:?}: {gpu:?} against {cpu:?}"
        );
        assert!(
            (gpu.lowest - cpu.lowest).abs() < 0.005,
            "{pipeline:?}: {gpu:?} against {cpu:?}"
        );
    }
}

fn gpu_flow_runs_are_byte_identical_and_resume_exactly() {
    let scene = flow_scene(40_000, common::JET_TANK_DRAIN);
    let dir = tempfile::tempdir().unwrap();
    let run = |frames: u64| {
        let mut sim = flow_sim(&scene, BackendKind::Cuda);
        self::frames(&mut sim, frames);
        sim
    };
    let (mut a, mut b) = (run(12), run(12));
    let (sa, sb) = (
        Checkpoint::capture(&mut a).unwrap(),
        Checkpoint::capture(&mut b).unwrap(),
    );
    assert_same_run(&sa, &sb, "two fixed-point runs with emitters and sinks");
    let mut first = run(5);
    let checkpoint = save_and_read(&mut first, dir.path());
    let mut resumed = checkpoint
        .resume(checkpoint.scene().unwrap(), BackendKind::Cuda)
        .unwrap();
    frames(&mut resumed, 7);
    let sr = Checkpoint::capture(&mut resumed).unwrap();
    assert_same_run(
        &sa,
        &sr,
        "the uninterrupted and the resumed run with emitters and sinks",
    );
}

/// Two runs' states, captured, are the same: their lifecycles, and every slot bit for bit.
fn assert_same_run(a: &Checkpoint, b: &Checkpoint, what: &str) {
    assert_eq!(a.flow, b.flow, "{what}: the lifecycles differ");
    assert!(
        common::same_particles(&a.particles, &b.particles),
        "{what}: the particles differ"
    );
}

/// The fused pipeline moves its particles into bin order at every binning (kernels/bin_order.cu),
/// while the free-slot stack and the nozzles' last particles name slots. With emitters and sinks
/// that run must be, word for word and slot for slot, the run whose particles stay in place.
fn gpu_flow_runs_in_bin_order_are_the_runs_in_place() {
    let mut scene = flow_scene(40_000, common::JET_TANK_DRAIN);
    scene.pipeline = Pipeline::Fused;
    let run = |bin_order: bool| {
        let options = CudaOptions {
            bin_order,
            ..CudaOptions::default()
        };
        let solver = CudaSolver::new(&scene, options).expect("a CUDA solver");
        let mut sim = Simulation::new(scene.clone(), Box::new(solver));
        frames(&mut sim, 12);
        Checkpoint::capture(&mut sim).unwrap()
    };
    let (sorted, in_place) = (run(true), run(false));
    let counts = in_place.flow.as_ref().expect("a lifecycle").counts;
    assert!(counts.drained > 0 && counts.emitted > 0, "{counts:?}");
    assert_same_run(
        &sorted,
        &in_place,
        "the run with its particles in bin order and the one with them in place",
    );
}

fn gpu_capacity_exhaustion_is_counted() {
    let initial = flow_scene(100_000, "").num_particles as u64;
    let scene = flow_scene(initial + 100, "");
    let mut sim = flow_sim(&scene, BackendKind::Cuda);
    frames(&mut sim, 20);
    let counts = sim.solver_mut().flow_counts().unwrap().unwrap();
    assert_eq!(counts.emitted, 100);
    assert_eq!(counts.live, initial + 100);
    assert!(counts.exhausted > 0);
}

fn the_report_pipeline_refuses_emitters() {
    let mut scene = flow_scene(40_000, "");
    scene.pipeline = Pipeline::Report;
    let e = mpm::backend::create(BackendKind::Cuda, &scene)
        .err()
        .expect("refused");
    assert!(format!("{e:#}").contains("binned"), "{e:#}");
}

/// The viewer steps each draw's frames on a fresh worker thread (src/render/app.rs), its frames'
/// last stretches left in flight (`overlap_frames`), and reads the particles on the main thread in
/// between. In fixed point that run must be the one stepped on one thread, word for word: nothing
/// of the solver's state may depend on the thread that drives it.
fn a_run_stepped_on_other_threads_is_byte_identical() {
    const FRAMES: u64 = 6;
    let scene = scene(Pipeline::Fused);
    let mut one_thread = cuda_sim(&scene);
    one_thread.overlap_frames(true).unwrap();
    for _ in 0..FRAMES {
        one_thread.step_frame_until(None).unwrap().expect("a whole frame");
    }
    one_thread.settle().unwrap();
    let expected = one_thread.solver_mut().read_particles().unwrap();

    let mut workers = cuda_sim(&scene);
    workers.overlap_frames(true).unwrap();
    for _ in 0..FRAMES {
        std::thread::scope(|scope| {
            let sim = &mut workers;
            scope
                .spawn(move || {
                    sim.bind_to_thread().unwrap();
                    sim.step_frame_until(None).unwrap().expect("a whole frame");
                })
                .join()
                .unwrap();
        });
        // The main thread reads the state between frames, as the viewer's feed does.
        assert_eq!(
            workers.solver_mut().read_particles().unwrap().len(),
            expected.len()
        );
    }
    workers.settle().unwrap();
    assert_eq!(workers.frame(), one_thread.frame());
    assert_eq!(
        workers.time().to_bits(),
        one_thread.time().to_bits(),
        "times differ"
    );
    let got = workers.solver_mut().read_particles().unwrap();
    let (a, b) = (common::particle_bits(&expected), common::particle_bits(&got));
    let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    assert_eq!(
        differing, 0,
        "the run stepped on worker threads differs from the one-thread run in {differing} words"
    );
}

/// The export's snapshots (`Solver::snapshot_particles`: a device-to-device copy, then a copy to
/// pinned memory on a stream of its own) are the particles `read_particles` gives at that frame, C
/// aside, although the next frame is stepped before each is waited on, with both staging copies
/// in flight, and the last waited on another thread: in bin order (the fused pipeline), with
/// parked slots (a draining tank) and with a deformation (jelly-drop).
fn export_snapshots_are_the_particles_of_their_frame() {
    let scenes = [
        ("the fused dam break", scene(Pipeline::Fused)),
        (
            "the draining jet tank",
            flow_scene(40_000, common::JET_TANK_DRAIN),
        ),
        ("jelly-drop", Scene::load("jelly-drop").expect("a preset loads")),
    ];
    for (name, scene) in scenes {
        let mut sim = cuda_sim(&scene);
        frames(&mut sim, 3);
        let mut held = Vec::new();
        for round in 0..3 {
            let mut expected = sim.solver_mut().read_particles().unwrap();
            expected.c = Vec::new();
            let snapshot = sim.solver_mut().snapshot_particles().unwrap();
            assert!(
                matches!(snapshot, ParticleSnapshot::Pending(_)),
                "{name}: the CUDA backend's snapshot is not asynchronous"
            );
            held.push((round, expected, snapshot));
            frames(&mut sim, 1);
            if held.len() == 2 {
                let (round, expected, snapshot) = held.remove(0);
                let got = snapshot.wait().unwrap();
                assert!(
                    common::same_particles(&expected, &got),
                    "{name}: snapshot {round} is not the particles of its frame"
                );
            }
        }
        let (round, expected, snapshot) = held.remove(0);
        let got = std::thread::spawn(move || snapshot.wait().unwrap())
            .join()
            .unwrap();
        assert!(
            common::same_particles(&expected, &got),
            "{name}: snapshot {round}, waited on another thread, is not the particles of its frame"
        );
        assert!(
            scene.has_deformation() != got.deformation.is_empty(),
            "{name}: the snapshot's deformation does not follow the scene's materials"
        );
    }
}

/// The viewer's hand-over on the GPU (src/render/app/stepping.rs): frames stepped as the viewer
/// steps them (overlapped, `step_frame_until`, on a thread of their own) and snapshotted at each
/// frame's boundary, before the next frame's substeps are enqueued, are the frames of a run
/// stepped and read back frame by frame. On a fixed substep, so that both runs take the same
/// substeps (the viewer's overlap chooses a CFL step from older extremes).
fn snapshots_between_overlapped_frames_are_those_frames() {
    const FRAMES: u64 = 5;
    let mut scene = scene(Pipeline::Fused);
    scene.time_step = mpm::sim::scene::TimeStepPolicy::Fixed { dt: 8.0e-4 };
    let mut plain = cuda_sim(&scene);
    let mut expected = Vec::new();
    for _ in 0..FRAMES {
        plain.advance_frame().unwrap();
        let mut particles = plain.solver_mut().read_particles().unwrap();
        particles.c = Vec::new();
        expected.push(particles);
    }
    let mut viewer = cuda_sim(&scene);
    viewer.overlap_frames(true).unwrap();
    let snapshots = std::thread::scope(|scope| {
        let sim = &mut viewer;
        scope
            .spawn(move || {
                sim.bind_to_thread().unwrap();
                // Each snapshot waited on only after the next frame is enqueued, as the export
                // thread would.
                let mut got = Vec::new();
                let mut pending: Option<ParticleSnapshot> = None;
                for _ in 0..FRAMES {
                    sim.step_frame_until(None).unwrap().expect("a whole frame");
                    let snapshot = sim.solver_mut().snapshot_particles().unwrap();
                    if let Some(earlier) = pending.replace(snapshot) {
                        got.push(earlier.wait().unwrap());
                    }
                }
                got.push(pending.expect("a snapshot").wait().unwrap());
                got
            })
            .join()
            .unwrap()
    });
    for (frame, (want, got)) in expected.iter().zip(&snapshots).enumerate() {
        assert!(
            common::same_particles(want, got),
            "frame {}: the snapshot taken between overlapped frames is not that frame",
            frame + 1
        );
    }
}
