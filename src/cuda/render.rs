//! kernels/render.cu: one float4 per particle (position, and the value the renderer colours by), in
//! slot order, into a device buffer, usually a GL vertex buffer mapped through interop, so the
//! particles are drawn without a trip through the host.

use super::launch::{host_kernel, Launcher};
use super::particles::DeviceParticles;
use crate::render::ColourBy;
use anyhow::Result;
use cudarc::driver::{sys::CUdeviceptr, PushKernelArg};

host_kernel!(RenderAttributes = "render" / "render_attributes");

impl RenderAttributes {
    /// Writes `16 * particles.count` bytes at `out`. Asynchronous on the launcher's stream.
    ///
    /// # Safety
    /// `out` must be a live device allocation of at least `16 * particles.count` bytes in the context
    /// of the launcher's stream, and `particles.slot` a permutation (as every binning leaves it).
    pub unsafe fn launch(
        &self,
        l: &Launcher,
        particles: &DeviceParticles,
        colour_by: ColourBy,
        rest_density: f32,
        out: CUdeviceptr,
    ) -> Result<()> {
        let n = particles.count as u32;
        let code = colour_by.code();
        let inv_rest_density = 1.0 / rest_density;
        // SAFETY: the arguments match render_attributes; the caller vouches for `out`.
        unsafe {
            self.0.launch(l, l.cover(particles.count), |a| {
                a.arg(&particles.x)
                    .arg(&particles.v)
                    .arg(&particles.rho)
                    .arg(&particles.slot)
                    .arg(&n)
                    .arg(&code)
                    .arg(&inv_rest_density)
                    .arg(&out);
            })
        }
    }
}
