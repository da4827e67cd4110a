//! The grid on the device: the scatter accumulators (float, and fixed point where that scatter runs),
//! the node velocities the grid update writes for the gather, and the binned pipeline's list of the
//! node blocks a substep touched; over the box of the domain's nodes this GPU holds (`GridBox`).

use super::bin_lists::{NODE_BLOCK_SLOTS, WORK_COUNTS};
use super::gpu::Gpu;
pub use crate::sim::cpu::GridBox;
use crate::sim::{Params, ScatterMode};
use anyhow::{Context, Result};
use cudarc::driver::{CudaSlice, CudaStream};
use glam::Vec3;
use std::sync::Arc;

/// Bytes on the device per node: two float4 and the report sort's cell count (the binned pipeline's
/// per-block lists are far smaller).
pub const BYTES_PER_NODE: usize = 4 * (4 + 4 + 1);
/// Added per node by the fixed-point scatter: mass and three momentum components as u64.
pub const FIXED_BYTES_PER_NODE: usize = 8 * 4;
/// Added per node where the rest densities differ: the grid's volume as u64.
pub const VOLUME_BYTES_PER_NODE: usize = 8;

/// Fixed-point accumulators, allocated on first use of the fixed-point scatter.
struct FixedGrid {
    mass: CudaSlice<u64>,
    /// Three per node, interleaved.
    momentum: CudaSlice<u64>,
}

/// The binned pipeline's list of touched node blocks (kernels/tiles.cuh): a mark per block and the
/// list the scatters append to, a slot per node block of the grid, in two parts: the blocks no
/// wall's mirror reaches from the front (`work_counts[WORK_NODE_BLOCKS]` of them), those some
/// wall's reach meets from the back (`work_counts[WORK_WALL_NODE_BLOCKS]`).
pub struct NodeBlockList {
    pub marks: CudaSlice<u32>,
    pub list: CudaSlice<u32>,
}

pub struct DeviceGrid {
    /// The nodes it holds.
    pub held: GridBox,
    /// Scatter accumulators, float4 per node: momentum xyz, mass w. Zeroed by the grid update.
    pub acc: CudaSlice<f32>,
    /// Node velocity xyz and mass w, written by the grid update, read by the gather.
    pub vel: CudaSlice<f32>,
    fixed: Option<FixedGrid>,
    /// The grid's volume where the rest densities differ (kernels/volume.cu): a u64 of
    /// fixed-point weights per node.
    volume: Option<CudaSlice<u64>>,
    /// Passed for the fixed-point pointers when the float scatter runs (never dereferenced).
    unused_fixed: CudaSlice<u64>,
    pub node_blocks: NodeBlockList,
    /// Device-side list lengths (WORK_BINS, WORK_NODE_BLOCKS, WORK_WALL_NODE_BLOCKS in
    /// kernels/tiles.cuh).
    pub work_counts: CudaSlice<u32>,
}

impl NodeBlockList {
    /// The list lengths (`work_counts`) and a list of up to `num_node_blocks` blocks (0 in the report
    /// pipeline), zeroed.
    pub fn allocate(
        stream: &Arc<CudaStream>,
        num_node_blocks: usize,
    ) -> Result<(CudaSlice<u32>, NodeBlockList)> {
        let alloc = |len: usize, what: &str| {
            stream
                .alloc_zeros::<u32>(len.max(1))
                .with_context(|| format!("allocating {what} ({len} values)"))
        };
        Ok((
            alloc(WORK_COUNTS, "work counts")?,
            NodeBlockList {
                marks: alloc(num_node_blocks, "node block marks")?,
                list: alloc(num_node_blocks, "the node block list")?,
            },
        ))
    }
}

impl DeviceGrid {
    /// A zeroed grid of the nodes of `held`, with the node-block list and list lengths from
    /// `NodeBlockList::allocate`.
    pub fn allocate(
        stream: &Arc<CudaStream>,
        held: GridBox,
        (work_counts, node_blocks): (CudaSlice<u32>, NodeBlockList),
    ) -> Result<DeviceGrid> {
        let nodes = held.nodes();
        let alloc = |len: usize, what: &str| {
            stream
                .alloc_zeros::<f32>(len)
                .with_context(|| format!("allocating {what} ({len} floats)"))
        };
        Ok(DeviceGrid {
            held,
            acc: alloc(4 * nodes, "grid accumulators")?,
            vel: alloc(4 * nodes, "grid velocities")?,
            fixed: None,
            volume: None,
            unused_fixed: stream.alloc_zeros::<u64>(1).context("allocating a placeholder")?,
            node_blocks,
            work_counts,
        })
    }

    pub fn num_nodes(&self) -> usize {
        self.held.nodes()
    }

    /// Allocates the fixed-point accumulators if they are not yet there.
    pub fn ensure_fixed(&mut self, stream: &Arc<CudaStream>) -> Result<()> {
        if self.fixed.is_none() {
            let nodes = self.num_nodes();
            self.fixed = Some(FixedGrid {
                mass: stream
                    .alloc_zeros::<u64>(nodes)
                    .context("allocating fixed-point mass")?,
                momentum: stream
                    .alloc_zeros::<u64>(3 * nodes)
                    .context("allocating fixed-point momentum")?,
            });
        }
        Ok(())
    }

    pub fn has_fixed(&self) -> bool {
        self.fixed.is_some()
    }

    pub fn has_volume(&self) -> bool {
        self.volume.is_some()
    }

    /// Allocates the grid's volume if it is not yet there (scenes whose rest densities differ).
    pub fn ensure_volume(&mut self, stream: &Arc<CudaStream>) -> Result<()> {
        if self.volume.is_none() {
            let nodes = self.num_nodes();
            self.volume = Some(
                stream
                    .alloc_zeros::<u64>(nodes)
                    .context("allocating the grid's volume")?,
            );
        }
        Ok(())
    }

    /// The grid's volume, or a placeholder that scenes of one rest density never dereference.
    pub fn volume(&self) -> &CudaSlice<u64> {
        self.volume.as_ref().unwrap_or(&self.unused_fixed)
    }

    /// Zeroes the grid's volume before its scatter.
    pub fn zero_volume(&mut self, stream: &Arc<CudaStream>) -> Result<()> {
        let volume = self
            .volume
            .as_mut()
            .context("the grid's volume was never allocated (DeviceState::check_params allocates it)")?;
        stream.memset_zeros(volume).context("zeroing the grid's volume")
    }

    /// The grid's volume read back as the CPU reference holds it (`Grid::volume`). Waits.
    pub fn read_volume(&self, gpu: &Gpu) -> Result<Vec<i64>> {
        let volume = self.volume.as_ref().context("the scene gathers no volume")?;
        Ok(gpu.download(volume)?.into_iter().map(|q| q as i64).collect())
    }

    /// The fixed-point mass accumulators, or a placeholder the float scatter never dereferences.
    pub fn fixed_mass(&self) -> &CudaSlice<u64> {
        self.fixed.as_ref().map_or(&self.unused_fixed, |f| &f.mass)
    }

    /// The fixed-point momentum accumulators (three per node), or the placeholder.
    pub fn fixed_momentum(&self) -> &CudaSlice<u64> {
        self.fixed.as_ref().map_or(&self.unused_fixed, |f| &f.momentum)
    }

    /// Zeroes every accumulator and empties the node-block list with its marks: the grid as before
    /// any scatter.
    pub fn clear(&mut self, stream: &Arc<CudaStream>) -> Result<()> {
        let zero = "zeroing the grid";
        stream.memset_zeros(&mut self.acc).context(zero)?;
        if let Some(fixed) = &mut self.fixed {
            stream.memset_zeros(&mut fixed.mass).context(zero)?;
            stream.memset_zeros(&mut fixed.momentum).context(zero)?;
        }
        stream.memset_zeros(&mut self.node_blocks.marks).context(zero)?;
        self.clear_node_block_list(stream)
    }

    /// Zeroes the fixed-point sums alone: the position-based substep's start, whose kernels touch
    /// neither the float accumulators nor the node-block list.
    pub fn clear_fixed(&mut self, stream: &Arc<CudaStream>) -> Result<()> {
        let fixed = self
            .fixed
            .as_mut()
            .context("the fixed-point sums are not allocated")?;
        let zero = "zeroing the grid's fixed-point sums";
        stream.memset_zeros(&mut fixed.mass).context(zero)?;
        stream.memset_zeros(&mut fixed.momentum).context(zero)
    }

    /// Empties the list of touched node blocks, both parts (the grid update empties them after each
    /// walk).
    fn clear_node_block_list(&mut self, stream: &Arc<CudaStream>) -> Result<()> {
        stream
            .memset_zeros(&mut self.work_counts.slice_mut(NODE_BLOCK_SLOTS))
            .context("clearing the node block list")
    }

    /// The scatter accumulators as the CPU reference's `Grid` holds them after p2g: mass and momentum
    /// per node (converted from fixed point with `params`' scales where that scatter ran). Waits.
    pub fn read_accumulators(&self, gpu: &Gpu, params: &Params) -> Result<(Vec<f32>, Vec<Vec3>)> {
        if params.scatter_mode != ScatterMode::FixedPoint.code() {
            return Ok(split_float4(&gpu.download(&self.acc)?));
        }
        let fixed = self
            .fixed
            .as_ref()
            .context("the fixed-point scatter has not run")?;
        let mass = gpu.download(&fixed.mass)?;
        let momentum = gpu.download(&fixed.momentum)?;
        let (ms, ps) = (1.0 / params.fixed_mass_scale, 1.0 / params.fixed_momentum_scale);
        let value = |q: u64, inv: f32| (q as i64) as f32 * inv;
        Ok((
            mass.iter().map(|&q| value(q, ms)).collect(),
            momentum
                .chunks_exact(3)
                .map(|m| Vec3::new(value(m[0], ps), value(m[1], ps), value(m[2], ps)))
                .collect(),
        ))
    }

    /// Node mass and velocity as the grid update left them. Waits.
    pub fn read_velocity(&self, gpu: &Gpu) -> Result<(Vec<f32>, Vec<Vec3>)> {
        Ok(split_float4(&gpu.download(&self.vel)?))
    }
}

fn split_float4(values: &[f32]) -> (Vec<f32>, Vec<Vec3>) {
    values
        .chunks_exact(4)
        .map(|q| (q[3], Vec3::new(q[0], q[1], q[2])))
        .unzip()
}
