//! kernels/volume.cu: the grid's volume of a scene whose rest densities differ (each node's sum of
//! the particles' stencil weights in fixed-point units) and every particle's density gathered from
//! it (`sim::params::gathers_volume`). Nothing launches where the scene has one rest density.

use super::launch::{Kernel, Launcher};
use super::modules::LoadedModules;
use super::state::{DeviceState, StateArgs};
use crate::sim::params::gathers_volume;
use crate::sim::{Params, Pipeline};
use anyhow::Result;
use cudarc::driver::PushKernelArg;

pub struct VolumeKernels {
    scatter: Kernel,
    scatter_tiled: Kernel,
    gather: Kernel,
}

impl VolumeKernels {
    pub fn load(modules: &LoadedModules) -> Result<VolumeKernels> {
        Ok(VolumeKernels {
            scatter: Kernel::load(modules, "volume", "scatter_volume")?,
            scatter_tiled: Kernel::load(modules, "volume", "scatter_volume_tiled")?,
            gather: Kernel::load(modules, "volume", "gather_volume_density")?,
        })
    }

    /// Zeroes the volume and scatters every live particle's weights into it at its current
    /// position: through a tile per bin chunk in the pipelines that bin by node block, by warp runs
    /// in the report's. Whether it launched.
    pub fn scatter(
        &self,
        l: &Launcher,
        pipeline: Pipeline,
        params: &Params,
        d: &mut DeviceState,
    ) -> Result<bool> {
        if !gathers_volume(params) {
            return Ok(false);
        }
        d.grid.zero_volume(&l.stream)?;
        let (p, g) = (&d.particles, &d.grid);
        if !pipeline.is_binned() {
            // SAFETY: the arguments match scatter_volume in kernels/volume.cu; the volume holds a u64
            // per node of this grid, `x` a float4 per slot.
            unsafe {
                self.scatter.launch(l, l.cover(p.count), |a| {
                    a.arg(&params.kernel).arg(&p.x).arg(g.volume());
                })?;
            }
            return Ok(true);
        }
        let list = d.bins.list()?;
        let config = d.bins.tiled_pass(l, &self.scatter_tiled, 1)?;
        // SAFETY: the arguments match scatter_volume_tiled in kernels/volume.cu; the bin list, order
        // and node-block list are sized for this grid and these particles; a null order where the
        // particles are stored in bin order (the kernel reads places).
        unsafe {
            self.scatter_tiled.launch(l, config, |a| {
                a.arg(&params.kernel)
                    .arg(list)
                    .bin_order_or_places(d)
                    .arg(&p.x)
                    .arg(g.volume())
                    .node_block_list(d);
            })?;
        }
        Ok(true)
    }

    /// Every live particle's density gathered from the volume (the walls' images added), into its
    /// `rho`. Whether it launched.
    pub fn gather_density(&self, l: &Launcher, params: &Params, d: &DeviceState) -> Result<bool> {
        if !gathers_volume(params) {
            return Ok(false);
        }
        let p = &d.particles;
        // SAFETY: the arguments match gather_volume_density in kernels/volume.cu; buffers are sized
        // for params.
        unsafe {
            self.gather.launch(l, l.cover(p.count), |a| {
                a.arg(&params.kernel)
                    .arg(&p.x)
                    .arg(&p.v)
                    .arg(d.grid.volume())
                    .arg(&p.rho);
            })?;
        }
        Ok(true)
    }
}
