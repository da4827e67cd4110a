//! How a reader sees a solver's particles without taking them over: in host memory, or left in a
//! GPU's memory for a reader of the same device (the renderer writes its vertex buffer there through
//! CUDA-OpenGL interop). This layer names no device type: the backend's own view sits behind
//! [`DeviceParticleView`].

use super::scene::Particles;
use anyhow::Result;
use glam::Vec3;
use std::any::Any;

/// The quantity each particle's render attributes carry in w: what kernels/render.cu writes on the
/// GPU and `render::feed::host_attribute` on the host.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum ColourBy {
    /// |v|, m/s.
    #[default]
    Speed,
    /// rho / rho0.
    Density,
    /// The particle's row of the material table (0, 1, ...), which the renderer turns into that
    /// material's colour.
    Material,
}

impl ColourBy {
    /// The switch value of kernels/render.cu.
    pub fn code(self) -> u32 {
        match self {
            ColourBy::Speed => crate::contract::COLOUR_BY_SPEED,
            ColourBy::Density => crate::contract::COLOUR_BY_DENSITY,
            ColourBy::Material => crate::contract::COLOUR_BY_MATERIAL,
        }
    }

    /// The value written for one particle of material row `material`.
    pub fn value(self, v: Vec3, rho: f32, rest_density: f32, material: u8) -> f32 {
        match self {
            ColourBy::Speed => v.length(),
            ColourBy::Density => rho / rest_density,
            ColourBy::Material => f32::from(material.min(crate::contract::MAX_MATERIALS as u8 - 1)),
        }
    }
}

/// Where a solver keeps its particles.
pub enum ParticleView<'a> {
    /// In a GPU's memory (the CUDA backend): drawn without a trip through the host.
    Device(Box<dyn DeviceParticleView + 'a>),
    /// In host memory (the CPU backends), every slot.
    Host(&'a Particles),
}

/// A solver's particles in a GPU's memory, valid while the solver is borrowed.
pub trait DeviceParticleView {
    /// Slots, parked ones included.
    fn count(&self) -> usize;
    /// Every slot's `[x, y, z, colour_by value]` (parked slots as the renderer clips them), computed
    /// on the device and copied to the host: the renderer's path where interop is unavailable.
    fn copy_render_attributes(&self, colour_by: ColourBy, rest_density: f32) -> Result<Vec<[f32; 4]>>;
    /// The backend's own view (`cuda::render::DeviceParticlesView`), for a reader that works on the
    /// same device, as the renderer's interop does.
    fn as_any(&self) -> &dyn Any;
}
