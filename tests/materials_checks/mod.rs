//! What the liquids' checks share: a run on any backend, and the power-law films of
//! tests/materials.rs at any resolution, on the CPU in CI at 10 cells across (tests/materials.rs),
//! finer on the GPU (tests/gpu_materials.rs), where the viscous limit's substeps at a fine cell cost
//! seconds.
#![allow(dead_code)]

use glam::Vec3;
use mpm::backend::{self, BackendKind};
use mpm::sim::{Particles, Scene, Simulation};

use super::common;

/// Standard gravity, m/s^2.
pub const G: f32 = 9.81;

/// `scene` on `backend`.
pub fn simulation(scene: &Scene, backend: BackendKind) -> Simulation {
    let solver = backend::create(backend, scene).expect("a backend");
    Simulation::new(scene.clone(), solver)
}

pub fn particles(sim: &mut Simulation) -> Particles {
    sim.solver_mut().read_particles().unwrap()
}

/// A `stick` collider under the floor of a tank `length` x `depth` m: its top half a cell below
/// the floor wall's mirror plane (node 1, y = dx), so that its band (the nodes within a cell of its
/// surface) holds nodes 0 and 1 still and leaves node 2 free. The floor is then no-slip at y = dx,
/// and the wall's mirror still gives the fluid there its interior density; a collider's own
/// surface has no mirror (docs/physics.md, "Colliders"), and fluid on it packs into the half cell
/// above it, which takes the lowest layer out of the flow.
pub fn no_slip_floor(length: f32, depth: f32, dx: f32) -> String {
    format!(
        "[[collider]]\nshape = \"box\"\ncenter = [{}, {}, {}]\nsize = [{}, 0.2, {}]\nboundary = \"stick\"\n",
        0.5 * length,
        0.5 * dx - 0.1,
        0.5 * depth,
        length + 0.2,
        depth + 0.2
    )
}

/// A power-law liquid and the film's slope: mu = K gammadot^(n - 1) within [floor, ceiling].
#[derive(Clone, Copy)]
pub struct FilmLaw {
    pub n: f32,
    pub consistency: f32,
    pub degrees: f32,
    pub ceiling: f32,
    pub floor_viscosity: f32,
}

/// Shear-thinning, n = 0.5: about 100 Pa s at the wall's shear rate; the viscosity grows without
/// bound towards the free surface, where the shear vanishes, and its ceiling, 400 Pa s, holds in the
/// top quarter of the film, which then moves 0.8 % of U faster than the pure law there.
pub const THINNING: FilmLaw = FilmLaw {
    n: 0.5,
    consistency: 221.0,
    degrees: 90.0,
    ceiling: 400.0,
    floor_viscosity: 0.0,
};

/// Shear-thickening, n = 1.5: about 100 Pa s at the wall's shear rate; its floor, 1 Pa s, holds
/// only where the shear rate is below 2e-4 1/s.
pub const THICKENING: FilmLaw = FilmLaw {
    n: 1.5,
    consistency: 45.2,
    degrees: 90.0,
    ceiling: 150.0,
    floor_viscosity: 1.0,
};

/// A film of a power-law liquid (mu = K gammadot^(n - 1)), 5 cm and `cells` cells thick, on a no-slip
/// floor (a `stick` collider, clear of the tank's walls) with gravity tilted down the slope by
/// `degrees`, from rest, for 0.1 s. Returns the worst deviation of the measured profile (mean
/// velocity along the slope in half-cell layers over the middle 4 cm, its amplitude fitted) from
/// u(y) = U (1 - (1 - y/h)^((n+1)/n)), as a fraction of U, and U over the fully developed film's
/// surface speed (n / (n + 1)) (rho g sin / K)^(1/n) h^((n+1)/n).
///
/// The film, 16 cm long, has free ends, 2.5 and 2 cm from the walls: a film that spans the tank
/// is held still by the walls within the first frames (the weakly compressible liquid takes up the
/// blockage by its density, at the speed of sound, long before its surface can slope). At 90
/// degrees (a film falling down a wall) nothing presses the film on the floor, so it does not pack
/// into the collider's surface as fluid resting on one does (docs/physics.md, "Colliders"), and its
/// ends do not slump. In the middle its profile develops over a few rho h^2 / mu (0.025 s at the
/// wall's viscosity of about 100 Pa s).
pub fn film(backend: BackendKind, cells: u32, law: FilmLaw) -> (f32, f32) {
    let FilmLaw {
        n,
        consistency,
        degrees,
        ceiling,
        floor_viscosity,
    } = law;
    let (rho, h) = (1000.0f32, 0.05f32);
    let dx = h / cells as f32;
    // A stick collider's band: the nodes at y = 0.02 and below held still.
    let floor = 0.02;
    // The tank 0.22 x 0.09 m, the slab 5 cells thick in z (8 nodes, the fewest allowed).
    let k = cells / 10;
    assert!(
        cells == 10 * k && k > 0,
        "the film is 10, 20, ... cells thick, not {cells}"
    );
    let (sin, cos) = degrees.to_radians().sin_cos();
    let scene = common::scene(&format!(
        "[domain]\nsize = [0.22, 0.09, {}]\nresolution = [{}, {}, 8]\n\
         [material]\nlaw = \"power-law\"\nrest_density = {rho}\nsound_speed = 10.0\n\
         consistency = {consistency}\nflow_index = {n}\nmax_viscosity = {ceiling}\nmin_viscosity = {floor_viscosity}\n\
         [solver]\ngravity = [{}, {}, 0.0]\n\
         [time_step]\ncfl = 0.4\nmax_substeps = 1000000\n\
         [[collider]]\nshape = \"box\"\ncenter = [0.11, {}, {}]\nsize = [0.42, 0.2, 0.24]\nboundary = \"stick\"\n\
         [[block]]\nmin = [0.03, {floor}, {dx}]\nmax = [0.19, {}, {}]\nparticles_per_cell = 8",
        8.0 * dx,
        44 * k,
        18 * k,
        G * sin,
        -G * cos,
        floor - 0.5 * dx - 0.1,
        4.0 * dx,
        floor + h,
        6.0 * dx
    ));
    let mut sim = simulation(&scene, backend);
    let surface_speed = n / (n + 1.0) * (rho * G * sin / consistency).powf(1.0 / n) * h.powf((n + 1.0) / n);
    let exponent = (n + 1.0) / n;
    let shape = |eta: f32| 1.0 - (1.0 - eta.min(1.0)).powf(exponent);
    let mut result = (f32::INFINITY, 0.0);
    for frame in 1..=6 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        if frame < 4 {
            continue;
        }
        let p = particles(&mut sim);
        // The middle 4 cm, 6 cm from either end of the film.
        let middle = |x: Vec3| x.x > 0.09 && x.x < 0.13;
        let top =
            p.x.iter()
                .filter(|x| middle(**x))
                .map(|x| x.y)
                .fold(0.0, f32::max)
                + 0.25 * dx;
        let depth = top - floor;
        // Mean velocity along the slope in half-cell layers (one lattice row of particles each).
        let layers = (depth / (0.5 * dx)).round() as usize;
        let mut sums = vec![(0.0f32, 0usize); layers];
        for (x, v) in p.x.iter().zip(&p.v) {
            if middle(*x) {
                let layer = (((x.y - floor) / (0.5 * dx)) as usize).min(layers - 1);
                sums[layer].0 += v.x;
                sums[layer].1 += 1;
            }
        }
        let rows: Vec<(f32, f32)> = sums
            .iter()
            .enumerate()
            .filter(|(_, s)| s.1 > 0)
            .map(|(i, s)| (((i as f32 + 0.5) * 0.5 * dx) / depth, s.0 / s.1 as f32))
            .collect();
        // Least squares for U in u = U f(eta).
        let (fu, ff) = rows.iter().fold((0.0, 0.0), |(a, b), &(eta, u)| {
            (a + shape(eta) * u, b + shape(eta) * shape(eta))
        });
        let amplitude = fu / ff;
        let worst = rows
            .iter()
            .map(|&(eta, u)| (u - amplitude * shape(eta)).abs() / amplitude)
            .fold(0.0, f32::max);
        println!(
            "  n = {n}: t = {:.3} s, depth {depth:.4} m, U = {amplitude:.4} m/s ({:.3} of the developed film's {surface_speed:.4}), worst layer {:.1} % of U",
            frame as f32 / 60.0,
            amplitude / surface_speed,
            100.0 * worst
        );
        if frame == 6 {
            for &(eta, u) in &rows {
                println!(
                    "    y/h {eta:.3}: u/U {:.4}, law {:.4}",
                    u / amplitude,
                    shape(eta)
                );
            }
            result = (worst, amplitude / surface_speed);
        }
    }
    result
}
