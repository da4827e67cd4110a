//! The kernel tests' interface to a solver: the substep's kernels one at a time, with the CPU
//! reference's names (p2g_init, mirror_mass, ...), and what they read back to compare with it (the
//! grid after each phase, the particle order, the bin list; each readback waits for the device).

use super::pipelines::{launches, Launch};
use super::solver::CudaSolver;
use crate::sim::{Params, Phase};
use anyhow::Result;
use glam::Vec3;

impl CudaSolver {
    /// Rebuilds the particle order by bin (kernels/bins.cu): by cell for the report's pipeline, by
    /// node block (with the list of bins that hold particles) for the binned one; the fused one then
    /// stores the particles in that order (kernels/bin_order.cu), leaving `order` the identity.
    pub fn sort_particles(&mut self, params: &Params) -> Result<()> {
        self.accept(params)?;
        self.sort()
    }

    /// Mass scatter, m_i += w m_p: the report's p2g_init, or the binned pipeline's tiled p2g_mass
    /// (which g2p2g does as its second half on every substep after the first), or the fused
    /// pipeline's one_pass without its gather, which scatters the momentum too (so its `p2g` does nothing). Where
    /// the bins were never built, the sort phase runs first, as in a solver's first substep.
    pub fn p2g_init(&mut self, params: &Params) -> Result<()> {
        self.accept(params)?;
        if self.pipeline().is_binned() && self.binnings() == 0 {
            self.sort()?;
        }
        // The phase's scatter, whether or not the grid holds one already.
        for &launch in launches(self.pipeline(), Phase::P2gInit) {
            match launch {
                Launch::P2gInit => return self.run(launch, false).map(drop),
                Launch::P2gMass | Launch::OnePassScatter => return self.scatter_mass(launch),
                _ => {}
            }
        }
        Ok(())
    }

    /// The grid's volume at the particles' positions now, the walls' images added (kernels/volume.cu,
    /// mirror_walls.cu), read back as the CPU reference holds it (`Grid::volume`), in a scene whose
    /// rest densities differ.
    pub fn scatter_and_read_volume(&mut self, params: &Params) -> Result<Vec<i64>> {
        self.accept(params)?;
        self.run(Launch::ScatterVolume, false)?;
        self.run(Launch::MirrorVolume, false)?;
        self.state.grid.read_volume(&self.gpu)
    }

    /// The walls' image mass, between the mass scatter and p2g (kernels/mirror_walls.cu).
    pub fn mirror_mass(&mut self, params: &Params) -> Result<()> {
        self.accept(params)?;
        self.run(Launch::MirrorMass, false).map(drop)
    }

    /// Density from the grid mass, pressure and stress, momentum scatter.
    pub fn p2g(&mut self, params: &Params) -> Result<()> {
        self.accept(params)?;
        self.run_phase(Phase::P2g, false).map(drop)
    }

    /// The walls' image momentum, wall-normal component reflected, between p2g and the grid update.
    pub fn mirror_momentum(&mut self, params: &Params) -> Result<()> {
        self.accept(params)?;
        self.run(Launch::MirrorMomentum, false).map(drop)
    }

    /// Momentum to velocity, gravity, boundary band and colliders; zeroes the accumulators. The
    /// walls' images are those `mirror_mass` and `mirror_momentum` added.
    pub fn grid_update(&mut self, params: &Params) -> Result<()> {
        self.accept(params)?;
        let launch = if self.pipeline().is_binned() {
            Launch::GridUpdateBlocks
        } else {
            Launch::GridUpdate
        };
        self.run(launch, false).map(drop)
    }

    /// The grid update phase as a substep runs it: under the fused pipeline the update adds the
    /// walls' images itself (call it on the scatter's sums, without `mirror_mass`/`mirror_momentum`);
    /// the other pipelines mirror the momentum first (after `mirror_mass` and `p2g`).
    pub fn mirror_and_grid_update(&mut self, params: &Params) -> Result<()> {
        self.accept(params)?;
        self.run_phase(Phase::GridUpdate, false).map(drop)
    }

    /// Velocity and C from the grid, soft wall, advection, clamp: the report's g2p, or the binned
    /// pipeline's g2p2g, which also scatters the mass of the new positions for the next substep, or
    /// the fused pipeline's one_pass, which also advects the density and scatters mass and momentum.
    pub fn g2p(&mut self, params: &Params) -> Result<()> {
        self.accept(params)?;
        self.run_phase(Phase::G2p, false).map(drop)
    }

    /// The scatter accumulators as the CPU reference's `Grid` holds them after p2g: mass and momentum
    /// per node (converted from fixed point where that scatter ran). Waits for the device.
    pub fn read_grid_accumulators(&mut self, params: &Params) -> Result<(Vec<f32>, Vec<Vec3>)> {
        self.accept(params)?;
        self.state.grid.read_accumulators(&self.gpu, &self.params)
    }

    /// Node mass and velocity as the grid update left them. Waits for the device.
    pub fn read_grid_velocity(&mut self) -> Result<(Vec<f32>, Vec<Vec3>)> {
        self.state.grid.read_velocity(&self.gpu)
    }

    /// Per place in the particle arrays, the slot of the particle stored there: the identity unless
    /// the fused pipeline gathered the particles into bin order. Waits for the device.
    pub fn read_particle_slots(&mut self) -> Result<Vec<u32>> {
        self.gpu.download(&self.state.particles.slot)
    }

    /// The particle order of the last binning (identity before the first; the identity again after
    /// the fused pipeline gathers the particles into it). Waits for the device.
    pub fn read_order(&mut self) -> Result<Vec<u32>> {
        self.gpu.download(&self.state.bins.order)
    }

    /// The binned pipeline's bin list: (bin, start, count) per chunk of a bin that holds particles,
    /// in the order the last binning listed them. Waits for the device.
    pub fn read_bin_list(&mut self) -> Result<Vec<[u32; 3]>> {
        self.state.bins.read_list(&self.gpu, &self.state.grid.work_counts)
    }
}
