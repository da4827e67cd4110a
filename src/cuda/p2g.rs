//! kernels/p2g.cu: density from the grid mass, pressure and stress, momentum scatter, by warp runs of
//! one cell summed before global atomics (integers for fixed point). The report pipeline's p2g, and
//! the binned pipeline's for float momentum without a flow (see `CudaSolver::p2g` for why each).

use super::launch::{Kernel, Launcher};
use super::modules::LoadedModules;
use super::state::{DeviceState, StateArgs};
use crate::sim::Params;
use anyhow::Result;
use cudarc::driver::PushKernelArg;

pub struct P2g(Kernel);

impl P2g {
    pub fn load(modules: &LoadedModules) -> Result<P2g> {
        Ok(P2g(Kernel::load(modules, "p2g", "p2g")?))
    }

    pub fn launch(&self, l: &Launcher, params: &Params, d: &DeviceState) -> Result<()> {
        let (p, g) = (&d.particles, &d.grid);
        // SAFETY: the arguments match p2g in kernels/p2g.cu; buffers are sized for params. In the
        // binned pipeline, g2p2g marked every node block these stencils cover (same positions).
        unsafe {
            self.0.launch(l, l.cover(p.count), |a| {
                a.arg(params)
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
