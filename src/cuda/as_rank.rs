//! What a solver does as one rank of a run split over slabs, everything `CudaRanks` (cuda_ranks.rs)
//! asks of a rank: its grid of its slab and ghost planes, made anew where the slabs move, and the
//! two ends of each ghost exchange on it (kernels/halo.cu, halo.rs), its
//! counts of the particles nearing its ghost planes and of its particles per block layer, its
//! leavers packed for a migration and its particles taken into the readers' set (kernels/ranks.cu,
//! ranks.rs), and its particles and counters as the transport and the reductions see them. The
//! ranks reach a solver's buffers and kernels only through these.

use super::grid::{DeviceGrid, GridBox};
use super::halo::{Exchange, HaloBuffers, Planes};
use super::particles::DeviceParticles;
use super::render::DeviceParticlesView;
use super::solver::CudaSolver;
use crate::sim::{Params, Particles};
use anyhow::{Context, Result};
use cudarc::driver::{CudaContext, CudaSlice, DevicePtr, DeviceRepr};
use std::ops::Range;
use std::sync::Arc;

impl CudaSolver {
    /// The parameters its kernels got last (`accept`): the grid, the scatter mode, the last step.
    pub(super) fn params(&self) -> &Params {
        &self.params
    }

    /// Send and receive buffers for its exchanges across `axis` (`HaloBuffers::allocate`).
    pub(super) fn halo_buffers(&self, axis: usize) -> Result<HaloBuffers> {
        HaloBuffers::allocate(&self.gpu, self.params.box_res, axis)
    }

    /// The nodes its grid holds.
    pub(super) fn held(&self) -> GridBox {
        self.state.grid.held
    }

    /// Bytes its particle, bin and grid buffers take on its GPU.
    pub(super) fn device_bytes(&self) -> usize {
        self.state.device_bytes()
    }

    /// A grid of the nodes of `held` in place of its own (the slabs moved), zeroed, its particles
    /// binned again before its next pass. Returns the grid it replaced, with the parameters its
    /// kernels ran on it, for `pack_old_sums`.
    pub(super) fn rebox(&mut self, held: GridBox) -> Result<(DeviceGrid, Params)> {
        let old = self.state.rebox(&self.gpu, held)?;
        let ran = self.params;
        held.set_in(&mut self.params);
        self.rebin_next();
        Ok((old, ran))
    }

    /// The sums on planes `planes` of a grid `rebox` replaced (`old`, with its parameters) into
    /// `out`, zeroed there, for `unpack_halo` to add where they belong now.
    pub(super) fn pack_old_sums(
        &self,
        old: &(DeviceGrid, Params),
        planes: &Planes,
        out: &CudaSlice<u32>,
    ) -> Result<()> {
        let (grid, ran) = old;
        self.kernels
            .halo
            .pack_sums(&self.gpu.launcher, ran, planes, grid, out)
    }

    /// Its side of `what` into `out`: the scatter's sums on its ghost planes `planes` (zeroed as they
    /// are packed), or its updated velocities on its edge planes `planes`.
    pub(super) fn pack_halo(&self, what: Exchange, planes: &Planes, out: &CudaSlice<u32>) -> Result<()> {
        let (k, l, p, d) = (
            &self.kernels.halo,
            &self.gpu.launcher,
            &self.params,
            &self.state.grid,
        );
        match what {
            Exchange::Sums => k.pack_sums(l, p, planes, d, out),
            Exchange::Velocities => k.pack_velocities(l, p, planes, d, out),
        }
    }

    /// What a neighbour packed for it, `got`, into its grid: sums added to its edge planes
    /// `planes` (listing the sender's node blocks), or velocities written over its ghost planes.
    pub(super) fn unpack_halo(&self, what: Exchange, planes: &Planes, got: &CudaSlice<u32>) -> Result<()> {
        let (k, l, p, d) = (
            &self.kernels.halo,
            &self.gpu.launcher,
            &self.params,
            &self.state.grid,
        );
        match what {
            Exchange::Sums => k.add_sums(l, p, planes, got, d),
            Exchange::Velocities => k.fill_velocities(l, p, planes, got, d),
        }
    }

    /// Sets `strays[0]` to its live particles among its first `places` whose stencil base along
    /// `axis` lies outside `keep` (`Slabs::keeps`), `strays[1]` to those of them whose stencil left
    /// its grid's box, in stream order.
    pub(super) fn count_strays(
        &self,
        places: usize,
        axis: usize,
        keep: (i32, i32),
        strays: &mut CudaSlice<u32>,
    ) -> Result<()> {
        self.stream()
            .memset_zeros(strays)
            .context("zeroing the stray counter")?;
        let (k, l) = (&self.kernels.ranks, &self.gpu.launcher);
        k.count_strays(
            l,
            &self.params,
            places,
            axis,
            keep,
            &self.state.particles.x,
            strays,
        )
    }

    /// Its live particles among its first `places` per block layer along `axis` (`layers` of them),
    /// waited for.
    pub(super) fn layer_counts(&self, places: usize, axis: usize, layers: u32) -> Result<Vec<u64>> {
        let mut counts = self
            .stream()
            .alloc_zeros::<u32>(layers as usize)
            .context("allocating layer counts")?;
        let (k, l) = (&self.kernels.ranks, &self.gpu.launcher);
        k.count_layers(
            l,
            &self.params,
            places,
            axis,
            layers,
            &self.state.particles.x,
            &mut counts,
        )?;
        Ok(self.gpu.download(&counts)?.into_iter().map(u64::from).collect())
    }

    /// A count its kernels left on its GPU, waited for.
    pub(super) fn read_count(&self, count: &CudaSlice<u32>) -> Result<u32> {
        self.download(count)?.first().copied().context("an empty count")
    }

    /// A buffer on its GPU (counts its kernels left, words the transport gathered), waited for.
    pub(super) fn download<T: DeviceRepr + Default + Clone>(&self, buffer: &CudaSlice<T>) -> Result<Vec<T>> {
        self.gpu.download(buffer)
    }

    /// Its particles, places and slots, as the transport reads and writes them.
    pub(super) fn owned(&self) -> &DeviceParticles {
        &self.state.particles
    }

    /// A set of `places` on its GPU shaped as its own (with a deformation where it has one): where
    /// a migration packs its leavers, or another rank's particles land on their way to the readers.
    pub(super) fn allocate_like_owned(&self, places: usize) -> Result<DeviceParticles> {
        let deformed = self.state.particles.deformation.is_some();
        DeviceParticles::allocate(self.stream(), places, deformed)
    }

    /// Packs its live particles among its first `walk` places whose block layer lies in `slab`
    /// (axis, block layers of the grid, the receiver's layers) into the first `count` places of
    /// `into` (on its GPU), parking them here. Returns the count it moved, for `read_count`.
    pub(super) fn pack_leavers(
        &self,
        slab: (usize, u32, Range<u32>),
        walk: usize,
        into: &DeviceParticles,
        count: usize,
    ) -> Result<CudaSlice<u32>> {
        let mut moved = self
            .stream()
            .alloc_zeros::<u32>(1)
            .context("allocating the migration counter")?;
        let (k, l) = (&self.kernels.ranks, &self.gpu.launcher);
        let walked = (&self.state.particles, walk);
        k.move_owned(l, &self.params, slab, walked, (into, 0..count), &mut moved)?;
        Ok(moved)
    }

    /// Copies the live particles of `from`'s first `places` (a set on its GPU: its own, another
    /// rank's on one GPU, or one landed here) to their slots in `readers`.
    pub(super) fn take_into_readers(
        &self,
        from: &DeviceParticles,
        places: usize,
        readers: &DeviceParticles,
    ) -> Result<()> {
        self.kernels
            .ranks
            .take_owned(&self.gpu.launcher, from, places, readers)
    }

    /// Parks every slot of the readers' set `readers` (a run with emitters or sinks: slots no rank
    /// holds read as parked).
    pub(super) fn park_readers(&self, readers: &DeviceParticles) -> Result<()> {
        self.kernels.ranks.park_slots(&self.gpu.launcher, readers)
    }

    /// Its step counters' device address (`StepCounters`, eight u32 words), which the ranks in
    /// processes of their own reduce in place over NCCL.
    pub(super) fn step_counters_at(&self) -> u64 {
        let (at, _) = self.state.counters.device.device_ptr(self.stream());
        at
    }

    /// The readers' set `readers` (on its GPU) as the renderer draws it.
    pub(super) fn view_of(&self, readers: &DeviceParticles) -> DeviceParticlesView {
        DeviceParticlesView::new(&self.gpu, &self.kernels.render_attributes, readers)
    }

    /// Its live particles among its first `places`, written over their slots of `all` on the host
    /// (`DeviceParticles::place_live_into`); how many.
    pub(super) fn place_owned_into(&self, places: usize, all: &mut Particles) -> Result<usize> {
        self.state.particles.place_live_into(&self.gpu, places, all)
    }

    /// A set on its GPU, on the host.
    pub(super) fn download_set(&self, set: &DeviceParticles) -> Result<Particles> {
        set.download(&self.gpu)
    }

    /// Fails, naming `what` and `fix`, where its GPU lacks `needed` bytes (`Gpu::ensure_fits`).
    pub(super) fn ensure_fits(&self, needed: usize, what: &str, fix: &str) -> Result<()> {
        self.gpu.ensure_fits(needed, what, fix)
    }

    /// Its CUDA context.
    pub(super) fn context(&self) -> &Arc<CudaContext> {
        &self.gpu.ctx
    }
}
