//! The one way a kernel is launched: the kernel named once (for NVTX, errors and the module it came
//! from), its arguments, the launch error with the kernel's name, and `MPM_CUDA_SYNC=1`'s wait after
//! every launch, so an asynchronous fault names its kernel.

use super::modules::LoadedModules;
use anyhow::{Context, Result};
use cudarc::driver::{
    CudaContext, CudaEvent, CudaFunction, CudaSlice, CudaStream, LaunchArgs, LaunchConfig, PushKernelArg,
};
use std::sync::Arc;

/// The most blocks a pass over a list launches per multiprocessor (`Launcher::over_list`).
const MOST_BLOCKS_PER_SM: usize = 32;
/// Waves of resident blocks under which a pass over a list launches whole waves (`Launcher::over_list`).
const WHOLE_WAVES_UNDER: usize = 3;

/// A null device pointer, for a pointer argument its kernel reads only where it is set (arguments
/// go by reference, so a null one needs a place to live).
pub static NULL_POINTER: u64 = 0;

/// A device buffer a kernel takes where the scene has it, and a null pointer (unread) where not.
pub trait OptionalArg<'a> {
    fn arg_or_null<T>(&mut self, buffer: Option<&'a CudaSlice<T>>) -> &mut Self;
}

impl<'a> OptionalArg<'a> for LaunchArgs<'a> {
    fn arg_or_null<T>(&mut self, buffer: Option<&'a CudaSlice<T>>) -> &mut Self {
        match buffer {
            Some(buffer) => self.arg(buffer),
            None => self.arg(&NULL_POINTER),
        }
    }
}

/// A loaded kernel and its name.
#[derive(Clone)]
pub struct Kernel {
    name: &'static str,
    function: CudaFunction,
}

impl Kernel {
    /// Kernel `name` of `kernels/{module}.cu`.
    pub fn load(modules: &LoadedModules, module: &str, name: &'static str) -> Result<Kernel> {
        Ok(Kernel {
            name,
            function: modules.function(module, name)?,
        })
    }

    /// Its name in `kernels/`, as Nsight shows it.
    pub fn name(&self) -> &'static str {
        self.name
    }

    /// How many blocks of `block_size` threads and `shared_mem_bytes` of dynamic shared memory one
    /// multiprocessor holds at once (its registers and launch bounds decide).
    pub fn resident_blocks(&self, block_size: u32, shared_mem_bytes: u32) -> Result<u32> {
        self.function
            .occupancy_max_active_blocks_per_multiprocessor(block_size, shared_mem_bytes as usize, None)
            .with_context(|| {
                format!(
                    "asking the driver how many blocks of `{}` a multiprocessor holds",
                    self.name
                )
            })
    }

    /// Launches the kernel on `launcher`'s stream with the arguments `args` pushes, inside an NVTX
    /// range of the kernel's name.
    ///
    /// # Safety
    /// `args` must push exactly the kernel's parameters, in order and of matching types, and every
    /// buffer must be large enough for what the kernel reads and writes at `config`.
    pub unsafe fn launch<'a>(
        &'a self,
        launcher: &'a Launcher,
        config: LaunchConfig,
        args: impl FnOnce(&mut LaunchArgs<'a>),
    ) -> Result<()> {
        let _range = NvtxRange::new(self.name);
        let mut builder = launcher.stream.launch_builder(&self.function);
        args(&mut builder);
        // SAFETY: the caller vouches for the arguments and sizes.
        unsafe { builder.launch(config) }.with_context(|| format!("launching kernel `{}`", self.name))?;
        if launcher.sync_each_launch {
            launcher
                .stream
                .synchronize()
                .with_context(|| format!("kernel `{}` failed while running", self.name))?;
        }
        Ok(())
    }
}

/// The host type of one kernel, `host_kernel!(P2g = "p2g" / "p2g")`: a struct holding kernel `p2g`
/// of kernels/p2g.cu, and its `load`. The host file beside the kernel file adds the launch, which
/// alone knows the kernel's arguments.
macro_rules! host_kernel {
    ($host:ident = $module:literal / $function:literal) => {
        #[derive(Clone)]
        pub struct $host(crate::cuda::launch::Kernel);

        impl $host {
            pub fn load(modules: &crate::cuda::modules::LoadedModules) -> anyhow::Result<$host> {
                Ok($host(crate::cuda::launch::Kernel::load(
                    modules, $module, $function,
                )?))
            }
        }
    };
}
pub(crate) use host_kernel;

/// The stream every launch goes to, and how launches are sized.
#[derive(Clone)]
pub struct Launcher {
    pub stream: Arc<CudaStream>,
    /// Threads per block of the particle and grid kernels.
    pub block_size: u32,
    /// Streaming multiprocessors of the device: sizes the passes that loop over device-side lists.
    pub multiprocessors: u32,
    /// `MPM_CUDA_SYNC=1`: wait after every launch.
    pub sync_each_launch: bool,
    /// A second stream for launches that run beside the main stream's (`beside`).
    side: Arc<SideStream>,
}

/// The side stream and the two events that fork it from the main stream and join it back, made once,
/// so that a substep launched outside a graph forks and joins without allocating.
struct SideStream {
    stream: Arc<CudaStream>,
    fork: CudaEvent,
    join: CudaEvent,
}

impl Launcher {
    /// Launches on `stream`, with a side stream of the same context for `beside`.
    pub fn new(stream: Arc<CudaStream>, block_size: u32, multiprocessors: u32) -> Result<Launcher> {
        let ctx: &Arc<CudaContext> = stream.context();
        let event = || {
            ctx.new_event(Some(cudarc::driver::sys::CUevent_flags::CU_EVENT_DISABLE_TIMING))
                .context("creating a CUDA event to join two streams")
        };
        let side = SideStream {
            stream: ctx.new_stream().context("creating a second CUDA stream")?,
            fork: event()?,
            join: event()?,
        };
        Ok(Launcher {
            stream,
            block_size,
            multiprocessors,
            sync_each_launch: std::env::var("MPM_CUDA_SYNC").is_ok_and(|v| v == "1"),
            side: Arc::new(side),
        })
    }

    /// Enqueues `branch` on the side stream and `main` on this one, side by side: both start after
    /// what this stream holds so far, and what this stream is given next waits for both. For two
    /// launches with no order between them, where one alone cannot fill the device: in a captured
    /// substep they become parallel branches of the graph, so neither waits for the other's tail.
    pub fn beside(
        &self,
        branch: impl FnOnce(&Launcher) -> Result<()>,
        main: impl FnOnce(&Launcher) -> Result<()>,
    ) -> Result<()> {
        let side = &self.side;
        side.fork
            .record(&self.stream)
            .context("forking the side stream")?;
        side.stream.wait(&side.fork).context("forking the side stream")?;
        let on_side = Launcher {
            stream: side.stream.clone(),
            ..self.clone()
        };
        // Joined whatever the branches did, so that nothing later on this stream runs beside them
        // (and a capture does not end with a stream left out of it).
        let enqueued = branch(&on_side).and_then(|()| main(self));
        let joined = side
            .join
            .record(&side.stream)
            .and_then(|()| self.stream.wait(&side.join))
            .context("joining the side stream");
        enqueued.and(joined)
    }

    /// 1D launch covering `count` items (the kernels loop grid-stride, so any count fits).
    pub fn cover(&self, count: usize) -> LaunchConfig {
        let blocks = count.div_ceil(self.block_size as usize).clamp(1, 1 << 20) as u32;
        LaunchConfig {
            grid_dim: (blocks, 1, 1),
            block_dim: (self.block_size, 1, 1),
            shared_mem_bytes: 0,
        }
    }

    /// A launch for a pass of `kernel` over a device-side list of at most `capacity` entries, whose
    /// blocks loop over the list (its length is on the device), so their count is a choice. `wanted`:
    /// the blocks the list's work would fill (0 where it is not known). Under three waves of the
    /// kernel's resident blocks, whole waves, one at least: the blocks of a short list past its end
    /// still start and leave, each block's start costs what its entries must amortise (a tiled pass
    /// zeroes and flushes a tile), and a wave and a part would leave the part's fixed strides of the
    /// list to run after the rest. Otherwise `MOST_BLOCKS_PER_SM` a multiprocessor (all of them,
    /// where the capacity is smaller), which the device hands out as others finish: a long list's
    /// entries are uneven, and many blocks share them more evenly than a few waves' strides.
    /// Measured on the H200 (BENCHMARKS.md M18).
    pub fn over_list(
        &self,
        kernel: &Kernel,
        capacity: usize,
        wanted: usize,
        block_size: u32,
        shared_mem_bytes: u32,
    ) -> Result<LaunchConfig> {
        let multiprocessors = self.multiprocessors.max(1) as usize;
        let wave = kernel.resident_blocks(block_size, shared_mem_bytes)? as usize * multiprocessors;
        let blocks = list_blocks(wanted, wave, MOST_BLOCKS_PER_SM * multiprocessors, capacity);
        Ok(LaunchConfig {
            grid_dim: (blocks as u32, 1, 1),
            block_dim: (block_size, 1, 1),
            shared_mem_bytes,
        })
    }
}

/// `Launcher::over_list`'s count of blocks: `wanted` in whole waves of `wave` blocks under
/// `WHOLE_WAVES_UNDER` waves, `most` (or a wave, where that is more) from there on, never more than
/// the list's `capacity` nor fewer than one.
fn list_blocks(wanted: usize, wave: usize, most: usize, capacity: usize) -> usize {
    let wave = wave.max(1);
    let blocks = if wanted < WHOLE_WAVES_UNDER * wave {
        (wanted / wave).max(1) * wave
    } else {
        most.max(wave)
    };
    blocks.min(capacity).max(1)
}

/// An NVTX range for the lifetime of the value: shows as a named span in Nsight Systems, and costs
/// almost nothing when no profiler is attached.
pub struct NvtxRange(());

impl NvtxRange {
    pub fn new(name: &str) -> NvtxRange {
        nvtx::range_push!("{name}");
        NvtxRange(())
    }
}

impl Drop for NvtxRange {
    fn drop(&mut self) {
        nvtx::range_pop!();
    }
}

#[cfg(test)]
mod tests {
    use super::list_blocks;

    #[test]
    fn a_short_list_takes_whole_waves_and_a_long_one_the_most() {
        let (wave, most) = (660, 4224);
        assert_eq!(
            list_blocks(0, wave, most, 15_625),
            wave,
            "nothing known: one wave"
        );
        assert_eq!(list_blocks(128, wave, most, 15_625), wave);
        assert_eq!(
            list_blocks(2 * wave - 1, wave, most, 15_625),
            wave,
            "never a wave and a part"
        );
        assert_eq!(list_blocks(2 * wave + 300, wave, most, 15_625), 2 * wave);
        assert_eq!(
            list_blocks(3 * wave, wave, most, 100_000),
            most,
            "from three waves on, the most"
        );
        assert_eq!(list_blocks(32_768, wave, most, 100_000), most);
        assert_eq!(list_blocks(32_768, 5000, most, 100_000), 5000, "at least a wave");
        assert_eq!(
            list_blocks(0, wave, most, 200),
            200,
            "never past the list's capacity"
        );
        assert_eq!(list_blocks(0, 0, most, 0), 1, "one block at least");
    }
}
