//! What the kernel tests read back from a solver to compare with the CPU reference: the grid after
//! each phase, the particle order and the bin list. Each waits for the device.

use super::solver::CudaSolver;
use crate::sim::Params;
use anyhow::Result;
use glam::Vec3;

impl CudaSolver {
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

    /// The particle order of the last binning (identity before the first). Waits for the device.
    pub fn read_order(&mut self) -> Result<Vec<u32>> {
        self.gpu.download(&self.state.bins.order)
    }

    /// The binned pipeline's bin list: (bin, start, count) per chunk of a bin that holds particles,
    /// in the order the last binning listed them. Waits for the device.
    pub fn read_bin_list(&mut self) -> Result<Vec<[u32; 3]>> {
        self.state.bins.read_list(&self.gpu, &self.state.grid.work_counts)
    }
}
