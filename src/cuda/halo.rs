//! kernels/halo.cu: the two ends of the ghost exchange on one rank's grid (the scatter's ghost sums
//! packed for their owner and added to its edge planes; the owner's updated edge planes packed and
//! written over the neighbours' ghosts) and the buffers a transport moves between ranks. A rank's
//! solver runs them (as_rank.rs), where cuda_ranks.rs asks; `dist::halo` is the CPU's version.

use super::gpu::Gpu;
use super::grid::DeviceGrid;
use super::launch::{Kernel, Launcher};
use super::modules::LoadedModules;
use super::state::StateArgs;
use crate::dist::slabs::BLOCK;
use crate::sim::{Params, Phase, ScatterMode};
use anyhow::{ensure, Context, Result};
use cudarc::driver::{CudaSlice, LaunchArgs, PushKernelArg};
use std::ops::Range;

/// 32-bit words per node of packed sums (`halo_sum_words` in kernels/halo.cu): mass and momentum x,
/// y, z as floats, or under the fixed-point scatter as 64-bit units of two words each; then the
/// sender's block mark.
pub fn sum_words(fixed_point: bool) -> usize {
    if fixed_point {
        9
    } else {
        5
    }
}
/// 32-bit words per node of packed velocities: a float4 of velocity and mass.
pub const VELOCITY_WORDS: usize = 4;
/// 32-bit words per node added to either where the rest densities differ: the grid's volume, 64
/// bits.
pub const VOLUME_WORDS: usize = 2;

/// What an exchange carries (cuda_ranks.rs: `CudaRanks::exchange`).
#[derive(Clone, Copy)]
pub enum Exchange {
    /// The scatter's sums on the ghost planes, to their owner (halo_sum).
    Sums,
    /// The grid update's velocities on the edge planes, to the neighbours' ghosts (halo_fill).
    Velocities,
}

impl Exchange {
    /// The exchange of `phase`, one of the two (`Phase::is_exchange`).
    pub fn of(phase: Phase) -> Option<Exchange> {
        match phase {
            Phase::HaloSum => Some(Exchange::Sums),
            Phase::HaloFill => Some(Exchange::Velocities),
            _ => None,
        }
    }

    /// 32-bit words a node takes packed under `params` (kernels/halo.cu): its sums in the scatter's
    /// width and its block mark, or one float4 of velocity and mass; and the grid's volume where the
    /// rest densities differ.
    pub fn words_per_node(self, params: &Params) -> usize {
        let words = match self {
            Exchange::Sums => sum_words(params.scatter_mode == ScatterMode::FixedPoint.code()),
            Exchange::Velocities => VELOCITY_WORDS,
        };
        let volume = match params.volume_density {
            0 => 0,
            _ => VOLUME_WORDS,
        };
        words + volume
    }
}

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

/// One rank's send and receive buffers of 32-bit words, below ([0]) and above ([1]), each large
/// enough for a block of planes of packed sums and volumes in either scatter mode (velocities take
/// less).
pub struct HaloBuffers {
    pub send: [CudaSlice<u32>; 2],
    pub recv: [CudaSlice<u32>; 2],
}

impl HaloBuffers {
    pub fn allocate(gpu: &Gpu, res: [u32; 3], axis: usize) -> Result<HaloBuffers> {
        let block = Planes {
            axis,
            range: 0..BLOCK,
        };
        let words = (sum_words(true) + VOLUME_WORDS) * block.nodes(res);
        let stream = gpu.stream();
        let alloc = || {
            stream
                .alloc_zeros::<u32>(words)
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

    /// Packs the scatter's sums on the planes `planes` of `grid` (whose kernels run with `params`)
    /// into `out` and zeroes them.
    pub fn pack_sums(
        &self,
        l: &Launcher,
        params: &Params,
        planes: &Planes,
        grid: &DeviceGrid,
        out: &CudaSlice<u32>,
    ) -> Result<()> {
        // SAFETY: the rest of halo_pack_sums' arguments; `out` holds the most words of sums and a
        // volume per node of a block of planes (`HaloBuffers::allocate`), and the planes packed at
        // once are at most a block.
        unsafe {
            over_planes(&self.pack_sums, l, params, &extent(planes, params)?, |a| {
                a.accumulators(grid)
                    .arg(grid.volume())
                    .arg(&grid.node_blocks.marks)
                    .arg(out);
            })
        }
    }

    /// Adds packed sums from `received` to the planes `planes` of `grid`, listing the sender's
    /// blocks.
    pub fn add_sums(
        &self,
        l: &Launcher,
        params: &Params,
        planes: &Planes,
        received: &CudaSlice<u32>,
        grid: &DeviceGrid,
    ) -> Result<()> {
        let blocks = &grid.node_blocks;
        // SAFETY: the rest of halo_add_sums' arguments; `received` as in `pack_sums`.
        unsafe {
            over_planes(&self.add_sums, l, params, &extent(planes, params)?, |a| {
                a.arg(received)
                    .accumulators(grid)
                    .arg(grid.volume())
                    .arg(&blocks.marks)
                    .arg(&blocks.list)
                    .arg(&grid.work_counts);
            })
        }
    }

    /// Packs the grid update's velocities on the edge planes `planes` into `out`.
    pub fn pack_velocities(
        &self,
        l: &Launcher,
        params: &Params,
        planes: &Planes,
        grid: &DeviceGrid,
        out: &CudaSlice<u32>,
    ) -> Result<()> {
        // SAFETY: the rest of halo_pack_velocities' arguments; a float4 and a volume per node take
        // less than the words per node `out` holds.
        unsafe {
            over_planes(&self.pack_velocities, l, params, &extent(planes, params)?, |a| {
                a.arg(&grid.vel).arg(grid.volume()).arg(out);
            })
        }
    }

    /// Writes packed velocities from `received` over the ghost planes `planes`.
    pub fn fill_velocities(
        &self,
        l: &Launcher,
        params: &Params,
        planes: &Planes,
        received: &CudaSlice<u32>,
        grid: &DeviceGrid,
    ) -> Result<()> {
        // SAFETY: the rest of halo_fill_velocities' arguments; `received` as in `pack_velocities`.
        unsafe {
            over_planes(&self.fill_velocities, l, params, &extent(planes, params)?, |a| {
                a.arg(received).arg(&grid.vel).arg(grid.volume());
            })
        }
    }
}

/// The leading arguments of kernels/halo.cu's kernels for `planes`: axis, first plane, nodes. The
/// grid's box must hold the planes (a rank's grid holds its slab and ghost planes alone).
fn extent(planes: &Planes, params: &Params) -> Result<[u32; 3]> {
    let (axis, range) = (planes.axis, &planes.range);
    let (lo, res) = (params.box_lo[axis], params.box_res[axis]);
    ensure!(
        lo <= range.start && range.end <= lo + res,
        "planes {range:?} across axis {axis} lie outside the grid's nodes {lo}..{}",
        lo + res
    );
    Ok([axis as u32, range.start, planes.nodes(params.box_res) as u32])
}

/// Launches one of kernels/halo.cu's kernels over the nodes of some planes: its leading arguments
/// (params, then `extent`'s axis, first plane and nodes), then what `rest` pushes.
///
/// # Safety
/// `rest` must push the kernel's remaining parameters, in order, every buffer large enough for the
/// planes' nodes.
unsafe fn over_planes<'a>(
    kernel: &'a Kernel,
    l: &'a Launcher,
    params: &'a Params,
    extent: &'a [u32; 3],
    rest: impl FnOnce(&mut LaunchArgs<'a>),
) -> Result<()> {
    let [axis, first, nodes] = extent;
    // SAFETY: the caller vouches for the arguments `rest` pushes.
    unsafe {
        kernel.launch(l, l.cover(*nodes as usize), |a| {
            a.arg(&params.kernel).arg(axis).arg(first).arg(nodes);
            rest(a);
        })
    }
}
