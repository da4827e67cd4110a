//! The particles' trip to the host for export, off the stepping thread's path
//! (`Solver::snapshot_particles`). A snapshot first copies the particles' buffers device to device
//! into a staging set, in stream order behind the substeps enqueued so far (tens of microseconds:
//! the next substep may then overwrite the state), then from there into pinned host memory on a
//! stream of its own, which overlaps the next substeps. Whoever holds the snapshot waits for that
//! copy and puts the particles in slot order (the export thread), and gives the set back.
//! Copied: positions, velocities (and material), densities, slots and deformations; not C, which no
//! export writes (40 of the 88 bytes a liquid particle holds).

use super::gpu::Gpu;
use super::particles::{DeviceParticles, HostParticles};
use crate::sim::{ParticleSnapshot, Particles, PendingParticles, SNAPSHOTS_IN_FLIGHT};
use anyhow::{Context, Result};
use cudarc::driver::sys::CUevent_flags;
use cudarc::driver::{CudaContext, CudaEvent, CudaSlice, CudaStream, DeviceRepr, PinnedHostSlice};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::Arc;

/// One snapshot's buffers on the device and on the host, and the event recorded after its copy to
/// the host.
struct StagingSet {
    device: Fields<CudaSlice<f32>, CudaSlice<u32>>,
    host: Fields<PinnedHostSlice<f32>, PinnedHostSlice<u32>>,
    copied: CudaEvent,
}

/// The copied buffers, as `DeviceParticles` holds them.
struct Fields<F, U> {
    x: F,
    v: F,
    rho: F,
    slot: U,
    deformation: Option<F>,
}

/// The staging sets of one solver: at most [`SNAPSHOTS_IN_FLIGHT`], made on first use; a snapshot
/// waited on or dropped sends its set back here.
pub struct SnapshotRing {
    copy_stream: Arc<CudaStream>,
    /// Recorded on the solver's stream after the device-to-device copy; the copy stream waits on it.
    staged: CudaEvent,
    free: Receiver<StagingSet>,
    give_back: Sender<StagingSet>,
    made: usize,
}

impl SnapshotRing {
    pub fn new(gpu: &Gpu) -> Result<SnapshotRing> {
        let copy_stream = gpu.ctx.new_stream().context("creating the export copy stream")?;
        let (give_back, free) = channel();
        Ok(SnapshotRing {
            copy_stream,
            staged: gpu
                .ctx
                .new_event(None)
                .context("creating the export copy's event")?,
            free,
            give_back,
            made: 0,
        })
    }

    /// Device bytes one staging set of `particles` takes.
    pub fn set_bytes(particles: &DeviceParticles) -> usize {
        let deformation = particles.deformation.as_ref().map_or(0, |d| d.len());
        4 * (particles.x.len() + particles.v.len() + particles.rho.len() + particles.slot.len() + deformation)
    }

    /// Starts copying `particles` to the host behind the work enqueued on `gpu`'s stream; returns at
    /// once unless every staging set is still held, then waits for one to come back.
    pub fn request(&mut self, gpu: &Gpu, particles: &DeviceParticles) -> Result<ParticleSnapshot> {
        let asked = std::time::Instant::now();
        let mut set = match self.free.try_recv() {
            Ok(set) => set,
            Err(_) if self.made < SNAPSHOTS_IN_FLIGHT => {
                gpu.ensure_fits(
                    Self::set_bytes(particles),
                    "copying the particles for export",
                    "export fewer particles, or free GPU memory",
                )?;
                self.made += 1;
                StagingSet::allocate(gpu, particles)?
            }
            // The sender half lives here too, so the channel never closes: a snapshot dropped
            // without a wait sends its set back (PendingSnapshot's Drop).
            Err(_) => self
                .free
                .recv()
                .context("waiting for an export snapshot's buffers")?,
        };
        let waited = asked.elapsed();
        let stream = gpu.stream();
        // The set's last copy to the host may still be running where its snapshot was dropped
        // unwaited: the device copy into it waits for that.
        stream.wait(&set.copied).context("ordering the export copy")?;
        let d = &mut set.device;
        let copy_failed =
            "copying the particles for export (a kernel may have failed; MPM_CUDA_SYNC=1 names it)";
        stream.memcpy_dtod(&particles.x, &mut d.x).context(copy_failed)?;
        stream.memcpy_dtod(&particles.v, &mut d.v).context(copy_failed)?;
        stream
            .memcpy_dtod(&particles.rho, &mut d.rho)
            .context(copy_failed)?;
        stream
            .memcpy_dtod(&particles.slot, &mut d.slot)
            .context(copy_failed)?;
        if let (Some(from), Some(to)) = (&particles.deformation, &mut d.deformation) {
            stream.memcpy_dtod(from, to).context(copy_failed)?;
        }
        self.staged.record(stream).context(copy_failed)?;
        let copy = &self.copy_stream;
        copy.wait(&self.staged).context(copy_failed)?;
        let (d, h) = (&set.device, &mut set.host);
        copy.memcpy_dtoh(&d.x, &mut h.x).context(copy_failed)?;
        copy.memcpy_dtoh(&d.v, &mut h.v).context(copy_failed)?;
        copy.memcpy_dtoh(&d.rho, &mut h.rho).context(copy_failed)?;
        copy.memcpy_dtoh(&d.slot, &mut h.slot).context(copy_failed)?;
        if let (Some(from), Some(to)) = (&d.deformation, &mut h.deformation) {
            copy.memcpy_dtoh(from, to).context(copy_failed)?;
        }
        set.copied.record(copy).context(copy_failed)?;
        Ok(ParticleSnapshot::Pending(Box::new(PendingSnapshot {
            set: Some(set),
            give_back: self.give_back.clone(),
            waited,
        })))
    }
}

impl StagingSet {
    fn allocate(gpu: &Gpu, particles: &DeviceParticles) -> Result<StagingSet> {
        let stream = gpu.stream();
        let device = Fields {
            x: alloc_like(stream, &particles.x)?,
            v: alloc_like(stream, &particles.v)?,
            rho: alloc_like(stream, &particles.rho)?,
            slot: alloc_like(stream, &particles.slot)?,
            deformation: particles
                .deformation
                .as_ref()
                .map(|d| alloc_like(stream, d))
                .transpose()?,
        };
        let host = Fields {
            x: pinned(&gpu.ctx, particles.x.len())?,
            v: pinned(&gpu.ctx, particles.v.len())?,
            rho: pinned(&gpu.ctx, particles.rho.len())?,
            slot: pinned(&gpu.ctx, particles.slot.len())?,
            deformation: particles
                .deformation
                .as_ref()
                .map(|d| pinned(&gpu.ctx, d.len()))
                .transpose()?,
        };
        // Blocking: the export thread sleeps on it rather than spinning a core.
        let copied = gpu
            .ctx
            .new_event(Some(CUevent_flags::CU_EVENT_BLOCKING_SYNC))
            .context("creating the export copy's event")?;
        Ok(StagingSet { device, host, copied })
    }

    fn particles(&self) -> Result<Particles> {
        let h = &self.host;
        let deformation = h.deformation.as_ref().map(PinnedHostSlice::as_slice).transpose();
        HostParticles {
            x: h.x.as_slice()?,
            v: h.v.as_slice()?,
            c: None,
            rho: h.rho.as_slice()?,
            slot: h.slot.as_slice()?,
            deformation: deformation?,
        }
        .in_slot_order()
    }
}

fn alloc_like<T: DeviceRepr + cudarc::driver::ValidAsZeroBits>(
    stream: &Arc<CudaStream>,
    like: &CudaSlice<T>,
) -> Result<CudaSlice<T>> {
    stream
        .alloc_zeros::<T>(like.len())
        .context("allocating the GPU's staging buffers for export")
}

/// Page-locked host memory the host reads at full speed (cudarc's `alloc_pinned` makes it
/// write-combined, which is for buffers the host only writes).
fn pinned<T: DeviceRepr + cudarc::driver::ValidAsZeroBits>(
    ctx: &Arc<CudaContext>,
    len: usize,
) -> Result<PinnedHostSlice<T>> {
    // SAFETY: the memory is written by the copy to the host before the host reads it (`wait`).
    unsafe { ctx.alloc_pinned_with_flags::<T>(len, 0) }.context("allocating pinned host memory for export")
}

/// A snapshot on its way: its staging set until waited on or dropped, then back to the ring.
struct PendingSnapshot {
    set: Option<StagingSet>,
    give_back: Sender<StagingSet>,
    /// How long the request waited for this set to come back.
    waited: std::time::Duration,
}

impl PendingParticles for PendingSnapshot {
    fn wait(self: Box<Self>) -> Result<Particles> {
        let set = self.set.as_ref().context("an export snapshot waited on twice")?;
        set.copied.synchronize().context(
            "waiting for the particles' copy for export (a kernel may have failed; MPM_CUDA_SYNC=1 names it)",
        )?;
        set.particles()
    }

    fn waited_for_buffers(&self) -> std::time::Duration {
        self.waited
    }
}

impl Drop for PendingSnapshot {
    fn drop(&mut self) {
        if let Some(set) = self.set.take() {
            // The ring is gone where this fails: the set is freed with it.
            let _ = self.give_back.send(set);
        }
    }
}
