//! The particle lifecycle on the device (kernels/lifecycle.cu; src/sim/flow.rs is the reference): the
//! free-slot stack, its counters, the nozzle points and the sinks, and the two one-block launches
//! that settle the stack after a substep's drains and emit from it; on the ranks of a run, each
//! rank's look at the nozzle points' last particles and its part of an emission (`RankEmission`).

use super::flow::DeviceFlow;
use super::launch::{Kernel, Launcher, OptionalArg};
use super::modules::LoadedModules;
use super::particles::DeviceParticles;
use super::state::{DeviceState, StateArgs};
use crate::sim::flow::NO_PARTICLE;
use crate::sim::Params;
use anyhow::{ensure, Context, Result};
use cudarc::driver::{CudaSlice, LaunchConfig, PushKernelArg};
use std::ops::Range;

/// Threads of the one-block launches (their `__launch_bounds__`).
const ONE_BLOCK: LaunchConfig = LaunchConfig {
    grid_dim: (1, 1, 1),
    block_dim: (1024, 1, 1),
    shared_mem_bytes: 0,
};

pub struct LifecycleKernels {
    settle: Kernel,
    emit: Kernel,
    nozzles_blocked: Kernel,
}

/// A rank's part of an emission that every rank of a run runs alike (kernels/lifecycle.cu): the
/// nozzle points every rank's look found blocked, which particles are its own, and where they go.
pub struct RankEmission<'a> {
    /// Per nozzle point, 1 where a rank found its last particle live and within the clearance.
    pub blocked: &'a CudaSlice<u32>,
    /// The slab axis, the grid's block layers along it, and the rank's.
    pub axis: usize,
    pub layers: u32,
    pub own: Range<u32>,
    /// The rank's places in use: its new particles go after them, counted in `appended`.
    pub append_at: usize,
    pub appended: &'a CudaSlice<u32>,
}

impl LifecycleKernels {
    pub fn load(modules: &LoadedModules) -> Result<LifecycleKernels> {
        Ok(LifecycleKernels {
            settle: Kernel::load(modules, "lifecycle", "settle_free")?,
            emit: Kernel::load(modules, "lifecycle", "emit_particles")?,
            nozzles_blocked: Kernel::load(modules, "lifecycle", "nozzles_blocked")?,
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
    /// it, and under the fused pipeline their momentum too. On a rank, `rank` says which of them are
    /// its own and where they go.
    pub fn emit(
        &self,
        l: &Launcher,
        params: &Params,
        mask: u32,
        scatter_mass: bool,
        d: &DeviceState,
        rank: Option<&RankEmission>,
    ) -> Result<()> {
        let flow = d.flow.as_ref().context("this CUDA solver has no emitters")?;
        let (p, g) = (&d.particles, &d.grid);
        let scatter_mass = u32::from(scatter_mass);
        // One GPU: no looks to take, one layer that holds every particle, each at its slot's place.
        let (axis, layers, own, append_at) = match rank {
            Some(r) => {
                ensure!(
                    r.append_at + flow.num_points as usize <= p.count,
                    "a rank emitting after {} of its {} places has no room for {} nozzle points",
                    r.append_at,
                    p.count,
                    flow.num_points
                );
                (r.axis as u32, r.layers, r.own.clone(), r.append_at as u32)
            }
            None => (0, 1, 0..1, NO_PARTICLE),
        };
        // SAFETY: arguments match emit_particles in kernels/lifecycle.cu; the point buffers and
        // `blocked` hold num_points entries, the particle buffers every place (the deformation's, or
        // null where the scene has none), `position` and `free` the run's slots; a rank's new
        // particles fit after `append_at` (checked above).
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
                    .arg_or_null(rank.map(|r| r.blocked))
                    .arg(&axis)
                    .arg(&layers)
                    .arg(&own.start)
                    .arg(&own.end)
                    .arg(&append_at)
                    .arg_or_null(rank.map(|r| r.appended))
                    .particle_state(p)
                    .arg(&p.slot)
                    .deformation(p)
                    .arg(&scatter_mass)
                    .accumulators(g)
                    .node_block_list(d);
            })
        }
    }

    /// A rank's look at the nozzle points of the emitters in `mask` (nozzles_blocked): into
    /// `blocked`, 1 where a point's last particle is live among `particles`' first `places` and
    /// within the clearance.
    pub fn nozzles_blocked(
        &self,
        l: &Launcher,
        mask: u32,
        flow: &DeviceFlow,
        (particles, places): (&DeviceParticles, usize),
        blocked: &mut CudaSlice<u32>,
    ) -> Result<()> {
        let points = flow.num_points as usize;
        ensure!(
            blocked.len() >= points && places <= particles.count,
            "looking at {points} nozzle points among {places} of {} places",
            particles.count
        );
        let places = places as u32;
        // SAFETY: arguments match nozzles_blocked; the point buffers and `blocked` hold num_points
        // entries, `position` the run's slots, the particle buffers `count` places (`places` read).
        unsafe {
            self.nozzles_blocked.launch(l, l.cover(points), |a| {
                a.arg(&mask)
                    .arg(&flow.points)
                    .arg(&flow.num_points)
                    .arg(&flow.clearance_sq)
                    .arg(&flow.last)
                    .arg(&flow.position)
                    .arg(&places)
                    .arg(&particles.x)
                    .arg(&particles.slot)
                    .arg(blocked);
            })
        }
    }
}
