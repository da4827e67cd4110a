//! kernels/push.cu: the viewer's mouse push, a velocity change inside a capsule along the ray.

use super::launch::{host_kernel, Launcher};
use super::particles::DeviceParticles;
use crate::sim::Push;
use anyhow::Result;
use cudarc::driver::PushKernelArg;

host_kernel!(PushParticles = "push" / "push_particles");

impl PushParticles {
    pub fn launch(&self, l: &Launcher, push: &Push, particles: &DeviceParticles) -> Result<()> {
        let n = particles.count as u32;
        // SAFETY: the arguments match push_particles; x and v hold n float4.
        unsafe {
            self.0.launch(l, l.cover(particles.count), |a| {
                a.arg(push).arg(&n).arg(&particles.x).arg(&particles.v);
            })
        }
    }
}
