//! Emitters and sinks in the viewer and `mpm render`: outlined in the scene pass, in one colour of
//! their own. An emitter is its nozzle's rim (a disc's circle, a rectangle's four edges) with a
//! short stroke along its normal, the way the water leaves, and where it has a pipe, the pipe's far
//! rim and four lines along it; a sink is its box's twelve edges.

use crate::sim::flow::{self, Flow, Nozzle};
use glam::Vec3;

/// Segments of a disc nozzle's circle.
const CIRCLE_SEGMENTS: usize = 32;
/// Magenta: apart from the grey box and colliders, the blue water and the colour scale.
pub const OUTLINE_COLOUR: [f32; 3] = [0.95, 0.35, 0.85];

/// The outlines of `flow`'s emitters and sinks as line segments (pairs of endpoints), each sink cut
/// to the box `domain` (lo, hi): what is drawn is the part of the drain that water can reach.
pub fn outline(flow: &Flow, (lo, hi): (Vec3, Vec3)) -> Vec<[Vec3; 2]> {
    let mut lines = Vec::new();
    for emitter in &flow.emitters {
        // The same frame across the normal that lays out the nozzle's points.
        let (t1, t2) = flow::frame(emitter.normal);
        let center = emitter.center.as_vec3();
        let (rim, width): (Vec<Vec3>, f32) = match emitter.nozzle {
            Nozzle::Disc { radius } => {
                let r = radius as f32;
                let rim = (0..CIRCLE_SEGMENTS)
                    .map(|k| {
                        let a = std::f32::consts::TAU * k as f32 / CIRCLE_SEGMENTS as f32;
                        center + (t1 * a.cos() + t2 * a.sin()) * r
                    })
                    .collect();
                (rim, 2.0 * r)
            }
            Nozzle::Rectangle { size } => {
                let (u, v) = (0.5 * size[0] as f32, 0.5 * size[1] as f32);
                let rim = [(-u, -v), (u, -v), (u, v), (-u, v)]
                    .map(|(s, t)| center + t1 * s + t2 * t)
                    .to_vec();
                (rim, size[0].max(size[1]) as f32)
            }
        };
        for (k, &a) in rim.iter().enumerate() {
            lines.push([a, rim[(k + 1) % rim.len()]]);
        }
        let pipe = emitter.normal * emitter.pipe_length as f32;
        if emitter.pipe_length > 0.0 {
            for (k, &a) in rim.iter().enumerate() {
                lines.push([a + pipe, rim[(k + 1) % rim.len()] + pipe]);
                if k % (rim.len() / 4) == 0 {
                    lines.push([a, a + pipe]);
                }
            }
        }
        lines.push([center + pipe, center + pipe + emitter.normal * width]);
    }
    for sink in &flow.sinks {
        let (min, max) = (sink.min.max(lo), sink.max.min(hi));
        if min.cmpge(max).any() {
            continue; // wholly outside the tank: nothing to show
        }
        let corner = |i: usize| Vec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), max, min);
        // The 12 edges join corners that differ in one bit.
        for a in 0..8usize {
            for bit in [1, 2, 4] {
                if a & bit == 0 {
                    lines.push([corner(a), corner(a | bit)]);
                }
            }
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::flow::{Emitter, Sink};
    use glam::DVec3;

    fn emitter(nozzle: Nozzle, normal: Vec3) -> Emitter {
        let center = DVec3::new(0.3, 0.4, 0.2);
        Emitter {
            nozzle,
            center,
            normal,
            speed: 1.0,
            rate: 1e-4,
            points: flow::nozzle_points(nozzle, center, normal, 0.005),
            material: 0,
            pipe_length: 0.0,
        }
    }

    const TANK: (Vec3, Vec3) = (Vec3::ZERO, Vec3::ONE);

    /// The rim lies in the nozzle's plane, on the circle or the rectangle's edges, it encloses every
    /// point the nozzle emits from, and the stroke leaves the centre along the normal.
    #[test]
    fn an_emitters_outline_lies_on_its_nozzle() {
        let normal = Vec3::new(1.0, 0.6, 0.0).normalize();
        let (t1, t2) = flow::frame(normal);
        for nozzle in [
            Nozzle::Disc { radius: 0.025 },
            Nozzle::Rectangle { size: [0.06, 0.02] },
        ] {
            let e = emitter(nozzle, normal);
            let flow = Flow {
                emitters: vec![e.clone()],
                sinks: vec![],
                capacity: 1,
            };
            let lines = outline(&flow, TANK);
            let (stroke, rim) = lines.split_last().unwrap();
            let center = e.center.as_vec3();
            assert!((stroke[0] - center).length() < 1e-6);
            let along = (stroke[1] - center).normalize();
            assert!(
                along.dot(normal) > 0.9999,
                "{nozzle:?}: the stroke points {along}"
            );
            // (u, v) of a point in the nozzle's frame, and its height off the nozzle's plane.
            let local = |p: Vec3| {
                (
                    (p - center).dot(t1),
                    (p - center).dot(t2),
                    (p - center).dot(normal),
                )
            };
            for [a, b] in rim {
                for p in [*a, *b, 0.5 * (*a + *b)] {
                    let (u, v, off) = local(p);
                    assert!(
                        off.abs() < 1e-6,
                        "{nozzle:?}: {p} is {off} m off the nozzle's plane"
                    );
                    match nozzle {
                        Nozzle::Disc { radius } => {
                            let r = (u * u + v * v).sqrt();
                            // A chord's midpoint is inside the circle by r (1 - cos(pi / segments)).
                            assert!(r <= radius as f32 + 1e-6 && r > 0.99 * radius as f32, "r {r}");
                        }
                        Nozzle::Rectangle { size } => {
                            let (du, dv) = (u.abs() - 0.5 * size[0] as f32, v.abs() - 0.5 * size[1] as f32);
                            assert!(du < 1e-6 && dv < 1e-6, "{p} outside the rectangle");
                            assert!(du.abs() < 1e-6 || dv.abs() < 1e-6, "{p} inside the rectangle");
                        }
                    }
                }
            }
            for p in &e.points {
                let (u, v, _) = local(*p);
                let inside = match nozzle {
                    Nozzle::Disc { radius } => (u * u + v * v).sqrt() < 0.99 * radius as f32,
                    Nozzle::Rectangle { size } => {
                        u.abs() <= 0.5 * size[0] as f32 && v.abs() <= 0.5 * size[1] as f32
                    }
                };
                assert!(inside, "{nozzle:?}: the nozzle point {p} is outside its outline");
            }
        }
    }

    /// A pipe adds its far rim, the nozzle's rim moved `pipe_length` along the normal, and four lines
    /// along it from the nozzle's rim; the stroke leaves from the pipe's end.
    #[test]
    fn a_pipe_s_outline_runs_from_the_nozzle_to_its_end() {
        let normal = Vec3::new(1.0, 0.6, 0.0).normalize();
        let length = 0.04f32;
        for nozzle in [
            Nozzle::Disc { radius: 0.025 },
            Nozzle::Rectangle { size: [0.06, 0.02] },
        ] {
            let bare = emitter(nozzle, normal);
            let piped = Emitter {
                pipe_length: f64::from(length),
                ..bare.clone()
            };
            let lines = |e: &Emitter| {
                outline(
                    &Flow {
                        emitters: vec![e.clone()],
                        sinks: vec![],
                        capacity: 1,
                    },
                    TANK,
                )
            };
            let (without, with) = (lines(&bare), lines(&piped));
            let rim = without.len() - 1;
            assert_eq!(with.len(), 2 * rim + 4 + 1, "{nozzle:?}");
            let center = bare.center.as_vec3();
            let height = |p: Vec3| (p - center).dot(normal);
            let far = with
                .iter()
                .filter(|[a, b]| (height(*a) - length).abs() < 1e-6 && (height(*b) - length).abs() < 1e-6);
            assert_eq!(far.count(), rim, "{nozzle:?}: the far rim");
            let along = with
                .iter()
                .filter(|[a, b]| height(*a).abs() < 1e-6 && (height(*b) - length).abs() < 1e-6);
            assert_eq!(
                along
                    .filter(|[a, b]| ((*b - *a) - normal * length).length() < 1e-6)
                    .count(),
                4,
                "{nozzle:?}"
            );
            let stroke = with.last().unwrap();
            assert!(
                (stroke[0] - (center + normal * length)).length() < 1e-6,
                "{nozzle:?}"
            );
        }
    }

    /// A sink is its box's 12 edges, cut to the tank; a sink wholly outside it draws nothing.
    #[test]
    fn a_sinks_outline_is_its_box_cut_to_the_tank() {
        let sink = |min: [f32; 3], max: [f32; 3]| Sink {
            min: Vec3::from(min),
            max: Vec3::from(max),
        };
        let flow = Flow {
            emitters: vec![],
            sinks: vec![sink([0.6, -0.1, 0.2], [0.7, 0.05, 0.3]), sink([2.0; 3], [3.0; 3])],
            capacity: 1,
        };
        let lines = outline(&flow, TANK);
        assert_eq!(lines.len(), 12);
        let (lo, hi) = (Vec3::new(0.6, 0.0, 0.2), Vec3::new(0.7, 0.05, 0.3));
        for [a, b] in lines {
            assert!((b - a).length() > 0.0);
            // One coordinate changes along an edge, and every endpoint is a corner of [lo, hi].
            assert_eq!((b - a).cmpne(Vec3::ZERO).bitmask().count_ones(), 1);
            for p in [a, b] {
                for k in 0..3 {
                    assert!(p[k] == lo[k] || p[k] == hi[k], "{p} is not a corner");
                }
            }
        }
    }
}
