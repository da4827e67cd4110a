//! Per-phase GPU time from CUDA events, read back without stalling the pipeline: each substep records
//! six events on the stream (at its start and after each of the five phases: sort, p2g_init, p2g,
//! grid_update, g2p; the sort's pair is recorded back to back on substeps without a sort), and
//! `take_completed` returns only the substeps whose last event has already completed (in practice,
//! the frames the host has already waited for), leaving the rest for a later call.
//!
//! A substep run as a CUDA graph (graph.rs) records the same six events: its capture records a set
//! of placeholder events as external event-record nodes, and each launch points those nodes at a
//! fresh set from here (`begin_graphed_step`).

use super::graph::record_external;
use crate::sim::{PhaseTimings, MAX_PENDING_STEP_TIMINGS};
use anyhow::{Context, Result};
use cudarc::driver::{sys, sys::CUevent_flags, CudaContext, CudaEvent, CudaStream};
use std::collections::VecDeque;
use std::sync::Arc;

pub const EVENTS_PER_STEP: usize = 6;

type StepEvents = [CudaEvent; EVENTS_PER_STEP];

pub struct PhaseEvents {
    ctx: Arc<CudaContext>,
    pending: VecDeque<StepEvents>,
    /// Events of read substeps, for reuse (creating events costs more than recording them).
    free: Vec<StepEvents>,
    /// The events a graph capture records (kept for the solver's life: the captured graphs name them),
    /// and whether a capture is under way.
    placeholders: Option<StepEvents>,
    capturing: bool,
}

impl PhaseEvents {
    pub fn new(ctx: Arc<CudaContext>) -> PhaseEvents {
        PhaseEvents {
            ctx,
            pending: VecDeque::new(),
            free: Vec::new(),
            placeholders: None,
            capturing: false,
        }
    }

    fn new_set(&mut self) -> Result<StepEvents> {
        if let Some(events) = self.free.pop() {
            return Ok(events);
        }
        let new = || {
            self.ctx
                .new_event(Some(CUevent_flags::CU_EVENT_DEFAULT))
                .context("creating a timing event")
        };
        Ok([new()?, new()?, new()?, new()?, new()?, new()?])
    }

    fn push_pending(&mut self, events: StepEvents) {
        if self.pending.len() >= MAX_PENDING_STEP_TIMINGS {
            self.pending.pop_front();
        }
        self.pending.push_back(events);
    }

    /// Records the start of a substep.
    pub fn begin_step(&mut self, stream: &CudaStream) -> Result<()> {
        self.mark(stream, 0)
    }

    /// Records the end of phase `phase` (1..=5, step order) of the current substep; phase 0 is its
    /// start.
    pub fn mark(&mut self, stream: &CudaStream, phase: usize) -> Result<()> {
        if self.capturing {
            let placeholders = self
                .placeholders
                .as_ref()
                .context("a graph capture without its timing events")?;
            return record_external(&placeholders[phase], stream);
        }
        if phase == 0 {
            let events = self.new_set()?;
            self.push_pending(events);
        }
        let events = self
            .pending
            .back()
            .context("a phase ended before its substep began")?;
        events[phase].record(stream).context("recording a timing event")
    }

    /// From here to `end_capture`, the marks record the placeholder events (as graph nodes); returns
    /// them in phase order.
    pub fn begin_capture(&mut self) -> Result<[sys::CUevent; EVENTS_PER_STEP]> {
        if self.placeholders.is_none() {
            self.placeholders = Some(self.new_set()?);
        }
        self.capturing = true;
        let placeholders = self.placeholders.as_ref().context("no placeholder events")?;
        Ok(placeholders.each_ref().map(CudaEvent::cu_event))
    }

    pub fn end_capture(&mut self) {
        self.capturing = false;
    }

    /// The events a graph launch of one substep records, queued like `begin_step`'s.
    pub fn begin_graphed_step(&mut self) -> Result<&[CudaEvent]> {
        let events = self.new_set()?;
        self.push_pending(events);
        let events = self.pending.back().context("no pending timing events")?;
        Ok(events)
    }

    /// One record per completed substep, oldest first, stopping at the first incomplete one.
    pub fn take_completed(&mut self) -> Result<Vec<PhaseTimings>> {
        let mut records = Vec::new();
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
            records.push(PhaseTimings {
                steps: 1,
                grid_clear: 0.0,
                sort: ms(0)?,
                p2g_init: ms(1)?,
                p2g: ms(2)?,
                grid_update: ms(3)?,
                g2p: ms(4)?,
            });
            if let Some(done) = self.pending.pop_front() {
                self.free.push(done);
            }
        }
        Ok(records)
    }
}
