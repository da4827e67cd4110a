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

// The bottom: one GPU and the buffers it holds.
pub mod colliders;
pub mod counters;
pub mod gpu;
pub mod graph;
pub mod grid;
pub mod interop;
pub mod launch;
pub mod library;
pub mod modules;
mod nvrtc_search;
pub mod particles;
pub mod state;
pub mod timing;

// One host file per kernel file: kernels/X.cu is launched from X.rs alone.
pub mod bins;
pub mod g2p;
pub mod g2p2g;
pub mod grid_update;
pub mod lifecycle;
pub mod mirror_walls;
pub mod p2g;
pub mod p2g_init;
pub mod p2g_tiled;
pub mod push;
pub mod render;
pub mod spawn;
pub mod stats;

// On top: the substep.
mod inspect;
pub mod solver;

pub use bins::SORT_INTERVAL;
pub use gpu::CudaOptions;
pub use grid::{BYTES_PER_NODE, FIXED_BYTES_PER_NODE};
pub use launch::NvtxRange;
pub use modules::Origin as ModuleOrigin;
pub use particles::BYTES_PER_PARTICLE;
pub use solver::CudaSolver;
