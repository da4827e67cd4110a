//! Per-phase GPU time from CUDA events, read back without stalling the pipeline: each substep records
//! an event on the stream at its start and one at the end of each phase the GPU runs
//! (`Phase::runs_on_gpu`) that has work that substep; a phase without (the sort between binnings, the
//! fused pipeline's p2g) records none and reads 0, the next phase's time running from the last event
//! recorded. `take_completed` returns only the substeps whose last event has already completed (in
//! practice, the frames the host has already waited for), leaving the rest for a later call. An event
//! costs about 1.3 us of a graph's critical path on the H100 (an empty phase's pair read 0.0013 ms),
//! a few per cent of a small scene's substep.
//!
//! A substep run as a CUDA graph (graph.rs) records the same events: its capture records a set of
//! placeholder events as external event-record nodes, and each launch points those nodes at a fresh
//! set from here (`begin_graphed_step`).
//!
//! **Sampled phases.** Each event recorded is a node on the substep's critical path, so a solver
//! may time the phases of one substep in `sample` only (`CudaOptions::phase_sample`): the others
//! record their start and their end alone and read as one whole substep
//! (`PhaseTimings::unphased_ms`), so every substep's time is still measured and the phase table
//! comes from the sampled ones.

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

/// The slot of the event at a substep's end: the last phase's.
const END: usize = EVENTS_PER_STEP - 1;

/// Which of a substep's events were recorded (its start always is).
pub type Recorded = [bool; EVENTS_PER_STEP];

pub struct PhaseEvents {
    ctx: Arc<CudaContext>,
    /// Each substep's events, which of them it recorded, and whether it timed its phases.
    pending: VecDeque<(StepEvents, Recorded, bool)>,
    /// Events of read substeps, for reuse (creating events costs more than recording them).
    free: Vec<StepEvents>,
    /// The events a graph capture records (kept for the solver's life: the captured graphs name them),
    /// whether a capture is under way, and which of them it recorded.
    placeholders: Option<StepEvents>,
    capturing: bool,
    captured: Recorded,
    /// One substep in `sample` times its phases; substeps begun so far (a capture begins none); and
    /// whether the substep being enqueued times its phases.
    sample: u64,
    begun: u64,
    phased: bool,
}

impl PhaseEvents {
    /// Events that time the phases of one substep in `sample` (every substep's for 1 or 0).
    pub fn new(ctx: Arc<CudaContext>, sample: u32) -> PhaseEvents {
        PhaseEvents {
            ctx,
            pending: VecDeque::new(),
            free: Vec::new(),
            placeholders: None,
            capturing: false,
            captured: [false; EVENTS_PER_STEP],
            sample: u64::from(sample.max(1)),
            begun: 0,
            phased: true,
        }
    }

    /// Whether the next substep begun times its phases (a graph key holds it: graph.rs).
    pub fn phases_next(&self) -> bool {
        self.begun % self.sample == 0
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

    fn push_pending(&mut self, events: StepEvents, recorded: Recorded) {
        if self.pending.len() >= MAX_PENDING_STEP_TIMINGS {
            self.pending.pop_front();
        }
        self.phased = self.phases_next();
        self.begun += 1;
        self.pending.push_back((events, recorded, self.phased));
    }

    /// Records the substep's start (outside a capture, on a fresh set of events; a capture's
    /// substep times its phases where the next substep begun would).
    pub fn begin_step(&mut self, stream: &CudaStream) -> Result<()> {
        if self.capturing {
            self.phased = self.phases_next();
        } else {
            let events = self.new_set()?;
            self.push_pending(events, [false; EVENTS_PER_STEP]);
        }
        self.record(stream, 0)
    }

    /// Records the end of `phase`, where it `ran` any work this substep and the substep times its
    /// phases; a phase that did not run takes no event and reads 0.
    pub fn end_phase(&mut self, stream: &CudaStream, phase: Phase, ran: bool) -> Result<()> {
        let slot = timed_phases()
            .find(|&(timed, _)| timed == phase)
            .map(|(_, slot)| slot)
            .with_context(|| format!("the GPU runs no phase {}", phase.name()))?;
        if ran && self.phased {
            self.record(stream, slot)?;
        }
        Ok(())
    }

    /// Records the end of a substep that does not time its phases (one that does ended with its
    /// last phase).
    pub fn end_step(&mut self, stream: &CudaStream) -> Result<()> {
        match self.phased {
            true => Ok(()),
            false => self.record(stream, END),
        }
    }

    fn record(&mut self, stream: &CudaStream, slot: usize) -> Result<()> {
        if self.capturing {
            let placeholders = self
                .placeholders
                .as_ref()
                .context("a graph capture without its timing events")?;
            self.captured[slot] = true;
            return record_external(&placeholders[slot], stream);
        }
        let (events, recorded, _) = self
            .pending
            .back_mut()
            .context("a phase ended before its substep began")?;
        recorded[slot] = true;
        events[slot].record(stream).context("recording a timing event")
    }

    /// Starts a graph capture: the phases record the placeholder events (returned, in slot order) as
    /// external event-record nodes.
    pub fn begin_capture(&mut self) -> Result<[sys::CUevent; EVENTS_PER_STEP]> {
        if self.placeholders.is_none() {
            self.placeholders = Some(self.new_set()?);
        }
        self.capturing = true;
        self.captured = [false; EVENTS_PER_STEP];
        let placeholders = self.placeholders.as_ref().context("no placeholder events")?;
        Ok(placeholders.each_ref().map(CudaEvent::cu_event))
    }

    /// Which placeholders the capture under way has recorded so far.
    pub fn captured(&self) -> Recorded {
        self.captured
    }

    pub fn end_capture(&mut self) {
        self.capturing = false;
    }

    /// A fresh set of events for one launch of a graph that records the slots `recorded`.
    pub fn begin_graphed_step(&mut self, recorded: Recorded) -> Result<&[CudaEvent]> {
        let events = self.new_set()?;
        self.push_pending(events, recorded);
        let (events, _, _) = self.pending.back().context("no pending timing events")?;
        Ok(events)
    }

    /// The per-phase times of every substep whose events have all completed, oldest first.
    pub fn take_completed(&mut self) -> Result<Vec<PhaseTimings>> {
        let mut records = Vec::new();
        while let Some((events, recorded, phased)) = self.pending.front() {
            let last = (0..EVENTS_PER_STEP)
                .rev()
                .find(|&slot| recorded[slot])
                .unwrap_or(0);
            if !events[last]
                .try_is_complete()
                .context("querying a timing event")?
            {
                break;
            }
            let elapsed = |from: usize, to: usize| {
                events[from]
                    .elapsed_ms(&events[to])
                    .map(f64::from)
                    .context("reading a timing event")
            };
            let record = match *phased {
                true => {
                    let mut record = PhaseTimings::one_step();
                    let mut since = 0;
                    for (phase, end) in timed_phases().filter(|&(_, end)| recorded[end]) {
                        record[phase] = elapsed(since, end)?;
                        since = end;
                    }
                    record
                }
                false => PhaseTimings::one_unphased_step(elapsed(0, last)?),
            };
            records.push(record);
            if let Some((done, _, _)) = self.pending.pop_front() {
                self.free.push(done);
            }
        }
        Ok(records)
    }
}

/// Records `event` on `stream` as an external event: during a capture it becomes an event-record node
/// of the graph (a plain record there would only order the capture), outside one a normal record.
pub fn record_external(event: &CudaEvent, stream: &CudaStream) -> Result<()> {
    // SAFETY: the event and the stream are live and of the current context.
    unsafe {
        sys::cuEventRecordWithFlags(
            event.cu_event(),
            stream.cu_stream(),
            sys::CUevent_record_flags::CU_EVENT_RECORD_EXTERNAL as u32,
        )
    }
    .result()
    .context("recording a timing event")
}
