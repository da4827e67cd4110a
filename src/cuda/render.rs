//! kernels/render.cu: one float4 per particle (position, and the value the renderer colours by), in
//! slot order, into a device buffer, usually a GL vertex buffer mapped through interop, so the
//! particles are drawn without a trip through the host. [`DeviceParticlesView`] is how a solver
//! shows its particles to such a reader (`sim::ParticleView::Device`).

use super::gpu::Gpu;
use super::launch::{host_kernel, Launcher};
use super::particles::DeviceParticles;
use crate::sim::{ColourBy, DeviceParticleView};
use anyhow::{Context, Result};
use cudarc::driver::{
    sys::CUdeviceptr, CudaContext, CudaSlice, CudaStream, DevicePtr, DevicePtrMut, PushKernelArg,
};
use std::any::Any;
use std::sync::Arc;

host_kernel!(RenderAttributes = "render" / "render_attributes");

/// A solver's particles on its GPU, for a reader that uses them in place: the renderer, which has the
/// render kernel write its vertex buffer. It holds the device's handles and the buffers' addresses,
/// valid while the solver it came from is borrowed (`ParticleView<'a>` ties it to that borrow).
pub struct DeviceParticlesView {
    ctx: Arc<CudaContext>,
    launcher: Launcher,
    kernel: RenderAttributes,
    /// x, v, rho and slot, in the order kernels/render.cu takes them.
    buffers: [CUdeviceptr; 4],
    count: usize,
}

impl DeviceParticlesView {
    /// The view of `particles` on `gpu`, drawn by `kernel`.
    pub fn new(gpu: &Gpu, kernel: &RenderAttributes, particles: &DeviceParticles) -> DeviceParticlesView {
        let stream = gpu.stream();
        // Event tracking is off (gpu.rs), so the addresses' guards record nothing when dropped.
        let buffers = [
            particles.x.device_ptr(stream).0,
            particles.v.device_ptr(stream).0,
            particles.rho.device_ptr(stream).0,
            particles.slot.device_ptr(stream).0,
        ];
        DeviceParticlesView {
            ctx: gpu.ctx.clone(),
            launcher: gpu.launcher.clone(),
            kernel: kernel.clone(),
            buffers,
            count: particles.count,
        }
    }

    /// The CUDA view behind a solver's `ParticleView::Device`, where the solver is a CUDA one.
    pub fn of(view: &dyn DeviceParticleView) -> Option<&DeviceParticlesView> {
        view.as_any().downcast_ref()
    }

    /// The CUDA context, for registering GL buffers with it (src/cuda/interop.rs).
    pub fn context(&self) -> &Arc<CudaContext> {
        &self.ctx
    }

    /// The stream the solver's work goes to: interop maps and unmaps on it, so a mapped buffer is
    /// written after the substeps' kernels and drawn after the write.
    pub fn stream(&self) -> &Arc<CudaStream> {
        &self.launcher.stream
    }

    /// Writes one float4 per particle (position, `colour_by` value) at `out`, asynchronously on
    /// `stream()`.
    ///
    /// # Safety
    /// `out` must be a live device allocation of at least `16 * count()` bytes in this context: a
    /// mapped GL buffer (`interop::MappedBuffer`).
    pub unsafe fn write_render_attributes(
        &self,
        colour_by: ColourBy,
        rest_density: f32,
        out: CUdeviceptr,
    ) -> Result<()> {
        let n = self.count as u32;
        let code = colour_by.code();
        let inv_rest_density = 1.0 / rest_density;
        let [x, v, rho, slot] = &self.buffers;
        let l = &self.launcher;
        // SAFETY: the arguments match render_attributes (the buffers live while the solver is
        // borrowed, and `slot` is a permutation, as every binning leaves it); the caller vouches for
        // `out`.
        unsafe {
            self.kernel.0.launch(l, l.cover(self.count), |a| {
                a.arg(x)
                    .arg(v)
                    .arg(rho)
                    .arg(slot)
                    .arg(&n)
                    .arg(&code)
                    .arg(&inv_rest_density)
                    .arg(&out);
            })
        }
    }

    /// The attributes through the host: written into `scratch` (a buffer of this GPU, allocated on
    /// first use and kept by the caller), then copied into `out`. Waits for the device.
    pub fn copy_render_attributes_through(
        &self,
        colour_by: ColourBy,
        rest_density: f32,
        scratch: &mut Option<CudaSlice<f32>>,
        out: &mut Vec<[f32; 4]>,
    ) -> Result<()> {
        let floats = 4 * self.count;
        let stream = self.stream().clone();
        if scratch.as_ref().is_none_or(|s| s.len() != floats) {
            *scratch = Some(
                stream
                    .alloc_zeros::<f32>(floats)
                    .context("allocating render attributes")?,
            );
        }
        let buffer = scratch.as_mut().context("no render scratch")?;
        let (ptr, guard) = buffer.device_ptr_mut(&stream);
        // SAFETY: `buffer` is a live allocation of this context holding 4 floats per particle.
        let written = unsafe { self.write_render_attributes(colour_by, rest_density, ptr) };
        drop(guard);
        written?;
        let mut flat = vec![0f32; floats];
        stream
            .memcpy_dtoh(buffer, &mut flat)
            .context("copying the render attributes from the GPU (MPM_CUDA_SYNC=1 names a failed kernel)")?;
        stream
            .synchronize()
            .context("waiting for the render attributes (MPM_CUDA_SYNC=1 names a failed kernel)")?;
        out.clear();
        out.extend(flat.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]));
        Ok(())
    }
}

impl DeviceParticleView for DeviceParticlesView {
    fn count(&self) -> usize {
        self.count
    }

    fn copy_render_attributes(&self, colour_by: ColourBy, rest_density: f32) -> Result<Vec<[f32; 4]>> {
        let mut out = Vec::new();
        self.copy_render_attributes_through(colour_by, rest_density, &mut None, &mut out)?;
        Ok(out)
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
