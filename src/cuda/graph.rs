//! The substep as a CUDA graph. Launching a substep's ten-odd kernels, memsets and timing events one
//! by one costs the host more than the GPU takes to run them at small particle counts, so the GPU
//! waits on the host between kernels. A graph is one launch for the whole substep.
//!
//! A substep is captured (stream capture) the first time it is enqueued with a given `Params`, sort
//! decision and mass-scatter state, and replayed for every later substep with the same key. A stretch
//! of substeps shares its dt, but the next stretch's dt is almost always another, so the work of a
//! new key is captured about every fourth substep. Instantiating and uploading each capture cost the
//! host about 45 us on the H200 (BENCHMARKS.md M19), as much as the GPU spends on two of bench-65k's
//! substeps: so a capture updates the executable of the cached graph most like it in place
//! (`cuGraphExecUpdate`: the same kernels in the same order, other arguments, about 12 us in all),
//! and is instantiated afresh only where there is none or the driver refuses the update. The timing
//! events are external event-record nodes, pointed at a fresh set of events before each launch, so
//! every substep keeps its CUDA-event timing (its phases' in the substeps that sample them).

use super::solver::Scattered;
use super::timing::Recorded;
use crate::sim::Params;
use anyhow::{bail, Context, Result};
use cudarc::driver::{sys, CudaEvent, CudaStream};
use std::collections::VecDeque;
use std::sync::Arc;

/// Graphs kept: the current stretch's eight (with and without the sort, from either set of particle
/// buffers where the particles are kept in bin order, with and without the phases' timing events)
/// and the previous stretch's.
const CACHED_GRAPHS: usize = 16;

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
    /// The position-based substep's constraint iterations (the viewer's slider sets them); `None`
    /// for the explicit substep.
    pub iterations: Option<u32>,
    /// Whether the substep times its phases, or only its start and end (timing.rs).
    pub phases_timed: bool,
    /// Whether the substep ends a frame (`Solver::ends_frame_next`: its fused pass scatters a
    /// plastic solid's stress as a resumed run's first scatter does).
    pub ends_frame: bool,
}

impl PartialEq for SubstepKey {
    /// Params compared bit for bit: the kernels get exactly these bytes.
    fn eq(&self, other: &SubstepKey) -> bool {
        bytemuck::bytes_of(&self.params) == bytemuck::bytes_of(&other.params)
            && self.sort == other.sort
            && self.mass_scattered == other.mass_scattered
            && self.colliders == other.colliders
            && self.particle_buffers == other.particle_buffers
            && self.iterations == other.iterations
            && self.phases_timed == other.phases_timed
            && self.ends_frame == other.ends_frame
    }
}

/// A captured graph and the executable made from it. Not cudarc's `CudaGraph`, which instantiates
/// every capture: an executable here may be updated to a later capture instead.
struct Executable {
    /// The graph it was instantiated from, kept for its nodes' handles (`timing_nodes`), which stay
    /// the executable's through its updates.
    graph: sys::CUgraph,
    exec: sys::CUgraphExec,
    stream: Arc<CudaStream>,
}

impl Executable {
    /// Instantiates `graph` (taking it over: it is destroyed with the executable, or here on failure)
    /// and uploads it, so that its first launch does not set it up on the stream.
    fn instantiate(graph: sys::CUgraph, stream: &Arc<CudaStream>) -> Result<Executable> {
        let mut exec = std::ptr::null_mut();
        // SAFETY: `graph` is a live graph that nothing else owns.
        if let Err(e) = unsafe { sys::cuGraphInstantiateWithFlags(&mut exec, graph, 0) }.result() {
            // SAFETY: as above; no executable was made of it.
            unsafe { sys::cuGraphDestroy(graph) };
            return Err(e).context("instantiating the substep's CUDA graph");
        }
        let executable = Executable {
            graph,
            exec,
            stream: stream.clone(),
        };
        executable.upload()?;
        Ok(executable)
    }

    fn upload(&self) -> Result<()> {
        // SAFETY: a live executable and stream of the current context.
        unsafe { sys::cuGraphUpload(self.exec, self.stream.cu_stream()) }
            .result()
            .context("uploading the substep's CUDA graph")
    }

    /// Makes the executable run `graph` where the driver takes it (its nodes must match the
    /// executable's one for one; otherwise nothing changes) and uploads it. Launches already enqueued
    /// run as they were. `graph` stays the caller's. Whether the driver took the update.
    fn update(&self, graph: sys::CUgraph) -> Result<bool> {
        // SAFETY: zeroed is a valid "no result yet" for this plain C struct.
        let mut info: sys::CUgraphExecUpdateResultInfo = unsafe { std::mem::zeroed() };
        // SAFETY: both are live; the driver reads `graph` and writes `info`.
        let updated = unsafe { sys::cuGraphExecUpdate_v2(self.exec, graph, &mut info) };
        if updated != sys::CUresult::CUDA_SUCCESS {
            return Ok(false);
        }
        self.upload()?;
        Ok(true)
    }

    fn launch(&self) -> Result<()> {
        // SAFETY: a live executable and stream of the current context.
        unsafe { sys::cuGraphLaunch(self.exec, self.stream.cu_stream()) }
            .result()
            .context("launching the substep's CUDA graph")
    }
}

impl Drop for Executable {
    fn drop(&mut self) {
        // Errors at teardown have nowhere to go.
        let _ = self.stream.context().bind_to_thread();
        // SAFETY: both handles are this value's alone; the driver frees an executable still in
        // flight once its launches complete.
        unsafe {
            sys::cuGraphExecDestroy(self.exec);
            sys::cuGraphDestroy(self.graph);
        }
    }
}

/// One captured and instantiated substep.
pub struct SubstepGraph {
    graph: Executable,
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
    /// returns which it recorded, and what the grid holds of a scatter after the substep. `alike`: a
    /// graph whose executable to update to the capture instead of instantiating one
    /// ([`SubstepGraphs::take_alike`]); dropped where the driver refuses the update.
    pub fn capture(
        stream: &Arc<CudaStream>,
        timing_events: &[sys::CUevent],
        enqueue: impl FnOnce() -> Result<(Recorded, Option<Scattered>)>,
        alike: Option<SubstepGraph>,
    ) -> Result<SubstepGraph> {
        stream
            .begin_capture(sys::CUstreamCaptureMode::CU_STREAM_CAPTURE_MODE_THREAD_LOCAL)
            .context("starting to capture the substep as a CUDA graph")?;
        // The capture must end whatever `enqueue` did, or the stream stays in capture mode.
        let enqueued = enqueue();
        let mut graph = std::ptr::null_mut();
        // SAFETY: the stream is capturing (begun above); the graph made is ours.
        let ended = unsafe { sys::cuStreamEndCapture(stream.cu_stream(), &mut graph) }.result();
        let captured = enqueued
            .context("enqueueing the substep into a CUDA graph capture")
            .and_then(|done| {
                ended.context(
                    "capturing the substep as a CUDA graph (MPM_CUDA_GRAPHS=0 runs without graphs)",
                )?;
                Ok(done)
            });
        let (recorded, scattered) = match captured {
            Ok(done) if !graph.is_null() => done,
            Ok(_) => bail!("the substep's CUDA graph capture recorded nothing"),
            Err(e) => {
                if !graph.is_null() {
                    // SAFETY: the graph the failed capture made, ours alone.
                    unsafe { sys::cuGraphDestroy(graph) };
                }
                return Err(e);
            }
        };
        // The same slots recorded, or the nodes differ and the update would be refused anyway.
        if let Some(mut alike) = alike.filter(|g| g.recorded == recorded) {
            let updated = alike.graph.update(graph);
            if !matches!(updated, Ok(false)) {
                // SAFETY: ours alone; an executable does not hold on to the graph it was updated to.
                unsafe { sys::cuGraphDestroy(graph) };
                alike.scattered = scattered;
                return updated.map(|_| alike);
            }
        }
        let graph = Executable::instantiate(graph, stream)?;
        let nodes = event_record_nodes(graph.graph)?;
        let mut timing_nodes = Vec::with_capacity(timing_events.len());
        for (event, &was_recorded) in timing_events.iter().zip(&recorded) {
            let node = nodes.iter().find(|(_, e)| e == event).map(|&(node, _)| node);
            if was_recorded && node.is_none() {
                bail!("the substep's CUDA graph lost a timing event");
            }
            timing_nodes.push(node.filter(|_| was_recorded));
        }
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
            unsafe { sys::cuGraphExecEventRecordNodeSetEvent(self.graph.exec, node, event.cu_event()) }
                .result()
                .context("pointing the substep graph's timing node at its event")?;
        }
        self.graph.launch()
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

    /// Takes out the most recently used graph that enqueued what a substep of `key` would but for
    /// its parameters' values (the same sort, scatter mode, collider count, particle buffers,
    /// iterations and timed phases): the one whose executable a capture for `key` is likeliest to
    /// update in place.
    pub fn take_alike(&mut self, key: &SubstepKey) -> Option<SubstepGraph> {
        let at = self.entries.iter().rposition(|(k, _)| {
            k.sort == key.sort
                && k.colliders == key.colliders
                && k.particle_buffers == key.particle_buffers
                && k.iterations == key.iterations
                && k.phases_timed == key.phases_timed
                && k.mass_scattered.map(|s| s.mode) == key.mass_scattered.map(|s| s.mode)
        })?;
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
