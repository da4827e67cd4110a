//! kernels/p2g.cu: density from the grid mass, pressure and stress, momentum scatter, by warp runs of
//! one cell summed before global atomics (integers for fixed point). The report pipeline's p2g, and
//! the binned pipeline's for float momentum without a flow (see `CudaSolver::scatter_momentum` for why each).

use super::launch::{host_kernel, Launcher};
use super::state::{DeviceState, StateArgs};
use crate::sim::Params;
use anyhow::Result;
use cudarc::driver::PushKernelArg;

host_kernel!(P2g = "p2g" / "p2g");

impl P2g {
    pub fn launch(&self, l: &Launcher, params: &Params, d: &DeviceState) -> Result<()> {
        let (p, g) = (&d.particles, &d.grid);
        // SAFETY: the arguments match p2g in kernels/p2g.cu; buffers are sized for params. In the
        // binned pipeline, g2p2g marked every node block these stencils cover (same positions).
        unsafe {
            self.0.launch(l, l.cover(p.count), |a| {
                a.arg(&params.kernel)
                    .arg(&p.x)
                    .arg(&d.bins.order)
                    .arg(&p.v)
                    .arg(&p.c)
                    .arg(&p.rho)
                    .accumulators(g)
                    .arg(&d.counters.device);
            })
        }
    }
}
