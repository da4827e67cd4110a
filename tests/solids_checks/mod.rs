//! What the solids' checks share: their scenes, and the floating blocks' measurement, on the CPU in
//! CI at a coarse cell (tests/solids.rs), finer on the GPU (tests/gpu_solids.rs).
#![allow(dead_code)]

use glam::Vec3;
use mpm::sim::{Scene, Simulation};

use super::common;
use super::materials_checks::{no_slip_floor, particles, G};

/// A `[[material]]` row: a fixed-corotated jelly of Young's modulus `e` (Pa) and Poisson's ratio `nu`.
pub fn jelly(name: &str, rho: f32, e: f32, nu: f32) -> String {
    format!(
        "[[material]]\nname = \"{name}\"\nlaw = \"fixed-corotated\"\nrest_density = {rho}\n\
         youngs_modulus = {e}\npoisson_ratio = {nu}\n"
    )
}

/// Two 6 cm jelly cubes (E = 100 kPa, nu = 0.3, rho = 1000 kg/m^3), the first flying at +1 m/s into
/// the second at -0.5 m/s, without gravity and clear of the walls, in the GPU's `scatter` mode.
pub fn colliding_cubes(scatter: &str) -> Scene {
    common::scene(&format!(
        "[domain]\nsize = [0.45, 0.2, 0.2]\nresolution = [45, 20, 20]\n{}\
         [solver]\ngravity = [0.0, 0.0, 0.0]\nscatter = \"{scatter}\"\n\
         [[block]]\nmin = [0.08, 0.07, 0.07]\nmax = [0.14, 0.13, 0.13]\nvelocity = [1.0, 0.0, 0.0]\n\
         [[block]]\nmin = [0.22, 0.08, 0.06]\nmax = [0.28, 0.14, 0.12]\nvelocity = [-0.5, 0.0, 0.0]\n",
        jelly("jelly", 1000.0, 1.0e5, 0.3)
    ))
}

/// Water 10 cm deep in a quasi-2D tank 20 cm long (a slab 5 cells of `dx` thick, 8 nodes in z)
/// with a jelly block (E = 40 kPa, nu = 0.3) of density `rho`: light (500 kg/m^3), 10 cm wide and 5
/// cm high (wide enough to float upright: a square of half the water's density is stable only
/// tipped onto an edge) against the low x wall, set in the water with 1 cm under; or heavy (1500
/// kg/m^3), 6 cm square, 3 cm above the floor. Rows: water 0, the block 1. `extra` goes after the
/// materials (a `[solver]` table, say).
pub fn block_in_water(dx: f32, rho: f32, extra: &str) -> Scene {
    let tank = 0.2f32;
    let floor = dx; // the floor wall's mirror plane, node 1
    let (width, height, bottom) = if rho < 1000.0 {
        (0.1, FLOAT_HEIGHT, floor + FLOAT_DEPTH - 0.01)
    } else {
        (0.06, 0.06, floor + 0.03)
    };
    let cells = |metres: f32| (metres / dx).round() as u32;
    let slab = 6.0 * dx; // the fluid region's end in z, 5 cells from the low wall's plane
    common::scene(&format!(
        "[domain]\nsize = [{tank}, 0.2, {}]\nresolution = [{}, {}, 8]\n\
         [[material]]\nname = \"water\"\nrest_density = 1000.0\nsound_speed = 10.0\nviscosity = 1.0e-3\n{}\
         [time_step]\ncfl = 0.4\n{extra}\
         [[block]]\nmaterial = \"jelly\"\nmin = [{floor}, {bottom}, {dx}]\nmax = [{}, {}, {slab}]\n\
         [[block]]\nmaterial = \"water\"\nmin = [{floor}, {floor}, {dx}]\nmax = [{}, {}, {slab}]\n",
        8.0 * dx,
        cells(tank),
        cells(0.2),
        jelly("jelly", rho, 4.0e4, 0.3),
        floor + width,
        bottom + height,
        tank - 0.02,
        floor + FLOAT_DEPTH,
    ))
}

/// The water's depth and the light block's height in [`block_in_water`], m.
pub const FLOAT_DEPTH: f32 = 0.1;
pub const FLOAT_HEIGHT: f32 = 0.05;

/// What [`settle_block`] measured.
pub struct Settled {
    /// The block's height under the surface over its height, averaged over the last half second,
    /// every frame (it bobs with a period of a few tenths of a second).
    pub fraction: f32,
    /// The block's bottom above the floor at the end, in cells.
    pub bottom_cells: f32,
}

/// Runs [`block_in_water`] for 2 s, gravity ramped in over the first half second (released at once,
/// the tank rings in its acoustic mode for seconds), printing every sixth of a second.
pub fn settle_block(sim: &mut Simulation, dx: f32) -> Settled {
    let floor = dx;
    let quarter = 0.25 * dx; // half the spacing of 2 particles a cell: a body's edge beyond its particles
    let (mut fractions, mut bottom_cells) = (Vec::new(), 0.0);
    for frame in 1..=120u32 {
        let ramp = (frame as f32 / 30.0).min(1.0);
        sim.set_gravity(Vec3::new(0.0, -G * ramp, 0.0)).unwrap();
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        if frame <= 90 && frame % 10 != 0 {
            continue;
        }
        let p = particles(sim);
        let (water, block): (Vec<usize>, Vec<usize>) = (0..p.len()).partition(|&n| p.material[n] == 0);
        // The surface beyond the light block, from 13 to 17 cm: each column of cells' highest water
        // particle, averaged.
        let columns = (0.13 / dx).round() as usize..(0.17 / dx).round() as usize;
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
        let bottom = block.iter().map(|&n| p.x[n].y).fold(f32::INFINITY, f32::min) - quarter;
        let top = block.iter().map(|&n| p.x[n].y).fold(f32::NEG_INFINITY, f32::max) + quarter;
        let fraction = (surface - bottom) / (top - bottom);
        bottom_cells = (bottom - floor) / dx;
        if frame > 90 {
            fractions.push(fraction);
        }
        if frame % 10 == 0 {
            println!(
                "  t = {:.2} s: surface {surface:.4} m; block {bottom:.4} to {top:.4} m, {:.1} % under, its \
                 bottom {bottom_cells:.2} cells above the floor",
                frame as f32 / 60.0,
                100.0 * fraction,
            );
        }
    }
    Settled {
        fraction: fractions.iter().sum::<f32>() / fractions.len() as f32,
        bottom_cells,
    }
}

/// A `[[material]]` row of dry sand: 1600 kg/m^3, E = 350 kPa, nu = 0.3 (Klar et al. 2016's), a
/// friction angle of 30 degrees.
pub const SAND: &str = "[[material]]\nname = \"sand\"\nlaw = \"sand\"\nrest_density = 1600.0\n\
                        youngs_modulus = 3.5e5\npoisson_ratio = 0.3\nfriction_angle = 30.0\n";

/// A quasi-2D column of [`SAND`] `length` m long and `height` m high against the low x wall of a
/// tank 80 cm long on a rough floor (a stick collider just under the floor's plane, as the channels
/// of Lube et al. (2005) had: [`no_slip_floor`]), a slab 5 cells of `dx` thick.
pub fn sand_column(dx: f32, length: f32, height: f32) -> Scene {
    let (tank, floor) = (0.8f32, dx);
    let cells = |metres: f32| (metres / dx).round() as u32;
    common::scene(&format!(
        "[domain]\nsize = [{tank}, {}, {}]\nresolution = [{}, {}, 8]\n{SAND}\
         [time_step]\ncfl = 0.4\n{}\
         [[block]]\nmin = [{floor}, {floor}, {dx}]\nmax = [{}, {}, {}]\n",
        (height + 0.05).max(0.1),
        8.0 * dx,
        cells(tank),
        cells((height + 0.05).max(0.1)),
        no_slip_floor(tank, 8.0 * dx, dx),
        floor + length,
        floor + height,
        6.0 * dx,
    ))
}

/// The runout of a [`sand_column`] of `length` m once it has stopped (after `seconds`): the front
/// (the 99.9th percentile of the particles' x, from the low wall's plane) less the column's length,
/// over its length, (L_inf - L_0) / L_0. Prints the front as it goes.
pub fn sand_runout(sim: &mut Simulation, dx: f32, length: f32, seconds: f32) -> f32 {
    let wall = dx;
    let mut front = 0.0;
    for frame in 1..=(seconds * 60.0).round() as u32 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        if frame % 15 == 0 {
            let p = particles(sim);
            let mut xs: Vec<f32> = p.x.iter().map(|x| x.x - wall).collect();
            xs.sort_by(f32::total_cmp);
            front = xs[((xs.len() - 1) as f32 * 0.999).round() as usize];
            let speed = p.v.iter().map(|v| v.length()).fold(0.0f32, f32::max);
            println!(
                "  t = {:.2} s: front {front:.4} m, fastest grain {speed:.3} m/s",
                frame as f32 / 60.0
            );
        }
    }
    (front - length) / length
}

/// Lube et al. (2005)'s runout of a quasi-2D granular column of aspect ratio `a` = height / length:
/// (L_inf - L_0) / L_0 = 1.2 a below a = 1.8, 1.9 a^(2/3) above.
pub fn lube_runout(a: f32) -> f32 {
    if a < 1.8 {
        1.2 * a
    } else {
        1.9 * a.powf(2.0 / 3.0)
    }
}

/// A ball 10 cm across of `law` ("snow", or "fixed-corotated" for a jelly of the same stiffness),
/// 400 kg/m^3, E = 140 kPa, nu = 0.2 (Stomakhin et al. 2013's snow), thrown at 8 m/s at the high x
/// wall of a 40 x 30 x 30 cm tank, its centre 15 cm from it.
pub fn ball_at_wall(dx: f32, law: &str) -> Scene {
    let cells = |metres: f32| (metres / dx).round() as u32;
    common::scene(&format!(
        "[domain]\nsize = [0.4, 0.3, 0.3]\nresolution = [{}, {}, {}]\n\
         [[material]]\nname = \"ball\"\nlaw = \"{law}\"\nrest_density = 400.0\n\
         youngs_modulus = 1.4e5\npoisson_ratio = 0.2\n\
         [time_step]\ncfl = 0.3\n\
         [[sphere]]\ncenter = [0.22, 0.15, 0.15]\nradius = 0.05\nvelocity = [8.0, 0.0, 0.0]\n",
        cells(0.4),
        cells(0.3),
        cells(0.3),
    ))
}

/// The pieces `p`'s live particles make: groups joined by chains of particles less than `reach`
/// apart. Returns their sizes, largest first.
pub fn pieces(p: &mpm::sim::Particles, reach: f32) -> Vec<usize> {
    use std::collections::HashMap;
    let live: Vec<usize> = (0..p.len()).filter(|&n| p.live[n]).collect();
    let key = |x: glam::Vec3| (x / reach).floor().as_ivec3();
    let mut cells: HashMap<glam::IVec3, Vec<usize>> = HashMap::new();
    for (k, &n) in live.iter().enumerate() {
        cells.entry(key(p.x[n])).or_default().push(k);
    }
    let mut seen = vec![false; live.len()];
    let mut sizes = Vec::new();
    for start in 0..live.len() {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        let (mut stack, mut size) = (vec![start], 0);
        while let Some(k) = stack.pop() {
            size += 1;
            let x = p.x[live[k]];
            let c = key(x);
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        for &j in cells
                            .get(&(c + glam::IVec3::new(dx, dy, dz)))
                            .into_iter()
                            .flatten()
                        {
                            if !seen[j] && p.x[live[j]].distance(x) < reach {
                                seen[j] = true;
                                stack.push(j);
                            }
                        }
                    }
                }
            }
        }
        sizes.push(size);
    }
    sizes.sort_unstable_by(|a, b| b.cmp(a));
    sizes
}
