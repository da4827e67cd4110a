//! CPU baseline: per-phase time of the single-thread reference, median and p95 over many substeps,
//! as a markdown table in the report's shape.
//!
//!     cargo bench --bench cpu_step                    # bench-65k, 200 steps
//!     cargo bench --bench cpu_step -- bench-655k 50   # another scene, step count

use mpm::sim::cpu::CpuSolver;
use mpm::sim::{PhaseTimings, Scene, Simulation};

fn percentile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let scene_name = args.first().map(String::as_str).unwrap_or("bench-65k");
    let steps: usize = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(200);
    let warmup = 10;

    let scene = Scene::load(scene_name)?;
    let solver = CpuSolver::new(scene.spawn(), scene.grid_res);
    let mut sim = Simulation::new(scene.clone(), Box::new(solver));
    let (_, dt) = sim.next_frame_steps()?;
    let mut params = *sim.params();
    params.dt = dt;
    let solver = sim.solver_mut();

    let mut samples: Vec<PhaseTimings> = Vec::with_capacity(steps);
    for i in 0..warmup + steps {
        solver.step(&params)?;
        let t = solver.take_timings()?.expect("the CPU measures its phases");
        if i >= warmup {
            samples.push(t);
        }
    }

    println!(
        "CPU reference, single thread: scene {scene_name}, {} particles, grid {}x{}x{}, dt = {dt:.3e} s, \
         {steps} steps after {warmup} warm-up",
        scene.num_particles, scene.grid_res[0], scene.grid_res[1], scene.grid_res[2]
    );
    println!("command: cargo bench --bench cpu_step -- {scene_name} {steps}\n");
    println!("| phase | median (ms) | p95 (ms) |\n|---|---:|---:|");
    let column = |f: &dyn Fn(&PhaseTimings) -> f64| {
        let mut v: Vec<f64> = samples.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        (percentile(&v, 0.5), percentile(&v, 0.95))
    };
    for (i, name) in PhaseTimings::PHASES.iter().enumerate() {
        let (median, p95) = column(&|t| t.phases()[i]);
        println!("| {name} | {median:.3} | {p95:.3} |");
    }
    let (median, p95) = column(&|t| t.total());
    println!("| **total** | **{median:.3}** | **{p95:.3}** |");
    Ok(())
}
