//! Finding the CUDA driver library and NVRTC before cudarc touches them: cudarc's dynamic loading
//! panics when a library is missing, so absence is checked here first and becomes an error that says
//! what to install.

use super::nvrtc_search::find_nvrtc;
use anyhow::{bail, Result};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// libcuda (the driver) can be opened; otherwise an error naming the fix.
pub fn ensure_driver() -> Result<()> {
    // SAFETY: only tries to open the library by its usual names.
    if unsafe { cudarc::driver::sys::is_culib_present() } {
        Ok(())
    } else {
        bail!(
            "the NVIDIA driver library (libcuda.so) was not found: this machine has no NVIDIA driver, \
             or it is not on the loader path. Install the NVIDIA driver, or use --backend cpu-parallel"
        )
    }
}

/// NVRTC can be opened, looking where build.rs looks (src/cuda/nvrtc_search.rs); the checkout whose
/// `.ci/install-nvrtc` cache may hold it is the working directory or a folder above the executable
/// (`target/release/mpm`). Checked once per process.
pub fn ensure_nvrtc() -> Result<()> {
    static FOUND: OnceLock<Result<String, String>> = OnceLock::new();
    let found = FOUND.get_or_init(|| {
        let mut checkouts: Vec<PathBuf> = std::env::current_dir().into_iter().collect();
        if let Ok(exe) = std::env::current_exe() {
            checkouts.extend(exe.ancestors().skip(1).take(3).map(Path::to_path_buf));
        }
        find_nvrtc(&checkouts)
    });
    match found {
        Ok(_) => Ok(()),
        Err(why) => bail!(
            "NVRTC (libnvrtc.so) was not found ({why}), and the kernels must be compiled at run time. \
             Install the CUDA toolkit (or only NVRTC: `pip install nvidia-cuda-nvrtc==13.0.88`) and set \
             NVRTC_LIB to its libnvrtc.so.*, or rebuild with NVRTC present (see .ci/install-nvrtc) so \
             the kernels are compiled into the binary"
        ),
    }
}

/// Whether a CUDA device can be used here: the driver library loads, initialises and reports a
/// device. The reason where not (for tests that skip, and for `--backend auto`'s notice).
pub fn device_available() -> Result<()> {
    ensure_driver()?;
    cudarc::driver::result::init()
        .map_err(|e| anyhow::anyhow!("the CUDA driver does not initialise: {e}"))?;
    let count = cudarc::driver::result::device::get_count()
        .map_err(|e| anyhow::anyhow!("cannot count CUDA devices: {e}"))?;
    if count < 1 {
        bail!("the CUDA driver reports no device");
    }
    Ok(())
}

/// Free device memory as cuMemGetInfo reports it, from a context held for the probe's lifetime (so
/// that a reading before a solver exists already counts the context itself).
pub struct MemoryProbe {
    ctx: std::sync::Arc<cudarc::driver::CudaContext>,
}

impl MemoryProbe {
    pub fn new(device: usize) -> Result<MemoryProbe> {
        ensure_driver()?;
        let ctx = cudarc::driver::CudaContext::new(device).map_err(|e| {
            anyhow::anyhow!(
                "cannot open CUDA device {device}: {e} (no NVIDIA GPU, or the driver is not working)"
            )
        })?;
        Ok(MemoryProbe { ctx })
    }

    /// Free bytes on the device now.
    pub fn free_bytes(&self) -> Result<u64> {
        let (free, _total) = self
            .ctx
            .mem_get_info()
            .map_err(|e| anyhow::anyhow!("cuMemGetInfo: {e}"))?;
        Ok(free as u64)
    }
}

/// One CUDA device as `mpm devices` lists it.
pub struct DeviceSummary {
    pub ordinal: usize,
    pub name: String,
    pub memory_bytes: usize,
    /// Per other device (by ordinal): whether this one can read and write its memory directly.
    pub peer_access: Vec<bool>,
}

/// Every CUDA device the driver shows, with peer access between them; an error where there is no
/// driver or no device.
pub fn devices() -> Result<Vec<DeviceSummary>> {
    ensure_driver()?;
    let count = cudarc::driver::CudaContext::device_count()
        .map_err(|e| anyhow::anyhow!("the NVIDIA driver cannot count its devices: {e}"))?
        .max(0) as usize;
    let contexts = (0..count)
        .map(|i| {
            cudarc::driver::CudaContext::new(i)
                .map_err(|e| anyhow::anyhow!("cannot open CUDA device {i}: {e}"))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut summaries = Vec::with_capacity(count);
    for (i, ctx) in contexts.iter().enumerate() {
        let mut peer_access = Vec::with_capacity(count);
        for (j, other) in contexts.iter().enumerate() {
            let mut can = 0;
            if i != j {
                // SAFETY: writes one int; both handles come from open contexts.
                let result = unsafe {
                    cudarc::driver::sys::cuDeviceCanAccessPeer(&mut can, ctx.cu_device(), other.cu_device())
                };
                if result != cudarc::driver::sys::CUresult::CUDA_SUCCESS {
                    bail!("cuDeviceCanAccessPeer({i}, {j}) failed: {result:?}");
                }
            }
            peer_access.push(can != 0);
        }
        summaries.push(DeviceSummary {
            ordinal: i,
            name: ctx.name().unwrap_or_else(|_| "unknown CUDA device".into()),
            memory_bytes: ctx.total_mem().unwrap_or(0),
            peer_access,
        });
    }
    Ok(summaries)
}
