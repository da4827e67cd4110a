//! The kernel table: every pass's loaded kernels on one GPU, each owned by the host file beside its
//! `kernels/X.cu`, which alone knows its arguments. Above the passes and below the solver: the
//! device layer (gpu.rs and the buffers) imports no pass, so it cannot hold this.

use super::bin_order::GatherIntoBinOrder;
use super::bins::BinKernels;
use super::bodies::StepBodies;
use super::g2p::G2p;
use super::g2p2g::{G2p2g, P2gMass};
use super::gpu::{CudaOptions, Gpu};
use super::grid_update::GridUpdate;
use super::halo::HaloKernels;
use super::lifecycle::LifecycleKernels;
use super::mirror_walls::MirrorWalls;
use super::one_pass::OnePass;
use super::p2g::P2g;
use super::p2g_init::P2gInit;
use super::p2g_tiled::P2gTiled;
use super::pbmpm::PbmpmKernels;
use super::push::PushParticles;
use super::ranks::RanksKernels;
use super::render::RenderAttributes;
use super::spawn::SpawnKernels;
use super::stats::StatsKernel;
use super::volume::VolumeKernels;
use anyhow::Result;

/// Every kernel of one GPU.
pub struct Kernels {
    pub bins: BinKernels,
    pub bin_order: GatherIntoBinOrder,
    pub p2g_init: P2gInit,
    pub p2g_mass: P2gMass,
    pub volume: VolumeKernels,
    pub mirror_walls: MirrorWalls,
    pub p2g: P2g,
    pub p2g_tiled: P2gTiled,
    pub grid_update: GridUpdate,
    pub step_bodies: StepBodies,
    pub g2p: G2p,
    pub g2p2g: G2p2g,
    pub one_pass: OnePass,
    pub pbmpm: PbmpmKernels,
    pub lifecycle: LifecycleKernels,
    pub spawn: SpawnKernels,
    pub stats: StatsKernel,
    pub render_attributes: RenderAttributes,
    pub push: PushParticles,
    pub halo: HaloKernels,
    pub ranks: RanksKernels,
}

impl Kernels {
    /// Takes every kernel from `gpu`'s modules.
    pub fn load(gpu: &Gpu, options: &CudaOptions) -> Result<Kernels> {
        let (modules, multiprocessors) = (&gpu.modules, gpu.launcher.multiprocessors);
        Ok(Kernels {
            bins: BinKernels::load(modules)?,
            bin_order: GatherIntoBinOrder::load(modules)?,
            p2g_init: P2gInit::load(modules)?,
            p2g_mass: P2gMass::load(modules)?,
            volume: VolumeKernels::load(modules)?,
            mirror_walls: MirrorWalls::load(modules)?,
            p2g: P2g::load(modules)?,
            p2g_tiled: P2gTiled::load(modules)?,
            grid_update: GridUpdate::load(modules)?,
            step_bodies: StepBodies::load(modules)?,
            g2p: G2p::load(modules)?,
            g2p2g: G2p2g::load(modules)?,
            one_pass: OnePass::load(modules, options.float_scatter, multiprocessors)?,
            pbmpm: PbmpmKernels::load(modules)?,
            lifecycle: LifecycleKernels::load(modules)?,
            spawn: SpawnKernels::load(modules)?,
            stats: StatsKernel::load(modules)?,
            render_attributes: RenderAttributes::load(modules)?,
            push: PushParticles::load(modules)?,
            halo: HaloKernels::load(modules)?,
            ranks: RanksKernels::load(modules)?,
        })
    }
}
