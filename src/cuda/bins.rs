//! Particle bins (kernels/bins.cu): a counting sort of particle indices by the cell of their stencil
//! base node into `order`, the cells of a bin consecutive, and, for the binned pipeline, the list of
//! bins that hold particles. The report's pipeline sorts by plain cell (bins of edge 1); the binned
//! pipeline bins by node block (edge 4, `NODE_BLOCK_EDGE`), a tile per listed chunk of a bin
//! (kernels/tiles.cuh).

use super::bin_lists::{Bins, BIN_COUNT_SLOT};
use super::launch::{Kernel, Launcher};
use super::modules::LoadedModules;
use crate::contract::SCAN_ITEMS_PER_THREAD;
use crate::sim::Params;
use anyhow::{Context, Result};
use cudarc::driver::{CudaSlice, LaunchConfig, PushKernelArg};

pub struct BinKernels {
    count: Kernel,
    scan_tiles: Kernel,
    scan_add: Kernel,
    scatter: Kernel,
    list: Kernel,
}

impl BinKernels {
    pub fn load(modules: &LoadedModules) -> Result<BinKernels> {
        Ok(BinKernels {
            count: Kernel::load(modules, "bins", "bin_count")?,
            scan_tiles: Kernel::load(modules, "bins", "scan_tiles")?,
            scan_add: Kernel::load(modules, "bins", "scan_add")?,
            scatter: Kernel::load(modules, "bins", "sort_scatter")?,
            list: Kernel::load(modules, "bins", "bin_list")?,
        })
    }
}

impl Bins {
    /// Rewrites `order` so that particles of one cell, and the cells of one bin, are consecutive, and
    /// (where listed) the bin list with its length in `work_counts[WORK_BINS]`.
    pub fn rebuild(
        &mut self,
        k: &BinKernels,
        launcher: &Launcher,
        params: &Params,
        x: &CudaSlice<f32>,
        work_counts: &mut CudaSlice<u32>,
    ) -> Result<()> {
        let stream = &launcher.stream;
        stream
            .memset_zeros(&mut self.levels[0])
            .context("clearing the cells' counts")?;
        let particles = launcher.cover(self.num_particles);
        // SAFETY: arguments match bin_count in kernels/bins.cu; levels[0] has one count per key,
        // key and rank one value per particle.
        unsafe {
            k.count.launch(launcher, particles, |a| {
                a.arg(&params.kernel)
                    .arg(&self.edge)
                    .arg(x)
                    .arg(&self.levels[0])
                    .arg(&self.key)
                    .arg(&self.rank);
            })?;
        }

        // Exclusive scan of the counts: scan each level's tiles (their totals go one level up), then
        // add the scanned totals back down.
        let block = launcher.block_size;
        let tile = block as usize * SCAN_ITEMS_PER_THREAD as usize;
        let tiles_of = |len: usize| LaunchConfig {
            grid_dim: (len.div_ceil(tile) as u32, 1, 1),
            block_dim: (block, 1, 1),
            shared_mem_bytes: block * 4,
        };
        let lens: Vec<u32> = self.levels.iter().map(|l| l.len() as u32).collect();
        for (level, (counts, len)) in self.levels.iter().zip(&lens).enumerate() {
            let sums = self.levels.get(level + 1).unwrap_or(&self.top);
            // SAFETY: as above; `sums` has one slot per tile of this level.
            unsafe {
                k.scan_tiles.launch(launcher, tiles_of(*len as usize), |a| {
                    a.arg(counts).arg(len).arg(sums);
                })?;
            }
        }
        for level in (0..self.levels.len() - 1).rev() {
            // SAFETY: as above.
            unsafe {
                k.scan_add.launch(launcher, tiles_of(lens[level] as usize), |a| {
                    a.arg(&self.levels[level])
                        .arg(&lens[level])
                        .arg(&self.levels[level + 1]);
                })?;
            }
        }

        let n = self.num_particles as u32;
        // SAFETY: as above; every start + rank is below n.
        unsafe {
            k.scatter.launch(launcher, particles, |a| {
                a.arg(&n)
                    .arg(&self.key)
                    .arg(&self.rank)
                    .arg(&self.levels[0])
                    .arg(&self.order);
            })?;
        }

        if let Some(list) = &self.list {
            stream
                .memset_zeros(&mut work_counts.slice_mut(BIN_COUNT_SLOT..BIN_COUNT_SLOT + 1))
                .context("clearing the bin list's length")?;
            let num_bins = self.num_bins() as u32;
            // SAFETY: arguments match bin_list; the list has room for every bin.
            unsafe {
                k.list.launch(launcher, launcher.cover(self.num_bins()), |a| {
                    a.arg(&num_bins)
                        .arg(&self.chunk)
                        .arg(&self.levels[0])
                        .arg(list)
                        .arg(&*work_counts);
                })?;
            }
        }
        Ok(())
    }
}

/// Substeps between particle sorts in the report's and binned pipelines (and the fused one where its
/// particles stay in place; where they are stored in bin order, `BIN_ORDER_SORT_INTERVAL`).
/// Particles move well under a cell per substep, so an order a few substeps old is nearly as good as
/// a fresh one; but the warp-aggregated scatters merge only lanes of one cell that sit side by side,
/// and an older order has fewer of them. Measured on the H200 (binned pipeline, means per substep),
/// sorting every 64 / 16 / 8 / 4 substeps: bench-655k 0.245 / 0.237 / 0.228 / 0.230 ms, a
/// 16.8M-particle column 4.16 / 4.03 / 4.01 / 4.06 ms. The binned pipeline also rebins sooner when
/// the kernels flag a particle that moved a cell (tiles.cuh), learnt at each substep choice; stale
/// bins are never wrong, only slower.
pub const SORT_INTERVAL: u32 = 8;

/// Substeps between sorts where each binning also gathers the particles into bin order
/// (bin_order.rs), 184 bytes a particle: measured on the H100 (BENCHMARKS.md 0r, means per substep),
/// 16 instead of 8 took 0.5 to 6 % off the fused pipeline's presets and the 16.8M column (half the
/// binnings, against a particle pass up to 6 % slower on staler bins), 4 added 5 to 10 %.
pub const BIN_ORDER_SORT_INTERVAL: u32 = 16;

/// Substeps between sorts of a solver whose binnings do (`bin_order`) or do not gather its particles.
pub fn sort_interval(bin_order: bool) -> u32 {
    if bin_order {
        BIN_ORDER_SORT_INTERVAL
    } else {
        SORT_INTERVAL
    }
}

/// When the bins are rebuilt: the host's record of the binnings enqueued so far.
pub struct BinSchedule {
    /// Substeps between binnings when no particle asks for one sooner.
    interval: u32,
    built: bool,
    /// Binnings since the solver was made.
    pub binnings: u64,
    steps_since: u32,
    /// The kernels flagged a particle that moved past its bin's reach (read at a substep choice).
    pub rebin_requested: bool,
}

impl BinSchedule {
    /// Substeps between binnings when no particle asks for one sooner.
    pub fn interval(&self) -> u32 {
        self.interval
    }

    /// Bins due at once, then every `interval` substeps.
    pub fn every(interval: u32) -> BinSchedule {
        BinSchedule {
            interval,
            built: false,
            binnings: 0,
            steps_since: 0,
            rebin_requested: false,
        }
    }

    /// Whether the next substep rebuilds the bins: every `interval` substeps, and in the binned
    /// and fused pipelines sooner where a particle moved past its bin's reach.
    pub fn due(&self) -> bool {
        !self.built || self.rebin_requested || self.steps_since >= self.interval
    }

    pub fn built(&self) -> bool {
        self.built
    }

    /// The bins were rebuilt.
    pub fn note_binning(&mut self) {
        self.built = true;
        self.binnings += 1;
        self.rebin_requested = false;
        self.steps_since = 0;
    }

    /// A substep ran on the bins as they are.
    pub fn note_substep(&mut self) {
        self.steps_since += 1;
    }

    /// New particles (emitted) are in no bin yet.
    pub fn invalidate(&mut self) {
        self.built = false;
    }
}
