//! kernels/p2g_tiled.cu: p2g through a shared tile per listed bin chunk, flushed once per node: the
//! binned pipeline's fixed-point momentum scatter (and any scatter of a scene with a flow).

use super::launch::{host_kernel, Launcher};
use super::state::{DeviceState, StateArgs};
use crate::sim::Params;
use anyhow::Result;
use cudarc::driver::PushKernelArg;

host_kernel!(P2gTiled = "p2g_tiled" / "p2g_tiled");

impl P2gTiled {
    pub fn launch(&self, l: &Launcher, params: &Params, d: &DeviceState) -> Result<()> {
        let (p, g) = (&d.particles, &d.grid);
        let list = d.bins.list()?;
        // Three channels: momentum xyz (the mass is already on the grid).
        let config = d.bins.tiled_pass(l, &self.0, 3)?;
        // SAFETY: the arguments match p2g_tiled in kernels/p2g_tiled.cu; the bin list, order and
        // node-block list are sized for this grid and these particles.
        unsafe {
            self.0.launch(l, config, |a| {
                a.arg(&params.kernel)
                    .arg(list)
                    .arg(&d.bins.order)
                    .particle_state(p)
                    .accumulators(g)
                    .node_block_list(d);
            })
        }
    }
}
