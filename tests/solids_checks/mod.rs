//! What the solids' checks share: their scenes, and the floating blocks' measurement, on the CPU in
//! CI at a coarse cell (tests/solids.rs), finer on the GPU (tests/gpu_solids.rs).
#![allow(dead_code)]

use glam::Vec3;
use mpm::sim::{Scene, Simulation};

use super::common;
use super::materials_checks::{coulomb_floor, no_slip_floor, particles, G};

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
    /// The block's height under the surface over its height, averaged over the last 1.5 s, every
    /// frame: it bobs by about a tenth of its height with a period of a few tenths of a second, and
    /// a shorter average (the last half second: 48.6 to 52.5 % at 2.5 mm over three runs of the
    /// float scatter) caught the bobbing's phase.
    pub fraction: f32,
    /// The block's bottom above the floor at the end, in cells.
    pub bottom_cells: f32,
}

/// Runs [`block_in_water`] for 3 s, gravity ramped in over the first half second (released at once,
/// the tank rings in its acoustic mode for seconds), printing every sixth of a second.
pub fn settle_block(sim: &mut Simulation, dx: f32) -> Settled {
    let floor = dx;
    let quarter = 0.25 * dx; // half the spacing of 2 particles a cell: a body's edge beyond its particles
    let (mut fractions, mut bottom_cells) = (Vec::new(), 0.0);
    for frame in 1..=180u32 {
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

/// A quasi-2D jelly block (10 x 4 cm, E = 100 kPa, 1000 kg/m^3) launched at 1.5 m/s along a Coulomb
/// floor (`friction = mu`, [`coulomb_floor`]) in a tank 80 cm long, 1 cm cells, where the walls'
/// mirror also acts unless `mirror` is false.
pub fn sliding_block_toml(mu: f32, mirror: bool) -> String {
    let (tank, dx, depth) = (0.8f32, 0.01f32, 0.08f32);
    format!(
        "[domain]\nsize = [{tank}, 0.15, {depth}]\nresolution = [80, 15, 8]\n{}\
         [time_step]\ncfl = 0.4\n[solver]\nmirror_wall_mass = {mirror}\n{}\
         [[block]]\nmin = [0.05, {dx}, {dx}]\nmax = [0.15, 0.05, {}]\nvelocity = [1.5, 0.0, 0.0]\n",
        jelly("jelly", 1000.0, 1.0e5, 0.3),
        coulomb_floor(tank, depth, dx, mu),
        depth - 2.0 * dx,
    )
}

/// The deceleration of a [`sliding_block_toml`] run while it slides: the slope of its particles'
/// mean x velocity, frame by frame, fitted from 1.3 down to 0.3 m/s. Prints it against mu g.
pub fn sliding_deceleration(sim: &mut Simulation, mu: f32, what: &str) -> f32 {
    let mut samples = Vec::new();
    for frame in 1..=36u32 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        let v = particles(sim).v;
        let vx = v.iter().map(|v| f64::from(v.x)).sum::<f64>() / v.len() as f64;
        if vx < 1.3 && vx > 0.3 {
            samples.push((f64::from(frame) / 60.0, vx));
        }
    }
    assert!(samples.len() >= 10, "{what}: too few sliding frames: {samples:?}");
    let deceleration = -common::fitted_slope(&samples) as f32;
    let expected = mu * G;
    println!(
        "{what}: the block slows at {deceleration:.3} m/s^2, mu g = {expected:.3} ({:+.1} %)",
        100.0 * (deceleration / expected - 1.0)
    );
    deceleration
}

/// The Coulomb friction of [`SAND`] on itself, tan 30 degrees: its columns' floor.
pub const SAND_FRICTION: f32 = 0.577;

/// A `[[material]]` row of dry sand: 1600 kg/m^3, E = 350 kPa, nu = 0.3 (Klar et al. 2016's), a
/// friction angle of 30 degrees.
pub const SAND: &str = "[[material]]\nname = \"sand\"\nlaw = \"sand\"\nrest_density = 1600.0\n\
                        youngs_modulus = 3.5e5\npoisson_ratio = 0.3\nfriction_angle = 30.0\n";

/// A quasi-2D column of [`SAND`] `length` m long and `height` m high against the low x wall of a
/// tank 80 cm long on a floor with the sand's own friction (a Coulomb collider of `tan 30` = 0.577
/// just under the floor's plane: [`coulomb_floor`]), a slab 5 cells of `dx` thick; without the
/// walls' mirror, which is there for a liquid's density at a wall (dry sand has none) and shortens
/// the columns' runouts (docs/physics.md, "Solids").
pub fn sand_column(dx: f32, length: f32, height: f32) -> Scene {
    common::scene(&sand_column_toml(dx, length, height))
}

/// [`sand_column`]'s scene file.
pub fn sand_column_toml(dx: f32, length: f32, height: f32) -> String {
    let (tank, floor) = (0.8f32, dx);
    let cells = |metres: f32| (metres / dx).round() as u32;
    format!(
        "[domain]\nsize = [{tank}, {}, {}]\nresolution = [{}, {}, 8]\n{SAND}\
         [time_step]\ncfl = 0.4\n[solver]\nmirror_wall_mass = false\n{}\
         [[block]]\nmin = [{floor}, {floor}, {dx}]\nmax = [{}, {}, {}]\n",
        (height + 0.05).max(0.1),
        8.0 * dx,
        cells(tank),
        cells((height + 0.05).max(0.1)),
        coulomb_floor(tank, 8.0 * dx, dx, SAND_FRICTION),
        floor + length,
        floor + height,
        6.0 * dx,
    )
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

/// A quasi-2D bank of [`SAND`] 10 cm long and 10 cm high against the low x wall of a tank 50 cm
/// long, held by a gate (a slip box 2 cm thick standing on the floor, half a cell clear of the bank)
/// that lifts at 5 cm/s from the start, on a rough floor ([`no_slip_floor`]); a slab 5 cells of `dx`
/// thick. The sand runs out under the gate and leaves a slope standing against the wall: the
/// lifting-gate (draining) measure of the angle of repose.
pub fn sand_behind_gate(dx: f32) -> Scene {
    let (tank, floor, bank) = (0.5f32, dx, 0.1f32);
    let depth = 8.0 * dx;
    let cells = |metres: f32| (metres / dx).round() as u32;
    common::scene(&format!(
        "[domain]\nsize = [{tank}, 0.25, {depth}]\nresolution = [{}, {}, 8]\n{SAND}\
         [time_step]\ncfl = 0.4\n{}\
         [[collider]]\nshape = \"box\"\ncenter = [{}, {}, {}]\nsize = [0.02, 0.2, {}]\nboundary = \"slip\"\n\
         [collider.motion]\nvelocity = [0.0, 0.05, 0.0]\n\
         [[block]]\nmin = [{floor}, {floor}, {dx}]\nmax = [{}, {}, {}]\n",
        cells(tank),
        cells(0.25),
        no_slip_floor(tank, depth, dx),
        floor + bank + 0.01 + 0.5 * dx,
        floor + 0.1,
        0.5 * depth,
        depth + 0.2,
        floor + bank,
        floor + bank,
        6.0 * dx,
    ))
}

/// The slope, in degrees, that a [`sand_behind_gate`] run leaves standing after `seconds` (the gate
/// is clear of the sand after 2 s, and it stops within another 1.5): the surface (each column of
/// cells' highest particle) from the wall out to where it first falls below a tenth of its highest,
/// fitted by least squares between a fifth and four fifths of that height (the flat top the wall
/// keeps and the toe left out). Prints the angle every half second.
pub fn repose_angle(sim: &mut Simulation, dx: f32, seconds: f32) -> f32 {
    let (wall, floor) = (dx, dx);
    let mut angle = f32::NAN;
    for frame in 1..=(seconds * 60.0).round() as u32 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        if frame % 30 != 0 {
            continue;
        }
        let p = particles(sim);
        let mut top = vec![0.0f32; (0.5 / dx).round() as usize];
        for x in &p.x {
            let column = (((x.x - wall) / dx).max(0.0) as usize).min(top.len() - 1);
            top[column] = top[column].max(x.y - floor);
        }
        let peak = top.iter().copied().fold(0.0, f32::max);
        let points: Vec<(f64, f64)> = (0..top.len())
            .take_while(|&c| top[c] > 0.1 * peak)
            .filter(|&c| top[c] > 0.2 * peak && top[c] < 0.8 * peak)
            .map(|c| ((c as f64 + 0.5) * f64::from(dx), f64::from(top[c])))
            .collect();
        let slope = common::fitted_slope(&points);
        angle = (-slope).atan().to_degrees() as f32;
        let speed = p.v.iter().map(|v| v.length()).fold(0.0f32, f32::max);
        println!(
            "  t = {:.1} s: the bank {peak:.4} m high, its slope {angle:.1} degrees over {} columns, fastest grain \
             {speed:.3} m/s",
            frame as f32 / 60.0,
            points.len()
        );
    }
    angle
}

/// A ball 10 cm across of `law` ("snow", or "fixed-corotated" for a jelly of the same stiffness),
/// 400 kg/m^3, E = 140 kPa, nu = 0.2, thrown at 8 m/s at the high x wall of a 40 x 30 x 30 cm tank,
/// its centre 15 cm from it. The snow is Stomakhin et al. (2013)'s reference with a lower critical
/// stretch (theta_s = 5e-3 for 7.5e-3; theta_c = 2.5e-2, xi = 10): with 7.5e-3 it stays whole at
/// every cell tried.
pub fn ball_at_wall(dx: f32, law: &str) -> Scene {
    common::scene(&ball_at_wall_toml(dx, law))
}

/// [`ball_at_wall`]'s scene file.
pub fn ball_at_wall_toml(dx: f32, law: &str) -> String {
    let cells = |metres: f32| (metres / dx).round() as u32;
    let stretch = if law == "snow" {
        "critical_stretch = 5.0e-3\n"
    } else {
        ""
    };
    format!(
        "[domain]\nsize = [0.4, 0.3, 0.3]\nresolution = [{}, {}, {}]\n\
         [[material]]\nname = \"{law}\"\nlaw = \"{law}\"\nrest_density = 400.0\n\
         youngs_modulus = 1.4e5\npoisson_ratio = 0.2\n{stretch}\
         [time_step]\ncfl = 0.3\n\
         [[sphere]]\ncenter = [0.22, 0.15, 0.15]\nradius = 0.05\nvelocity = [8.0, 0.0, 0.0]\n",
        cells(0.4),
        cells(0.3),
        cells(0.3),
    )
}

/// What a [`ball_at_wall`] did.
pub struct Thrown {
    /// The pieces of at least a thousandth of the ball's particles ([`pieces`], a cell's reach),
    /// largest first: the grains flung off alone are spray, not pieces.
    pub pieces: Vec<usize>,
    /// The particles' mean x velocity at the end, m/s: negative once the ball comes off the wall.
    pub mean_vx: f32,
}

/// Runs a [`ball_at_wall`] of `scene` (cells of `dx`) for `seconds` and measures what it left,
/// asserting on the way that no particle is lost and that snow stays inside its clamp: every
/// particle's elastic singular values within [1 - theta_c, 1 + theta_s], J_p positive.
pub fn throw_at_wall(sim: &mut Simulation, scene: &Scene, dx: f32, seconds: f32) -> Thrown {
    let law = scene.materials[0].law;
    let start = particles(sim).num_live();
    for _ in 0..(seconds * 60.0).round() as u32 {
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
    }
    let p = particles(sim);
    assert_eq!(p.num_live(), start, "particles lost");
    if law.law == mpm::contract::LAW_SNOW {
        let (lo, hi) = (1.0 - law.critical_compression, 1.0 + law.critical_stretch);
        for d in &p.deformation {
            let (_, sigma, _) = mpm::sim::svd::svd3(d.f);
            assert!(
                sigma.min_element() >= lo - 1e-4 && sigma.max_element() <= hi + 1e-4 && d.plastic > 0.0,
                "snow outside its clamp: singular values {sigma}, J_p {}",
                d.plastic
            );
        }
    }
    let all = pieces(&p, dx);
    let thrown = Thrown {
        pieces: all.iter().copied().filter(|&n| n * 1000 >= start).collect(),
        mean_vx: p.v.iter().map(|v| v.x).sum::<f32>() / p.len() as f32,
    };
    println!(
        "  dx = {dx} m, after {seconds} s: {} pieces of a thousandth of the ball or more ({:?}), {} groups in all; \
         mean x velocity {:+.3} m/s",
        thrown.pieces.len(),
        &thrown.pieces[..thrown.pieces.len().min(6)],
        all.len(),
        thrown.mean_vx
    );
    thrown
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
