//! kernels/one_pass.cu: the fused pipeline's particle pass. With `Gather::Substep` it gathers
//! velocity, C and the grid mass, applies the soft wall, colliders and sinks, advects, advances the
//! particle's density, and scatters the next substep's mass and momentum; with `Gather::None` it is
//! the scatter alone, from the state and density the particles carry (the first substep after they
//! were spawned or uploaded). One kernel for both (an entry point per scatter, each serving both
//! uses), so both scatter with the same instructions.

use super::launch::{Kernel, Launcher, NULL_POINTER};
use super::modules::LoadedModules;
use super::state::{DeviceState, StateArgs};
use crate::sim::{Params, ScatterMode};
use anyhow::Result;
use cudarc::driver::PushKernelArg;

/// Channels per tile node of the fixed-point scatter: mass, momentum xyz.
const SCATTER_CHANNELS: u32 = 4;

/// What the pass does before it scatters.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Gather {
    /// Nothing: scatter the particles as they are.
    None,
    /// The end of a substep: g2p, advection and the density, from the grid the substep updated.
    Substep,
}

/// The kernel's two entry points, one per scatter: each is compiled for its own blocks per SM.
pub struct OnePass {
    float: Kernel,
    fixed: Kernel,
}

impl OnePass {
    pub fn load(modules: &LoadedModules) -> Result<OnePass> {
        Ok(OnePass {
            float: Kernel::load(modules, "one_pass", "one_pass_float")?,
            fixed: Kernel::load(modules, "one_pass", "one_pass_fixed")?,
        })
    }

    pub fn launch(&self, l: &Launcher, gather: Gather, params: &Params, d: &DeviceState) -> Result<()> {
        let (p, g) = (&d.particles, &d.grid);
        let list = d.bins.list()?;
        // The float scatter sums in registers and needs no tile.
        let fixed = params.scatter_mode == ScatterMode::FixedPoint.code();
        let (kernel, config) = if fixed {
            (&self.fixed, d.bins.tiled_pass(l, SCATTER_CHANNELS))
        } else {
            (&self.float, d.bins.tiled_pass(l, 0))
        };
        let gather = u32::from(gather == Gather::Substep);
        // SAFETY: the arguments match one_pass_float and one_pass_fixed in kernels/one_pass.cu; the
        // bin list, order and node-block list are sized for this grid and these particles; a null
        // order where the particles are stored in bin order (the kernel reads places). Without a
        // flow the sink and free-slot pointers are null and never read (no sinks); without `gather`
        // the node velocities are not read.
        unsafe {
            kernel.launch(l, config, |a| {
                a.arg(params).arg(&gather).arg(list);
                // Particles stored in bin order are read at their places (every binning gathered
                // them), without `order`.
                match d.bin_order {
                    Some(_) => a.arg(&NULL_POINTER),
                    None => a.arg(&d.bins.order),
                };
                a.particle_state(p)
                    .arg(&p.slot)
                    .arg(&g.vel)
                    .accumulators(g)
                    .node_block_list(d)
                    .colliders(&d.colliders)
                    .sinks(d.flow.as_ref());
            })
        }
    }
}
