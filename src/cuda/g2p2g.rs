//! kernels/g2p2g.cu: the binned pipeline's particle pass. `g2p2g` gathers velocity and C from the
//! grid, applies the soft wall, colliders and sinks, advects, and scatters the mass of the new
//! position through a shared tile for the next substep; `p2g_mass` is its second half alone, for the
//! first substep (nothing to gather yet) and after emission.

use super::launch::{host_kernel, Launcher};
use super::state::{DeviceState, StateArgs};
use crate::sim::Params;
use anyhow::Result;
use cudarc::driver::PushKernelArg;

/// One channel per tile node: the mass.
const MASS_CHANNELS: u32 = 1;

host_kernel!(G2p2g = "g2p2g" / "g2p2g");

impl G2p2g {
    pub fn launch(&self, l: &Launcher, params: &Params, d: &DeviceState) -> Result<()> {
        let (p, g) = (&d.particles, &d.grid);
        let list = d.bins.list()?;
        let config = d.bins.tiled_pass(l, &self.0, MASS_CHANNELS)?;
        // SAFETY: the arguments match g2p2g in kernels/g2p2g.cu; the bin list, order and node-block
        // list are sized for this grid and these particles. Without a flow the sink and free-slot
        // pointers are null and never read (no sinks).
        unsafe {
            self.0.launch(l, config, |a| {
                a.arg(&params.kernel)
                    .arg(list)
                    .arg(&d.bins.order)
                    .arg(&p.x)
                    .arg(&p.v)
                    .arg(&p.c)
                    .arg(&g.vel)
                    .arg(&p.rho)
                    .arg(&g.acc)
                    .arg(g.fixed_mass())
                    .node_block_list(d)
                    .colliders(&d.colliders)
                    .sinks(d.flow.as_ref());
            })
        }
    }
}

host_kernel!(P2gMass = "g2p2g" / "p2g_mass");

impl P2gMass {
    pub fn launch(&self, l: &Launcher, params: &Params, d: &DeviceState) -> Result<()> {
        let g = &d.grid;
        let list = d.bins.list()?;
        let config = d.bins.tiled_pass(l, &self.0, MASS_CHANNELS)?;
        // SAFETY: the arguments match p2g_mass in kernels/g2p2g.cu; sized as for g2p2g.
        unsafe {
            self.0.launch(l, config, |a| {
                a.arg(&params.kernel)
                    .arg(list)
                    .arg(&d.bins.order)
                    .arg(&d.particles.x)
                    .arg(&d.particles.v)
                    .arg(&g.acc)
                    .arg(g.fixed_mass())
                    .node_block_list(d);
            })
        }
    }
}
