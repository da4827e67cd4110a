//! The CUDA backend: NVRTC-built kernels (kernels/*.cu) launched through cudarc, in three layers.
//!
//! **The bottom: one GPU and what it holds.** [`gpu::Gpu`] is one opened device (context, stream,
//! loaded kernels; [`library`], [`modules`] and `nvrtc_search` find the driver and NVRTC and load the
//! PTX build.rs embedded, or compile at run time). [`state::DeviceState`] holds every buffer of a
//! scene on it: [`particles`], [`grid`], the bins ([`bins`]), the step [`counters`], the
//! [`colliders`], the particle lifecycle ([`lifecycle`]) and the statistics ([`stats`]).
//! [`timing`] and [`graph`] time and replay a substep on it. A second GPU is a second `Gpu` with its
//! own `DeviceState`: nothing is global.
//!
//! **One host file per kernel file.** `kernels/X.cu` is launched only from `X.rs`, which owns its
//! argument list, and through [`launch::Kernel`] its NVTX name and its error text: [`p2g_init`],
//! [`mirror_walls`], [`p2g`], [`p2g_tiled`], [`grid_update`], [`g2p`], [`g2p2g`], [`one_pass`], [`bins`],
//! [`lifecycle`], [`spawn`], [`stats`], [`render`], [`push`], [`halo`].
//!
//! **On top: the substep.** [`solver::CudaSolver`] reads as the substep's phases (`Phase::ALL`) in
//! any pipeline, and answers what a frame asks of a solver; `inspect` is the kernel tests' view of
//! it. [`ranks::CudaRanks`] runs several solvers as the ranks of one run, each over its slab
//! (`crate::dist`), with the ghost exchanges between their phases. [`interop`] registers the
//! renderer's GL buffers with CUDA.

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
pub mod bin_order;
pub mod bins;
pub mod g2p;
pub mod g2p2g;
pub mod grid_update;
pub mod halo;
pub mod lifecycle;
pub mod mirror_walls;
pub mod one_pass;
pub mod p2g;
pub mod p2g_init;
pub mod p2g_tiled;
pub mod push;
pub mod render;
pub mod spawn;
pub mod stats;
pub mod thickness;

// On top: the substep, on one GPU or as several ranks.
mod inspect;
pub mod ranks;
pub mod solver;

pub use bins::SORT_INTERVAL;
pub use gpu::CudaOptions;
pub use grid::{BYTES_PER_NODE, FIXED_BYTES_PER_NODE};
pub use launch::NvtxRange;
pub use modules::Origin as ModuleOrigin;
pub use one_pass::FloatScatter;
pub use particles::BYTES_PER_PARTICLE;
pub use ranks::CudaRanks;
pub use solver::CudaSolver;
