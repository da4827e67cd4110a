//! The body table that kernels/spawn.cu reads: each body's lattice range and shape, computed here with
//! the same f64 arithmetic as `Lattice` in src/sim/scene.rs, so the device visits the same points.

use crate::sim::scene::{Scene, Shape};
use anyhow::{bail, Result};
use bytemuck::{Pod, Zeroable};
use std::mem::{offset_of, size_of};

pub const BODY_BLOCK: u32 = 0;
pub const BODY_SPHERE: u32 = 1;

/// Mirror of `SpawnBody` in kernels/spawn.cu.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct SpawnBody {
    /// Lattice index range visited, `[lo, hi)` per axis; for a block also its containment test.
    pub range_lo: [i64; 3],
    pub range_hi: [i64; 3],
    pub center: [f64; 3],
    pub radius_sq: f64,
    pub velocity: [f32; 3],
    pub kind: u32,
    /// Offset of this body's range in the list of all candidates.
    pub first_candidate: u64,
}

const _: () = {
    assert!(size_of::<SpawnBody>() == 104);
    assert!(offset_of!(SpawnBody, center) == 48);
    assert!(offset_of!(SpawnBody, radius_sq) == 72);
    assert!(offset_of!(SpawnBody, velocity) == 80);
    assert!(offset_of!(SpawnBody, kind) == 92);
    assert!(offset_of!(SpawnBody, first_candidate) == 96);
};

// SAFETY: plain old data, laid out as the kernel's struct (asserted above and there).
unsafe impl cudarc::driver::DeviceRepr for SpawnBody {}

/// The body table and the number of candidate points (the sum of the ranges' sizes).
pub fn body_table(scene: &Scene) -> Result<(Vec<SpawnBody>, u64)> {
    let spacing = scene.lattice().spacing;
    // Lattice::index_range: the first lattice index at or above each bound.
    let first = |v: f64| (v / spacing - 0.5).ceil() as i64;
    let mut table = Vec::with_capacity(scene.bodies.len());
    let mut total = 0u64;
    for body in &scene.bodies {
        let (min, max, center, radius_sq, kind) = match body.shape {
            Shape::Block { min, max } => (min, max, [0.0; 3], 0.0, BODY_BLOCK),
            // Lattice::points widens a sphere's box by one spacing so boundary points are visited.
            Shape::Sphere { center, radius } => (
                center - radius - spacing,
                center + radius + spacing,
                center.to_array(),
                radius * radius,
                BODY_SPHERE,
            ),
        };
        let range_lo = [first(min.x), first(min.y), first(min.z)];
        let range_hi = [first(max.x), first(max.y), first(max.z)];
        let count = (0..3)
            .map(|a| (range_hi[a] - range_lo[a]).max(0) as u64)
            .product::<u64>();
        table.push(SpawnBody {
            range_lo,
            range_hi,
            center,
            radius_sq,
            velocity: body.velocity.to_array(),
            kind,
            first_candidate: total,
        });
        total += count;
    }
    if total == 0 {
        bail!("scene {}: no lattice points to spawn", scene.source);
    }
    Ok((table, total))
}
