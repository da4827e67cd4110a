//! kernels/ranks.cu: what the ranks of a run split over slabs (cuda_ranks.rs) do to their particles
//! on the device: count the particles that could step past their rank's ghost planes, count a
//! slab's particles by layer (for rebalancing), pack the particles a migration sends to their new
//! rank, and take every rank's own particles to their slots in the one set readers see.

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
    park_slots: Kernel,
}

impl RanksKernels {
    pub fn load(modules: &LoadedModules) -> Result<RanksKernels> {
        Ok(RanksKernels {
            count_strays: Kernel::load(modules, "ranks", "count_strays")?,
            count_layers: Kernel::load(modules, "ranks", "count_layers")?,
            move_owned: Kernel::load(modules, "ranks", "move_owned")?,
            take_owned: Kernel::load(modules, "ranks", "take_owned")?,
            park_slots: Kernel::load(modules, "ranks", "park_slots")?,
        })
    }

    /// Adds to `strays` the live particles of `x`'s first `places` whose stencil base along `axis`
    /// lies outside `keep` (`Slabs::keeps`).
    #[allow(clippy::too_many_arguments)]
    pub fn count_strays(
        &self,
        l: &Launcher,
        params: &Params,
        places: usize,
        axis: usize,
        keep: (i32, i32),
        x: &CudaSlice<f32>,
        strays: &CudaSlice<u32>,
    ) -> Result<()> {
        ensure!(
            places <= x.len() / 4,
            "counting strays in {places} places of {}",
            x.len() / 4
        );
        let (places, axis) = (places as u32, axis as u32);
        // SAFETY: the arguments match count_strays; x holds `places` float4 at least.
        unsafe {
            self.count_strays.launch(l, l.cover(places as usize), |a| {
                a.arg(&params.kernel)
                    .arg(&places)
                    .arg(&axis)
                    .arg(&keep.0)
                    .arg(&keep.1)
                    .arg(x)
                    .arg(strays);
            })
        }
    }

    /// Adds the live particles of `x`'s first `places` per block layer along `axis` (`layers` of
    /// them) to `counts`.
    #[allow(clippy::too_many_arguments)]
    pub fn count_layers(
        &self,
        l: &Launcher,
        params: &Params,
        places: usize,
        axis: usize,
        layers: u32,
        x: &CudaSlice<f32>,
        counts: &mut CudaSlice<u32>,
    ) -> Result<()> {
        ensure!(
            places <= x.len() / 4,
            "counting layers in {places} places of {}",
            x.len() / 4
        );
        let axis = axis as u32;
        // A few CUDA blocks per multiprocessor, each walking many slots: a block per 128 slots spent
        // most of its time zeroing and flushing its histogram between two barriers. Measured on the
        // H100 (BENCHMARKS.md 0y), 16.8M slots on two ranks of one GPU: 221 to 236 us a launch
        // before, 91 to 95 after.
        let config = l.over_list(&self.count_layers, places, places, l.block_size, 4 * layers)?;
        let places = places as u32;
        // SAFETY: the arguments match count_layers; x holds `places` float4 at least, counts
        // `layers` u32, and the shared histogram is sized for them.
        unsafe {
            self.count_layers.launch(l, config, |a| {
                a.arg(&params.kernel)
                    .arg(&places)
                    .arg(&axis)
                    .arg(&layers)
                    .arg(x)
                    .arg(counts);
            })
        }
    }

    /// Packs the particles live in `from`'s first `walk` places whose block layer lies in `slab`
    /// (axis, layers of the grid, the receiving rank's layers) into `to`'s places `places` (the
    /// sender's buffer for that receiver, on the same GPU) and parks them in `from`, counting them in
    /// `moved`.
    #[allow(clippy::too_many_arguments)]
    pub fn move_owned(
        &self,
        l: &Launcher,
        params: &Params,
        (axis, layers, mine): (usize, u32, Range<u32>),
        (from, walk): (&DeviceParticles, usize),
        (to, places): (&DeviceParticles, Range<usize>),
        moved: &mut CudaSlice<u32>,
    ) -> Result<()> {
        ensure!(
            params.num_particles as usize == from.count && walk <= from.count && places.end <= to.count,
            "a migration of {walk} of {} places into {places:?} of {}",
            from.count,
            to.count
        );
        ensure!(
            from.deformation.is_some() == to.deformation.is_some(),
            "a migration into a set that differs in carrying a deformation"
        );
        let axis = axis as u32;
        let (walk, to_count) = (walk as u32, to.count as u32);
        let (first, end) = (places.start as u32, places.end as u32);
        // SAFETY: the arguments match move_owned; `from` holds num_particles places of each array
        // (walk of them read), `to` to_count, and the kernel writes only to_first..to_end of them.
        unsafe {
            self.move_owned.launch(l, l.cover(walk as usize), |a| {
                a.arg(&params.kernel)
                    .arg(&axis)
                    .arg(&layers)
                    .arg(&mine.start)
                    .arg(&mine.end)
                    .arg(&walk)
                    .particle_state(from)
                    .arg(&from.slot)
                    .deformation(from)
                    .arg(&to_count)
                    .arg(&first)
                    .arg(&end)
                    .particle_state(to)
                    .arg(&to.slot)
                    .deformation(to)
                    .arg(moved);
            })
        }
    }

    /// Copies the particles live in the first `places` of `rank` to their slots in `out`.
    pub fn take_owned(
        &self,
        l: &Launcher,
        rank: &DeviceParticles,
        places: usize,
        out: &DeviceParticles,
    ) -> Result<()> {
        ensure!(places <= rank.count, "taking {places} places of {}", rank.count);
        ensure!(
            rank.deformation.is_some() == out.deformation.is_some(),
            "taking particles into a set that differs in carrying a deformation"
        );
        let (walk, count, out_count) = (places as u32, rank.count as u32, out.count as u32);
        // SAFETY: the arguments match take_owned; `rank` holds `count` places of each array (the
        // first `walk` read), `out` `out_count` slots, and the kernel skips a slot past them.
        unsafe {
            self.take_owned.launch(l, l.cover(places), |a| {
                a.arg(&walk)
                    .arg(&count)
                    .particle_state(rank)
                    .arg(&rank.slot)
                    .deformation(rank)
                    .arg(&out_count)
                    .particle_state(out)
                    .deformation(out);
            })
        }
    }

    /// Parks every slot of `set` (cuda_ranks.rs: the readers' set of a run with emitters or sinks,
    /// before the ranks take their particles to it).
    pub fn park_slots(&self, l: &Launcher, set: &DeviceParticles) -> Result<()> {
        let count = set.count as u32;
        // SAFETY: the arguments match park_slots; x holds `count` float4.
        unsafe {
            self.park_slots.launch(l, l.cover(set.count), |a| {
                a.arg(&count).arg(&set.x);
            })
        }
    }
}
