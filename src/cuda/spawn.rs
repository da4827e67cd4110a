//! Spawning a scene's particles on the device (kernels/spawn.cu), in the order of `Scene::spawn()`:
//! the body table (each body's lattice range and shape, computed here with the same f64 arithmetic as
//! `Lattice` in src/sim/scene/lattice.rs, so the device visits the same points), a count pass, a prefix sum
//! of the per-block counts here, and a write pass.

use super::gpu::Gpu;
use super::launch::{Kernel, NvtxRange};
use super::modules::LoadedModules;
use super::particles::{material_tag, DeviceParticles};
use super::state::StateArgs;
use crate::contract::{SpawnBody, BODY_BLOCK, BODY_SPHERE};
use crate::sim::scene::{Scene, Shape};
use anyhow::{bail, ensure, Context, Result};
use cudarc::driver::{CudaSlice, LaunchConfig, PushKernelArg};

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
            material_tag: material_tag(body.material),
            rest_density: scene.materials[usize::from(body.material)].law.rest_density,
            first_candidate: total,
        });
        total += count;
    }
    if total == 0 {
        bail!("scene {}: no lattice points to spawn", scene.source);
    }
    Ok((table, total))
}

pub struct SpawnKernels {
    count: Kernel,
    write: Kernel,
}

impl SpawnKernels {
    pub fn load(modules: &LoadedModules) -> Result<SpawnKernels> {
        Ok(SpawnKernels {
            count: Kernel::load(modules, "spawn", "spawn_count")?,
            write: Kernel::load(modules, "spawn", "spawn_write")?,
        })
    }
}

/// Writes `scene`'s lattice particles into `particles` (which must hold exactly as many), and waits.
pub fn spawn_on_device(
    gpu: &Gpu,
    kernels: &SpawnKernels,
    scene: &Scene,
    particles: &DeviceParticles,
) -> Result<()> {
    let _range = NvtxRange::new("spawn");
    let l = &gpu.launcher;
    let (table, candidates) = body_table(scene)?;
    let block = l.block_size;
    let blocks_u64 = candidates.div_ceil(u64::from(block));
    ensure!(
        blocks_u64 <= u64::from(i32::MAX as u32),
        "scene {}: {candidates} lattice candidates are too many to spawn on the device",
        scene.source
    );
    let blocks = blocks_u64 as u32;
    let config = LaunchConfig {
        grid_dim: (blocks, 1, 1),
        block_dim: (block, 1, 1),
        shared_mem_bytes: 0,
    };
    let stream = gpu.stream();
    let bodies: CudaSlice<SpawnBody> = stream.clone_htod(&table).context("uploading bodies")?;
    let num_bodies = table.len() as u32;
    let spacing = scene.lattice().spacing;
    let counts = stream
        .alloc_zeros::<u32>(blocks as usize)
        .context("spawn counts")?;
    // SAFETY: arguments match spawn_count in kernels/spawn.cu; `counts` has one slot per block.
    unsafe {
        kernels.count.launch(l, config, |a| {
            a.arg(&bodies)
                .arg(&num_bodies)
                .arg(&spacing)
                .arg(&candidates)
                .arg(&counts);
        })?;
    }

    let block_counts = gpu.download(&counts)?;
    let mut offsets = Vec::with_capacity(block_counts.len());
    let mut total = 0u64;
    for &count in &block_counts {
        offsets.push(total as u32);
        total += u64::from(count);
    }
    ensure!(
        total == particles.count as u64,
        "device spawn made {total} particles but scene {} has {} (the device and host lattices disagree)",
        scene.source,
        particles.count
    );
    let offsets = stream.clone_htod(&offsets).context("uploading spawn offsets")?;
    let n = particles.count as u32;
    // SAFETY: as above; every output holds `n` particles.
    unsafe {
        kernels.write.launch(l, config, |a| {
            a.arg(&bodies)
                .arg(&num_bodies)
                .arg(&spacing)
                .arg(&candidates)
                .arg(&offsets)
                .arg(&n)
                .particle_state(particles);
        })?;
    }
    stream.synchronize().context("spawning particles on the GPU")?;
    Ok(())
}
