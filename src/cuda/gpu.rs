//! One GPU: its context, its stream (through the [`Launcher`]), the kernel modules loaded into it,
//! and the checks that come before anything is allocated there. Everything else of a solver that
//! lives on a device (buffers, kernels, graphs, timing) hangs off the solver that owns one `Gpu`, so
//! a second device is a second `Gpu`, never shared state. The bottom of src/cuda: it imports no pass.

use super::launch::Launcher;
use super::library;
use super::modules::{LoadedModules, Origin};
use crate::sim::{Method, Pipeline, Scene};
use anyhow::{anyhow, bail, ensure, Context, Result};
use cudarc::driver::{CudaContext, CudaStream, DevicePtr, DeviceRepr};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A module load slower than this was the driver compiling PTX, not reading its cache.
const SLOW_MODULE_LOAD: Duration = Duration::from_secs(1);

/// Where and how to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CudaOptions {
    /// CUDA device ordinal.
    pub device: usize,
    /// Threads per block of the particle and grid kernels: a multiple of 32 (the kernels reduce per
    /// warp with full-mask shuffles), at most 1024.
    pub block_size: u32,
    /// Each substep as one CUDA graph launch (graph.rs) rather than a launch per kernel.
    pub graphs: bool,
    /// The fused pipeline and the position-based solver store their particles in bin order,
    /// gathering them there at each binning (bin_order.rs); off, they stay at their slots (for
    /// comparing the two).
    pub bin_order: bool,
    /// How one_pass's float scatter sums its runs (one_pass.rs).
    pub float_scatter: FloatScatter,
    /// One substep in this many times its phases by CUDA events, the others only whole (timing.rs):
    /// each event is a node on the substep's critical path. 1 times every substep's.
    pub phase_sample: u32,
    /// Several ranks (cuda_ranks.rs): the rank whose stream their phases are timed on. Each phase is
    /// timed from the end of the one before on that stream, so another rank's view shows where it
    /// waits.
    pub timed_rank: usize,
}

/// How the float scatter sums a warp's runs of particles (kernels/one_pass.cu's `Scatter`):
/// `MPM_FLOAT_SCATTER=runs` or `planes` fixes it, for comparing the two; by default the size of
/// the scene chooses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FloatScatter {
    /// `runs` where the particles are fewer than PLANES_FROM_WAVES times what the device holds of
    /// the planes kernel at once, `planes` from there.
    BySize,
    /// Node by node (`one_pass_float`): the shortest warp, for scenes too small to fill the device.
    Runs,
    /// A plane of 9 nodes at a time, in the shuffle steps the warp's longest run needs
    /// (`one_pass_float_planes`): the fewest shuffles, for scenes that fill it.
    Planes,
}

impl FloatScatter {
    /// The `MPM_FLOAT_SCATTER` value `text`.
    pub fn parse(text: &str) -> Result<FloatScatter> {
        match text.trim() {
            "runs" => Ok(FloatScatter::Runs),
            "planes" => Ok(FloatScatter::Planes),
            _ => bail!(
                "MPM_FLOAT_SCATTER={text:?}: use runs or planes (leave it unset and the scene's size chooses)"
            ),
        }
    }
}

/// The substeps of which one times its phases by default (`CudaOptions::phase_sample`): on the H200
/// the events of the others took bench-65k's substep 4.8 % (BENCHMARKS.md M19, one in 8). Odd, so
/// that the sampled substeps fall on each place of the rebin cadence (16 substeps) in turn: one in
/// 8 would time a binning in every other sample.
pub const PHASE_SAMPLE: u32 = 7;

impl Default for CudaOptions {
    fn default() -> Self {
        CudaOptions {
            device: 0,
            block_size: 128,
            graphs: true,
            bin_order: true,
            float_scatter: FloatScatter::BySize,
            phase_sample: PHASE_SAMPLE,
            timed_rank: 0,
        }
    }
}

impl CudaOptions {
    /// The defaults, overridden by `MPM_CUDA_DEVICE`, `MPM_CUDA_BLOCK_SIZE`, `MPM_CUDA_GRAPHS`,
    /// `MPM_BIN_ORDER`, `MPM_FLOAT_SCATTER`, `MPM_PHASE_SAMPLE` and `MPM_TIMED_RANK` where set.
    pub fn from_env() -> Result<CudaOptions> {
        let mut options = CudaOptions::default();
        if let Ok(text) = std::env::var("MPM_CUDA_DEVICE") {
            options.device = text
                .trim()
                .parse()
                .map_err(|_| anyhow!("MPM_CUDA_DEVICE={text:?} is not a device number (0, 1, ...)"))?;
        }
        if let Ok(text) = std::env::var("MPM_CUDA_BLOCK_SIZE") {
            options.block_size = text.trim().parse().map_err(|_| {
                anyhow!("MPM_CUDA_BLOCK_SIZE={text:?} is not a number; use 128 (or 64, 256, ...)")
            })?;
        }
        if let Ok(text) = std::env::var("MPM_CUDA_GRAPHS") {
            options.graphs = match text.trim() {
                "1" => true,
                "0" => false,
                _ => bail!("MPM_CUDA_GRAPHS={text:?}: use 1 (substeps as CUDA graphs, the default) or 0"),
            };
        }
        if let Ok(text) = std::env::var("MPM_BIN_ORDER") {
            options.bin_order = match text.trim() {
                "1" => true,
                "0" => false,
                _ => bail!(
                    "MPM_BIN_ORDER={text:?}: use 1 (the fused pipeline and the position-based solver store \
                     particles in bin order, the default) or 0 (they stay at their slots)"
                ),
            };
        }
        if let Ok(text) = std::env::var("MPM_FLOAT_SCATTER") {
            options.float_scatter = FloatScatter::parse(&text)?;
        }
        if let Ok(text) = std::env::var("MPM_PHASE_SAMPLE") {
            options.phase_sample = text.trim().parse().ok().filter(|&n| n >= 1).ok_or_else(|| {
                anyhow!(
                    "MPM_PHASE_SAMPLE={text:?}: use a whole number from 1 (every substep's phases \
                     timed) up; the default, {PHASE_SAMPLE}, times one substep's in {PHASE_SAMPLE}"
                )
            })?;
        }
        if let Ok(text) = std::env::var("MPM_TIMED_RANK") {
            options.timed_rank = text.trim().parse().map_err(|_| {
                anyhow!("MPM_TIMED_RANK={text:?} is not a rank number (0, the default, 1, ...)")
            })?;
        }
        options.validate()?;
        Ok(options)
    }

    /// Whether a solver of `scene` stores its particles in bin order: the fused pipeline's and the
    /// position-based solver's do (a run without memory for the second copy still keeps them in
    /// place, state.rs).
    pub fn bin_order_for(&self, scene: &Scene) -> bool {
        self.bin_order && (scene.pipeline == Pipeline::Fused || scene.method == Method::Pbmpm)
    }

    pub fn validate(&self) -> Result<()> {
        ensure!(
            self.block_size >= 32 && self.block_size <= 1024 && self.block_size % 32 == 0,
            "block size {} must be a multiple of 32 between 32 and 1024 (128 is the default)",
            self.block_size
        );
        Ok(())
    }
}

/// One device, opened: the context, the one stream every launch goes to, the kernel modules.
pub struct Gpu {
    pub ctx: Arc<CudaContext>,
    pub launcher: Launcher,
    pub modules: LoadedModules,
    pub ordinal: usize,
}

impl Gpu {
    /// Opens device `options.device` and loads every kernel module into it (the kernels are taken
    /// from them by `kernels::Kernels::load`).
    pub fn open(options: &CudaOptions) -> Result<Gpu> {
        options.validate()?;
        library::ensure_driver()?;
        let ctx = CudaContext::new(options.device).map_err(|e| {
            anyhow!(
                "cannot open CUDA device {}: {e} (no NVIDIA GPU, or the driver is not working)",
                options.device
            )
        })?;
        // The streams are ordered by the code itself (Launcher::beside joins its side stream back
        // before anything else is enqueued), so cudarc's cross-stream event tracking only costs time.
        // SAFETY: called before any allocation in this context.
        unsafe { ctx.disable_event_tracking() };
        let stream = ctx.new_stream().context("creating a CUDA stream")?;
        let loading = Instant::now();
        let modules = LoadedModules::load(&ctx)?;
        let took = loading.elapsed();
        // On a machine's first run the driver compiles the embedded PTX for its GPU, seconds (6.8 s on
        // an H200, BENCHMARKS.md 0z), and caches the result: later runs load in milliseconds. Said,
        // so that a slow first start is not taken for the program's own cost.
        if took > SLOW_MODULE_LOAD && modules.origin == Origin::EmbeddedPtx {
            eprintln!(
                "note: the driver compiled the kernels for this GPU in {:.1} s; it keeps them in its cache \
                 (CUDA_CACHE_PATH, by default ~/.nv/ComputeCache), so later runs start in well under a second",
                took.as_secs_f64()
            );
        }
        let multiprocessors = ctx
            .attribute(cudarc::driver::sys::CUdevice_attribute::CU_DEVICE_ATTRIBUTE_MULTIPROCESSOR_COUNT)
            .context("reading the multiprocessor count")?;
        let multiprocessors = multiprocessors.max(1) as u32;
        Ok(Gpu {
            launcher: Launcher::new(stream, options.block_size, multiprocessors)?,
            modules,
            ordinal: options.device,
            ctx,
        })
    }

    pub fn stream(&self) -> &Arc<CudaStream> {
        &self.launcher.stream
    }

    /// The device's name, e.g. "NVIDIA H200".
    pub fn name(&self) -> String {
        self.ctx.name().unwrap_or_else(|_| "unknown CUDA device".into())
    }

    /// Refuses a run that needs `needed` bytes of device memory where fewer are free (with room left
    /// for the context, the modules and the spawn scratch); `what` and `fix` say what asked and what
    /// to change.
    pub fn ensure_fits(&self, needed: usize, what: &str, fix: &str) -> Result<()> {
        if !self.fits(needed)? {
            let (free, total) = self.ctx.mem_get_info().context("cuMemGetInfo")?;
            bail!(
                "{what} needs {:.2} GiB of GPU memory but device {} ({}) has {:.2} GiB free of {:.2} GiB; \
                 {fix}",
                gib(needed),
                self.ordinal,
                self.name(),
                gib(free),
                gib(total)
            );
        }
        Ok(())
    }

    /// Whether `needed` bytes fit in the device's free memory, with that room left.
    pub fn fits(&self, needed: usize) -> Result<bool> {
        let (free, _) = self.ctx.mem_get_info().context("cuMemGetInfo")?;
        Ok(needed + (64 << 20) <= free)
    }

    /// A host copy of `buffer`, waiting for everything enqueued before it.
    pub fn download<T: DeviceRepr + Default + Clone>(&self, buffer: &impl DevicePtr<T>) -> Result<Vec<T>> {
        let mut host = vec![T::default(); buffer.len()];
        let stream = self.stream();
        stream
            .memcpy_dtoh(buffer, &mut host)
            .context("copying from the GPU (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
        stream
            .synchronize()
            .context("waiting for the GPU (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
        Ok(host)
    }
}

fn gib(bytes: usize) -> f64 {
    bytes as f64 / (1u64 << 30) as f64
}
