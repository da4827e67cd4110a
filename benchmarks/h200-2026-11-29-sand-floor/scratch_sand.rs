mod common;
mod materials_checks;
mod solids_checks;
use mpm::backend::BackendKind;

#[test]
fn floors() {
    let dxs: Vec<f32> = std::env::var("DX")
        .unwrap_or("0.01".into())
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    let floors: Vec<String> = std::env::var("FLOOR")
        .unwrap_or("stick".into())
        .split(',')
        .map(String::from)
        .collect();
    let backend = if std::env::var("BACKEND").as_deref() == Ok("cuda") {
        BackendKind::Cuda
    } else {
        BackendKind::CpuParallel
    };
    for &dx in &dxs {
        for which in &floors {
            let cols: Vec<(f32, f32)> = match std::env::var("COL").as_deref() {
                Ok("low") => vec![(0.2, 0.1)],
                Ok("tall") => vec![(0.08, 0.24)],
                _ => vec![(0.2, 0.1), (0.08, 0.24)],
            };
            for (length, height) in cols {
                let mut toml = solids_checks::sand_column_toml(dx, length, height);
        if which.contains("stick") { toml = toml.replace("friction = 0.577", "boundary = \"stick\""); }
        if which == "stick" || which.ends_with("-mirror") { toml = toml.replace("mirror_wall_mass = false", "mirror_wall_mass = true"); }
        let scene = common::scene(&toml);
                let mut sim = materials_checks::simulation(&scene, backend);
                let runout = solids_checks::sand_runout(&mut sim, dx, length, 1.5);
                let a = height / length;
                println!(
                    "RESULT {which} dx={dx} a={a:.2}: runout {runout:.3} lube {:.3} ({:+.1} %)",
                    solids_checks::lube_runout(a),
                    100.0 * (runout / solids_checks::lube_runout(a) - 1.0)
                );
            }
        }
    }
}

#[test]
fn slide() {
    let dx: f32 = std::env::var("DX").unwrap_or("0.01".into()).parse().unwrap();
    let mu: f32 = std::env::var("MU").unwrap_or("0.3".into()).parse().unwrap();
    let mirror = std::env::var("MIRROR").as_deref() != Ok("off");
    let law = std::env::var("LAW").unwrap_or("jelly".into());
    let backend = if std::env::var("BACKEND").as_deref() == Ok("cuda") {
        BackendKind::Cuda
    } else {
        BackendKind::CpuParallel
    };
    let (tank, depth) = (0.8f32, 8.0 * dx);
    let material = if law == "jelly" {
        solids_checks::jelly("jelly", 1000.0, 1.0e5, 0.3)
    } else {
        solids_checks::SAND.to_string()
    };
    let floor = format!(
        "[[collider]]\nshape = \"box\"\ncenter = [{}, {}, {}]\nsize = [{}, 0.2, {}]\nfriction = {mu}\n",
        0.5 * tank,
        0.5 * dx - 0.1,
        0.5 * depth,
        tank + 0.2,
        depth + 0.2
    );
    let toml = format!(
        "[domain]\nsize = [{tank}, 0.15, {depth}]\nresolution = [{}, {}, 8]\n{material}[time_step]\ncfl = 0.4\n{floor}[solver]\nmirror_wall_mass = {mirror}\n\
         [[block]]\nmin = [0.05, {dx}, {dx}]\nmax = [0.15, 0.05, {}]\nvelocity = [2.0, 0.0, 0.0]\n",
        (tank / dx).round() as u32, (0.15 / dx).round() as u32, 6.0 * dx);
    let scene = common::scene(&toml);
    let mut sim = materials_checks::simulation(&scene, backend);
    let mut samples = vec![];
    for frame in 1..=60u32 {
        sim.advance_frame().unwrap();
        let p = materials_checks::particles(&mut sim);
        let vx = p.v.iter().map(|v| v.x).sum::<f32>() / p.v.len() as f32;
        let t = frame as f32 / 60.0;
        samples.push((t, vx));
        if frame % 6 == 0 {
            println!("  t = {t:.2} s: mean vx {vx:.4}");
        }
    }
    // deceleration from a fit over the samples with 1.6 > vx > 0.3
    let pts: Vec<(f32, f32)> = samples
        .iter()
        .copied()
        .filter(|&(_, v)| v < 1.6 && v > 0.3)
        .collect();
    let n = pts.len() as f32;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (sxx, sxy) = pts
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p.0 * p.0, a.1 + p.0 * p.1));
    let slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    println!("RESULT slide {law} mirror={mirror} mu={mu} dx={dx}: deceleration {:.3} m/s^2 over {} samples, mu g {:.3} ({:+.1} %)", -slope, pts.len(), mu * 9.81, 100.0 * (-slope / (mu * 9.81) - 1.0));
}
