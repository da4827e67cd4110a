//! GPU phase tables of the report's two scenarios (bench-65k, bench-655k) from CUDA events, and with
//! `sweep` the scaling sweep. The same code as `mpm bench`; prints `skipped: <reason>` without a GPU.
//!
//!     cargo bench --bench gpu_step                 # both scenarios, 1000 substeps each
//!     cargo bench --bench gpu_step -- 5000         # the report's 5000
//!     cargo bench --bench gpu_step -- 1000 sweep   # and the scaling sweep

use mpm::bench::{self, BenchPlan, PhaseBenchOptions};
use mpm::cuda::library;
use mpm::sim::Scene;

fn main() -> std::process::ExitCode {
    mpm::text::exit_code(bench_main())
}

fn bench_main() -> anyhow::Result<()> {
    if let Err(why) = library::device_available() {
        println!("gpu_step: skipped: {why:#}");
        return Ok(());
    }
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let steps: usize = match args.first() {
        Some(text) => text
            .parse()
            .map_err(|_| anyhow::anyhow!("substeps `{text}` is not a number; e.g. 1000"))?,
        None => 1000,
    };
    let sweep = args.iter().any(|a| a == "sweep");
    let plan = BenchPlan {
        command: format!(
            "cargo bench --bench gpu_step -- {steps}{}",
            if sweep { " sweep" } else { "" }
        ),
        scenes: bench::REPORT_SCENES
            .iter()
            .map(|name| Scene::load(name))
            .collect::<Result<_, _>>()?,
        options: PhaseBenchOptions {
            steps,
            ..PhaseBenchOptions::default()
        },
        cpu_baseline_steps: None,
        sweep: sweep.then(|| (bench::SWEEP_PARTICLES.to_vec(), 100)),
    };
    bench::run(&plan, &mut std::io::stdout().lock())?;
    Ok(())
}
