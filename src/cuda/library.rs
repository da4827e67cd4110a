//! Finding the CUDA driver library and NVRTC before cudarc touches them: cudarc's dynamic loading
//! panics when a library is missing, so absence is checked here first and becomes an error that says
//! what to install.

use super::nvrtc_preload::preload_folder_libraries;
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
             or it is not on the loader path. Install the NVIDIA driver, or use --backend cpu"
        )
    }
}

/// NVRTC can be opened, looking where build.rs looks: `NVRTC_LIB`, `CUDA_HOME`/`CUDA_PATH`,
/// /usr/local/cuda, then the loader path. Checked once per process.
pub fn ensure_nvrtc() -> Result<()> {
    static FOUND: OnceLock<Result<(), String>> = OnceLock::new();
    match FOUND.get_or_init(find_nvrtc) {
        Ok(()) => Ok(()),
        Err(why) => bail!("{why}"),
    }
}

fn find_nvrtc() -> Result<(), String> {
    let mut folders: Vec<PathBuf> = Vec::new();
    if let Some(lib) = std::env::var_os("NVRTC_LIB").map(PathBuf::from) {
        // A library that does not load is reported below, by the presence check.
        let _ = preload_folder_libraries(lib.parent().unwrap_or(Path::new(".")), Some(&lib));
    } else {
        for var in ["CUDA_HOME", "CUDA_PATH"] {
            if let Some(root) = std::env::var_os(var) {
                folders.push(PathBuf::from(root).join("lib64"));
            }
        }
        folders.push(PathBuf::from("/usr/local/cuda/lib64"));
        for folder in &folders {
            if preload_folder_libraries(folder, None).unwrap_or(false) {
                break;
            }
        }
    }
    // SAFETY: only tries to open the library by its usual names (or finds the one preloaded above).
    if unsafe { cudarc::nvrtc::sys::is_culib_present() } {
        Ok(())
    } else {
        Err(
            "NVRTC (libnvrtc.so) was not found, and the kernels must be compiled at run time. \
             Install the CUDA toolkit (or only NVRTC: `pip install nvidia-cuda-nvrtc==13.0.88`) and set \
             NVRTC_LIB to its libnvrtc.so.*, or rebuild with NVRTC present (see .ci/install-nvrtc) so \
             the kernels are compiled into the binary"
                .to_string(),
        )
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
