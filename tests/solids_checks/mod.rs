//! What the solids' checks share: their scenes, and the floating blocks' measurement, on the CPU in
//! CI at a coarse cell (tests/solids.rs), finer on the GPU (tests/gpu_solids.rs).
#![allow(dead_code)]

use glam::Vec3;
use mpm::sim::{Particles, Scene, Simulation};

use super::common;
use super::materials_checks::{particles, G};

/// A `[[material]]` row: a fixed-corotated jelly of Young's modulus `e` (Pa) and Poisson's ratio `nu`.
pub fn jelly(name: &str, rho: f32, e: f32, nu: f32) -> String {
    format!(
        "[[material]]\nname = \"{name}\"\nlaw = \"fixed-corotated\"\nrest_density = {rho}\n\
         youngs_modulus = {e}\npoisson_ratio = {nu}\n"
    )
}

/// Two 6 cm jelly cubes (E = 100 kPa, nu = 0.3, rho = 1000 kg/m^3), the first flying at +1 m/s into
/// the second at -0.5 m/s, without gravity and clear of the walls.
pub fn colliding_cubes(extra: &str) -> Scene {
    common::scene(&format!(
        "[domain]\nsize = [0.45, 0.2, 0.2]\nresolution = [45, 20, 20]\n{}{extra}\
         [solver]\ngravity = [0.0, 0.0, 0.0]\n\
         [[block]]\nmin = [0.08, 0.07, 0.07]\nmax = [0.14, 0.13, 0.13]\nvelocity = [1.0, 0.0, 0.0]\n\
         [[block]]\nmin = [0.22, 0.08, 0.06]\nmax = [0.28, 0.14, 0.12]\nvelocity = [-0.5, 0.0, 0.0]\n",
        jelly("jelly", 1000.0, 1.0e5, 0.3)
    ))
}

/// Water 15 cm deep in a quasi-2D tank 50 x 30 cm (a slab 5 cells of `dx` thick, 8 nodes in z), with
/// two jelly blocks (E = 40 kPa, nu = 0.3): a light one (500 kg/m^3), 12 cm wide and 6 cm high
/// (wide enough to float upright: a square of half the water's density is stable only tipped onto
/// an edge), set in the water with 1 cm under; and a heavy one (1500 kg/m^3), 8 cm square, 4 cm
/// above the floor. Rows: water 0, light 1, heavy 2. `extra` goes after the materials (a
/// `[solver]` table, say).
pub fn floating_blocks(dx: f32, extra: &str) -> Scene {
    let floor = dx; // the floor wall's mirror plane, node 1
    let (light_bottom, heavy_bottom) = (floor + FLOAT_DEPTH - 0.01, floor + 0.04);
    let cells = |metres: f32| (metres / dx).round() as u32;
    common::scene(&format!(
        "[domain]\nsize = [0.5, 0.3, {}]\nresolution = [{}, {}, 8]\n\
         [[material]]\nname = \"water\"\nrest_density = 1000.0\nsound_speed = 10.0\nviscosity = 1.0e-3\n{}{}\
         [time_step]\ncfl = 0.4\n{extra}\
         [[block]]\nmaterial = \"light\"\nmin = [0.06, {light_bottom}, {dx}]\nmax = [0.18, {}, {}]\n\
         [[block]]\nmaterial = \"heavy\"\nmin = [0.32, {heavy_bottom}, {dx}]\nmax = [0.40, {}, {}]\n\
         [[block]]\nmaterial = \"water\"\nmin = [{dx}, {floor}, {dx}]\nmax = [0.48, {}, {}]\n",
        8.0 * dx,
        cells(0.5),
        cells(0.3),
        jelly("light", 500.0, 4.0e4, 0.3),
        jelly("heavy", 1500.0, 4.0e4, 0.3),
        light_bottom + FLOAT_HEIGHT,
        6.0 * dx,
        heavy_bottom + 0.08,
        6.0 * dx,
        floor + FLOAT_DEPTH,
        6.0 * dx,
    ))
}

/// The water's depth and the light block's height in [`floating_blocks`], m.
pub const FLOAT_DEPTH: f32 = 0.15;
pub const FLOAT_HEIGHT: f32 = 0.06;

/// What [`float_blocks`] measured.
pub struct Floating {
    /// The light block's height under the surface over its height, averaged over the last second.
    pub fraction: f32,
    /// The heavy block's bottom above the floor, in cells, at the end.
    pub heavy_bottom_cells: f32,
    /// The heavy block's mean speed at the end, m/s.
    pub heavy_speed: f32,
}

/// Runs [`floating_blocks`] for 3 s, gravity ramped in over the first half second (released at
/// once, the tank rings in its acoustic mode for seconds), printing every sixth of a second.
pub fn float_blocks(sim: &mut Simulation, dx: f32) -> Floating {
    let floor = dx;
    let rows =
        |p: &Particles, row: u8| -> Vec<usize> { (0..p.len()).filter(|&n| p.material[n] == row).collect() };
    let quarter = 0.25 * dx; // half the spacing of 2 particles a cell: a body's edge beyond its particles
    let (mut fractions, mut frame) = (Vec::new(), 0u32);
    let mut last = Floating {
        fraction: 0.0,
        heavy_bottom_cells: 0.0,
        heavy_speed: 0.0,
    };
    while frame < 180 {
        frame += 1;
        let ramp = (frame as f32 / 30.0).min(1.0);
        sim.set_gravity(Vec3::new(0.0, -G * ramp, 0.0)).unwrap();
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        if frame % 10 != 0 {
            continue;
        }
        let p = particles(sim);
        let (water, light, heavy) = (rows(&p, 0), rows(&p, 1), rows(&p, 2));
        // The surface away from both blocks, from 20 to 30 cm: each column of cells' highest water
        // particle, averaged.
        let columns = (0.2 / dx).round() as usize..(0.3 / dx).round() as usize;
        let tops: Vec<f32> = columns
            .map(|c| {
                let x0 = c as f32 * dx;
                water
                    .iter()
                    .filter(|&&n| p.x[n].x >= x0 && p.x[n].x < x0 + dx)
                    .map(|&n| p.x[n].y)
                    .fold(f32::NEG_INFINITY, f32::max)
                    + quarter
            })
            .collect();
        let surface = tops.iter().sum::<f32>() / tops.len() as f32;
        let extent = |set: &[usize]| {
            let lo = set.iter().map(|&n| p.x[n].y).fold(f32::INFINITY, f32::min) - quarter;
            let hi = set.iter().map(|&n| p.x[n].y).fold(f32::NEG_INFINITY, f32::max) + quarter;
            (lo, hi)
        };
        let (bottom, top) = extent(&light);
        let fraction = (surface - bottom) / (top - bottom);
        let heavy_bottom = extent(&heavy).0;
        last.heavy_bottom_cells = (heavy_bottom - floor) / dx;
        last.heavy_speed = heavy.iter().map(|&n| p.v[n].length()).sum::<f32>() / heavy.len() as f32;
        println!(
            "  t = {:.2} s: surface {surface:.4} m; light block {bottom:.4} to {top:.4} m, {:.1} % under; \
             heavy block's bottom {:.2} cells above the floor, at {:.1e} m/s",
            frame as f32 / 60.0,
            100.0 * fraction,
            last.heavy_bottom_cells,
            last.heavy_speed
        );
        if frame > 120 {
            fractions.push(fraction);
        }
    }
    last.fraction = fractions.iter().sum::<f32>() / fractions.len() as f32;
    last
}
