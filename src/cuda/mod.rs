//! The CUDA backend: NVRTC-built kernels (kernels/*.cu) launched through cudarc on one stream.
//!
//! - [`library`]: finding libcuda and NVRTC before cudarc touches them (missing = error, not panic).
//! - [`modules`]: the PTX that build.rs embedded, or a run-time NVRTC compile where needed.
//! - [`launch`]: the one launch helper (kernel name, NVTX range, errors naming the kernel).
//! - [`solver`]: [`CudaSolver`], the device particle state and the substep, in either pipeline.
//! - [`bins`]: particles binned by cell or node block (kernels/bins.cu), and the bin list.
//! - [`lifecycle`]: emitters, sinks and the free particle slots (kernels/lifecycle.cu).
//! - [`stats`]: the per-frame statistics as a device reduction (kernels/stats.cu).
//! - [`spawn`]: the body table for spawning particles on the device in `Scene::spawn()` order.
//! - [`interop`]: OpenGL buffers registered with CUDA, mapped for the render kernel each frame.
//! - [`graph`]: the substep captured as a CUDA graph and replayed, one launch per substep.
//! - [`timing`]: per-phase CUDA events, read back without stalling.

pub mod bins;
pub mod graph;
pub mod interop;
pub mod launch;
pub mod library;
pub mod lifecycle;
pub mod modules;
mod nvrtc_preload;
pub mod solver;
pub mod spawn;
pub mod stats;
pub mod timing;

pub use launch::NvtxRange;
pub use modules::Origin as ModuleOrigin;
pub use solver::{
    fixed_point_scales, CudaOptions, CudaSolver, BYTES_PER_NODE, BYTES_PER_PARTICLE, FIXED_BYTES_PER_NODE,
    SORT_INTERVAL,
};
