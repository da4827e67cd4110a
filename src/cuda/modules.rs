//! The kernel modules: PTX embedded by build.rs, loaded into the context; or, where the build had no
//! NVRTC or the driver refuses the PTX, the embedded source compiled at run time by NVRTC straight to
//! a cubin for this GPU (a cubin carries no PTX version, so a newer NVRTC than the driver still works).

use super::library;
use super::nvrtc_search::COMPILE_OPTIONS;
use crate::contract::{Material, MAX_MATERIALS};
use anyhow::{anyhow, bail, Context, Result};
use cudarc::driver::{sys::CUresult, CudaContext, CudaFunction, CudaModule, CudaStream, DriverError};
use cudarc::nvrtc::{result as nvrtc, sys as nvrtc_sys, Ptx};
use std::ffi::{CStr, CString};
use std::sync::Arc;

/// The `__constant__` array of material rows every module that includes material.cuh holds.
const MATERIAL_TABLE: &str = "material_table";

/// One `kernels/*.cu` file as build.rs embedded it.
#[derive(Debug, Clone, Copy)]
pub struct KernelModule {
    /// The file stem, e.g. `p2g`.
    pub name: &'static str,
    /// The source with `common.cuh` pasted in.
    pub source: &'static str,
    /// `compute_75` PTX, or `None` where the build had no NVRTC.
    pub ptx_compute_75: Option<&'static str>,
    /// `compute_90` PTX (Hopper and newer), or `None` where the build had no NVRTC.
    pub ptx_compute_90: Option<&'static str>,
}

#[allow(dead_code)] // every module is listed in `ALL`; not each constant is named elsewhere
mod embedded {
    use super::KernelModule;
    include!(concat!(env!("OUT_DIR"), "/kernels.rs"));
}
pub use embedded::ALL as MODULES;

/// How a module came to be loaded, for messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// Build-time PTX, JIT-compiled by the driver.
    EmbeddedPtx,
    /// Run-time NVRTC, because the build had no NVRTC.
    RuntimeNoPtx,
    /// Run-time NVRTC, because the driver refused the embedded PTX.
    RuntimeRefusedPtx,
    /// PTX files from `MPM_PTX_DIR` (kernel development: time a variant without rebuilding).
    OverridePtx,
}

/// Every kernel module, loaded.
pub struct LoadedModules {
    modules: Vec<(&'static str, Arc<CudaModule>)>,
    pub origin: Origin,
}

/// Modules no solver or renderer launches, only a test: kernels/solid_laws.cu, the solid laws on
/// their own. A GPU's start-up leaves them out; their test loads them (`load_named`).
pub const TEST_ONLY_MODULES: [&str; 1] = ["solid_laws"];

impl LoadedModules {
    /// Every module a solver or renderer launches (all but [`TEST_ONLY_MODULES`]).
    pub fn load(ctx: &Arc<CudaContext>) -> Result<LoadedModules> {
        Self::load_some(ctx, |name| !TEST_ONLY_MODULES.contains(&name))
    }

    /// The modules named in `names` only (a renderer's kernels, without the solver's).
    pub fn load_named(ctx: &Arc<CudaContext>, names: &[&str]) -> Result<LoadedModules> {
        Self::load_some(ctx, |name| names.contains(&name))
    }

    fn load_some(ctx: &Arc<CudaContext>, wanted: impl Fn(&str) -> bool) -> Result<LoadedModules> {
        let mut modules = Vec::new();
        let mut origin = Origin::EmbeddedPtx;
        for module in MODULES.iter().filter(|m| wanted(m.name)) {
            let (loaded, how) = load_module(ctx, module)?;
            if how != Origin::EmbeddedPtx {
                origin = how;
            }
            modules.push((module.name, loaded));
        }
        Ok(LoadedModules { modules, origin })
    }

    /// Writes the material table (`sim::Params::materials`) into every module's `material_table`
    /// (kernels/material.cuh), in `stream`'s order: each module holds its own copy of a
    /// `__constant__`. A module without the symbol has no kernel that reads it.
    pub fn write_material_table(
        &self,
        stream: &Arc<CudaStream>,
        table: &[Material; MAX_MATERIALS as usize],
    ) -> Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(table);
        for (name, module) in &self.modules {
            let mut symbol = match module.get_global(MATERIAL_TABLE, stream) {
                Ok(symbol) => symbol,
                Err(DriverError(CUresult::CUDA_ERROR_NOT_FOUND)) => continue,
                Err(e) => {
                    return Err(e).with_context(|| format!("finding {MATERIAL_TABLE} in kernels/{name}.cu"))
                }
            };
            anyhow::ensure!(
                symbol.len() == bytes.len(),
                "kernels/{name}.cu's {MATERIAL_TABLE} holds {} bytes, the host's table {}",
                symbol.len(),
                bytes.len()
            );
            stream
                .memcpy_htod(bytes, &mut symbol)
                .with_context(|| format!("writing the material table of kernels/{name}.cu"))?;
        }
        Ok(())
    }

    /// Kernel `function` of module `module`.
    pub fn function(&self, module: &str, function: &str) -> Result<CudaFunction> {
        let (_, loaded) = self
            .modules
            .iter()
            .find(|(name, _)| *name == module)
            .ok_or_else(|| anyhow!("no kernel module `{module}` was embedded (kernels/{module}.cu)"))?;
        loaded
            .load_function(function)
            .with_context(|| format!("kernel `{function}` not found in kernels/{module}.cu"))
    }
}

fn load_module(ctx: &Arc<CudaContext>, module: &KernelModule) -> Result<(Arc<CudaModule>, Origin)> {
    let (major, minor) = ctx
        .compute_capability()
        .context("reading the compute capability")?;
    let arch = if major >= 9 { "compute_90" } else { "compute_75" };
    if let Some(dir) = std::env::var_os("MPM_PTX_DIR") {
        let path = std::path::Path::new(&dir).join(format!("{}.{arch}.ptx", module.name));
        if path.is_file() {
            let text = std::fs::read_to_string(&path)
                .with_context(|| format!("reading {} (MPM_PTX_DIR)", path.display()))?;
            let loaded = ctx
                .load_module(Ptx::from_src(text))
                .with_context(|| format!("loading {} (MPM_PTX_DIR)", path.display()))?;
            return Ok((loaded, Origin::OverridePtx));
        }
    }
    let ptx = if major >= 9 {
        module.ptx_compute_90
    } else {
        module.ptx_compute_75
    };
    let why_runtime = match ptx {
        Some(ptx) => match ctx.load_module(Ptx::from_src(ptx)) {
            Ok(loaded) => return Ok((loaded, Origin::EmbeddedPtx)),
            Err(DriverError(
                CUresult::CUDA_ERROR_UNSUPPORTED_PTX_VERSION | CUresult::CUDA_ERROR_INVALID_PTX,
            )) => Origin::RuntimeRefusedPtx,
            Err(e) => {
                return Err(e).with_context(|| format!("loading the PTX of kernels/{}.cu", module.name))
            }
        },
        None => Origin::RuntimeNoPtx,
    };
    let reason = match why_runtime {
        Origin::RuntimeNoPtx => "this binary was built without NVRTC, so it carries no PTX",
        _ => "the driver refused the embedded PTX (built by an NVRTC newer than the driver)",
    };
    let cubin = compile_cubin(module, major, minor).with_context(|| {
        format!(
            "kernels/{}.cu must be compiled at run time: {reason}",
            module.name
        )
    })?;
    let loaded = ctx
        .load_module(Ptx::from_binary(cubin))
        .with_context(|| format!("loading the run-time compiled kernels/{}.cu", module.name))?;
    Ok((loaded, why_runtime))
}

/// NVRTC the embedded source to a cubin for `sm_{major}{minor}`.
fn compile_cubin(module: &KernelModule, major: i32, minor: i32) -> Result<Vec<u8>> {
    library::ensure_nvrtc()?;
    let file_name = CString::new(format!("{}.cu", module.name))?;
    let source = CString::new(module.source)?;
    let program = nvrtc::create_program(&source, Some(file_name.as_c_str()))
        .map_err(|e| anyhow!("nvrtcCreateProgram: {e:?}"))?;
    let mut options: Vec<String> = COMPILE_OPTIONS.iter().map(|s| s.to_string()).collect();
    options.push(format!("--gpu-architecture=sm_{major}{minor}"));
    // SAFETY: `program` is live until destroy_program below.
    let compiled = unsafe { nvrtc::compile_program(program, &options) };
    let result = match compiled {
        Ok(()) => cubin_of(program),
        Err(e) => {
            // SAFETY: as above; the log is NUL-terminated.
            let log = unsafe { nvrtc::get_program_log(program) }
                .map(|raw| {
                    unsafe { CStr::from_ptr(raw.as_ptr()) }
                        .to_string_lossy()
                        .into_owned()
                })
                .unwrap_or_default();
            Err(anyhow!("NVRTC failed ({e:?}, options {options:?}):\n{log}"))
        }
    };
    // SAFETY: destroyed exactly once.
    let _ = unsafe { nvrtc::destroy_program(program) };
    result
}

fn cubin_of(program: nvrtc_sys::nvrtcProgram) -> Result<Vec<u8>> {
    let mut size = 0usize;
    // SAFETY: `program` compiled successfully; the buffer has the size NVRTC asked for.
    unsafe { nvrtc_sys::nvrtcGetCUBINSize(program, &mut size) }
        .result()
        .map_err(|e| anyhow!("nvrtcGetCUBINSize: {e:?}"))?;
    if size == 0 {
        bail!("NVRTC produced an empty cubin");
    }
    let mut cubin = vec![0u8; size];
    unsafe { nvrtc_sys::nvrtcGetCUBIN(program, cubin.as_mut_ptr().cast()) }
        .result()
        .map_err(|e| anyhow!("nvrtcGetCUBIN: {e:?}"))?;
    Ok(cubin)
}
