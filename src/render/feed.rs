//! Getting the particle state into the renderer's vertex buffer each frame, by one of two paths:
//! - interop (CUDA backend): the GL buffer is registered with CUDA, mapped, written by the
//!   `render_attributes` kernel, and unmapped: the data never leaves the GPU;
//! - host copy (CPU backend, or CUDA when asked for the comparison or when interop is refused):
//!   the attributes are copied to the host and uploaded with glBufferSubData.

use super::renderer::{Colouring, Renderer};
use crate::cuda::interop::GlBufferResource;
use crate::cuda::render::DeviceParticlesView;
use crate::sim::flow::PARKED_RENDER_ATTRIBUTES;
use crate::sim::{ColourBy, DeviceParticleView, ParticleView, Particles, Simulation, Solver};
use anyhow::{ensure, Context, Result};
use cudarc::driver::CudaSlice;
use rayon::prelude::*;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Transfer {
    /// CUDA-OpenGL interop where the backend is CUDA, else a host copy.
    #[default]
    Interop,
    /// Always copy through the host (to measure what interop saves).
    HostCopy,
}

/// What one feed put into the renderer's buffer.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Fed {
    /// Slots written, parked ones included: what the renderer draws (a parked slot is clipped). A
    /// scene's sinks park slots anywhere below its highest live one, so drawing only the first
    /// `live` slots would leave live particles out.
    pub slots: usize,
    /// Live particles among them: all, unless the scene's emitters and sinks say otherwise.
    pub live: usize,
}

impl Fed {
    fn of(sim: &mut Simulation, slots: usize) -> Result<Fed> {
        let live = sim
            .solver_mut()
            .flow_counts()?
            .map_or(slots, |flow| flow.live as usize);
        Ok(Fed { slots, live })
    }
}

pub struct ParticleFeed {
    transfer: Transfer,
    registration: Option<GlBufferResource>,
    /// Set once interop failed here (e.g. GL runs on another GPU than CUDA): host copies from then on.
    interop_refused: Option<String>,
    host: Vec<[f32; 4]>,
    /// The slots' material rows, for the host copy, in a scene with solids (`Renderer::ensure_layout`).
    host_rows: Vec<[f32; 4]>,
    /// The host-copy path's device buffer, on the CUDA solver's GPU (dropped with the registration).
    device_scratch: Option<CudaSlice<f32>>,
}

impl ParticleFeed {
    pub fn new(transfer: Transfer) -> ParticleFeed {
        ParticleFeed {
            transfer,
            registration: None,
            interop_refused: None,
            host: Vec::new(),
            host_rows: Vec::new(),
            device_scratch: None,
        }
    }

    /// The path the last update took, for the HUD.
    pub fn path(&self) -> &'static str {
        if self.registration.is_some() {
            "CUDA-GL interop"
        } else {
            "host copy + glBufferSubData"
        }
    }

    /// Why interop is off, where it was tried and failed.
    pub fn interop_refused(&self) -> Option<&str> {
        self.interop_refused.as_deref()
    }

    /// Drops the CUDA registration (before the GL buffer is reallocated or deleted, or the solver
    /// replaced). The next update registers again.
    pub fn release(&mut self) {
        self.registration = None;
        self.device_scratch = None;
    }

    /// Writes the simulation's current particles, every slot, into the renderer's buffer; in a scene
    /// with solids, their material rows too, whatever the colouring (the surface draws the solids
    /// apart from the liquid).
    pub fn update(
        &mut self,
        sim: &mut Simulation,
        renderer: &mut Renderer,
        colouring: Colouring,
    ) -> Result<Fed> {
        // Every slot, parked ones included (they arrive clipped): the buffer keeps the solver's indices.
        let n = sim.scene().slots();
        let rest_density = sim.params().materials[0].rest_density;
        let quantity = colouring.quantity();
        // Fed every frame, not once per scene: a sink can park a solid's slot and an emitter fill it
        // with a liquid.
        let rows = sim.scene().has_solids();
        if renderer.capacity() != n || renderer.holds_material_rows() != rows {
            self.release();
            renderer.ensure_layout(n, rows);
        }
        let want_interop = self.transfer == Transfer::Interop && self.interop_refused.is_none();
        sim.solver_mut().publish_particles()?;
        let drawn_in_place = match sim.solver().particles() {
            ParticleView::Device(view) => {
                let view = DeviceParticlesView::of(view.as_ref())
                    .context("the renderer draws device particles of the CUDA backend only")?;
                let written = want_interop
                    .then(|| self.write_through_interop(view, renderer, quantity, rest_density, rows));
                match written {
                    Some(Ok(())) => true,
                    refused => {
                        if let Some(Err(why)) = refused {
                            let why = format!("{why:#}");
                            eprintln!(
                                "note: CUDA-OpenGL interop unavailable ({why}); copying through the host"
                            );
                            self.interop_refused = Some(why);
                            self.release();
                        }
                        view.copy_render_attributes_through(
                            quantity,
                            rest_density,
                            &mut self.device_scratch,
                            &mut self.host,
                        )?;
                        if rows {
                            view.copy_render_attributes_through(
                                ColourBy::Material,
                                rest_density,
                                &mut self.device_scratch,
                                &mut self.host_rows,
                            )?;
                        }
                        false
                    }
                }
            }
            ParticleView::Host(particles) => {
                host_attributes(particles, quantity, rest_density, &mut self.host);
                if rows {
                    host_attributes(particles, ColourBy::Material, rest_density, &mut self.host_rows);
                }
                false
            }
        };
        if !drawn_in_place {
            renderer.upload(&self.host);
            if rows {
                renderer.upload_material_rows(&self.host_rows);
            }
        }
        Fed::of(sim, n)
    }

    fn write_through_interop(
        &mut self,
        cuda: &DeviceParticlesView,
        renderer: &mut Renderer,
        quantity: ColourBy,
        rest_density: f32,
        rows: bool,
    ) -> Result<()> {
        let registration = match &mut self.registration {
            Some(registration) => registration,
            None => {
                // SAFETY: the renderer's context is current on this thread, its buffer has storage
                // for every particle, and `release` drops this before the buffer changes.
                let registered =
                    unsafe { GlBufferResource::register(cuda.context(), renderer.particle_buffer_name())? };
                self.registration.insert(registered)
            }
        };
        let stream = cuda.stream().clone();
        let mapped = registration.map(&stream)?;
        let rows_at = renderer.material_rows_offset();
        let needed = if rows {
            rows_at + 16 * cuda.count()
        } else {
            16 * cuda.count()
        };
        let written = if mapped.bytes >= needed {
            // SAFETY: the mapped buffer is a device allocation of `mapped.bytes` >= needed bytes: the
            // attributes from its start, the rows (where asked) from `rows_at`.
            unsafe {
                let attributes = cuda.write_render_attributes(quantity, rest_density, mapped.ptr);
                if rows && attributes.is_ok() {
                    let at = mapped.ptr + rows_at as u64;
                    cuda.write_render_attributes(ColourBy::Material, rest_density, at)
                } else {
                    attributes
                }
            }
        } else {
            Err(anyhow::anyhow!(
                "the mapped GL buffer holds {} bytes, {needed} needed",
                mapped.bytes
            ))
        };
        // With solids the surface has GL splat the thickness, leaving them out: CUDA's copy would be
        // wasted.
        if written.is_ok() && !rows {
            // SAFETY: the mapped buffer holds the `count` float4 just written, and the copy is queued
            // on `stream` before the unmap hands the buffer back to GL.
            unsafe { renderer.take_cuda_particles(cuda.context(), mapped.ptr, cuda.count(), &stream) };
        }
        let unmapped = registration.unmap(&stream);
        written?;
        unmapped?;
        ensure!(
            renderer.capacity() == cuda.count(),
            "renderer and solver disagree on the particle count"
        );
        Ok(())
    }
}

/// The renderer's `[x, y, z, value]` of slot `i`: `value` as `colour_by` says, or
/// `PARKED_RENDER_ATTRIBUTES` (clipped by the shader) for a parked slot.
#[inline]
pub fn host_attribute(p: &Particles, i: usize, colour_by: ColourBy, rest_density: f32) -> [f32; 4] {
    if !p.live[i] {
        return PARKED_RENDER_ATTRIBUTES;
    }
    let value = colour_by.value(p.v[i], p.rho[i], rest_density, p.material[i]);
    [p.x[i].x, p.x[i].y, p.x[i].z, value]
}

/// Every slot's attributes, computed on the host (on every core).
fn host_attributes(p: &Particles, colour_by: ColourBy, rest_density: f32, out: &mut Vec<[f32; 4]>) {
    (0..p.len())
        .into_par_iter()
        .with_min_len(4096)
        .map(|i| host_attribute(p, i, colour_by, rest_density))
        .collect_into_vec(out);
}

/// The vertex attributes the renderer would draw for `solver`'s particles, published first, copied
/// to the host (kernels/render.cu on a CUDA solver): what the host-copy path uploads.
pub fn read_attributes(
    solver: &mut dyn Solver,
    colour_by: ColourBy,
    rest_density: f32,
) -> Result<Vec<[f32; 4]>> {
    solver.publish_particles()?;
    let mut out = Vec::new();
    match solver.particles() {
        ParticleView::Device(view) => out = view.copy_render_attributes(colour_by, rest_density)?,
        ParticleView::Host(particles) => host_attributes(particles, colour_by, rest_density, &mut out),
    }
    Ok(out)
}
