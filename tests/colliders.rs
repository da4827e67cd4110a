//! Colliders on the CPU backends (docs/physics.md, "Colliders"): resting contact, the boundary
//! conditions (slip, stick, Coulomb friction), the wave maker against linear theory, and bad colliders
//! refused. Small grids, so each runs in seconds in release builds.

mod common;
mod materials_checks;
mod solids_checks;

use glam::{DVec3, Vec3};
use mpm::backend::{self, BackendKind};
use mpm::sim::{Particles, Scene, Simulation};

/// Runs `frames` 60 Hz frames of a scene on the multi-threaded CPU backend (the reference's math);
/// returns the simulation for inspection.
fn run(scene: &Scene, frames: u64) -> Simulation {
    let solver = backend::create(BackendKind::CpuParallel, scene).expect("a CPU backend");
    let mut sim = Simulation::new(scene.clone(), solver);
    for _ in 0..frames {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
    }
    sim
}

fn particles(sim: &mut Simulation) -> Particles {
    sim.solver_mut().read_particles().unwrap()
}

fn mean(values: impl Iterator<Item = Vec3>) -> DVec3 {
    let (mut sum, mut n) = (DVec3::ZERO, 0usize);
    for v in values {
        sum += v.as_dvec3();
        n += 1;
    }
    sum / n.max(1) as f64
}

/// A tank of 0.5 x 0.5 x `depth` m at dx = 1/64 m, water at c0 = 10 m/s, with `body` (TOML tables).
fn tank(depth: f64, extra: &str) -> Scene {
    let res_z = (depth * 64.0).round() as u32;
    common::scene(&format!(
        "[domain]\nsize = [0.5, 0.5, {depth}]\nresolution = [32, 32, {res_z}]\n\
         [material]\nrest_density = 1000.0\nsound_speed = 10.0\n\
         [time_step]\ncfl = 0.4\n{extra}"
    ))
}

/// The raised floor of the resting and sliding tests: a box through the x and z walls, top at
/// y = 0.2 m, with `boundary` (TOML lines).
fn raised_floor(boundary: &str) -> String {
    format!(
        "[[collider]]\nshape = \"box\"\ncenter = [0.25, 0.15, 0.125]\nsize = [0.6, 0.1, 0.4]\n{boundary}\n"
    )
}

#[test]
fn block_resting_on_an_obstacle_stays_at_rest() {
    let scene = tank(
        0.25,
        &(raised_floor("") + "[[block]]\nmin = [0.02, 0.2, 0.02]\nmax = [0.46, 0.3, 0.21]"),
    );
    let mut sim = run(&scene, 0);
    let mut energies = Vec::new();
    for _ in 0..36 {
        let stats = sim.advance_frame().unwrap();
        energies.push(stats.summary.kinetic_energy);
        let p = particles(&mut sim);
        let lowest = p.x.iter().map(|x| x.y).fold(f32::INFINITY, f32::min);
        // The backstop would put a leaking particle back on the surface; none gets that far.
        assert!(
            lowest > 0.2,
            "a particle at y = {lowest} reached the obstacle's top (0.2 m)"
        );
        assert_eq!(stats.backstop_pushes, 0, "particles reached into the obstacle");
    }
    // Settling (the block starts at rest density, so it compresses and rings) decays: the last
    // 6 frames hold under a tenth of the peak kinetic energy.
    let peak = energies.iter().copied().fold(0.0, f64::max);
    let late = energies[30..].iter().copied().fold(0.0, f64::max);
    println!("kinetic energy: peak {peak:.3e} J, last 6 frames at most {late:.3e} J");
    assert!(
        late < 0.1 * peak,
        "kinetic energy {late} J late vs {peak} J at its peak"
    );
}

/// The inclined plane: a box turned 30 degrees about z, its top surface through (0.225, 0.1433) m.
const SLOPE_DEGREES: f32 = 30.0;

/// Runs a block of water dropped onto the inclined plane with friction `mu` for `frames` frames;
/// per frame the mean velocity down the slope of all the water and of its contact layer (the
/// particles within 0.75 dx of the plane).
fn slide(mu: f64, frames: usize) -> Vec<(f32, f32)> {
    let scene = tank(
        0.125,
        &format!(
            "[[collider]]\nshape = \"box\"\ncenter = [0.25, 0.1, 0.0625]\nsize = [1.0, 0.1, 0.5]\n\
             rotation = [0.0, 0.0, {SLOPE_DEGREES}]\nfriction = {mu}\n\
             [[block]]\nmin = [0.26, 0.16, 0.0157]\nmax = [0.36, 0.26, 0.0937]"
        ),
    );
    let (sin, cos) = SLOPE_DEGREES.to_radians().sin_cos();
    let normal = Vec3::new(-sin, cos, 0.0);
    let down = Vec3::new(-cos, -sin, 0.0);
    let surface = Vec3::new(0.25, 0.1, 0.0) + 0.05 * normal;
    let mut sim = run(&scene, 0);
    (0..frames)
        .map(|_| {
            sim.advance_frame().unwrap();
            let p = particles(&mut sim);
            let all = mean(p.v.iter().copied()).as_vec3().dot(down);
            let contact =
                p.x.iter()
                    .zip(&p.v)
                    .filter(|(x, _)| (**x - surface).dot(normal) < 0.75 / 64.0);
            (all, mean(contact.map(|(_, v)| *v)).as_vec3().dot(down))
        })
        .collect()
}

#[test]
fn friction_plane_slides_above_the_friction_angle_and_sticks_below() {
    let g = 9.81f32;
    let (sin, cos) = SLOPE_DEGREES.to_radians().sin_cos();
    // tan 30 = 0.577. At mu = 0.2 the water slides as a block: every contact node slips, so the
    // plane removes mu times the normal momentum it removes, and the centre of mass accelerates at
    // g (sin - mu cos) whatever the water does inside. Fitted over frames 2 to 12 (after the drop
    // onto the plane, before the front reaches the wall).
    let fast = slide(0.2, 12);
    let accel = (fast[11].0 - fast[1].0) / (10.0 / 60.0);
    let expected = g * (sin - 0.2 * cos);
    println!("mu 0.2: acceleration down the slope {accel:.3} m/s^2, Coulomb {expected:.3}");
    assert!(
        (accel / expected - 1.0).abs() < 0.1,
        "{accel} m/s^2 vs {expected}"
    );

    // Either side of the friction angle: the contact layer slips at mu = 0.45 < tan 30 and holds at
    // mu = 0.7 > tan 30 (the water above it still flows down over it, as water does). Means over
    // frames 3 to 9.
    let contact = |runs: &[(f32, f32)]| runs[3..9].iter().map(|r| r.1).sum::<f32>() / 6.0;
    let (below, above) = (contact(&slide(0.45, 9)), contact(&slide(0.7, 9)));
    println!("contact layer down the slope: mu 0.45 {below:.4} m/s, mu 0.7 {above:.4} m/s");
    assert!(
        above < 0.05,
        "the contact layer slips at {above} m/s with mu above tan(theta)"
    );
    assert!(
        below > 2.0 * above,
        "mu 0.45 slips at {below} m/s, mu 0.7 at {above} m/s"
    );
}

/// A block sliding on a Coulomb floor slows at mu g, under the walls' mirror as without it: the
/// floor's friction counts the momentum into the wall that the mirror's image took before the
/// collider projected (without that it read only a substep's gravity and barely gripped). The
/// slope of the jelly block's mean velocity ([`solids_checks::sliding_block_toml`]), fitted while
/// it slides, within 6 % of mu g = 2.94 m/s^2 (measured at 1 cm: -4.9 % with the mirror, +0.0 %
/// without; the elastic block rocks on its front edge as it brakes).
#[test]
fn a_block_slides_to_rest_on_a_coulomb_floor_at_mu_g_under_the_walls_mirror() {
    let mu = 0.3f32;
    for mirror in [true, false] {
        let scene = common::scene(&solids_checks::sliding_block_toml(mu, mirror));
        let mut sim = run(&scene, 0);
        let what = format!("the mirror {}", if mirror { "on" } else { "off" });
        let deceleration = solids_checks::sliding_deceleration(&mut sim, mu, &what);
        assert!(
            (deceleration / (mu * 9.81) - 1.0).abs() < 0.06,
            "{what}: {deceleration:.3} m/s^2 against mu g = {:.3}",
            mu * 9.81
        );
    }
}

/// Mean x velocity of the particles within 0.75 dx of the raised floor's top after 0.1 s of a layer
/// of water moving along it at 0.5 m/s.
fn tangential_speed_at_the_floor(boundary: &str) -> f32 {
    let scene = tank(
        0.25,
        &(raised_floor(boundary)
            + "[[block]]\nmin = [0.08, 0.2, 0.02]\nmax = [0.3, 0.25, 0.21]\nvelocity = [0.5, 0.0, 0.0]"),
    );
    let mut sim = run(&scene, 6);
    let p = particles(&mut sim);
    let floor = p.x.iter().zip(&p.v).filter(|(x, _)| x.y < 0.2 + 0.75 / 64.0);
    mean(floor.map(|(_, v)| *v)).x as f32
}

#[test]
fn free_slip_keeps_and_no_slip_removes_the_tangential_velocity() {
    let (slip, stick) = (
        tangential_speed_at_the_floor("boundary = \"slip\""),
        tangential_speed_at_the_floor("boundary = \"stick\""),
    );
    println!("along the floor after 0.1 s: slip {slip:.4} m/s, stick {stick:.4} m/s (started at 0.5)");
    assert!(slip > 0.45, "free slip lost tangential velocity: {slip} m/s");
    assert!(stick < 0.1, "no slip kept tangential velocity: {stick} m/s");
}

/// A piston wave maker in a 1.5 m flume (2.5D: 5 cells across), water 0.13 m deep, against linear
/// wavemaker theory (Biesel): wave height H over stroke S = 2 (cosh 2kh - 1) / (sinh 2kh + 2kh),
/// with k from the dispersion relation. The gauge is the water volume in a strip 2 dx wide at
/// 0.55 m from the paddle (three depths: past the evanescent modes), fitted with a sine at the
/// paddle's frequency from 1.2 s (when the front has passed) to 2.5 s (before the far wall's
/// reflection is back, at about 4 s). Tolerance 20 %: at 24 cells per wavelength and 6 cells of depth
/// the grid damps the wave by about 10 % over its run to the gauge (measured: -10 %), steepness
/// H / L = 0.04 gives second-order corrections of a few percent, and the strip averages 1 % away; a
/// wrong sign, phase or stroke is off by 50 % or more.
#[test]
fn piston_wave_maker_matches_linear_wavemaker_theory() {
    let (period, amplitude) = (0.6f64, 0.0075f64);
    let dx = 1.0 / 48.0;
    let scene = common::scene(&format!(
        "[domain]\nsize = [1.5, 0.3125, {lz}]\nresolution = [72, 15, 8]\n\
         [material]\nrest_density = 1000.0\nsound_speed = 5.0\n\
         [time_step]\ncfl = 0.4\n\
         [[collider]]\nshape = \"box\"\ncenter = [0.06, 0.1, 0.08]\nsize = [0.04, 0.5, 0.5]\n\
         [collider.motion]\npiston = {{ direction = [1.0, 0.0, 0.0], amplitude = {amplitude}, period = {period} }}\n\
         [[block]]\nmin = [0.0209, 0.0209, 0.0209]\nmax = [1.4583, 0.15, {zmax}]",
        lz = 8.0 * dx,
        zmax = 6.0 * dx - 1e-4,
    ));
    let mut sim = run(&scene, 0);
    let (gauge, width, across) = (0.55f32, 2.0 * dx as f32, 5.0 * dx as f32);
    let m_p = scene.material().particle_mass;
    let mut window = Vec::new();
    for _ in 0..150 {
        sim.advance_frame().unwrap();
        let p = particles(&mut sim);
        let volume: f32 =
            p.x.iter()
                .zip(&p.rho)
                .filter(|(x, _)| (x.x - gauge).abs() < 0.5 * width)
                .map(|(_, rho)| m_p / rho)
                .sum();
        if sim.time() >= 1.2 {
            window.push((sim.time(), f64::from(volume / (width * across))));
        }
    }
    let omega = std::f64::consts::TAU / period;
    let (a, depth) = fit_sine(&window, omega);
    let k = wavenumber(omega, depth);
    let kh2 = 2.0 * k * depth;
    let expected = 2.0 * (kh2.cosh() - 1.0) / (kh2.sinh() + kh2) * 2.0 * amplitude;
    println!(
        "wave height {:.4} m at the gauge, Biesel {expected:.4} m (depth {depth:.4} m, kh {:.2})",
        2.0 * a,
        k * depth
    );
    assert!(
        (2.0 * a / expected - 1.0).abs() < 0.2,
        "H = {} m vs {expected} m",
        2.0 * a
    );
}

/// Least-squares fit of c0 + c1 t + a cos(wt) + b sin(wt): returns (amplitude sqrt(a^2 + b^2), mean level).
fn fit_sine(samples: &[(f64, f64)], omega: f64) -> (f64, f64) {
    let t_mid = samples.iter().map(|s| s.0).sum::<f64>() / samples.len() as f64;
    let basis = |t: f64| [1.0, t - t_mid, (omega * t).cos(), (omega * t).sin()];
    let mut m = [[0.0f64; 5]; 4];
    for &(t, y) in samples {
        let b = basis(t);
        for i in 0..4 {
            for j in 0..4 {
                m[i][j] += b[i] * b[j];
            }
            m[i][4] += b[i] * y;
        }
    }
    // Gauss-Jordan on the 4x4 normal equations.
    for c in 0..4 {
        let pivot = (c..4)
            .max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs()))
            .unwrap();
        m.swap(c, pivot);
        let pivot_row = m[c];
        for (r, row) in m.iter_mut().enumerate() {
            if r != c {
                let f = row[c] / pivot_row[c];
                for (x, p) in row.iter_mut().zip(pivot_row).skip(c) {
                    *x -= f * p;
                }
            }
        }
    }
    let x: Vec<f64> = (0..4).map(|i| m[i][4] / m[i][i]).collect();
    ((x[2] * x[2] + x[3] * x[3]).sqrt(), x[0])
}

/// The wavenumber of linear waves of angular frequency omega in water of depth h: omega^2 = g k tanh(k h).
fn wavenumber(omega: f64, h: f64) -> f64 {
    let g = 9.81;
    let mut k = omega * omega / g;
    for _ in 0..100 {
        k = omega * omega / (g * (k * h).tanh());
    }
    k
}

// ---------------------------------------------------------------------------------------------
// Bad colliders and meshes.

/// A 20^3-node box of water (0.2 m) with one collider table (and a mesh file `dir` may hold).
fn water_with(collider: &str) -> String {
    common::water_box(
        20,
        &format!("[[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.1, 0.1, 0.1]\n[[collider]]\n{collider}"),
    )
}

/// An axis-aligned cube of edge 2 h about the origin as OBJ text, outward-facing; without the last
/// face when `open`.
fn cube_obj(h: f64, open: bool) -> String {
    let mut text = String::new();
    for i in 0..8 {
        let c = |bit: usize| if i >> bit & 1 == 1 { h } else { -h };
        text += &format!("v {} {} {}\n", c(0), c(1), c(2));
    }
    let faces = [
        [1, 3, 4, 2],
        [5, 6, 8, 7],
        [1, 2, 6, 5],
        [3, 7, 8, 4],
        [1, 5, 7, 3],
        [2, 4, 8, 6],
    ];
    for f in &faces[..if open { 5 } else { 6 }] {
        text += &format!("f {} {} {} {}\n", f[0], f[1], f[2], f[3]);
    }
    text
}

#[test]
fn bad_colliders_are_refused_with_the_key_and_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("open.obj"), cube_obj(0.03, true)).unwrap();
    let scene_path = dir.path().join("scene.toml");
    let cases = [
        (
            "outside the domain",
            "shape = \"sphere\"\ncenter = [0.5, 0.1, 0.1]\nradius = 0.05",
            "collider[0].center",
            "outside the domain",
        ),
        (
            "an open mesh",
            "shape = \"mesh\"\nfile = \"open.obj\"\ncenter = [0.15, 0.1, 0.1]",
            "collider[0].file",
            "not a closed mesh",
        ),
        (
            "an unknown boundary kind",
            "shape = \"sphere\"\ncenter = [0.15, 0.1, 0.1]\nradius = 0.03\nboundary = \"sticky\"",
            "collider[0].boundary",
            "not a boundary kind",
        ),
        (
            "negative friction",
            "shape = \"sphere\"\ncenter = [0.15, 0.1, 0.1]\nradius = 0.03\nfriction = -0.2",
            "collider[0].friction",
            "zero or positive",
        ),
        (
            "zero size",
            "shape = \"box\"\ncenter = [0.15, 0.1, 0.1]\nsize = [0.05, 0.0, 0.05]",
            "collider[0].size[1]",
            "positive",
        ),
        (
            "zero radius",
            "shape = \"capsule\"\ncenter = [0.15, 0.1, 0.1]\nradius = 0.0\nlength = 0.05",
            "collider[0].radius",
            "positive",
        ),
        (
            "an unknown shape",
            "shape = \"cone\"\ncenter = [0.15, 0.1, 0.1]",
            "collider[0].shape",
            "not a collider shape",
        ),
        (
            "a missing mesh file",
            "shape = \"mesh\"\nfile = \"nowhere.stl\"",
            "collider[0].file",
            "nowhere.stl",
        ),
        (
            "a key of another shape",
            "shape = \"sphere\"\ncenter = [0.15, 0.1, 0.1]\nradius = 0.03\nsize = [0.1, 0.1, 0.1]",
            "collider[0].size",
            "not a key of a sphere",
        ),
        (
            "two kinds of motion",
            "shape = \"sphere\"\ncenter = [0.15, 0.1, 0.1]\nradius = 0.03\n[collider.motion]\nvelocity = [1.0, 0.0, 0.0]\n\
             piston = { direction = [1.0, 0.0, 0.0], amplitude = 0.01, period = 1.0 }",
            "collider[0].motion",
            "one kind per collider",
        ),
        (
            "a piston of zero period",
            "shape = \"box\"\ncenter = [0.15, 0.1, 0.1]\nsize = [0.02, 0.2, 0.2]\n[collider.motion]\n\
             piston = { direction = [1.0, 0.0, 0.0], amplitude = 0.01, period = 0.0 }",
            "collider[0].motion.piston.period",
            "positive",
        ),
        // Rigid bodies (issue 42).
        (
            "a body given a density and a mass",
            "shape = \"sphere\"\ncenter = [0.15, 0.1, 0.1]\nradius = 0.03\ndensity = 500.0\nmass = 0.1",
            "collider[0].mass",
            "both given",
        ),
        (
            "a hinge on a collider that is no body",
            "shape = \"box\"\ncenter = [0.15, 0.1, 0.1]\nsize = [0.02, 0.1, 0.1]\n\
             hinge = { point = [0.15, 0.1, 0.1], axis = [0.0, 0.0, 1.0] }",
            "collider[0].hinge",
            "only for a rigid body",
        ),
        (
            "a body driven by a piston",
            "shape = \"box\"\ncenter = [0.15, 0.1, 0.1]\nsize = [0.02, 0.1, 0.1]\ndensity = 500.0\n\
             [collider.motion]\npiston = { direction = [1.0, 0.0, 0.0], amplitude = 0.01, period = 1.0 }",
            "collider[0].motion",
            "piston or flap",
        ),
        (
            "a body of negative density",
            "shape = \"sphere\"\ncenter = [0.15, 0.1, 0.1]\nradius = 0.03\ndensity = -3.0",
            "collider[0].density",
            "must be a positive number",
        ),
        (
            "a body through a wall",
            "shape = \"sphere\"\ncenter = [0.02, 0.1, 0.1]\nradius = 0.03\ndensity = 500.0",
            "collider[0].center",
            "through a wall",
        ),
        (
            "a body far lighter than the water its boundary holds",
            "shape = \"sphere\"\ncenter = [0.15, 0.1, 0.1]\nradius = 0.03\ndensity = 5.0",
            "collider[0].density",
            "lighter than the liquid",
        ),
    ];
    for (what, collider, key, words) in cases {
        std::fs::write(&scene_path, water_with(collider)).unwrap();
        let e = match Scene::load(scene_path.to_str().unwrap()) {
            Ok(_) => panic!("accepted {what}"),
            Err(e) => e,
        };
        let message = e.to_string();
        println!("{what}: {message}");
        assert_eq!(e.key, key, "{what}: {message}");
        assert!(message.contains(words), "{what}: `{words}` not in: {message}");
        assert!(!e.fix.is_empty(), "{what}: no fix in {message}");
    }
}

#[test]
fn colliders_on_the_report_pipeline_are_refused_naming_the_fused_pipeline() {
    let mut scene = common::scene(&water_with(
        "shape = \"sphere\"\ncenter = [0.15, 0.1, 0.1]\nradius = 0.03",
    ));
    assert!(scene.check_pipeline().is_ok());
    scene.pipeline = mpm::sim::Pipeline::Report;
    let e = scene.check_pipeline().unwrap_err().to_string();
    assert!(e.contains("--pipeline fused"), "{e}");
    let e = backend::create(BackendKind::Cuda, &scene)
        .err()
        .expect("refused")
        .to_string();
    assert!(
        e.contains("--pipeline fused"),
        "refused before any device work: {e}"
    );
}

/// The binned pipeline mirrors the walls before its grid update, which then cannot see what the
/// mirror pushed: a Coulomb collider that reaches the walls' mirror is refused there while the mirror
/// is on, naming both fixes; one clear of the walls is not.
#[test]
fn coulomb_colliders_at_the_mirror_on_the_binned_pipeline_are_refused() {
    let binned = |collider: &str| {
        let mut scene = common::scene(&water_with(collider));
        scene.pipeline = mpm::sim::Pipeline::Binned;
        scene
    };
    let mut floor =
        binned("shape = \"box\"\ncenter = [0.1, -0.09, 0.1]\nsize = [0.4, 0.2, 0.4]\nfriction = 0.5");
    let e = floor.check_pipeline().unwrap_err().to_string();
    assert!(
        e.contains("--pipeline fused") && e.contains("mirror_wall_mass = false"),
        "{e}"
    );
    floor.mirror_wall_mass = false;
    assert!(floor.check_pipeline().is_ok());
    let clear = binned("shape = \"sphere\"\ncenter = [0.1, 0.1, 0.1]\nradius = 0.03\nfriction = 0.5");
    assert!(clear.check_pipeline().is_ok());
}

/// A cube mesh read from OBJ and from STL has the distance field of the same box collider, and no
/// fluid spawns inside it.
#[test]
fn a_closed_mesh_collider_matches_the_box_it_describes() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cube.obj"), cube_obj(0.03, false)).unwrap();
    // The same cube as STL, through stl_io's writer.
    let obj = tobj_free_triangles(&cube_obj(0.03, false));
    let stl: Vec<stl_io::Triangle> = obj
        .iter()
        .map(|t| stl_io::Triangle {
            normal: stl_io::Normal::new([0.0; 3]),
            vertices: t.map(stl_io::Vertex::new),
        })
        .collect();
    let mut file = std::fs::File::create(dir.path().join("cube.stl")).unwrap();
    stl_io::write_stl(&mut file, stl.iter()).unwrap();
    drop(file);
    let scene_path = dir.path().join("scene.toml");
    let center = "center = [0.15, 0.1, 0.1]";
    std::fs::write(
        &scene_path,
        water_with(&format!("shape = \"box\"\n{center}\nsize = [0.06, 0.06, 0.06]")),
    )
    .unwrap();
    let reference = Scene::load(scene_path.to_str().unwrap())
        .unwrap()
        .colliders
        .frame(0.0);
    for file in ["cube.obj", "cube.stl"] {
        std::fs::write(
            &scene_path,
            water_with(&format!("shape = \"mesh\"\nfile = \"{file}\"\n{center}")),
        )
        .unwrap();
        let scene = Scene::load(scene_path.to_str().unwrap()).unwrap_or_else(|e| panic!("{e}"));
        let frame = scene.colliders.frame(0.0);
        let mut worst = 0.0f32;
        for i in 0..400 {
            // Points on a jittered lattice around the cube, inside the sampled box.
            let t = i as f32;
            let x = Vec3::new(0.15, 0.1, 0.1)
                + Vec3::new((t * 0.37).sin(), (t * 0.73).cos(), (t * 1.31).sin()) * 0.04;
            let (a, _) = frame.distance(&frame.states[0], x);
            let (b, _) = reference.distance(&reference.states[0], x);
            // Deep inside, the exact field peaks (a pyramid) and trilinear samples round the peak off:
            // there only the sign is held to (away from the edges, where the rounding below may flip
            // it); the boundary conditions read the field near the surface.
            if b.abs() > 0.3 * 0.01 {
                assert_eq!(a < 0.0, b < 0.0, "{file}: inside and outside disagree at {x}");
            }
            if b.abs() < 0.01 {
                worst = worst.max((a - b).abs());
            }
        }
        // Across the middle of a face the field is linear, so its samples are exact there.
        for d in [-0.015f32, -0.004, 0.0, 0.003, 0.012] {
            let x = Vec3::new(0.15 + 0.03 + d, 0.1, 0.1);
            let (a, n) = frame.distance(&frame.states[0], x);
            assert!(
                (a - d).abs() < 1e-5 && (n - Vec3::X).length() < 1e-4,
                "{file}: {a} at {d} m from the face, normal {n}"
            );
        }
        println!("{file}: largest distance difference from the box within a cell of its surface {worst:.2e} m (dx = 0.01)");
        // Within a cell of the surface: trilinear samples of the exact field round its kinks and
        // curves at the cube's edges and corners by up to about a quarter of a cell.
        assert!(worst < 0.3 * 0.01, "{file}: {worst} m");
        let p = scene.spawn();
        assert!(
            p.x.iter().all(|x| frame.distance(&frame.states[0], *x).0 >= 0.0),
            "fluid spawned inside the mesh"
        );
    }
}

/// The triangles of OBJ text with quads (as `cube_obj` writes), without a reader: for the STL copy.
fn tobj_free_triangles(obj: &str) -> Vec<[[f32; 3]; 3]> {
    let mut v = Vec::new();
    let mut t = Vec::new();
    for line in obj.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w[0] {
            "v" => v.push([w[1], w[2], w[3]].map(|s| s.parse::<f32>().unwrap())),
            "f" => {
                let i: Vec<usize> = w[1..].iter().map(|s| s.parse::<usize>().unwrap() - 1).collect();
                t.push([v[i[0]], v[i[1]], v[i[2]]]);
                t.push([v[i[0]], v[i[2]], v[i[3]]]);
            }
            _ => {}
        }
    }
    t
}

/// The reference and the multi-threaded backend apply the same colliders (a moving piston, a
/// friction sphere and a stick capsule) to rounding: both run 40 substeps of the same scene.
#[test]
fn cpu_parallel_follows_the_reference_with_colliders() {
    let scene = tank(
        0.25,
        "[[collider]]\nshape = \"sphere\"\ncenter = [0.3, 0.12, 0.12]\nradius = 0.06\nfriction = 0.3\n\
         [[collider]]\nshape = \"capsule\"\ncenter = [0.15, 0.1, 0.12]\nradius = 0.03\nlength = 0.1\nrotation = [90.0, 0.0, 0.0]\nboundary = \"stick\"\n\
         [[collider]]\nshape = \"box\"\ncenter = [0.45, 0.2, 0.12]\nsize = [0.03, 0.4, 0.3]\n\
         [collider.motion]\npiston = { direction = [1.0, 0.0, 0.0], amplitude = 0.02, period = 0.5 }\n\
         [[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.42, 0.2, 0.21]",
    );
    let mut reference = Simulation::new(scene.clone(), backend::create(BackendKind::Cpu, &scene).unwrap());
    let mut parallel = Simulation::new(
        scene.clone(),
        backend::create(BackendKind::CpuParallel, &scene).unwrap(),
    );
    let (mut a, mut b) = (0, 0);
    for _ in 0..3 {
        a += reference.advance_frame().unwrap().backstop_pushes;
        b += parallel.advance_frame().unwrap().backstop_pushes;
    }
    let (p, q) = (particles(&mut reference), particles(&mut parallel));
    let worst =
        p.x.iter()
            .zip(&q.x)
            .map(|(x, y)| (*x - *y).length())
            .fold(0.0, f32::max)
            / scene.dx;
    println!("after 3 frames: largest position difference {worst:.2e} dx; backstop pushes {a} and {b}");
    assert!(worst < 1e-3, "{worst} dx");
    assert_eq!(reference.backstop_pushes(), a);
}

/// The viewer's drag, as the simulation sees it: a sphere set moving through still water at 1 m/s
/// is where the motion says after 0.2 s, and has pushed the water along (momentum along x).
#[test]
fn a_dragged_collider_moves_and_pushes_the_water() {
    let scene = tank(
        0.25,
        "[[collider]]\nshape = \"sphere\"\ncenter = [0.1, 0.1, 0.125]\nradius = 0.05\n\
         [[block]]\nmin = [0.02, 0.02, 0.02]\nmax = [0.46, 0.15, 0.21]",
    );
    let mut sim = run(&scene, 1);
    let start = Vec3::from(sim.collider_frame().states[0].center);
    sim.drag_collider(0, start.as_dvec3(), DVec3::new(1.0, 0.0, 0.0))
        .unwrap();
    for _ in 0..12 {
        sim.advance_frame().unwrap();
    }
    let moved = Vec3::from(sim.collider_frame().states[0].center) - start;
    let p = particles(&mut sim);
    let momentum = mean(p.v.iter().copied()).x;
    println!("the sphere moved {moved} m; mean water velocity along x {momentum:.4} m/s");
    assert!((moved - Vec3::new(0.2, 0.0, 0.0)).length() < 1e-5, "{moved}");
    assert!(momentum > 0.02, "the water was not pushed: {momentum} m/s");
    assert!(
        sim.drag_collider(5, DVec3::ZERO, DVec3::ZERO).is_err(),
        "a collider that is not there"
    );
}

/// A mesh far larger than the tank (issue 17, item 2): a static one is sampled only where it can
/// touch the fluid, so it loads at once; a moving one whose field would not fit in memory is refused,
/// naming its scale, instead of hanging while memory grows.
#[test]
fn a_mesh_larger_than_the_tank_loads_or_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cube.obj"), cube_obj(0.03, false)).unwrap();
    let scene_path = dir.path().join("scene.toml");
    let started = std::time::Instant::now();
    std::fs::write(
        &scene_path,
        water_with("shape = \"mesh\"\nfile = \"cube.obj\"\nscale = 100.0\ncenter = [0.15, -2.95, 0.1]"),
    )
    .unwrap();
    let scene = Scene::load(scene_path.to_str().unwrap()).expect("a static mesh larger than the tank");
    let elapsed = started.elapsed().as_secs_f64();
    println!("a 6 m static cube under a 0.2 m tank loads in {elapsed:.2} s");
    assert_eq!(scene.colliders.len(), 1);

    std::fs::write(
        &scene_path,
        water_with(
            "shape = \"mesh\"\nfile = \"cube.obj\"\nscale = 100000.0\ncenter = [0.15, 0.1, 0.1]\n\
             [collider.motion]\nvelocity = [0.1, 0.0, 0.0]",
        ),
    )
    .unwrap();
    let e = Scene::load(scene_path.to_str().unwrap()).expect_err("a 6 km moving mesh");
    let message = e.to_string();
    println!("{message}");
    assert_eq!(e.key, "collider[0].scale", "{message}");
    assert!(
        message.contains("GiB") && message.contains("cube.obj"),
        "{message}"
    );
}
