//! Where NVRTC is looked for and how kernels are compiled with it: one list of places and one list of
//! options, shared by build.rs (through `#[path]`) and the run-time compile (src/cuda/modules.rs).

use std::path::{Path, PathBuf};

/// NVRTC options of every kernel compile, at build time and at run time (each adds its target).
pub const COMPILE_OPTIONS: [&str; 2] = ["-lineinfo", "--std=c++17"];

/// Makes libnvrtc loadable by cudarc (which opens it by bare name), looking in order at `NVRTC_LIB` (a
/// file), `CUDA_HOME`/`CUDA_PATH` (`lib64/`), /usr/local/cuda, the cache `.ci/install-nvrtc` fills
/// (`MPM_NVRTC_CACHE`, else `.ci-cache/nvrtc` in each of `checkouts`), then the loader path. Returns
/// where it was found, or every place looked in.
pub fn find_nvrtc(checkouts: &[PathBuf]) -> Result<String, String> {
    let mut folders: Vec<PathBuf> = Vec::new();
    let mut found_in = std::env::var("NVRTC_LIB").ok();
    if let Some(lib) = std::env::var_os("NVRTC_LIB").map(PathBuf::from) {
        if !lib.is_file() {
            return Err(format!("NVRTC_LIB={} is not a file", lib.display()));
        }
        preload_folder_libraries(lib.parent().unwrap_or(Path::new(".")), Some(&lib))?;
    } else {
        for var in ["CUDA_HOME", "CUDA_PATH"] {
            if let Some(root) = std::env::var_os(var) {
                folders.push(PathBuf::from(root).join("lib64"));
            }
        }
        folders.push(PathBuf::from("/usr/local/cuda/lib64"));
        let caches = match std::env::var_os("MPM_NVRTC_CACHE") {
            Some(cache) => vec![PathBuf::from(cache)],
            None => checkouts.iter().map(|c| c.join(".ci-cache/nvrtc")).collect(),
        };
        for cache in caches {
            if let Ok(entries) = std::fs::read_dir(&cache) {
                let mut wheels: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
                wheels.sort();
                folders.extend(wheels.iter().rev().map(|w| w.join("nvidia/cu13/lib")));
            }
        }
        for folder in &folders {
            if preload_folder_libraries(folder, None)? {
                found_in = Some(folder.display().to_string());
                break;
            }
        }
    }
    // SAFETY: only probes whether the library can be opened (or finds the one preloaded above).
    if unsafe { cudarc::nvrtc::sys::is_culib_present() } {
        Ok(found_in.unwrap_or_else(|| "found on the loader path".into()))
    } else {
        Err(format!(
            "no libnvrtc in NVRTC_LIB, CUDA_HOME, CUDA_PATH, /usr/local/cuda or the .ci/install-nvrtc \
             cache (looked in {folders:?}), nor on the loader path"
        ))
    }
}

/// Opens the builtins library and libnvrtc of `folder` (or `nvrtc` itself) with RTLD_GLOBAL and keeps
/// them open, so the later opens by bare name find them. Returns whether a libnvrtc was loaded.
pub fn preload_folder_libraries(folder: &Path, nvrtc: Option<&Path>) -> Result<bool, String> {
    let Ok(entries) = std::fs::read_dir(folder) else {
        return Ok(false);
    };
    let mut names: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    names.sort();
    let is_lib = |p: &PathBuf, prefix: &str| {
        p.file_name()
            .and_then(|f| f.to_str())
            .is_some_and(|f| f.starts_with(prefix) && !f.contains(".alt."))
    };
    let builtins = names.iter().find(|p| is_lib(p, "libnvrtc-builtins.so"));
    let nvrtc = match nvrtc {
        Some(path) => Some(path.to_path_buf()),
        None => names.iter().find(|p| is_lib(p, "libnvrtc.so")).cloned(),
    };
    let Some(nvrtc) = nvrtc else {
        return Ok(false);
    };
    for library in builtins.into_iter().chain(std::iter::once(&nvrtc)) {
        // SAFETY: NVIDIA's libraries run no unusual initialisers; the handle is leaked on purpose
        // so the library stays loaded for cudarc.
        let handle = unsafe {
            libloading::os::unix::Library::open(
                Some(library),
                libloading::os::unix::RTLD_NOW | libloading::os::unix::RTLD_GLOBAL,
            )
        }
        .map_err(|e| format!("cannot load {}: {e}", library.display()))?;
        std::mem::forget(handle);
    }
    Ok(true)
}
