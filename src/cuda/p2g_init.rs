//! kernels/p2g_init.cu: the report pipeline's mass scatter, m_i += w m_p, warp runs of one cell summed
//! before global atomics.

use super::launch::{host_kernel, Launcher};
use super::state::DeviceState;
use crate::sim::Params;
use anyhow::Result;
use cudarc::driver::PushKernelArg;

host_kernel!(P2gInit = "p2g_init" / "p2g_init");

impl P2gInit {
    pub fn launch(&self, l: &Launcher, params: &Params, d: &DeviceState) -> Result<()> {
        let (p, g) = (&d.particles, &d.grid);
        // SAFETY: the arguments match p2g_init in kernels/p2g_init.cu; buffers are sized for params.
        unsafe {
            self.0.launch(l, l.cover(p.count), |a| {
                a.arg(&params.kernel)
                    .arg(&p.x)
                    .arg(&p.v)
                    .arg(&d.bins.order)
                    .arg(&g.acc)
                    .arg(g.fixed_mass())
                    .arg(&d.counters.device);
            })
        }
    }
}
