//! What the kernels count and reduce between substep choices (`StepCounters`, src/contract/items.rs),
//! and the ring of pinned host copies it travels back in without stalling the stream.

use crate::contract::StepCounters;
use crate::sim::{Params, StepExtremes};
use anyhow::{bail, Context, Result};
use cudarc::driver::{CudaContext, CudaEvent, CudaSlice, CudaStream, PinnedHostSlice};
use std::sync::Arc;

/// Host copies in the ring: more than the two requests `Solver` allows outstanding.
const COUNTER_COPIES: usize = 3;

/// What an overflow of the explicit solver's fixed-point scatter advises.
pub const EXPLICIT_OVERFLOW_FIX: &str = "the fluid is moving far faster than expected, or blowing up. Lower the \
     CFL number; the report pipeline's float scatter (solver.pipeline = \"report\", solver.scatter = \"float\") \
     has no such bound";

/// What one read of the counters says beyond the extremes: the binned pipeline's bookkeeping.
pub struct CounterReading {
    pub extremes: StepExtremes,
    /// A kernel flagged a particle that moved past its bin's reach.
    pub rebin_needed: bool,
    /// Particles scattered outside their tile (by global atomics).
    pub tile_misses: u64,
}

pub struct CounterRing {
    /// The device words the kernels reduce into; reset after each copy.
    pub device: CudaSlice<StepCounters>,
    /// Pinned host copies, one per outstanding request, each with the event recorded after its copy.
    /// (cudarc's pinned slices carry an event of their own, but record it only where cudarc tracks
    /// events between streams, which a one-stream solver turns off: waiting on it returned before the
    /// copy had landed.)
    copies: Vec<(PinnedHostSlice<StepCounters>, CudaEvent)>,
    next_copy: usize,
}

impl CounterRing {
    pub fn allocate(ctx: &Arc<CudaContext>, stream: &Arc<CudaStream>) -> Result<CounterRing> {
        Ok(CounterRing {
            device: stream
                .alloc_zeros::<StepCounters>(1)
                .context("allocating the step counters")?,
            copies: (0..COUNTER_COPIES)
                .map(|_| {
                    // SAFETY: each copy is written by a device copy before it is read (`wait`).
                    let copy = unsafe { ctx.alloc_pinned::<StepCounters>(1) }?;
                    Ok((copy, ctx.new_event(None)?))
                })
                .collect::<Result<_, cudarc::driver::DriverError>>()
                .context("allocating pinned memory for the step counters")?,
            next_copy: 0,
        })
    }

    /// Copies the counters to a pinned host slot and resets them, both in stream order behind the
    /// work enqueued so far; nothing waits. Returns the slot to `wait` on.
    pub fn request(&mut self, stream: &Arc<CudaStream>) -> Result<usize> {
        let slot = self.next_copy;
        self.next_copy = (slot + 1) % COUNTER_COPIES;
        let (copy, copied) = &mut self.copies[slot];
        stream
            .memcpy_dtoh(&self.device, copy)
            .context("copying the step counters (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
        copied.record(stream).context("recording the counters' copy")?;
        stream
            .memset_zeros(&mut self.device)
            .context("resetting the step counters")?;
        Ok(slot)
    }

    /// Whether that slot's copy has landed, without waiting.
    pub fn copied(&self, slot: usize) -> Result<bool> {
        let (_, copied) = self
            .copies
            .get(slot)
            .context("an extremes ticket of another solver")?;
        copied
            .try_is_complete()
            .context("querying the step counters' copy (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")
    }

    /// Waits for that slot's copy only (its own event), not for the whole stream. `params` gives the
    /// fixed-point scales an overflow report names, `fix` what it advises ([`EXPLICIT_OVERFLOW_FIX`],
    /// or the position-based solver's).
    pub fn wait(&self, slot: usize, params: &Params, fix: &str) -> Result<CounterReading> {
        let (copy, copied) = self
            .copies
            .get(slot)
            .context("an extremes ticket of another solver")?;
        let waited = copied.synchronize().and_then(|()| copy.as_slice());
        let counters = waited
            .context("waiting for the step counters (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?
            .first()
            .context("an empty copy of the step counters")?;
        let overflows = counters.fixed_overflows;
        if overflows > 0 {
            bail!(
                "the fixed-point scatter overflowed {overflows} times since the last frame (a grid \
                 contribution or sum left the 64-bit range at {:.3e} units/kg, {:.3e} units/(kg m/s), \
                 or a shared tile's 32-bit sum may have wrapped); {fix}",
                params.fixed_mass_scale,
                params.fixed_momentum_scale
            );
        }
        Ok(CounterReading {
            extremes: StepExtremes {
                max_density: f32::from_bits(counters.max_density_bits),
                max_speed: f32::from_bits(counters.max_speed_bits),
                max_signal_speed: f32::from_bits(counters.max_signal_bits),
                backstop_pushes: u64::from(counters.backstop_pushes),
            },
            rebin_needed: counters.rebin_needed != 0,
            tile_misses: u64::from(counters.tile_misses),
        })
    }
}
