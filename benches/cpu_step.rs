//! CPU baseline (the report's CPU column): per-phase time of the single-thread reference, median and
//! p95 over per-substep samples, as a markdown table. The same code as `mpm bench --backend cpu`.
//!
//!     cargo bench --bench cpu_step                     # bench-65k, 1000 substeps
//!     cargo bench --bench cpu_step -- bench-655k 100   # another scene, substeps

use mpm::backend::BackendKind;
use mpm::bench::{self, BenchPlan, PhaseBenchOptions};
use mpm::sim::Scene;

fn main() -> std::process::ExitCode {
    mpm::text::exit_code(bench_main())
}

fn bench_main() -> anyhow::Result<()> {
    // `cargo bench` passes `--bench`; the positional arguments are ours.
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let scene_name = args
        .first()
        .map(String::as_str)
        .unwrap_or(bench::CPU_BASELINE_SCENE);
    let steps: usize = match args.get(1) {
        Some(text) => text
            .parse()
            .map_err(|_| anyhow::anyhow!("substeps `{text}` is not a number; e.g. 1000"))?,
        None => 1000,
    };
    let plan = BenchPlan {
        command: format!("cargo bench --bench cpu_step -- {scene_name} {steps}"),
        scenes: vec![Scene::load(scene_name)?],
        options: PhaseBenchOptions {
            backend: BackendKind::Cpu,
            warmup_steps: 10,
            steps,
            ..PhaseBenchOptions::default()
        },
        cpu_baseline_steps: None,
        sweep: None,
    };
    bench::run(&plan, &mut std::io::stdout().lock())?;
    Ok(())
}
