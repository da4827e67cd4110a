//! Per-frame statistics as a device reduction (kernels/stats.cu): the host reads `STATS_BLOCKS`
//! partial records (14 KiB) instead of every particle, and sums them in a fixed order, so the
//! figures are the same on every run. The reduction and the copy are enqueued behind a frame's last
//! substeps (`request`) and arrive with them, so a frame of `mpm run` waits for the GPU once.

use super::launch::{host_kernel, Launcher};
use super::particles::DeviceParticles;
use crate::contract::{KernelParams, StatsPartial, STATS_THREADS};
use crate::sim::{Params, Summary};
use anyhow::{ensure, Context, Result};
use cudarc::driver::{CudaEvent, CudaSlice, CudaStream, LaunchConfig, PinnedHostSlice, PushKernelArg};
use std::sync::Arc;

/// Blocks of the reduction (a fixed count: the partials do not depend on the device).
pub const STATS_BLOCKS: usize = 256;
host_kernel!(StatsKernel = "stats" / "particle_stats");

/// The partials on the device and their pinned host copy.
pub struct ParticleStats {
    partials: CudaSlice<StatsPartial>,
    /// The partials' host copy, written in stream order, and the event recorded after the copy.
    host: PinnedHostSlice<StatsPartial>,
    copied: CudaEvent,
    requested: bool,
}

impl ParticleStats {
    pub fn allocate(stream: &Arc<CudaStream>) -> Result<ParticleStats> {
        let ctx = stream.context();
        Ok(ParticleStats {
            partials: stream
                .alloc_zeros::<StatsPartial>(STATS_BLOCKS)
                .context("allocating the statistics partials")?,
            // SAFETY: written by a device copy before it is read (`wait`).
            host: unsafe { ctx.alloc_pinned::<StatsPartial>(STATS_BLOCKS) }
                .context("allocating pinned memory for the statistics")?,
            copied: ctx.new_event(None).context("creating the statistics' event")?,
            requested: false,
        })
    }

    /// Enqueues the reduction of the particles as they are after the work enqueued so far, under
    /// `params` with the material table in the kernels' constant memory (`CudaSolver::use_materials`),
    /// and the copy of its partials to the host; nothing waits.
    pub fn request(
        &mut self,
        kernel: &StatsKernel,
        launcher: &Launcher,
        params: &KernelParams,
        particles: &DeviceParticles,
    ) -> Result<()> {
        let config = LaunchConfig {
            grid_dim: (STATS_BLOCKS as u32, 1, 1),
            block_dim: (STATS_THREADS as u32, 1, 1),
            shared_mem_bytes: 0,
        };
        // SAFETY: the arguments match particle_stats in kernels/stats.cu; `partials` holds one record
        // per block of this launch.
        unsafe {
            kernel.0.launch(launcher, config, |a| {
                a.arg(params)
                    .arg(&particles.x)
                    .arg(&particles.v)
                    .arg(&particles.rho)
                    .arg(&self.partials);
            })?;
        }
        let stream = &launcher.stream;
        stream.memcpy_dtoh(&self.partials, &mut self.host).context(
            "copying the statistics from the GPU (a kernel may have failed; MPM_CUDA_SYNC=1 names it)",
        )?;
        self.copied
            .record(stream)
            .context("recording the statistics' copy")?;
        self.requested = true;
        Ok(())
    }

    /// Waits for the requested statistics' copy only (its own event), and sums the partials.
    pub fn wait(&mut self) -> Result<Summary> {
        ensure!(self.requested, "statistics awaited without a request");
        self.requested = false;
        let partials = self
            .copied
            .synchronize()
            .and_then(|()| self.host.as_slice())
            .context("waiting for the statistics (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
        Ok(combine(partials))
    }
}

fn combine(partials: &[StatsPartial]) -> Summary {
    let mut ke = 0.0f64;
    let mut position = [0.0f64; 3];
    let mut density_sum = 0.0f64;
    let (mut max_speed, mut rmin, mut rmax) = (0.0f32, f32::INFINITY, f32::NEG_INFINITY);
    let mut count = 0u64;
    for p in partials {
        ke += p.kinetic_energy;
        for (sum, part) in position.iter_mut().zip(p.position_sum) {
            *sum += part;
        }
        density_sum += p.density_ratio_sum;
        max_speed = max_speed.max(p.max_speed);
        rmin = rmin.min(p.density_ratio_min);
        rmax = rmax.max(p.density_ratio_max);
        count += u64::from(p.count);
    }
    if count == 0 {
        // Every slot parked (a tank before its emitters start): zeros, as `Summary::of` gives.
        return Summary::of(&crate::sim::Particles::default(), &Params::default());
    }
    let inv_n = 1.0 / count.max(1) as f64;
    Summary {
        particles: count as usize,
        max_speed,
        density_ratio_min: rmin,
        density_ratio_mean: (density_sum * inv_n) as f32,
        density_ratio_max: rmax,
        kinetic_energy: ke,
        centre_of_mass: position.map(|p| p * inv_n),
    }
}
