//! Per-phase GPU time from CUDA events, read back without stalling the pipeline: each substep records
//! five events on the stream (before p2g_init and after each of the four phases), and
//! `take_completed` sums only the substeps whose last event has already completed (in practice, the
//! frames the host has already waited for), leaving the rest for a later call.

use crate::sim::PhaseTimings;
use anyhow::{Context, Result};
use cudarc::driver::{sys::CUevent_flags, CudaContext, CudaEvent, CudaStream};
use std::collections::VecDeque;
use std::sync::Arc;

const EVENTS_PER_STEP: usize = 5;
/// Substeps whose events may wait to be read; beyond that the oldest are dropped (a caller that never
/// takes timings must not grow memory without bound).
const MAX_PENDING_STEPS: usize = 1 << 14;

type StepEvents = [CudaEvent; EVENTS_PER_STEP];

pub struct PhaseEvents {
    ctx: Arc<CudaContext>,
    pending: VecDeque<StepEvents>,
    /// Events of read substeps, for reuse (creating events costs more than recording them).
    free: Vec<StepEvents>,
}

impl PhaseEvents {
    pub fn new(ctx: Arc<CudaContext>) -> PhaseEvents {
        PhaseEvents {
            ctx,
            pending: VecDeque::new(),
            free: Vec::new(),
        }
    }

    /// Records the start of a substep.
    pub fn begin_step(&mut self, stream: &CudaStream) -> Result<()> {
        let events = match self.free.pop() {
            Some(events) => events,
            None => {
                let new = || {
                    self.ctx
                        .new_event(Some(CUevent_flags::CU_EVENT_DEFAULT))
                        .context("creating a timing event")
                };
                [new()?, new()?, new()?, new()?, new()?]
            }
        };
        events[0].record(stream).context("recording a timing event")?;
        if self.pending.len() >= MAX_PENDING_STEPS {
            self.pending.pop_front();
        }
        self.pending.push_back(events);
        Ok(())
    }

    /// Records the end of phase `phase` (1..=4) of the current substep.
    pub fn mark(&mut self, stream: &CudaStream, phase: usize) -> Result<()> {
        let events = self
            .pending
            .back()
            .context("a phase ended before its substep began")?;
        events[phase].record(stream).context("recording a timing event")
    }

    /// Sums the phases of every completed substep, oldest first, stopping at the first incomplete one.
    pub fn take_completed(&mut self) -> Result<PhaseTimings> {
        let mut timings = PhaseTimings::default();
        while let Some(events) = self.pending.front() {
            if !events[EVENTS_PER_STEP - 1]
                .try_is_complete()
                .context("querying a timing event")?
            {
                break;
            }
            let ms = |a: usize| -> Result<f64> {
                Ok(f64::from(
                    events[a]
                        .elapsed_ms(&events[a + 1])
                        .context("reading a timing event")?,
                ))
            };
            // grid_clear stays 0: grid_update clears the accumulators it reads (consume-and-zero).
            timings.p2g_init += ms(0)?;
            timings.p2g += ms(1)?;
            timings.grid_update += ms(2)?;
            timings.g2p += ms(3)?;
            timings.steps += 1;
            if let Some(done) = self.pending.pop_front() {
                self.free.push(done);
            }
        }
        Ok(timings)
    }
}
