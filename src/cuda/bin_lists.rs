//! The bins' buffers (the pass that fills them is bins.rs, beside kernels/bins.cu): per particle
//! its key and rank, per cell a count then a start, the particle `order` by bin, and, for the binned
//! and fused pipelines, the list of bin chunks their tiled passes walk.

use super::gpu::Gpu;
use super::launch::{Kernel, Launcher};
use super::particles::slots_in_place;
use anyhow::{Context, Result};
use cudarc::driver::{CudaSlice, LaunchConfig};

use crate::contract::{
    BinEntry, PARKED_KEYS, SCAN_ITEMS_PER_THREAD, TILE_NODES, TILE_THREADS, WORK_BINS, WORK_NODE_BLOCKS,
    WORK_NODE_BLOCKS_DONE, WORK_WALL_NODE_BLOCKS, WORK_WALL_NODE_BLOCKS_DONE,
};
pub use crate::contract::{NODE_BLOCK_EDGE, NODE_BLOCK_NODES};
/// Slots of the work-count buffer: `WORK_BINS`, then the node-block list's, `WORK_NODE_BLOCKS`,
/// `WORK_NODE_BLOCKS_DONE`, `WORK_WALL_NODE_BLOCKS` and `WORK_WALL_NODE_BLOCKS_DONE`.
pub const WORK_COUNTS: usize = 5;
/// The work-count slots as indices.
pub const BIN_COUNT_SLOT: usize = WORK_BINS as usize;
/// Every slot of the node-block list (its two parts' lengths and their walks' counts), which
/// emptying the list zeroes.
pub const NODE_BLOCK_SLOTS: std::ops::Range<usize> = WORK_NODE_BLOCKS as usize..WORK_COUNTS;
const _: () = {
    const fn node_block_slot(slot: i32) -> bool {
        NODE_BLOCK_SLOTS.start <= slot as usize && (slot as usize) < NODE_BLOCK_SLOTS.end
    }
    assert!(
        BIN_COUNT_SLOT < NODE_BLOCK_SLOTS.start
            && node_block_slot(WORK_NODE_BLOCKS_DONE)
            && node_block_slot(WORK_WALL_NODE_BLOCKS)
            && node_block_slot(WORK_WALL_NODE_BLOCKS_DONE)
    );
};
/// The smallest chunk a bin is listed in: one particle per thread of a tiled pass (TILE_THREADS).
pub const MIN_BIN_CHUNK: usize = 128;
/// Particles a block of a tiled pass takes, for the blocks its list would fill (`Launcher::over_list`
/// launches whole waves of them where these are under three waves): four of the smallest chunks.
/// Measured on the H200 against 32 blocks a multiprocessor (BENCHMARKS.md M18): one_pass in whole
/// waves 5 to 12 % faster from 65k to 655k particles; at 1M particles one to four waves within
/// -0.2 to +2 %, at 16.8M one to four waves 0.7 to 4.7 % slower.
const PARTICLES_PER_TILED_BLOCK: usize = 4 * MIN_BIN_CHUNK;
/// Chunks a tiled pass should have at least to keep every multiprocessor busy several times over.
pub const CHUNKS_PER_MULTIPROCESSOR: usize = 48;

/// Bins per axis for bins of `edge` nodes.
pub fn bins_per_axis(grid_res: [u32; 3], edge: u32) -> [u32; 3] {
    grid_res.map(|r| r.div_ceil(edge))
}

pub struct Bins {
    pub(super) edge: u32,
    num_bins: usize,
    pub(super) num_particles: usize,
    pub(super) key: CudaSlice<u32>,
    pub(super) rank: CudaSlice<u32>,
    /// levels[0]: one count (then start) per bin; levels[i + 1]: the tile sums of levels[i]. The last
    /// level fits one tile; `top` takes its (unused) total.
    pub(super) levels: Vec<CudaSlice<u32>>,
    pub(super) top: CudaSlice<u32>,
    /// Particle indices by bin (identity before the first rebuild).
    pub order: CudaSlice<u32>,
    /// The bins that hold particles, in chunks of at most `chunk` particles (BIN_ENTRY_WORDS each),
    /// where listed.
    pub list: Option<CudaSlice<BinEntry>>,
    /// Particles per listed chunk at the most: the smallest chunk (a thread per particle) where bins
    /// are too few to fill the device, up to whole bins where they are plentiful, since each chunk
    /// clears and flushes a tile. Measured on the H200: 128-particle chunks took bench-65k from 0.106
    /// to 0.077 ms per step but a 16.8M-particle column from 5.16 to 5.58 ms.
    pub(super) chunk: u32,
}

impl Bins {
    /// Buffers for `num_particles` particles on `grid_res`, bins of `edge` nodes; `with_list` for the
    /// binned pipeline's bin list.
    pub fn new(
        launcher: &Launcher,
        grid_res: [u32; 3],
        num_particles: usize,
        edge: u32,
        with_list: bool,
    ) -> Result<Bins> {
        let stream = &launcher.stream;
        let num_bins: usize = bins_per_axis(grid_res, edge)
            .iter()
            .map(|&b| b as usize)
            .product();
        // One key per cell, and PARKED_KEYS past them for the parked slots (kernels/bins.cu).
        let num_keys = num_bins * (edge as usize).pow(3) + PARKED_KEYS as usize;
        let alloc = |len: usize, what: &str| {
            stream
                .alloc_zeros::<u32>(len.max(1))
                .with_context(|| format!("allocating {what} ({len} values)"))
        };
        let tile = launcher.block_size as usize * SCAN_ITEMS_PER_THREAD as usize;
        let mut levels = vec![alloc(num_keys, "the cells' counts")?];
        let mut level_len = num_keys;
        while level_len > tile {
            level_len = level_len.div_ceil(tile);
            levels.push(alloc(level_len, "the bins' scan")?);
        }
        let wanted_chunks = CHUNKS_PER_MULTIPROCESSOR * launcher.multiprocessors as usize;
        let chunk = (num_particles / wanted_chunks.max(1)).next_multiple_of(MIN_BIN_CHUNK);
        Ok(Bins {
            chunk: chunk.clamp(MIN_BIN_CHUNK, 8 * MIN_BIN_CHUNK) as u32,
            edge,
            num_bins,
            num_particles,
            key: alloc(num_particles, "bin keys")?,
            rank: alloc(num_particles, "bin ranks")?,
            levels,
            top: alloc(1, "the bins' scan")?,
            order: stream
                .clone_htod(&slots_in_place(num_particles))
                .context("allocating the particle order")?,
            list: if with_list {
                // A bin of c particles lists ceil(c / chunk) chunks: at most one per bin plus one per
                // chunk of particles.
                let capacity = num_bins + num_particles / MIN_BIN_CHUNK;
                Some(
                    stream
                        .alloc_zeros::<BinEntry>(capacity.max(1))
                        .context("allocating the bin list")?,
                )
            } else {
                None
            },
        })
    }

    pub fn num_bins(&self) -> usize {
        self.num_bins
    }

    /// The most chunks the bin list can hold.
    pub fn list_capacity(&self) -> usize {
        self.list.as_ref().map_or(0, |l| l.len())
    }

    /// The binned pipeline's list of bin chunks, which its tiled passes walk.
    pub fn list(&self) -> Result<&CudaSlice<BinEntry>> {
        self.list
            .as_ref()
            .context("only the binned pipeline lists its bins")
    }

    /// A tiled pass of `kernel` over the listed bins: a block per bin chunk at a time, a thread per
    /// particle, and `channels` 32-bit accumulators per tile node (kernels/tiles.cuh); a block for
    /// each `PARTICLES_PER_TILED_BLOCK` particles, within `Launcher::over_list`'s bounds.
    pub fn tiled_pass(&self, launcher: &Launcher, kernel: &Kernel, channels: u32) -> Result<LaunchConfig> {
        launcher.over_list(
            kernel,
            self.list_capacity(),
            self.num_particles / PARTICLES_PER_TILED_BLOCK,
            TILE_THREADS as u32,
            channels * TILE_NODES as u32 * 4,
        )
    }

    /// The bin list as the last binning left it: (bin, start, count) per chunk of a bin that holds
    /// particles, `work_counts` being the device's list lengths. Waits for the device.
    pub fn read_list(&self, gpu: &Gpu, work_counts: &CudaSlice<u32>) -> Result<Vec<[u32; 3]>> {
        let counts = gpu.download(work_counts)?;
        let entries = gpu.download(self.list()?)?;
        Ok(entries
            .iter()
            .take(counts[BIN_COUNT_SLOT] as usize)
            .map(|e| [e.bin, e.start, e.count])
            .collect())
    }
}
