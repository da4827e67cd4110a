//! kernels/halo.cu: the two ends of the ghost exchange on one rank's grid (the scatter's ghost sums
//! packed for their owner and added to its edge planes; the owner's updated edge planes packed and
//! written over the neighbours' ghosts) and the buffers a carrier moves between ranks. `ranks.rs`
//! runs them; `dist::halo` is the CPU's version.

use super::gpu::Gpu;
use super::launch::{Kernel, Launcher};
use super::modules::LoadedModules;
use super::state::{DeviceState, StateArgs};
use crate::dist::slabs::BLOCK;
use crate::sim::Params;
use anyhow::{Context, Result};
use cudarc::driver::{CudaSlice, PushKernelArg};
use std::ops::Range;

/// u64 words per node of packed sums: mass, momentum x, y, z, and the sender's block mark
/// (`HALO_SUM_WORDS` in kernels/halo.cu).
pub const HALO_SUM_WORDS: usize = 5;

pub struct HaloKernels {
    pack_sums: Kernel,
    add_sums: Kernel,
    pack_velocities: Kernel,
    fill_velocities: Kernel,
}

/// Node planes across the slab axis, where one transfer reads or writes.
#[derive(Debug, Clone)]
pub struct Planes {
    pub axis: usize,
    pub range: Range<u32>,
}

impl Planes {
    /// Nodes in the planes, for a grid of `res` nodes.
    pub fn nodes(&self, res: [u32; 3]) -> usize {
        let across: usize = res.iter().map(|&r| r as usize).product::<usize>() / res[self.axis] as usize;
        self.range.len() * across
    }
}

/// One rank's send and receive buffers, below ([0]) and above ([1]), each large enough for a block
/// of planes of packed sums (velocities take less).
pub struct HaloBuffers {
    pub send: [CudaSlice<u64>; 2],
    pub recv: [CudaSlice<u64>; 2],
}

impl HaloBuffers {
    pub fn allocate(gpu: &Gpu, res: [u32; 3], axis: usize) -> Result<HaloBuffers> {
        let block = Planes {
            axis,
            range: 0..BLOCK,
        };
        let words = HALO_SUM_WORDS * block.nodes(res);
        let stream = gpu.stream();
        let alloc = || {
            stream
                .alloc_zeros::<u64>(words)
                .with_context(|| format!("allocating a halo buffer ({words} words)"))
        };
        Ok(HaloBuffers {
            send: [alloc()?, alloc()?],
            recv: [alloc()?, alloc()?],
        })
    }
}

impl HaloKernels {
    pub fn load(modules: &LoadedModules) -> Result<HaloKernels> {
        let kernel = |name| Kernel::load(modules, "halo", name);
        Ok(HaloKernels {
            pack_sums: kernel("halo_pack_sums")?,
            add_sums: kernel("halo_add_sums")?,
            pack_velocities: kernel("halo_pack_velocities")?,
            fill_velocities: kernel("halo_fill_velocities")?,
        })
    }

    /// Packs the scatter's sums on the ghost planes `planes` into `out` and zeroes them.
    pub fn pack_sums(
        &self,
        l: &Launcher,
        params: &Params,
        planes: &Planes,
        d: &DeviceState,
        out: &CudaSlice<u64>,
    ) -> Result<()> {
        let (axis, first, nodes) = extent(planes, params);
        // SAFETY: the arguments match halo_pack_sums; `out` holds HALO_SUM_WORDS per node of a block
        // of planes (`HaloBuffers::allocate`) and ghost planes are at most a block.
        unsafe {
            self.pack_sums.launch(l, l.cover(nodes as usize), |a| {
                a.arg(params)
                    .arg(&axis)
                    .arg(&first)
                    .arg(&nodes)
                    .accumulators(&d.grid)
                    .arg(&d.grid.node_blocks.marks)
                    .arg(out);
            })
        }
    }

    /// Adds packed sums from `received` to the edge planes `planes`, listing the sender's blocks.
    pub fn add_sums(
        &self,
        l: &Launcher,
        params: &Params,
        planes: &Planes,
        received: &CudaSlice<u64>,
        d: &DeviceState,
    ) -> Result<()> {
        let (axis, first, nodes) = extent(planes, params);
        let blocks = &d.grid.node_blocks;
        // SAFETY: the arguments match halo_add_sums; `received` as in `pack_sums`.
        unsafe {
            self.add_sums.launch(l, l.cover(nodes as usize), |a| {
                a.arg(params)
                    .arg(&axis)
                    .arg(&first)
                    .arg(&nodes)
                    .arg(received)
                    .accumulators(&d.grid)
                    .arg(&blocks.marks)
                    .arg(&blocks.list)
                    .arg(&d.grid.work_counts);
            })
        }
    }

    /// Packs the grid update's velocities on the edge planes `planes` into `out`.
    pub fn pack_velocities(
        &self,
        l: &Launcher,
        params: &Params,
        planes: &Planes,
        d: &DeviceState,
        out: &CudaSlice<u64>,
    ) -> Result<()> {
        let (axis, first, nodes) = extent(planes, params);
        // SAFETY: the arguments match halo_pack_velocities; a float4 per node takes less than the
        // HALO_SUM_WORDS u64 per node `out` holds.
        unsafe {
            self.pack_velocities.launch(l, l.cover(nodes as usize), |a| {
                a.arg(params)
                    .arg(&axis)
                    .arg(&first)
                    .arg(&nodes)
                    .arg(&d.grid.vel)
                    .arg(out);
            })
        }
    }

    /// Writes packed velocities from `received` over the ghost planes `planes`.
    pub fn fill_velocities(
        &self,
        l: &Launcher,
        params: &Params,
        planes: &Planes,
        received: &CudaSlice<u64>,
        d: &DeviceState,
    ) -> Result<()> {
        let (axis, first, nodes) = extent(planes, params);
        // SAFETY: the arguments match halo_fill_velocities; `received` as in `pack_velocities`.
        unsafe {
            self.fill_velocities.launch(l, l.cover(nodes as usize), |a| {
                a.arg(params)
                    .arg(&axis)
                    .arg(&first)
                    .arg(&nodes)
                    .arg(received)
                    .arg(&d.grid.vel);
            })
        }
    }
}

/// The kernels' (axis, first plane, nodes) of `planes`.
fn extent(planes: &Planes, params: &Params) -> (u32, u32, u32) {
    (
        planes.axis as u32,
        planes.range.start,
        planes.nodes(params.grid_res) as u32,
    )
}
