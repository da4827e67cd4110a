//! Checkpoint and restart on the CUDA backend: a fixed-point run resumed from a checkpoint is byte
//! for byte the uninterrupted one, in both pipelines. Where no CUDA device and driver are usable,
//! every test is reported as ignored, with the reason (tests/harness: `harness = false`).
//!
//! What this guards: the CUDA solver keeps state between substeps that a checkpoint does not hold
//! (the particle bins, rebuilt every few substeps or on a flag; the binned pipeline's grid mass of the
//! next substep, scattered by g2p2g). A resumed solver rebuilds both from the particles on its first
//! substep; the fixed-point scatter must then give the very integers the uninterrupted run had.

use mpm::backend::BackendKind;
use mpm::checkpoint::Checkpoint;
use mpm::sim::params::{Pipeline, ScatterMode};
use mpm::sim::{Particles, Scene, Simulation};

mod harness;

fn main() -> std::process::ExitCode {
    harness::run(
        "GPU",
        harness::cuda_device,
        harness::tests![
            a_resumed_fixed_point_run_is_byte_identical,
            a_gpu_checkpoint_resumes_on_the_cpu
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

fn particle_bits(p: &Particles) -> Vec<u32> {
    let mut bits = Vec::new();
    bits.extend(p.x.iter().flat_map(|v| v.to_array()).map(f32::to_bits));
    bits.extend(p.v.iter().flat_map(|v| v.to_array()).map(f32::to_bits));
    bits.extend(p.c.iter().flat_map(|c| c.to_cols_array()).map(f32::to_bits));
    bits.extend(p.rho.iter().map(|r| r.to_bits()));
    bits
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
    let dir = tempfile::tempdir().unwrap();
    for pipeline in [Pipeline::Binned, Pipeline::Report] {
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
        let (a, b) = (particle_bits(&expected), particle_bits(&got));
        let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        println!(
            "{pipeline:?}: {differing} of {} words differ after the resume",
            a.len()
        );
        assert!(
            differing == 0,
            "{pipeline:?}: the resumed fixed-point run differs from the uninterrupted one in {differing} words"
        );
    }
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
