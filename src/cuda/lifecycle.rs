//! The particle lifecycle on the device (kernels/lifecycle.cu; src/sim/flow.rs is the reference): the
//! free-slot stack, its counters, the nozzle points and the sinks, and the two one-block launches
//! that settle the stack after a substep's drains and emit from it.

use super::flow::DeviceFlow;
use super::launch::{Kernel, Launcher};
use super::modules::LoadedModules;
use super::state::{DeviceState, StateArgs};
use crate::sim::Params;
use anyhow::{Context, Result};
use cudarc::driver::{LaunchConfig, PushKernelArg};

/// Threads of the one-block launches (their `__launch_bounds__`).
const ONE_BLOCK: LaunchConfig = LaunchConfig {
    grid_dim: (1, 1, 1),
    block_dim: (1024, 1, 1),
    shared_mem_bytes: 0,
};

pub struct LifecycleKernels {
    settle: Kernel,
    emit: Kernel,
}

impl LifecycleKernels {
    pub fn load(modules: &LoadedModules) -> Result<LifecycleKernels> {
        Ok(LifecycleKernels {
            settle: Kernel::load(modules, "lifecycle", "settle_free")?,
            emit: Kernel::load(modules, "lifecycle", "emit_particles")?,
        })
    }

    /// Sorts the slots this substep's drains pushed (after g2p2g).
    pub fn settle(&self, l: &Launcher, flow: &DeviceFlow) -> Result<()> {
        // SAFETY: arguments match settle_free; `free` holds `capacity` slots.
        unsafe {
            self.settle.launch(l, ONE_BLOCK, |a| {
                a.arg(&flow.free).arg(&flow.counters);
            })
        }
    }

    /// Emits a layer from each emitter whose bit is set in `mask` into free slots; where the grid
    /// already holds the next substep's scatter (`scatter_mass`), the new particles' mass is added to
    /// it, and under the fused pipeline their momentum too.
    pub fn emit(
        &self,
        l: &Launcher,
        params: &Params,
        mask: u32,
        scatter_mass: bool,
        d: &DeviceState,
    ) -> Result<()> {
        let flow = d.flow.as_ref().context("this CUDA solver has no emitters")?;
        let (p, g) = (&d.particles, &d.grid);
        let scatter_mass = u32::from(scatter_mass);
        // SAFETY: arguments match emit_particles in kernels/lifecycle.cu; the point buffers hold
        // num_points entries, the particle buffers every slot (the deformation's, or null where the
        // scene has none), `free` the capacity.
        unsafe {
            self.emit.launch(l, ONE_BLOCK, |a| {
                a.arg(&params.kernel)
                    .arg(&mask)
                    .arg(&flow.points)
                    .arg(&flow.num_points)
                    .arg(&flow.velocities)
                    .arg(&flow.clearance_sq)
                    .arg(&flow.emits)
                    .arg(&flow.last)
                    .arg(&flow.position)
                    .arg(&flow.free)
                    .arg(&flow.counters)
                    .particle_state(p)
                    .deformation(p)
                    .arg(&scatter_mass)
                    .accumulators(g)
                    .node_block_list(d);
            })
        }
    }
}
