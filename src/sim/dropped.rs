//! Rigid bodies dropped into a running scene ([`super::Simulation::drop_body`]; the viewer's B and O
//! keys): a box or a ball of a given size and density, let go at rest.
//!
//! They are held apart from the scene file. Its text (what a checkpoint carries and a restart loads)
//! never names them, so they carve no fluid out of the spawn, a restarted scene has none of them, and
//! a checkpoint's scene still spawns the particle count its file says. A run appends each to its
//! colliders after the scene's own (so the scene's bodies keep their slots and contact features, and
//! the emitters' pipes, which ride after the colliders, move up one), and a checkpoint lists them, so
//! that a resumed run makes the same colliders again ([`add_to`]). Each is validated as a scene
//! file's `[[collider]]` with a density is ([`colliders::validate`]), through the same code.

use super::colliders::{self, Collider, ColliderFrame, ColliderSpec, MAX_COLLIDERS};
use super::material::densest_liquid;
use super::{Particles, Scene};
use crate::contract::BOUNDARY_PIPE;
use anyhow::{bail, Result};
use glam::DVec3;

/// What is dropped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DropShape {
    /// Axis-aligned, its full edge lengths, m.
    Box { size: DVec3 },
    /// m.
    Ball { radius: f64 },
}

impl DropShape {
    pub fn name(&self) -> &'static str {
        match self {
            DropShape::Box { .. } => "box",
            DropShape::Ball { .. } => "ball",
        }
    }

    /// Half the edges of the axis-aligned box that holds it, m.
    pub fn half_extents(&self) -> DVec3 {
        match *self {
            DropShape::Box { size } => 0.5 * size,
            DropShape::Ball { radius } => DVec3::splat(radius),
        }
    }

    /// The viewer's size for `scene`: about a tenth of the tank's smallest side across, and at least
    /// four cells, so that the grid resolves it; no wider than the walls leave room for on any axis
    /// (in a slab thinner than that, as a soft wall's or a wide boundary band's can be, a box spans
    /// it, a tenth of a cell short of each wall, as the logs of tests/bodies.rs do, and a ball is as
    /// wide as it allows).
    pub fn sized_for(ball: bool, scene: &Scene) -> DropShape {
        let dx = f64::from(scene.dx);
        let domain = DVec3::from(scene.grid_res.map(f64::from)) * dx;
        let across = (0.1 * domain.min_element()).max(4.0 * dx);
        let walls = scene.body_walls();
        let room = DVec3::from(walls.hi) - DVec3::from(walls.lo) - DVec3::splat(0.2 * dx);
        if ball {
            DropShape::Ball {
                radius: 0.5 * across.min(room.min_element()),
            }
        } else {
            DropShape::Box {
                size: DVec3::splat(across).min(room),
            }
        }
    }

    /// The viewer's density for `scene`, kg/m^3: a box half as dense as the densest liquid (it
    /// floats, half of it under), a ball twice as dense (it sinks); against water where the scene
    /// has no liquid.
    pub fn default_density(ball: bool, scene: &Scene) -> f64 {
        let liquid = match densest_liquid(&scene.materials) {
            rho if rho > 0.0 => rho,
            _ => 1000.0,
        };
        if ball {
            2.0 * liquid
        } else {
            0.5 * liquid
        }
    }
}

/// A body dropped into a running scene: at rest, upright, with the default contact friction and a
/// slip boundary, as a scene file's collider given only these keys would be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DroppedBody {
    pub shape: DropShape,
    /// kg/m^3.
    pub density: f64,
    /// Where its centre is let go, m.
    pub center: DVec3,
}

impl DroppedBody {
    /// The `[[collider]]` table a scene file would give it.
    fn spec(&self) -> ColliderSpec {
        let mut spec = ColliderSpec {
            center: Some(self.center.to_array()),
            density: Some(self.density),
            ..ColliderSpec::default()
        };
        match self.shape {
            DropShape::Box { size } => {
                spec.shape = "box".into();
                spec.size = Some(size.to_array());
            }
            DropShape::Ball { radius } => {
                spec.shape = "sphere".into();
                spec.radius = Some(radius);
            }
        }
        spec
    }

    /// The rigid body this makes in `scene` after the colliders it holds now (the scene's own and
    /// any dropped before). Refused, with what to do: a run that holds as many colliders as the
    /// solvers take ([`MAX_COLLIDERS`]); a size, density or position a scene file's collider could
    /// not have; a body reaching past the walls that hold the bodies (the fluid region's faces); and
    /// one too light for the explicit coupling, as the scene file's bodies are refused.
    pub fn collider(&self, scene: &Scene) -> Result<Collider> {
        let name = self.shape.name();
        let held = scene.colliders.len();
        if held >= MAX_COLLIDERS {
            bail!(
                "cannot drop a {name}: the run holds {held} colliders, the most the solvers take \
                 ({MAX_COLLIDERS}), so no slot is left for another body; restart the scene (the \
                 viewer's R) to clear the bodies dropped into it"
            );
        }
        let dx = f64::from(scene.dx);
        let domain = DVec3::from(scene.grid_res.map(f64::from)) * dx;
        let no_mesh = |file: &str, _scale: f64| -> Result<_, String> {
            Err(format!("{file}: a dropped body is a box or a ball"))
        };
        let collider = colliders::validate(&self.spec(), &no_mesh, domain, dx)
            .map_err(|e| anyhow::anyhow!("cannot drop a {name}: its {} {}; {}", e.key, e.problem, e.fix))?;
        let walls = scene.body_walls();
        let (lo, hi) = (DVec3::from(walls.lo), DVec3::from(walls.hi));
        let half = self.shape.half_extents();
        let (reach_lo, reach_hi) = (self.center - half, self.center + half);
        if reach_lo.cmplt(lo).any() || reach_hi.cmpgt(hi).any() {
            bail!(
                "cannot drop a {name} reaching [{:.3}, {:.3}, {:.3}] to [{:.3}, {:.3}, {:.3}] m: the walls hold \
                 the bodies within [{:.3}, {:.3}, {:.3}] to [{:.3}, {:.3}, {:.3}] m; let it go further inside, \
                 or make it smaller",
                reach_lo.x,
                reach_lo.y,
                reach_lo.z,
                reach_hi.x,
                reach_hi.y,
                reach_hi.z,
                lo.x,
                lo.y,
                lo.z,
                hi.x,
                hi.y,
                hi.z
            );
        }
        let dynamics = collider
            .body
            .as_ref()
            .expect("a collider with a density is a rigid body");
        if let Err((problem, fix)) =
            dynamics.check_band_mass(&collider.shape, densest_liquid(&scene.materials), dx)
        {
            bail!(
                "cannot drop a {name} of {} kg/m^3: its density {problem}; {fix}",
                self.density
            );
        }
        Ok(collider)
    }
}

/// Adds the bodies `dropped` to `scene`'s colliders, in their order, each checked as when it was
/// dropped ([`DroppedBody::collider`]): a checkpoint's scene made again as its run had it.
pub fn add_to(scene: &mut Scene, dropped: &[DroppedBody]) -> Result<()> {
    for body in dropped {
        let collider = body.collider(scene)?;
        scene.colliders.add(collider);
    }
    Ok(())
}

/// Where the viewer lets a body of `shape` go over the point (x, z) of the floor: clamped inside the
/// walls, its bottom two cells above the highest live particle of `particles` under it (the liquid's
/// surface is about half a cell above its particles), or on the floor where there is none; then
/// raised, a cell at a time, until its bounding ball is a cell clear of every collider in `frame`
/// (a body floating there, an obstacle), but never through the ceiling.
pub fn drop_center(
    scene: &Scene,
    particles: &Particles,
    frame: &ColliderFrame,
    shape: &DropShape,
    over: (f64, f64),
) -> DVec3 {
    let dx = f64::from(scene.dx);
    let walls = scene.body_walls();
    let half = shape.half_extents();
    // A tenth of a cell inside the walls, where the bodies' contacts cannot already touch them.
    let lo = DVec3::from(walls.lo) + half + 0.1 * dx;
    let hi = DVec3::from(walls.hi) - half - 0.1 * dx;
    let inside = |v: f64, a: usize| {
        if lo[a] <= hi[a] {
            v.clamp(lo[a], hi[a])
        } else {
            0.5 * (lo[a] + hi[a])
        }
    };
    let (x, z) = (inside(over.0, 0), inside(over.1, 2));
    let liquid_top = (0..particles.len())
        .filter(|&n| particles.live[n])
        .map(|n| particles.x[n].as_dvec3())
        .filter(|p| (p.x - x).abs() <= half.x + dx && (p.z - z).abs() <= half.z + dx)
        .map(|p| p.y)
        .reduce(f64::max);
    let mut y = match liquid_top {
        Some(top) => top + 2.0 * dx + half.y,
        None => lo.y,
    };
    let reach = match *shape {
        DropShape::Ball { radius } => radius,
        DropShape::Box { .. } => half.length(),
    };
    let clear = |y: f64| {
        let centre = DVec3::new(x, y, z).as_vec3();
        frame
            .states
            .iter()
            .all(|s| s.boundary == BOUNDARY_PIPE || f64::from(frame.distance(s, centre).0) > reach + dx)
    };
    while y < hi.y && !clear(y) {
        y += dx;
    }
    DVec3::new(x, inside(y, 1), z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The viewer's bodies: a tenth of the smallest side across where that is four cells or more
    /// (a tank 50 cm deep at 1 cm cells: 5 cm), else four cells (a quasi-2D slab 5 cells thick);
    /// each let go where [`drop_center`] puts it over the middle (inside the walls, its bottom two
    /// cells above the water under it) is accepted, and a box dropped where the ball already is
    /// starts above the ball.
    #[test]
    fn the_viewers_bodies_fit_their_tank_and_are_accepted_where_they_are_let_go() {
        let tank = |size: [f64; 3], res: [u32; 3], water: [f64; 3]| {
            let text = format!(
                "[domain]\nsize = {size:?}\nresolution = {res:?}\n[material]\nrest_density = 1000.0\nsound_speed = 10.0\n\
                 [[block]]\nmin = [0.01, 0.01, 0.01]\nmax = {water:?}\n"
            );
            Scene::from_toml(&text, "test tank").unwrap_or_else(|e| panic!("{e}"))
        };
        let cases = [
            (
                tank([0.8, 0.5, 0.5], [80, 50, 50], [0.78, 0.1, 0.48]),
                [0.05; 3],
                0.025,
            ),
            (
                tank([0.4, 0.3, 0.08], [40, 30, 8], [0.38, 0.1, 0.06]),
                [0.04; 3],
                0.02,
            ),
        ];
        for (mut scene, box_size, radius) in cases {
            let particles = scene.spawn();
            let walls = scene.body_walls();
            let (lo, hi) = (DVec3::from(walls.lo), DVec3::from(walls.hi));
            let middle = 0.5 * (lo + hi);
            let water_top = f64::from(particles.x.iter().map(|x| x.y).fold(f32::MIN, f32::max));
            for ball in [true, false] {
                let shape = DropShape::sized_for(ball, &scene);
                // To the f32 cell size's rounding.
                match shape {
                    DropShape::Box { size } => {
                        assert!(
                            (size - DVec3::from(box_size)).abs().max_element() < 1e-6,
                            "{size}"
                        )
                    }
                    DropShape::Ball { radius: r } => assert!((r - radius).abs() < 1e-6, "{r}"),
                }
                let frame = scene.colliders.frame(0.0);
                let center = drop_center(&scene, &particles, &frame, &shape, (middle.x, middle.z));
                let half = shape.half_extents();
                assert!(
                    center.y - half.y > water_top + 1.9 * f64::from(scene.dx),
                    "a {} let go at {center} under the water's top {water_top}",
                    shape.name()
                );
                let body = DroppedBody {
                    shape,
                    density: DropShape::default_density(ball, &scene),
                    center,
                };
                let collider = body.collider(&scene).unwrap_or_else(|e| panic!("{e:#}"));
                // The box, after the ball, starts above it.
                if !ball {
                    let ball_top = scene.colliders.list[0].center.y + radius;
                    assert!(
                        center.y - half.y > ball_top,
                        "the box starts in the ball: {center}"
                    );
                }
                scene.colliders.add(collider);
            }
        }
    }
}
