//! Compiles every `kernels/*.cu` to PTX with NVRTC and embeds it, one constant per module
//! (candle-kernels style), in `$OUT_DIR/kernels.rs`, which `src/cuda/modules.rs` includes.
//!
//! - Each kernel's `#include "common.cuh"` is pasted in here (with `#line` markers, so NVRTC's log still
//!   names the right file and line); the pasted source is embedded too, for run-time compilation.
//!   `#include "contract.cuh"` pastes the header written from src/contract/items.rs (the structs and
//!   constants the kernels share with the host).
//! - Targets: `compute_75` PTX (NVRTC 13 accepts nothing older; the driver JIT-compiles it for any newer
//!   GPU on first load and caches the result) and `compute_90` PTX, which Hopper and newer load instead
//!   (it uses sm_90's vector atomics in p2g). Both with `-lineinfo`.
//! - NVRTC is looked for where the run-time compile looks (src/cuda/nvrtc_search.rs, with the same
//!   compile options). Its builtins library, which libnvrtc opens by bare name, is loaded first from
//!   the same folder, so LD_LIBRARY_PATH is not needed.
//! - A kernel that does not compile fails the build with NVRTC's log.
//! - The PTX of the pinned NVRTC (13.0) is also committed, in `kernels/ptx/`, with a manifest of the
//!   sources it was compiled from (a fingerprint of each module's pasted source, options and target).
//!   A build without NVRTC (a machine with only the NVIDIA driver, the common desktop and cloud image)
//!   embeds that PTX wherever its fingerprint matches the sources, so `cargo run --release` needs no
//!   toolkit. A build with NVRTC 13.0 checks that the committed PTX is what it compiled; CI
//!   (`MPM_REQUIRE_NVRTC=1`) fails where it is stale, and `MPM_UPDATE_PTX=1 cargo build` rewrites it.
//! - No NVRTC and no matching committed PTX for a module: the build succeeds with a warning and the
//!   program compiles that module's embedded source at run time, unless `MPM_REQUIRE_NVRTC=1` (CI),
//!   which makes a missing NVRTC an error.

#[path = "src/contract/header.rs"]
mod contract_header;
#[path = "src/cuda/nvrtc_search.rs"]
mod nvrtc_search;
use cudarc::nvrtc::{result, sys};
use nvrtc_search::{find_nvrtc, COMPILE_OPTIONS};
use std::ffi::CStr;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const KERNEL_DIR: &str = "kernels";
/// Every module is compiled for each; src/cuda/modules.rs picks the newest the GPU runs.
const ARCHS: [&str; 2] = ["compute_75", "compute_90"];
/// The header written from src/contract/items.rs, pasted where a kernel includes it.
const CONTRACT_HEADER: &str = "contract.cuh";
/// The committed PTX and its manifest.
const COMMITTED_PTX_DIR: &str = "kernels/ptx";
const MANIFEST: &str = "manifest.txt";
/// The NVRTC release whose PTX is committed (the pinned one: its PTX loads on a CUDA 13.0 driver).
const COMMITTED_NVRTC: (i32, i32) = (13, 0);

fn main() {
    println!("cargo:rerun-if-changed={KERNEL_DIR}");
    println!("cargo:rerun-if-changed=src/contract/items.rs");
    println!("cargo:rerun-if-changed=src/contract/header.rs");
    println!("cargo:rerun-if-changed=src/cuda/nvrtc_search.rs");
    for var in [
        "NVRTC_LIB",
        "CUDA_HOME",
        "CUDA_PATH",
        "MPM_NVRTC_CACHE",
        "MPM_REQUIRE_NVRTC",
        "MPM_UPDATE_PTX",
        "LD_LIBRARY_PATH",
    ] {
        println!("cargo:rerun-if-env-changed={var}");
    }
    if let Err(message) = run() {
        eprintln!("\nerror: {message}\n");
        std::process::exit(1);
    }
}

struct Module {
    /// File stem: `p2g` for kernels/p2g.cu.
    name: String,
    /// The source with its includes pasted in.
    source: String,
}

fn run() -> Result<(), String> {
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").map_err(|e| format!("OUT_DIR: {e}"))?);
    let modules = read_modules(Path::new(KERNEL_DIR))?;
    let require = std::env::var("MPM_REQUIRE_NVRTC").is_ok_and(|v| v == "1");

    let checkout = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    let nvrtc = find_nvrtc(std::slice::from_ref(&checkout));
    let compiled = match &nvrtc {
        Ok(found) => {
            let mut ptx = Vec::new();
            for module in &modules {
                let per_arch: Result<Vec<String>, String> =
                    ARCHS.iter().map(|arch| compile(module, arch)).collect();
                ptx.push(per_arch?);
            }
            check_contract_layout()?;
            let (major, minor) = nvrtc_version()?;
            if (major, minor) == COMMITTED_NVRTC {
                check_committed_ptx(&checkout, &modules, &ptx, require)?;
            }
            // Said aloud only where NVRTC is required (CI), so the log shows that every kernel compiled.
            if require {
                println!(
                "cargo:warning=compiled {} CUDA kernel modules to PTX ({ARCHS:?}) with NVRTC {major}.{minor} ({found})",
                modules.len()
            );
            }
            Some(ptx)
        }
        Err(why) if require => {
            return Err(format!(
                "MPM_REQUIRE_NVRTC=1 but NVRTC was not found: {why}\n\
                 run `eval \"$(.ci/install-nvrtc)\"` or set NVRTC_LIB to a libnvrtc.so"
            ))
        }
        Err(why) => {
            let committed = committed_ptx(&checkout, &modules);
            let stale: Vec<&str> = modules
                .iter()
                .zip(&committed)
                .filter(|(_, ptx)| ptx.iter().any(Option::is_none))
                .map(|(m, _)| m.name.as_str())
                .collect();
            if !stale.is_empty() {
                println!(
                    "cargo:warning=NVRTC not found ({why}), and the committed PTX in {COMMITTED_PTX_DIR}/ \
                     does not match the sources of {stale:?}; those kernels are embedded as source and \
                     compiled when the program first uses the GPU. To compile them now, set NVRTC_LIB or \
                     CUDA_HOME, or run .ci/install-nvrtc"
                );
            }
            return write_modules(&out_dir, &modules, |index, arch_index| {
                Ok(committed[index][arch_index].clone())
            });
        }
    };

    let compiled = compiled.unwrap_or_default();
    write_modules(&out_dir, &modules, |index, arch_index| {
        let module = &modules[index];
        let ptx_file = out_dir.join(format!("{}.{}.ptx", module.name, ARCHS[arch_index]));
        write(&ptx_file, &compiled[index][arch_index])?;
        Ok(Some(ptx_file))
    })
}

/// Writes `$OUT_DIR/kernels.rs`: each module's pasted source, and the PTX file `ptx(module, arch)`
/// names (`None`: compiled at run time).
fn write_modules(
    out_dir: &Path,
    modules: &[Module],
    mut ptx_of: impl FnMut(usize, usize) -> Result<Option<PathBuf>, String>,
) -> Result<(), String> {
    let mut rust = String::from("// Generated by build.rs from kernels/*.cu: one module per file.\n\n");
    let mut list = String::new();
    for (index, module) in modules.iter().enumerate() {
        let source_file = out_dir.join(format!("{}.cu", module.name));
        write(&source_file, &module.source)?;
        let mut ptx = Vec::new();
        for arch_index in 0..ARCHS.len() {
            ptx.push(match ptx_of(index, arch_index)? {
                Some(file) => format!("Some(include_str!({:?}))", file.display().to_string()),
                None => "None".to_string(),
            });
        }
        let constant = module.name.to_uppercase();
        let _ = writeln!(
            rust,
            "pub const {constant}: KernelModule = KernelModule {{ name: {:?}, source: include_str!({:?}), \
             ptx_compute_75: {}, ptx_compute_90: {} }};",
            module.name,
            source_file.display().to_string(),
            ptx[0],
            ptx[1]
        );
        let _ = write!(list, "{constant}, ");
    }
    let _ = writeln!(rust, "\npub const ALL: &[KernelModule] = &[{list}];");
    write(&out_dir.join("kernels.rs"), &rust)
}

/// NVRTC names each source file of the line table after the build's working folder
/// (`.file 1 "/home/me/mpm/p2g.cu"`): PTX that differs from checkout to checkout, which could be
/// neither committed nor compared. The folder is dropped (`.file 1 "p2g.cu"`), as profilers find
/// the files by name (`ncu --source-folders kernels`).
fn without_build_folder(ptx: &str) -> String {
    let Ok(folder) = std::env::current_dir() else {
        return ptx.to_string();
    };
    let prefix = format!("\"{}/", folder.display());
    ptx.lines()
        .map(|line| match line.trim_start().starts_with(".file") {
            true => line.replacen(&prefix, "\"", 1),
            false => line.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
        + if ptx.ends_with('\n') { "\n" } else { "" }
}

/// What a module's PTX for `arch` was compiled from: a fingerprint (FNV-1a, 64 bits) of its pasted
/// source, the compile options and the target, the same on every machine.
fn fingerprint(module: &Module, arch: &str) -> String {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for part in [module.source.as_str(), &COMPILE_OPTIONS.join(" "), arch] {
        for byte in part.bytes().chain([0]) {
            hash = (hash ^ u64::from(byte)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    format!("{hash:016x}")
}

/// The manifest's line for one module's PTX.
fn manifest_line(module: &Module, arch: &str) -> String {
    let (major, minor) = COMMITTED_NVRTC;
    format!(
        "{} {arch} {} nvrtc-{major}.{minor}",
        module.name,
        fingerprint(module, arch)
    )
}

/// The committed PTX file of each module and target whose manifest line matches the sources now.
fn committed_ptx(checkout: &Path, modules: &[Module]) -> Vec<Vec<Option<PathBuf>>> {
    let dir = checkout.join(COMMITTED_PTX_DIR);
    let manifest = std::fs::read_to_string(dir.join(MANIFEST)).unwrap_or_default();
    println!("cargo:rerun-if-changed={COMMITTED_PTX_DIR}");
    modules
        .iter()
        .map(|module| {
            ARCHS
                .iter()
                .map(|arch| {
                    let file = dir.join(format!("{}.{arch}.ptx", module.name));
                    let fresh = manifest.lines().any(|l| l == manifest_line(module, arch));
                    (fresh && file.is_file()).then_some(file)
                })
                .collect()
        })
        .collect()
}

/// Compares what NVRTC 13.0 compiled (`compiled[module][arch]`) with the committed PTX:
/// `MPM_UPDATE_PTX=1` rewrites it; otherwise a difference is an error where NVRTC is `required` (CI)
/// and a warning elsewhere, each naming the fix.
fn check_committed_ptx(
    checkout: &Path,
    modules: &[Module],
    compiled: &[Vec<String>],
    required: bool,
) -> Result<(), String> {
    let dir = checkout.join(COMMITTED_PTX_DIR);
    if std::env::var("MPM_UPDATE_PTX").is_ok_and(|v| v == "1") {
        std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let mut manifest = String::from(
            "# Written by `MPM_UPDATE_PTX=1 cargo build` (build.rs): module, target, fingerprint of the\n\
             # pasted source, options and target, and the NVRTC that compiled kernels/ptx/MODULE.TARGET.ptx.\n",
        );
        for (module, ptx) in modules.iter().zip(compiled) {
            for (arch, text) in ARCHS.iter().zip(ptx) {
                write(&dir.join(format!("{}.{arch}.ptx", module.name)), text)?;
                manifest.push_str(&manifest_line(module, arch));
                manifest.push('\n');
            }
        }
        return write(&dir.join(MANIFEST), &manifest);
    }
    let committed = committed_ptx(checkout, modules);
    let stale: Vec<String> = modules
        .iter()
        .zip(compiled)
        .zip(&committed)
        .flat_map(|((module, ptx), files)| {
            ARCHS
                .iter()
                .zip(ptx)
                .zip(files)
                .filter_map(move |((arch, text), file)| {
                    let same = file
                        .as_ref()
                        .and_then(|f| std::fs::read_to_string(f).ok())
                        .is_some_and(|committed| committed == *text);
                    (!same).then(|| format!("{}.{arch}", module.name))
                })
        })
        .collect();
    if stale.is_empty() {
        return Ok(());
    }
    let message = format!(
        "the committed PTX in {COMMITTED_PTX_DIR}/ is not what NVRTC compiled from kernels/ now ({}); \
         run `MPM_UPDATE_PTX=1 cargo build` with NVRTC 13.0 (.ci/install-nvrtc) and commit {COMMITTED_PTX_DIR}/, \
         so that machines without NVRTC get these kernels compiled",
        stale.join(", ")
    );
    if required {
        return Err(message);
    }
    println!("cargo:warning={message}");
    Ok(())
}

fn write(path: &Path, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Every `*.cu` in the kernel folder, sorted, with local includes pasted in.
fn read_modules(dir: &Path) -> Result<Vec<Module>, String> {
    let entries = std::fs::read_dir(dir).map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "cu"))
        .collect();
    paths.sort();
    if paths.is_empty() {
        return Err(format!("no .cu files in {}", dir.display()));
    }
    paths
        .iter()
        .map(|path| {
            let name = path
                .file_stem()
                .and_then(|s| s.to_str())
                .ok_or_else(|| format!("{}: the file name is not UTF-8", path.display()))?
                .to_string();
            Ok(Module {
                source: paste_includes(dir, path)?,
                name,
            })
        })
        .collect()
}

/// Replaces each `#include "file"` (a file in the kernel folder) with that file, between `#line`
/// markers, recursively and once per file (as `#pragma once` would). NVRTC would take include paths at
/// build time, but the run-time compile has only the embedded text, so both compile the same single
/// pasted source.
fn paste_includes(dir: &Path, path: &Path) -> Result<String, String> {
    let mut out = String::new();
    paste_file(dir, path, &mut Vec::new(), &mut out)?;
    Ok(out)
}

fn paste_file(dir: &Path, path: &Path, pasted: &mut Vec<PathBuf>, out: &mut String) -> Result<(), String> {
    if path.file_name().is_some_and(|f| f == CONTRACT_HEADER) {
        pasted.push(path.to_path_buf());
        let _ = writeln!(out, "#line 1 \"{CONTRACT_HEADER}\"");
        out.push_str(&contract_header::contract_header());
        return Ok(());
    }
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    pasted.push(path.to_path_buf());
    let file_name = path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let _ = writeln!(out, "#line 1 \"{file_name}\"");
    for (number, line) in text.lines().enumerate() {
        let included = line
            .trim()
            .strip_prefix("#include")
            .map(str::trim)
            .and_then(|rest| rest.strip_prefix('"'))
            .and_then(|rest| rest.strip_suffix('"'));
        match included {
            Some(header) => {
                let header_path = dir.join(header);
                if header != CONTRACT_HEADER && !header_path.is_file() {
                    return Err(format!("{}:{}: cannot read {header}", path.display(), number + 1));
                }
                if !pasted.contains(&header_path) {
                    paste_file(dir, &header_path, pasted, out)?;
                }
                let _ = writeln!(out, "\n#line {} \"{file_name}\"", number + 2);
            }
            None => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    Ok(())
}

fn nvrtc_version() -> Result<(i32, i32), String> {
    let (mut major, mut minor) = (0, 0);
    // SAFETY: NVRTC is loaded (find_nvrtc succeeded); the pointers are to locals.
    unsafe { sys::nvrtcVersion(&mut major, &mut minor) }
        .result()
        .map_err(|e| format!("nvrtcVersion: {e:?}"))?;
    Ok((major, minor))
}

/// Compiles the contract header with its field-offset checks (src/contract/header.rs): a struct
/// that C lays out differently from Rust fails the build here, naming the field.
fn check_contract_layout() -> Result<(), String> {
    let check = Module {
        name: "contract_layout_check".into(),
        source: contract_header::layout_check_source(),
    };
    compile(&check, ARCHS[0]).map(|_| ())
}

/// NVRTC `module.source` to PTX for `arch`, or an error carrying NVRTC's log (file:line: message).
fn compile(module: &Module, arch: &str) -> Result<String, String> {
    let file_name = format!("{}.cu", module.name);
    let source = std::ffi::CString::new(module.source.as_str())
        .map_err(|_| format!("{KERNEL_DIR}/{file_name} contains a NUL byte"))?;
    let name = std::ffi::CString::new(file_name.as_str()).map_err(|e| e.to_string())?;
    let program = result::create_program(&source, Some(name.as_c_str()))
        .map_err(|e| format!("NVRTC cannot create a program for {file_name}: {e:?}"))?;
    let mut options: Vec<String> = COMPILE_OPTIONS.iter().map(|s| s.to_string()).collect();
    options.push(format!("--gpu-architecture={arch}"));
    // SAFETY: `program` was created above and is destroyed once, below.
    let compiled = unsafe { result::compile_program(program, &options) };
    let log = unsafe { result::get_program_log(program) }
        .map(|raw| {
            // SAFETY: NVRTC's log is NUL-terminated.
            unsafe { CStr::from_ptr(raw.as_ptr()) }
                .to_string_lossy()
                .trim()
                .to_string()
        })
        .unwrap_or_default();
    let ptx = match compiled {
        Ok(()) => unsafe { result::get_ptx(program) }
            .map(|raw| without_build_folder(&unsafe { CStr::from_ptr(raw.as_ptr()) }.to_string_lossy()))
            .map_err(|e| format!("NVRTC compiled {file_name} but returned no PTX: {e:?}")),
        Err(e) => Err(format!(
            "CUDA kernel {KERNEL_DIR}/{file_name} does not compile ({e:?}, options {options:?}):\n{log}"
        )),
    };
    // SAFETY: destroyed exactly once.
    let _ = unsafe { result::destroy_program(program) };
    if ptx.is_ok() && !log.is_empty() {
        for line in log.lines() {
            println!("cargo:warning={KERNEL_DIR}/{file_name}: {line}");
        }
    }
    ptx
}
