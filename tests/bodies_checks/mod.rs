//! What the rigid bodies' checks share: their scenes and measurements, on the CPU in CI at a coarse
//! cell (tests/bodies.rs), finer on the GPU (tests/gpu_bodies.rs).
#![allow(dead_code)]

use glam::{DQuat, DVec3, Vec3};
use mpm::backend::BackendKind;
use mpm::sim::colliders::bodies::RigidBody;
use mpm::sim::dropped::{DropShape, DroppedBody};
use mpm::sim::{Particles, Scene, Simulation};

use super::common;
use super::materials_checks::{particles, simulation, G};

/// The tank of the floating checks: 40 cm long, 30 cm high, water 15 cm deep, a quasi-2D slab 5 cells
/// of `dx` thick (8 nodes in z: the fluid region runs from node 1 to node 6).
pub const TANK: f32 = 0.4;
pub const WATER_DEPTH: f32 = 0.15;

/// A square log `side` m across, as long as the slab is thick (less a tenth of a cell at each end),
/// of density `rho`, its axis along z, turned `angle` degrees about it, its centre `sink` m under the
/// still water's surface, in the tank's middle. Its contacts are frictionless: where a tilt about x
/// or y brings an end against the slab's walls, they straighten it without holding it. `extra` goes
/// after the material.
pub fn log_in_water(dx: f32, side: f32, rho: f32, angle: f32, sink: f32, extra: &str) -> Scene {
    let floor = dx;
    let (z_lo, z_hi) = (dx, 6.0 * dx);
    tank_text(
        dx,
        extra,
        &format!(
            "[[collider]]\nshape = \"box\"\ncenter = [{}, {}, {}]\nsize = [{side}, {side}, {}]\n\
             rotation = [0.0, 0.0, {angle}]\ndensity = {rho}\ncontact_friction = 0.0\n",
            0.5 * TANK,
            floor + WATER_DEPTH - sink,
            0.5 * (z_lo + z_hi),
            z_hi - z_lo - 0.2 * dx,
        ),
    )
}

/// [`log_in_water`]'s tank of still water, `extra` after the material, without the log: what bodies
/// are dropped into (tests/bodies.rs).
pub fn tank_of_water(dx: f32, extra: &str) -> Scene {
    tank_text(dx, extra, "")
}

/// The floating checks' tank, its water [`WATER_DEPTH`] deep, `extra` after the material and
/// `colliders` after the water.
fn tank_text(dx: f32, extra: &str, colliders: &str) -> Scene {
    let cells = |metres: f32| (metres / dx).round() as u32;
    let floor = dx;
    let (z_lo, z_hi) = (dx, 6.0 * dx);
    common::scene(&format!(
        "[domain]\nsize = [{TANK}, 0.3, {}]\nresolution = [{}, {}, 8]\n\
         [[material]]\nname = \"water\"\nrest_density = 1000.0\nsound_speed = 10.0\nviscosity = 1.0e-3\n\
         [time_step]\ncfl = 0.4\n{extra}\
         [[block]]\nmin = [{floor}, {floor}, {z_lo}]\nmax = [{}, {}, {z_hi}]\n{colliders}",
        8.0 * dx,
        cells(TANK),
        cells(0.3),
        TANK - 2.5 * dx,
        floor + WATER_DEPTH,
    ))
}

/// A square log as the floating checks' (`side` m across, as long as the slab is thick less a tenth
/// of a cell at each end), of density `rho`, to drop into [`tank_of_water`] at `center` (its
/// contacts have the default friction: a dropped body's).
pub fn dropped_log(dx: f32, side: f32, rho: f64, center: DVec3) -> DroppedBody {
    DroppedBody {
        shape: DropShape::Box {
            size: DVec3::new(f64::from(side), f64::from(side), f64::from(5.0 * dx - 0.2 * dx)),
        },
        density: rho,
        center,
    }
}

/// Three cubes of `side` m (density 1500 kg/m^3: they sink), quasi-2D like [`log_in_water`]'s
/// logs, dropped one above the other (each 1 cm off the one below, and turned a little) into water
/// 4 cm deep in the same tank: they fall through it and come to rest stacked on the floor.
/// `floor` is the tank's floor (the fluid region's bottom).
pub fn box_pile(dx: f32, side: f32, extra: &str) -> Scene {
    let cells = |metres: f32| (metres / dx).round() as u32;
    let floor = dx;
    let (z_lo, z_hi) = (dx, 6.0 * dx);
    let cubes: String = (0..3)
        .map(|k| {
            let k = k as f32;
            format!(
                "[[collider]]\nshape = \"box\"\ncenter = [{}, {}, {}]\nsize = [{side}, {side}, {}]\n\
                 rotation = [0.0, 0.0, {}]\ndensity = 1500.0\n",
                0.5 * TANK + 0.01 * (k - 1.0),
                floor + 0.06 + (side + 0.03) * k,
                0.5 * (z_lo + z_hi),
                z_hi - z_lo - 0.2 * dx,
                4.0 * (k - 1.0),
            )
        })
        .collect();
    common::scene(&format!(
        "[domain]\nsize = [{TANK}, 0.3, {}]\nresolution = [{}, {}, 8]\n\
         [[material]]\nname = \"water\"\nrest_density = 1000.0\nsound_speed = 10.0\nviscosity = 1.0e-3\n\
         [time_step]\ncfl = 0.4\n{extra}\
         [[block]]\nmin = [{floor}, {floor}, {z_lo}]\nmax = [{}, {}, {z_hi}]\n{cubes}",
        8.0 * dx,
        cells(TANK),
        cells(0.3),
        TANK - 2.5 * dx,
        floor + 0.04,
    ))
}

/// The deepest a corner of one of `bodies` (cubes of `side` m) lies inside another, m.
pub fn deepest_cube_overlap(bodies: &[RigidBody], side: f64) -> f64 {
    let h = 0.5 * side;
    let mut deepest: f64 = 0.0;
    for (a, body) in bodies.iter().enumerate() {
        let rotation = DQuat::from_array(body.orientation);
        for corner in 0..8 {
            let s = |bit: u32| if corner & (1 << bit) == 0 { -h } else { h };
            let p = DVec3::from_array(body.center) + rotation * DVec3::new(s(0), s(1), s(2));
            for (b, other) in bodies.iter().enumerate() {
                if a != b {
                    // Inside the other cube: the least of its faces' depths.
                    let local = DQuat::from_array(other.orientation).inverse()
                        * (p - DVec3::from_array(other.center));
                    let depth = (DVec3::splat(h) - local.abs()).min_element();
                    deepest = deepest.max(depth);
                }
            }
        }
    }
    deepest
}

/// The part of a square of side `side` centred at height `center_y`, turned `angle` radians, that
/// lies below the height `surface`, as a fraction of its area: the polygon clipped by the plane.
pub fn submerged_fraction(side: f64, center_y: f64, angle: f64, surface: f64) -> f64 {
    let h = 0.5 * side;
    let corners: Vec<(f64, f64)> = [(-h, -h), (h, -h), (h, h), (-h, h)]
        .iter()
        .map(|&(x, y)| {
            let (s, c) = angle.sin_cos();
            (c * x - s * y, center_y + s * x + c * y)
        })
        .collect();
    // Sutherland-Hodgman against y <= surface, then the shoelace formula.
    let mut clipped = Vec::new();
    for k in 0..4 {
        let (a, b) = (corners[k], corners[(k + 1) % 4]);
        let (a_in, b_in) = (a.1 <= surface, b.1 <= surface);
        if a_in {
            clipped.push(a);
        }
        if a_in != b_in {
            let t = (surface - a.1) / (b.1 - a.1);
            clipped.push((a.0 + t * (b.0 - a.0), surface));
        }
    }
    let n = clipped.len();
    let area: f64 = (0..n)
        .map(|k| {
            let (p, q) = (clipped[k], clipped[(k + 1) % n]);
            p.0 * q.1 - q.0 * p.1
        })
        .sum::<f64>()
        .abs()
        * 0.5;
    area / (side * side)
}

/// The log's tilt about z, degrees, folded into [0, 90) (a square looks the same every quarter turn)
/// and reported as the distance from flat, [0, 45].
pub fn tilt_degrees(body: &RigidBody) -> f64 {
    let (axis, angle) = DQuat::from_array(body.orientation).to_axis_angle();
    let about_z = (axis.z.signum() * angle).to_degrees().rem_euclid(90.0);
    about_z.min(90.0 - about_z)
}

/// What [`settle_log`] measured, averaged over the last half second.
pub struct Floating {
    /// The submerged part of the log's section, as a draft: the fraction times the side, m.
    pub draft: f64,
    /// From flat, degrees ([`tilt_degrees`]).
    pub tilt: f64,
    /// The largest tilt and draft over that half second less the smallest: how still it came to rest.
    pub tilt_swing: f64,
    pub draft_swing: f64,
}

/// The still water's surface in the floating checks' tank, m, and the draft of `body` (a square log
/// `side` m across in it), m: the submerged share of its section times the side. The surface is
/// taken away from the log (it drifts): each column of cells at least 2 cm from the walls and 10 cm
/// from the log's axis (its half diagonal, 7 cm, and 3 more), by its highest particle, averaged.
pub fn surface_and_draft(sim: &mut Simulation, body: &RigidBody, dx: f32, side: f32) -> (f64, f64) {
    let quarter = 0.25 * dx; // half the spacing of 2 particles a cell: the surface beyond its particles
    let center = DVec3::from_array(body.center);
    let p = particles(sim);
    let columns = (0..(TANK / dx) as usize).filter(|&c| {
        let x = (c as f32 + 0.5) * dx;
        x > 0.02 && x < TANK - 0.02 && (f64::from(x) - center.x).abs() > 0.1
    });
    let tops: Vec<f32> = columns
        .map(|c| {
            let x0 = c as f32 * dx;
            p.x.iter()
                .filter(|x| x.x >= x0 && x.x < x0 + dx)
                .map(|x| x.y)
                .fold(f32::NEG_INFINITY, f32::max)
                + quarter
        })
        .collect();
    let surface = f64::from(tops.iter().sum::<f32>() / tops.len() as f32);
    let (axis, angle) = DQuat::from_array(body.orientation).to_axis_angle();
    let fraction = submerged_fraction(f64::from(side), center.y, axis.z.signum() * angle, surface);
    (surface, fraction * f64::from(side))
}

/// A box 6 cm across of 500 kg/m^3 and a ball 4 cm across of 2000 kg/m^3, dropped at its tenth
/// frame into `scene` (a [`tank_of_water`] at 1 cm cells, or a [`log_in_water`]: either side of its
/// log, above the water) on `backend`, gravity ramped in as [`calm`] does: the run's bodies (the
/// scene's, then the box and the ball) and particles 20 frames later.
pub fn drop_box_and_ball(scene: &Scene, backend: BackendKind) -> (Vec<RigidBody>, Particles) {
    let dx = scene.dx;
    let mut sim = simulation(scene, backend);
    calm(&mut sim, 10);
    let z = 3.5 * f64::from(dx);
    sim.drop_body(dropped_log(dx, 0.06, 500.0, DVec3::new(0.08, 0.22, z)))
        .unwrap_or_else(|e| panic!("{e:#}"));
    sim.drop_body(DroppedBody {
        shape: DropShape::Ball { radius: 0.02 },
        density: 2000.0,
        center: DVec3::new(0.32, 0.2, z),
    })
    .unwrap_or_else(|e| panic!("{e:#}"));
    for frame in 11..=30 {
        let ramp = (frame as f32 / 30.0).min(1.0);
        sim.set_gravity(Vec3::new(0.0, -G * ramp, 0.0)).unwrap();
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
    }
    (sim.bodies().to_vec(), particles(&mut sim))
}

/// Brings the water of a [`tank_of_water`] to rest under gravity: ramped in over the first half
/// second (released at once, the tank rings in its acoustic mode for seconds), then `frames` - 30
/// more frames of it.
pub fn calm(sim: &mut Simulation, frames: u32) {
    for frame in 1..=frames {
        let ramp = (frame as f32 / 30.0).min(1.0);
        sim.set_gravity(Vec3::new(0.0, -G * ramp, 0.0)).unwrap();
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
    }
}

/// Runs a [`log_in_water`] for `seconds`, gravity ramped in over the first half second (released at
/// once, the tank rings in its acoustic mode for seconds), printing every sixth of a second.
pub fn settle_log(sim: &mut Simulation, dx: f32, side: f32, seconds: f32) -> Floating {
    let frames = (seconds * 60.0).round() as u32;
    let (mut drafts, mut tilts) = (Vec::new(), Vec::new());
    for frame in 1..=frames {
        let ramp = (frame as f32 / 30.0).min(1.0);
        sim.set_gravity(Vec3::new(0.0, -G * ramp, 0.0)).unwrap();
        sim.advance_frame().unwrap_or_else(|e| panic!("{e:#}"));
        let last_half = frame + 30 > frames;
        if !last_half && frame % 10 != 0 {
            continue;
        }
        let body = sim.bodies()[0];
        let center = DVec3::from_array(body.center);
        let (surface, draft) = surface_and_draft(sim, &body, dx, side);
        let tilt = tilt_degrees(&body);
        if last_half {
            drafts.push(draft);
            tilts.push(tilt);
        }
        if frame % 10 == 0 {
            println!(
                "  t = {:.2} s: surface {surface:.4} m; log at ({:.4}, {:.4}) m, tilted {tilt:.1} degrees, \
                 draft {:.1} mm, moving {:.3} m/s",
                frame as f32 / 60.0,
                center.x,
                center.y,
                1e3 * draft,
                DVec3::from_array(body.velocity).length(),
            );
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let swing =
        |v: &[f64]| v.iter().copied().fold(f64::MIN, f64::max) - v.iter().copied().fold(f64::MAX, f64::min);
    Floating {
        draft: mean(&drafts),
        tilt: mean(&tilts),
        tilt_swing: swing(&tilts),
        draft_swing: swing(&drafts),
    }
}

/// Without gravity, a square log 6 cm across of density 500 kg/m^3 moving at 0.3 m/s along x into a
/// still block of water 16 cm square, in a quasi-2D tank 60 x 45 cm (5 cells of `dx` thick): the
/// water stays clear of every wall but the slab's for the second the check runs.
pub fn log_into_still_water(dx: f32, scatter: &str) -> Scene {
    let cells = |metres: f32| (metres / dx).round() as u32;
    let (z_lo, z_hi) = (dx, 6.0 * dx);
    common::scene(&format!(
        "[domain]\nsize = [0.6, 0.45, {}]\nresolution = [{}, {}, 8]\n\
         [[material]]\nname = \"water\"\nrest_density = 1000.0\nsound_speed = 10.0\nviscosity = 1.0e-3\n\
         [solver]\ngravity = [0.0, 0.0, 0.0]\nscatter = \"{scatter}\"\n[time_step]\ncfl = 0.4\n\
         [[block]]\nmin = [0.2, 0.145, {z_lo}]\nmax = [0.36, 0.305, {z_hi}]\n\
         [[collider]]\nshape = \"box\"\ncenter = [0.12, 0.225, {}]\nsize = [0.06, 0.06, {}]\n\
         density = 500.0\ncontact_friction = 0.0\nmotion.velocity = [0.3, 0.0, 0.0]\n",
        8.0 * dx,
        cells(0.6),
        cells(0.45),
        0.5 * (z_lo + z_hi),
        z_hi - z_lo - 0.2 * dx,
    ))
}

/// The total momentum of the liquid's particles and the rigid bodies, kg m/s.
pub fn total_momentum(sim: &mut Simulation) -> DVec3 {
    let table = *sim.params();
    let p = particles(sim);
    let liquid: DVec3 = (0..p.len())
        .filter(|&n| p.live[n])
        .map(|n| p.v[n].as_dvec3() * f64::from(table.materials[p.material[n] as usize].particle_mass))
        .sum();
    let bodies: DVec3 = sim
        .bodies()
        .iter()
        .map(|b| DVec3::from_array(b.velocity) / b.inv_mass)
        .sum();
    liquid + bodies
}

/// A test tube as OBJ text: a closed, outward-wound surface of `segments` sides, its hollow of
/// radius `inner` open at the top, walls and bottom `wall` thick, `height` tall, its axis along y
/// from y = 0.
pub fn tube_obj(inner: f64, wall: f64, height: f64, segments: usize) -> String {
    let mut vertices: Vec<DVec3> = Vec::new();
    let mut faces: Vec<[usize; 3]> = Vec::new();
    let ring = |radius: f64, y: f64, vertices: &mut Vec<DVec3>| -> Vec<usize> {
        (0..segments)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / segments as f64;
                vertices.push(DVec3::new(radius * a.cos(), y, radius * a.sin()));
                vertices.len() - 1
            })
            .collect()
    };
    let outer = inner + wall;
    let outer_base = ring(outer, 0.0, &mut vertices);
    let outer_top = ring(outer, height, &mut vertices);
    let inner_top = ring(inner, height, &mut vertices);
    let inner_bottom = ring(inner, wall, &mut vertices);
    vertices.push(DVec3::ZERO);
    let base_centre = vertices.len() - 1;
    vertices.push(DVec3::new(0.0, wall, 0.0));
    let hollow_centre = vertices.len() - 1;
    // Each triangle wound so that its normal points `outward`, away from the solid.
    let mut triangle = |a: usize, b: usize, c: usize, outward: DVec3| {
        let n = (vertices[b] - vertices[a]).cross(vertices[c] - vertices[a]);
        faces.push(if n.dot(outward) >= 0.0 {
            [a, b, c]
        } else {
            [a, c, b]
        });
    };
    for k in 0..segments {
        let m = (k + 1) % segments;
        let a = std::f64::consts::TAU * (k as f64 + 0.5) / segments as f64;
        let radial = DVec3::new(a.cos(), 0.0, a.sin());
        for (lower, upper, outward) in [
            (&outer_base, &outer_top, radial),
            (&inner_top, &outer_top, DVec3::Y),
            (&inner_bottom, &inner_top, -radial),
        ] {
            triangle(lower[k], lower[m], upper[m], outward);
            triangle(lower[k], upper[m], upper[k], outward);
        }
        triangle(hollow_centre, inner_bottom[k], inner_bottom[m], DVec3::Y);
        triangle(base_centre, outer_base[k], outer_base[m], -DVec3::Y);
    }
    let mut text = String::new();
    for v in &vertices {
        text += &format!("v {} {} {}\n", v.x, v.y, v.z);
    }
    for [a, b, c] in faces {
        text += &format!("f {} {} {}\n", a + 1, b + 1, c + 1);
    }
    text
}

/// Stokes' settling check: a sphere of radius `radius` (`cells` cells across its radius), density
/// 2000 kg/m^3, `stick`, let go from rest on the axis of a `stick` test tube of 5 radii (the wall
/// correction's lambda = d / D = 0.2) full of a liquid of 1000 kg/m^3 and viscosity `viscosity`
/// (sound speed 40 m/s: the column's own compression under gravity, and the sound it rings with, stay
/// far below the sphere's speed), 2 tube radii above its bottom and below the surface (where a
/// tube's walls have screened the ends' effect). The tube's mesh goes into `dir`, beside the scene
/// file; `extra` is scene text added at the end (a `[solver]` table). Returns the scene and the time
/// over which the flow fills the tube (its radius squared over the kinematic viscosity).
pub fn sphere_in_tube(
    cells: u32,
    radius: f64,
    viscosity: f64,
    cfl: f64,
    extra: &str,
    dir: &std::path::Path,
) -> (Scene, f64) {
    let dx = radius / f64::from(cells);
    let tube = 5.0 * radius;
    let wall = 3.0 * dx;
    let floor = 2.0 * dx;
    let water = wall + 4.0 * tube;
    let height = water + 2.0 * dx;
    let half = tube + wall + 2.0 * dx;
    let res_xz = (2.0 * half / dx).ceil() as u32;
    let res_y = ((floor + height + 3.0 * dx) / dx).ceil() as u32;
    let centre = 0.5 * f64::from(res_xz) * dx;
    std::fs::write(dir.join("tube.obj"), tube_obj(tube, wall, height, 96)).unwrap();
    let text = format!(
        "[domain]\nsize = [{x}, {y}, {x}]\nresolution = [{res_xz}, {res_y}, {res_xz}]\n\
         [material]\nrest_density = 1000.0\nsound_speed = 40.0\nviscosity = {viscosity}\n\
         [time_step]\ncfl = {cfl}\nmax_substeps = 10000\n\
         [[block]]\nmin = [{lo}, {bottom}, {lo}]\nmax = [{hi}, {top}, {hi}]\nparticles_per_cell = 8\n\
         [[collider]]\nshape = \"mesh\"\nfile = \"tube.obj\"\ncenter = [{centre}, {floor}, {centre}]\nboundary = \"stick\"\n\
         [[collider]]\nshape = \"sphere\"\nradius = {radius}\ncenter = [{centre}, {sphere}, {centre}]\n\
         boundary = \"stick\"\ndensity = 2000.0\n{extra}",
        x = f64::from(res_xz) * dx,
        y = f64::from(res_y) * dx,
        lo = centre - tube,
        hi = centre + tube,
        bottom = floor + wall,
        top = floor + water,
        sphere = floor + wall + 2.0 * tube,
    );
    let path = dir.join("stokes.toml");
    std::fs::write(&path, text).unwrap();
    let scene = Scene::load(path.to_str().unwrap()).unwrap_or_else(|e| panic!("{e}"));
    (scene, tube * tube * 1000.0 / viscosity)
}

/// Haberman and Sayre's (1958) wall correction for a sphere falling on the axis of a long cylinder,
/// lambda = its diameter over the cylinder's: the drag is Stokes' times this, so the sphere falls at
/// Stokes' velocity over it.
pub fn haberman_sayre(lambda: f64) -> f64 {
    (1.0 - 0.75857 * lambda.powi(5))
        / (1.0 - 2.1050 * lambda + 2.0865 * lambda.powi(3) - 1.7068 * lambda.powi(5)
            + 0.72603 * lambda.powi(6))
}
