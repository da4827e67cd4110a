//! Per-phase GPU time from CUDA events, read back without stalling the pipeline: each substep records
//! an event on the stream at its start and one at the end of each phase the GPU runs
//! (`Phase::runs_on_gpu`; a phase with no work that substep, such as the sort between binnings, gets
//! its pair back to back), and `take_completed` returns only the substeps whose last event has already
//! completed (in practice, the frames the host has already waited for), leaving the rest for a later
//! call.
//!
//! A substep run as a CUDA graph (graph.rs) records the same events: its capture records a set of
//! placeholder events as external event-record nodes, and each launch points those nodes at a fresh
//! set from here (`begin_graphed_step`).

use super::graph::record_external;
use crate::sim::{Phase, PhaseTimings, MAX_PENDING_STEP_TIMINGS};
use anyhow::{anyhow, Context, Result};
use cudarc::driver::{sys, sys::CUevent_flags, CudaContext, CudaEvent, CudaStream};
use std::collections::VecDeque;
use std::sync::Arc;

/// The events of one substep: its start, then the end of each phase the GPU runs.
pub const EVENTS_PER_STEP: usize = 1 + gpu_phases();

const fn gpu_phases() -> usize {
    let (mut count, mut i) = (0, 0);
    while i < Phase::COUNT {
        if Phase::ALL[i].runs_on_gpu() {
            count += 1;
        }
        i += 1;
    }
    count
}

/// The phases the GPU times, in step order, each with the slot of the event at its end (slot 0 is
/// the substep's start, so the phase spans its slot's predecessor to its slot).
fn timed_phases() -> impl Iterator<Item = (Phase, usize)> {
    Phase::ALL
        .into_iter()
        .filter(|phase| phase.runs_on_gpu())
        .zip(1..)
}

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
        let events: Vec<CudaEvent> = (0..EVENTS_PER_STEP).map(|_| new()).collect::<Result<_>>()?;
        events
            .try_into()
            .map_err(|_| anyhow!("a timing event set of the wrong size"))
    }

    fn push_pending(&mut self, events: StepEvents) {
        if self.pending.len() >= MAX_PENDING_STEP_TIMINGS {
            self.pending.pop_front();
        }
        self.pending.push_back(events);
    }

    /// Records the start of a substep.
    pub fn begin_step(&mut self, stream: &CudaStream) -> Result<()> {
        if !self.capturing {
            let events = self.new_set()?;
            self.push_pending(events);
        }
        self.record(stream, 0)
    }

    /// Records the end of `phase` in the current substep.
    pub fn end_phase(&mut self, stream: &CudaStream, phase: Phase) -> Result<()> {
        let slot = timed_phases()
            .find(|&(timed, _)| timed == phase)
            .map(|(_, slot)| slot)
            .with_context(|| format!("the GPU runs no phase {}", phase.name()))?;
        self.record(stream, slot)
    }

    fn record(&mut self, stream: &CudaStream, slot: usize) -> Result<()> {
        if self.capturing {
            let placeholders = self
                .placeholders
                .as_ref()
                .context("a graph capture without its timing events")?;
            return record_external(&placeholders[slot], stream);
        }
        let events = self
            .pending
            .back()
            .context("a phase ended before its substep began")?;
        events[slot].record(stream).context("recording a timing event")
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
            let mut record = PhaseTimings::one_step();
            for (phase, end) in timed_phases() {
                let ms = events[end - 1]
                    .elapsed_ms(&events[end])
                    .context("reading a timing event")?;
                record[phase] = f64::from(ms);
            }
            records.push(record);
            if let Some(done) = self.pending.pop_front() {
                self.free.push(done);
            }
        }
        Ok(records)
    }
}
