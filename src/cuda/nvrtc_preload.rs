//! Making NVRTC loadable before cudarc opens it by bare name. Shared by build.rs (through `#[path]`)
//! and the run-time compile path, which look for NVRTC in the same places.

use std::path::{Path, PathBuf};

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
