//! kernels/ranks.cu: what the ranks of a run split over slabs (cuda_ranks.rs) do to their particles
//! on the device: count the particles that could step past their rank's ghost planes, count a
//! slab's particles by layer (for rebalancing), move the slots a migration sends, and gather every
//! rank's own slots into the one set readers see.

use super::launch::{Kernel, Launcher};
use super::modules::LoadedModules;
use super::particles::DeviceParticles;
use super::state::StateArgs;
use crate::sim::Params;
use anyhow::{ensure, Result};
use cudarc::driver::{CudaSlice, PushKernelArg};
use std::ops::Range;

/// The kernels of kernels/ranks.cu.
pub struct RanksKernels {
    count_strays: Kernel,
    count_layers: Kernel,
    move_owned: Kernel,
    take_owned: Kernel,
}

impl RanksKernels {
    pub fn load(modules: &LoadedModules) -> Result<RanksKernels> {
        Ok(RanksKernels {
            count_strays: Kernel::load(modules, "ranks", "count_strays")?,
            count_layers: Kernel::load(modules, "ranks", "count_layers")?,
            move_owned: Kernel::load(modules, "ranks", "move_owned")?,
            take_owned: Kernel::load(modules, "ranks", "take_owned")?,
        })
    }

    /// Adds to `strays` the live particles of `x` whose stencil base along `axis` lies outside
    /// `keep` (`Slabs::keeps`).
    pub fn count_strays(
        &self,
        l: &Launcher,
        params: &Params,
        axis: usize,
        keep: (i32, i32),
        x: &CudaSlice<f32>,
        strays: &CudaSlice<u32>,
    ) -> Result<()> {
        let axis = axis as u32;
        // SAFETY: the arguments match count_strays; x holds num_particles float4.
        unsafe {
            self.count_strays
                .launch(l, l.cover(params.num_particles as usize), |a| {
                    a.arg(&params.kernel)
                        .arg(&axis)
                        .arg(&keep.0)
                        .arg(&keep.1)
                        .arg(x)
                        .arg(strays);
                })
        }
    }

    /// Adds the live particles of `x` per block layer along `axis` (`layers` of them) to `counts`.
    pub fn count_layers(
        &self,
        l: &Launcher,
        params: &Params,
        axis: usize,
        layers: u32,
        x: &CudaSlice<f32>,
        counts: &mut CudaSlice<u32>,
    ) -> Result<()> {
        let axis = axis as u32;
        // A few CUDA blocks per multiprocessor, each walking many slots: a block per 128 slots spent
        // most of its time zeroing and flushing its histogram between two barriers. Measured on the
        // H100 (BENCHMARKS.md 0y), 16.8M slots on two ranks of one GPU: 221 to 236 us a launch
        // before, 91 to 95 after.
        let config = l.over_list(
            &self.count_layers,
            params.num_particles as usize,
            params.num_particles as usize,
            l.block_size,
            4 * layers,
        )?;
        // SAFETY: the arguments match count_layers; x holds num_particles float4, counts `layers`
        // u32, and the shared histogram is sized for them.
        unsafe {
            self.count_layers.launch(l, config, |a| {
                a.arg(&params.kernel).arg(&axis).arg(&layers).arg(x).arg(counts);
            })
        }
    }

    /// Moves the slots live in `from` whose block layer lies in `slab` (axis, layers of the grid,
    /// the receiving rank's layers) to `to`, which may lie on another GPU, counting them in `moved`.
    pub fn move_owned(
        &self,
        l: &Launcher,
        params: &Params,
        (axis, layers, mine): (usize, u32, Range<u32>),
        from: &DeviceParticles,
        to: &DeviceParticles,
        moved: &mut CudaSlice<u32>,
    ) -> Result<()> {
        ensure!(from.count == to.count, "{} slots for {}", from.count, to.count);
        let axis = axis as u32;
        // SAFETY: the arguments match move_owned; both hold num_particles slots of each array.
        unsafe {
            self.move_owned
                .launch(l, l.cover(params.num_particles as usize), |a| {
                    a.arg(&params.kernel)
                        .arg(&axis)
                        .arg(&layers)
                        .arg(&mine.start)
                        .arg(&mine.end)
                        .particle_state(from)
                        .particle_state(to)
                        .arg(moved);
                })
        }
    }

    /// Copies the slots live in `rank` into `out` (as many slots), which may lie on another GPU.
    pub fn take_owned(&self, l: &Launcher, rank: &DeviceParticles, out: &DeviceParticles) -> Result<()> {
        ensure!(rank.count == out.count, "{} slots for {}", rank.count, out.count);
        let n = rank.count as u32;
        // SAFETY: the arguments match take_owned; both hold `count` slots of each array.
        unsafe {
            self.take_owned.launch(l, l.cover(rank.count), |a| {
                a.arg(&n).particle_state(rank).particle_state(out);
            })
        }
    }
}
