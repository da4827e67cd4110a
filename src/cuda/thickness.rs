//! kernels/thickness.cu: the surface's thickness splats by CUDA, for the renderer, where the particles
//! come through CUDA-OpenGL interop. The feed copies the particles it wrote into the GL vertex buffer
//! ([`CudaThickness::take_particles`]); when the surface draws, the splats are summed with integer
//! atomics and resolved into a GL pixel buffer registered with CUDA, from which GL fills the thickness
//! texture ([`CudaThickness::splat`]). Its own stream: the viewer's solver goes on stepping on its
//! stream while the frame is drawn, and the splats wait only for the copy, through an event.

use super::interop::GlBufferResource;
use super::launch::{host_kernel, Launcher};
use super::modules::LoadedModules;
use crate::contract::SplatCamera;
use anyhow::{ensure, Context, Result};
use cudarc::driver::sys::{self, CUdeviceptr, CUresult};
use cudarc::driver::{CudaContext, CudaEvent, CudaSlice, CudaStream, DevicePtr, DevicePtrMut, PushKernelArg};
use std::sync::Arc;

host_kernel!(SplatThickness = "thickness" / "splat_thickness");
host_kernel!(ResolveThickness = "thickness" / "resolve_thickness");

/// Bytes of one particle in the renderer's vertex buffer: xyz and the colour quantity.
const PARTICLE_BYTES: usize = 16;
/// Bytes of one texel of the resolved thickness: two half floats, the thickness texture's format.
pub const TEXEL_BYTES: usize = 4;

pub struct CudaThickness {
    ctx: Arc<CudaContext>,
    launcher: Launcher,
    splat: SplatThickness,
    resolve: ResolveThickness,
    /// The particles of the last feed, as the GL vertex buffer holds them.
    particles: Option<CudaSlice<f32>>,
    count: usize,
    /// Recorded on the feed's stream after the copy: the splats wait for it, not for the solver.
    fed: Option<CudaEvent>,
    /// One per texel (thickness and thickness times the quantity, kernels/thickness.cu), zero between
    /// frames.
    sums: Option<CudaSlice<u64>>,
    /// The GL pixel buffer the texels go to, by its GL name, registered with CUDA.
    target: Option<(u32, GlBufferResource)>,
}

impl CudaThickness {
    /// The thickness kernels loaded into `ctx` (the solver's context, where the particles are).
    pub fn new(ctx: &Arc<CudaContext>) -> Result<CudaThickness> {
        ctx.bind_to_thread().context("binding the CUDA context")?;
        let modules = LoadedModules::load_named(ctx, &["thickness"])?;
        let multiprocessors = ctx
            .attribute(sys::CUdevice_attribute::CU_DEVICE_ATTRIBUTE_MULTIPROCESSOR_COUNT)
            .context("reading the multiprocessor count")?;
        Ok(CudaThickness {
            ctx: ctx.clone(),
            launcher: Launcher::new(
                ctx.new_stream()
                    .context("creating the thickness splats' stream")?,
                256,
                multiprocessors.max(1) as u32,
            )?,
            splat: SplatThickness::load(&modules)?,
            resolve: ResolveThickness::load(&modules)?,
            particles: None,
            count: 0,
            fed: None,
            sums: None,
            target: None,
        })
    }

    /// Whether this is `ctx`'s.
    pub fn serves(&self, ctx: &Arc<CudaContext>) -> bool {
        Arc::ptr_eq(&self.ctx, ctx)
    }

    /// Particles held for the next splats (0 before the first feed).
    pub fn count(&self) -> usize {
        self.count
    }

    /// Copies `count` particles (float4 each, as kernels/render.cu writes them) from `from`, on
    /// `stream` after the work that wrote them.
    ///
    /// # Safety
    /// `from` must be a device allocation of this context holding `count` float4, live until the
    /// work queued on `stream` so far is done.
    pub unsafe fn take_particles(
        &mut self,
        from: CUdeviceptr,
        count: usize,
        stream: &Arc<CudaStream>,
    ) -> Result<()> {
        let floats = 4 * count;
        if self.particles.as_ref().is_none_or(|p| p.len() != floats) {
            self.particles = None;
            self.particles = Some(
                stream
                    .alloc_zeros::<f32>(floats)
                    .context("allocating the thickness splats' particles")?,
            );
        }
        let particles = self.particles.as_mut().context("no particle buffer")?;
        let (to, guard) = particles.device_ptr_mut(stream);
        // SAFETY: both are allocations of this context holding `count` float4; ordered on `stream`.
        let copied =
            unsafe { sys::cuMemcpyDtoDAsync_v2(to, from, PARTICLE_BYTES * count, stream.cu_stream()) };
        drop(guard);
        ensure!(
            copied == CUresult::CUDA_SUCCESS,
            "copying the particles for the thickness splats failed: {copied:?}"
        );
        self.fed = Some(stream.record_event(None).context("recording the feed's event")?);
        self.count = count;
        Ok(())
    }

    /// Forgets the GL pixel buffer (before GL deletes or reallocates it).
    pub fn release_target(&mut self) {
        self.target = None;
    }

    /// Splats the first `count` particles held with `camera` into GL pixel buffer `target` (a buffer
    /// object of at least `TEXEL_BYTES` per texel of `camera`'s texture, its context current on this
    /// thread): row by row from the bottom, two half floats a texel, as glTexSubImage2D reads RG
    /// half-float data.
    pub fn splat(&mut self, camera: &SplatCamera, count: usize, target: u32) -> Result<()> {
        let texels = camera.width as usize * camera.height as usize;
        ensure!(
            count <= self.count,
            "{count} particles to splat, {} fed",
            self.count
        );
        if self.target.as_ref().is_none_or(|(name, _)| *name != target) {
            self.target = None;
            // SAFETY: the caller's GL context is current and the buffer lives until `release_target`.
            let registered = unsafe { GlBufferResource::register(&self.ctx, target)? };
            self.target = Some((target, registered));
        }
        let l = &self.launcher;
        if self.sums.as_ref().is_none_or(|s| s.len() != texels) {
            self.sums = None;
            self.sums = Some(
                l.stream
                    .alloc_zeros::<u64>(texels)
                    .context("allocating the thickness sums")?,
            );
        }
        if let Some(fed) = &self.fed {
            l.stream.wait(fed).context("waiting for the feed")?;
        }
        let (Some(particles), Some(sums), Some((_, registration))) =
            (&self.particles, &mut self.sums, &mut self.target)
        else {
            anyhow::bail!("the thickness splats have no buffers");
        };
        let mapped = registration.map(&l.stream)?;
        let launched = if mapped.bytes >= TEXEL_BYTES * texels {
            let particle_count = count as u32;
            let texel_count = texels as u32;
            let (sums_ptr, sums_guard) = sums.device_ptr_mut(&l.stream);
            let (particles_ptr, particles_guard) = particles.device_ptr(&l.stream);
            let out = mapped.ptr;
            // SAFETY: the arguments match splat_thickness and resolve_thickness: `count` float4
            // particles, a u64 sum and (mapped, checked above) two half floats per texel.
            let launched = unsafe {
                self.splat
                    .0
                    .launch(l, l.cover(count), |a| {
                        a.arg(&particles_ptr)
                            .arg(&particle_count)
                            .arg(camera)
                            .arg(&sums_ptr);
                    })
                    .and_then(|()| {
                        self.resolve.0.launch(l, l.cover(texels), |a| {
                            a.arg(&sums_ptr).arg(&texel_count).arg(&out);
                        })
                    })
            };
            drop((sums_guard, particles_guard));
            launched
        } else {
            Err(anyhow::anyhow!(
                "the mapped GL pixel buffer holds {} bytes, {} needed",
                mapped.bytes,
                TEXEL_BYTES * texels
            ))
        };
        let unmapped = registration.unmap(&l.stream);
        launched?;
        unmapped
    }
}
