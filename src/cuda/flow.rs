//! The emitters' and sinks' buffers on the device (the lifecycle pass that uses them is
//! lifecycle.rs, beside kernels/lifecycle.cu): the free-slot stack, the counters, the nozzle points
//! and the sinks, and their readback for the frame line and checkpoints.

use super::gpu::Gpu;
use super::launch::Launcher;
use super::particles::{material_tag, slots_in_place};
use crate::contract::FlowCounters;
use crate::sim::flow::{Flow, FlowCounts, FlowState, CLEARANCE, NO_PARTICLE};
use anyhow::{ensure, Context, Result};
use cudarc::driver::{CudaSlice, CudaStream};
use std::sync::Arc;

/// The lifecycle's device buffers.
pub struct DeviceFlow {
    pub capacity: usize,
    /// The free-slot stack, `capacity` long; its length is `counters.free_count`.
    pub free: CudaSlice<u32>,
    pub counters: CudaSlice<FlowCounters>,
    /// Per nozzle point: its last slot.
    pub last: CudaSlice<u32>,
    /// Per slot, its place in the particle arrays: the fused pipeline keeps it as it moves the
    /// particles into bin order (bin_order.rs); the identity elsewhere.
    pub position: CudaSlice<u32>,
    /// Per nozzle point: xyz and the emitter's index as bits.
    pub points: CudaSlice<f32>,
    pub num_points: u32,
    /// Per emitter: the velocity its particles leave with (float4).
    pub velocities: CudaSlice<f32>,
    /// Per nozzle point: whether it emits this time (scratch of emit_particles).
    pub emits: CudaSlice<u32>,
    /// Per sink: min and max as two float4.
    pub sinks: CudaSlice<f32>,
    pub num_sinks: u32,
    pub clearance_sq: f32,
    /// Whether this is a rank's copy of a lifecycle that every rank of a run keeps alike
    /// (cuda_ranks.rs): `position` then names only the live particles this rank holds, and each
    /// substep's drains are settled once every rank's are on the stack, not by the substep itself.
    pub shared: bool,
}

impl DeviceFlow {
    /// The buffers of `flow` in `state` (a fresh start or a checkpoint's).
    pub fn new(launcher: &Launcher, flow: &Flow, state: &FlowState, spacing: f32) -> Result<DeviceFlow> {
        let stream = &launcher.stream;
        ensure!(
            state.free.len() <= flow.capacity && state.last.len() == flow.num_points(),
            "the lifecycle state does not fit the scene's flow"
        );
        let mut free = vec![0u32; flow.capacity.max(1)];
        free[..state.free.len()].copy_from_slice(&state.free);
        let c = &state.counts;
        let counters = [FlowCounters {
            free_count: state.free.len() as u64,
            sorted: state.sorted as u64,
            emitted: c.emitted,
            drained: c.drained,
            exhausted: c.exhausted,
            blocked: c.blocked,
        }];
        let mut points = Vec::with_capacity(4 * flow.num_points());
        let mut velocities = Vec::with_capacity(4 * flow.emitters.len());
        for (e, emitter) in flow.emitters.iter().enumerate() {
            for p in &emitter.points {
                points.extend([p.x, p.y, p.z, f32::from_bits(e as u32)]);
            }
            let u = emitter.normal * emitter.speed;
            velocities.extend([u.x, u.y, u.z, material_tag(emitter.material)]);
        }
        let sinks: Vec<f32> = flow
            .sinks
            .iter()
            .flat_map(|s| [s.min.x, s.min.y, s.min.z, 0.0, s.max.x, s.max.y, s.max.z, 0.0])
            .collect();
        let upload_u32 = |v: &[u32], what: &str| {
            let v = if v.is_empty() { &[0u32][..] } else { v };
            stream.clone_htod(v).with_context(|| format!("uploading {what}"))
        };
        let upload_f32 = |v: &[f32], what: &str| {
            let v = if v.is_empty() { &[0f32; 4][..] } else { v };
            stream.clone_htod(v).with_context(|| format!("uploading {what}"))
        };
        Ok(DeviceFlow {
            capacity: flow.capacity,
            free: upload_u32(&free, "the free particle slots")?,
            counters: stream
                .clone_htod(&counters)
                .context("uploading the lifecycle's counters")?,
            last: upload_u32(&state.last, "the nozzle points' particles")?,
            // The particles are uploaded or spawned next, each at its slot.
            position: upload_u32(&slots_in_place(flow.capacity), "the particles' places")?,
            points: upload_f32(&points, "the nozzle points")?,
            num_points: flow.num_points() as u32,
            velocities: upload_f32(&velocities, "the emitters' velocities")?,
            emits: upload_u32(&vec![0; flow.num_points()], "the emission scratch")?,
            sinks: upload_f32(&sinks, "the sinks")?,
            num_sinks: flow.sinks.len() as u32,
            clearance_sq: (CLEARANCE * spacing) * (CLEARANCE * spacing),
            shared: false,
        })
    }

    /// Makes this a rank's copy (`shared`) holding the slots `slots[place]`: every other slot's
    /// place is none (`NO_PARTICLE`), which the nozzles' look rejects.
    pub fn share_with_ranks(&mut self, stream: &Arc<CudaStream>, slots: &[u32]) -> Result<()> {
        self.shared = true;
        let mut position = vec![NO_PARTICLE; self.capacity.max(1)];
        for (place, &slot) in slots.iter().enumerate() {
            let at = position
                .get_mut(slot as usize)
                .with_context(|| format!("slot {slot} of a run of {}", self.capacity))?;
            *at = place as u32;
        }
        stream
            .memcpy_htod(&position, &mut self.position)
            .context("uploading the rank's places of its slots")
    }

    /// What emitters and sinks did so far. Waits for the device.
    pub fn read_counts(&self, gpu: &Gpu) -> Result<FlowCounts> {
        Ok(self.counts(&self.read_counters(gpu)?))
    }

    /// The state as a checkpoint holds it. Waits for the device.
    pub fn read_state(&self, gpu: &Gpu) -> Result<FlowState> {
        let counters = self.read_counters(gpu)?;
        let mut free = gpu.download(&self.free)?;
        free.truncate(counters.free_count as usize);
        let mut last = gpu.download(&self.last)?;
        last.truncate(self.num_points as usize);
        Ok(FlowState {
            free,
            sorted: counters.sorted as usize,
            last,
            counts: self.counts(&counters),
        })
    }

    /// The slots pushed on the stack since it was last settled (on a rank: its sinks' drains of a
    /// substep), and the counters as they stand. Waits for the device.
    pub fn unsettled(&self, gpu: &Gpu) -> Result<(FlowCounters, Vec<u32>)> {
        let counters = self.read_counters(gpu)?;
        let (sorted, count) = (counters.sorted as usize, counters.free_count as usize);
        let pushed = match count > sorted {
            true => gpu.download(&self.free.slice(sorted..count))?,
            false => Vec::new(),
        };
        Ok((counters, pushed))
    }

    /// Puts `drained` (every rank's drains of a substep) in place of this rank's own, the `own`
    /// slots pushed since the stack was settled as `counters` read them, counting the others' as
    /// drained too: every rank's stack then holds the same slots, which the settle that follows
    /// sorts.
    pub fn replace_unsettled(
        &mut self,
        stream: &Arc<CudaStream>,
        counters: FlowCounters,
        own: usize,
        drained: &[u32],
    ) -> Result<()> {
        let sorted = counters.sorted as usize;
        ensure!(
            sorted + drained.len() <= self.capacity && own <= drained.len(),
            "{} drained slots on a stack of {sorted} settled, {} slots in all",
            drained.len(),
            self.capacity
        );
        if !drained.is_empty() {
            stream
                .memcpy_htod(drained, &mut self.free.slice_mut(sorted..sorted + drained.len()))
                .context("uploading the ranks' drained slots")?;
        }
        let shared = FlowCounters {
            free_count: (sorted + drained.len()) as u64,
            drained: counters.drained + (drained.len() - own) as u64,
            ..counters
        };
        stream
            .memcpy_htod(&[shared], &mut self.counters)
            .context("uploading the lifecycle's counters")
    }

    fn read_counters(&self, gpu: &Gpu) -> Result<FlowCounters> {
        gpu.download(&self.counters)?
            .first()
            .copied()
            .context("an empty copy of the lifecycle's counters")
    }

    fn counts(&self, counters: &FlowCounters) -> FlowCounts {
        FlowCounts {
            live: self.capacity as u64 - counters.free_count,
            emitted: counters.emitted,
            drained: counters.drained,
            exhausted: counters.exhausted,
            blocked: counters.blocked,
        }
    }
}
