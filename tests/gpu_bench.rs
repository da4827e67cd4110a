//! The benchmark code on the GPU, briefly: a phase table of bench-65k and one sweep size, from CUDA
//! events. Asserts that every GPU phase was measured and the tables print (timings vary by GPU; the
//! figures themselves come from `mpm bench`). Reported as ignored, with the reason, where no CUDA
//! device is usable (tests/harness: `harness = false`).

use mpm::bench::{self, PhaseBenchOptions};
use mpm::sim::{Phase, Scene};

mod harness;

fn main() -> std::process::ExitCode {
    harness::run(
        "GPU",
        harness::cuda_device,
        harness::tests![bench_code_measures_every_gpu_phase],
    )
}

fn bench_code_measures_every_gpu_phase() {
    // Every substep's phases: 50 substeps hold few of one in 7, and perhaps no binning among them.
    let options = PhaseBenchOptions {
        warmup_steps: 10,
        steps: 50,
        phase_sample: Some(1),
        ..PhaseBenchOptions::default()
    };
    let scene = Scene::load("bench-65k").expect("preset");
    let report = bench::phase_bench(&scene, &options).expect("phase bench");
    println!("{}", bench::phase_table(&report));
    assert_eq!((report.steps, report.phased_steps), (50, 50));
    // One GPU: no exchanges between ranks, so no rows for them.
    let phases: Vec<Phase> = Phase::ALL.into_iter().filter(|p| !p.is_exchange()).collect();
    assert_eq!(report.rows.len(), phases.len());
    for (phase, row) in phases.into_iter().zip(&report.rows) {
        assert_eq!(row.phase, phase.name());
        match phase {
            // No launch of its own (grid_update clears), and every eighth substep only.
            Phase::GridClear => assert_eq!(row.mean_ms, 0.0),
            Phase::Sort => assert!(row.p95_ms > 0.0, "the sort ran in the sample"),
            // The fused pipeline (the preset's) scatters the momentum with the mass and mirrors both
            // in the grid update: p2g has no work, nor p2g_init after the first substep (a
            // warm-up one), so they take no timing event and read 0.
            Phase::P2g | Phase::P2gInit => assert_eq!(row.mean_ms, 0.0, "{} timed", row.phase),
            _ => assert!(row.median_ms > 0.0, "{} measured", row.phase),
        }
    }
    // The particle pass names the float scatter's entry point that ran (the device's size chooses:
    // src/cuda/one_pass.rs).
    let pass = report.rows.iter().find(|r| r.phase == Phase::G2p.name()).unwrap();
    assert!(
        [", as one_pass_float", ", as one_pass_float_planes"]
            .iter()
            .any(|k| pass.label.ends_with(k)),
        "{}",
        pass.label
    );

    // By default the phases of a sample: their rows from those substeps, the total from all of them.
    let sampled = PhaseBenchOptions {
        phase_sample: None,
        ..options
    };
    let report = bench::phase_bench(&scene, &sampled).expect("phase bench");
    let expected = 50usize.div_ceil(mpm::cuda::PHASE_SAMPLE as usize);
    assert!(
        report.phased_steps.abs_diff(expected) <= 1,
        "{} of 50 substeps timed their phases, one in {} expected",
        report.phased_steps,
        mpm::cuda::PHASE_SAMPLE
    );
    let update = report
        .rows
        .iter()
        .find(|r| r.phase == Phase::GridUpdate.name())
        .unwrap();
    assert!(update.median_ms > 0.0 && report.total.median_ms > update.median_ms);
    println!("{}", bench::phase_table(&report));

    let sweep = bench::scaling_sweep(&[65_536], 20, &options).expect("sweep");
    println!("{}", bench::sweep_table(&sweep));
    let point = &sweep.points[0];
    assert!(point.median_step_ms > 0.0 && point.device_bytes > 0);
}
