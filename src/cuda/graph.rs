//! The substep as a CUDA graph. Launching a substep's ten-odd kernels, memsets and timing events one
//! by one costs the host more than the GPU takes to run them at small particle counts, so the GPU
//! waits on the host between kernels. A graph is one launch for the whole substep.
//!
//! A substep is captured (stream capture) the first time it is enqueued with a given `Params`, sort
//! decision and mass-scatter state, and replayed for every later substep with the same key: a stretch
//! of substeps shares its dt, so a frame captures at most two graphs (with and without the sort) and
//! replays them. The timing events are external event-record nodes, pointed at a fresh set of events
//! before each launch, so every substep keeps its per-phase CUDA-event timings.

use super::solver::Scattered;
use super::timing::Recorded;
use crate::sim::Params;
use anyhow::{bail, Context, Result};
use cudarc::driver::{sys, CudaEvent, CudaGraph, CudaStream};
use std::collections::VecDeque;
use std::sync::Arc;

/// Graphs kept: the current stretch's four (with and without the sort, from either set of particle
/// buffers where the particles are kept in bin order) and the previous stretch's.
const CACHED_GRAPHS: usize = 8;

/// What decides the work a substep enqueues; equal keys enqueue identical work.
#[derive(Clone, Copy)]
pub struct SubstepKey {
    pub params: Params,
    pub sort: bool,
    pub mass_scattered: Option<Scattered>,
    /// Colliders the kernels loop over (their states are read from device memory, updated between
    /// launches; the count is a kernel argument).
    pub colliders: u32,
    /// Which of the solver's two sets of particle buffers the substep starts on
    /// (`DeviceState::particle_buffers`).
    pub particle_buffers: bool,
}

impl PartialEq for SubstepKey {
    /// Params compared bit for bit: the kernels get exactly these bytes.
    fn eq(&self, other: &SubstepKey) -> bool {
        bytemuck::bytes_of(&self.params) == bytemuck::bytes_of(&other.params)
            && self.sort == other.sort
            && self.mass_scattered == other.mass_scattered
            && self.colliders == other.colliders
            && self.particle_buffers == other.particle_buffers
    }
}

/// One captured and instantiated substep.
pub struct SubstepGraph {
    graph: CudaGraph,
    /// Per timing slot, the event-record node of its placeholder event; none for a phase that had no
    /// work in the captured substep (timing.rs).
    timing_nodes: Vec<Option<sys::CUgraphNode>>,
    recorded: Recorded,
    /// What the grid holds of a scatter once the substep has run (`CudaSolver`'s host-side note,
    /// which the next substep's key and grid update read): set by the captured run, restored by each
    /// replay. Not a replay's own to work out again: the key that found the graph fixes it.
    scattered: Option<Scattered>,
}

// SAFETY: a graph and its nodes are driver handles, which the driver lets any thread use while the
// graph's context is current there (`Solver::bind_to_thread`, called by a thread before it steps).
// Send but not Sync: the solver that owns the graph may move to another thread (the viewer steps on
// a worker while its main thread draws), but only one thread uses it at a time.
unsafe impl Send for SubstepGraph {}

impl SubstepGraph {
    /// Captures what `enqueue` puts on `stream` into a graph. `timing_events` are the events that
    /// `enqueue` may record as external event-record nodes (`timing::record_external`), in slot order; it
    /// returns which it recorded, and what the grid holds of a scatter after the substep.
    pub fn capture(
        stream: &Arc<CudaStream>,
        timing_events: &[sys::CUevent],
        enqueue: impl FnOnce() -> Result<(Recorded, Option<Scattered>)>,
    ) -> Result<SubstepGraph> {
        stream
            .begin_capture(sys::CUstreamCaptureMode::CU_STREAM_CAPTURE_MODE_THREAD_LOCAL)
            .context("starting to capture the substep as a CUDA graph")?;
        // The capture must end whatever `enqueue` did, or the stream stays in capture mode.
        let enqueued = enqueue();
        let ended = stream.end_capture(sys::CUgraphInstantiate_flags(0));
        let (recorded, scattered) = enqueued.context("enqueueing the substep into a CUDA graph capture")?;
        let graph = ended
            .context("capturing the substep as a CUDA graph (MPM_CUDA_GRAPHS=0 runs without graphs)")?
            .context("the substep's CUDA graph capture recorded nothing")?;
        let nodes = event_record_nodes(graph.cu_graph())?;
        let mut timing_nodes = Vec::with_capacity(timing_events.len());
        for (event, &was_recorded) in timing_events.iter().zip(&recorded) {
            let node = nodes.iter().find(|(_, e)| e == event).map(|&(node, _)| node);
            if was_recorded && node.is_none() {
                bail!("the substep's CUDA graph lost a timing event");
            }
            timing_nodes.push(node.filter(|_| was_recorded));
        }
        graph.upload().context("uploading the substep's CUDA graph")?;
        Ok(SubstepGraph {
            graph,
            timing_nodes,
            recorded,
            scattered,
        })
    }

    /// What the grid holds of a scatter after this substep, as its captured run left it.
    pub fn scattered(&self) -> Option<Scattered> {
        self.scattered
    }

    /// Which timing slots the graph records.
    pub fn recorded(&self) -> Recorded {
        self.recorded
    }

    /// Launches the substep, its timing nodes recording `events` (in slot order).
    pub fn launch(&self, events: &[CudaEvent]) -> Result<()> {
        if events.len() != self.timing_nodes.len() {
            bail!(
                "{} timing events for a graph with {} timing slots",
                events.len(),
                self.timing_nodes.len()
            );
        }
        for (node, event) in self.timing_nodes.iter().zip(events) {
            let Some(node) = *node else {
                continue;
            };
            // SAFETY: the node belongs to the graph this exec was instantiated from, and the event is
            // live (held by the timing queue until its substep completes). Updates apply to later
            // launches only, never to one in flight.
            unsafe {
                sys::cuGraphExecEventRecordNodeSetEvent(self.graph.cu_graph_exec(), node, event.cu_event())
            }
            .result()
            .context("pointing the substep graph's timing node at its event")?;
        }
        self.graph.launch().context("launching the substep's CUDA graph")
    }
}

/// The event-record nodes of `graph`, with the event each records.
fn event_record_nodes(graph: sys::CUgraph) -> Result<Vec<(sys::CUgraphNode, sys::CUevent)>> {
    let mut count = 0usize;
    // SAFETY: a null array asks for the count only.
    unsafe { sys::cuGraphGetNodes(graph, std::ptr::null_mut(), &mut count) }
        .result()
        .context("counting the graph's nodes")?;
    let mut nodes = vec![std::ptr::null_mut(); count];
    // SAFETY: `nodes` holds `count` entries.
    unsafe { sys::cuGraphGetNodes(graph, nodes.as_mut_ptr(), &mut count) }
        .result()
        .context("listing the graph's nodes")?;
    let mut records = Vec::new();
    for node in nodes.into_iter().take(count) {
        let mut kind = sys::CUgraphNodeType::CU_GRAPH_NODE_TYPE_EMPTY;
        // SAFETY: `node` is a node of `graph`.
        unsafe { sys::cuGraphNodeGetType(node, &mut kind) }
            .result()
            .context("reading a graph node's type")?;
        if kind == sys::CUgraphNodeType::CU_GRAPH_NODE_TYPE_EVENT_RECORD {
            let mut event = std::ptr::null_mut();
            // SAFETY: `node` is an event-record node.
            unsafe { sys::cuGraphEventRecordNodeGetEvent(node, &mut event) }
                .result()
                .context("reading a graph node's event")?;
            records.push((node, event));
        }
    }
    Ok(records)
}

/// The captured substeps, most recently used last.
#[derive(Default)]
pub struct SubstepGraphs {
    entries: VecDeque<(SubstepKey, SubstepGraph)>,
}

impl SubstepGraphs {
    /// Takes the graph for `key` out of the cache, if one was captured.
    pub fn take(&mut self, key: &SubstepKey) -> Option<SubstepGraph> {
        let at = self.entries.iter().position(|(k, _)| k == key)?;
        self.entries.remove(at).map(|(_, graph)| graph)
    }

    /// Puts a graph (back) as the most recently used, dropping the oldest beyond the cache's size. A
    /// dropped graph still in flight finishes first (the driver frees it when it completes).
    pub fn put(&mut self, key: SubstepKey, graph: SubstepGraph) {
        self.entries.push_back((key, graph));
        while self.entries.len() > CACHED_GRAPHS {
            self.entries.pop_front();
        }
    }

    pub fn clear(&mut self) {
        self.entries.clear();
    }
}
