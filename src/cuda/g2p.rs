//! kernels/g2p.cu: the report pipeline's gather: velocity and C from the grid, soft wall, advection,
//! clamp.

use super::launch::{host_kernel, Launcher};
use super::state::DeviceState;
use crate::sim::Params;
use anyhow::Result;
use cudarc::driver::PushKernelArg;

host_kernel!(G2p = "g2p" / "g2p");

impl G2p {
    pub fn launch(&self, l: &Launcher, params: &Params, d: &DeviceState) -> Result<()> {
        let p = &d.particles;
        // SAFETY: the arguments match g2p in kernels/g2p.cu; buffers are sized for params.
        unsafe {
            self.0.launch(l, l.cover(p.count), |a| {
                a.arg(&params.kernel)
                    .arg(&p.x)
                    .arg(&p.v)
                    .arg(&p.c)
                    .arg(&d.grid.vel)
                    .arg(&p.rho)
                    .arg(&d.counters.device);
            })
        }
    }
}
