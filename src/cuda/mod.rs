//! The CUDA backend: NVRTC-built kernels (kernels/*.cu) launched through cudarc, in three layers,
//! each importing only the ones below it.
//!
//! **The bottom: one GPU and what it holds.** [`gpu::Gpu`] is one opened device (context, stream,
//! loaded kernel modules; [`library`], [`modules`] and `nvrtc_search` find the driver and NVRTC and
//! load the PTX build.rs embedded, or compile at run time). [`state::DeviceState`] holds every
//! buffer of a scene on it: [`particles`], [`grid`], the bins ([`bin_lists`]), the step
//! [`counters`], the [`colliders`], the particle lifecycle ([`flow`]) and the staging buffers that
//! take the particles to the host for export ([`snapshot`]). [`timing`] and [`graph`]
//! time and replay a substep on it. A second GPU is a second `Gpu` with its own `DeviceState`:
//! nothing is global. No file of this layer imports a kernel's host file.
//!
//! **One host file per kernel file.** `kernels/X.cu` is launched only from `X.rs`, which owns its
//! argument list, and through [`launch::Kernel`] its NVTX name and its error text: [`bins`],
//! [`bin_order`], [`p2g_init`], [`volume`], [`mirror_walls`], [`p2g`], [`p2g_tiled`], [`grid_update`], [`g2p`],
//! [`g2p2g`], [`one_pass`], [`pbmpm`], [`lifecycle`], [`spawn`], [`stats`], [`render`], [`push`], [`halo`],
//! [`ranks`], [`thickness`], and [`solid_laws`], which only the tests launch.
//!
//! **On top: the substep.** [`kernels::Kernels`] is every kernel loaded on one GPU;
//! [`pipelines`] says which launches each pipeline runs in each phase; [`solver::CudaSolver`] steps
//! through that table phase by phase (`Phase::ALL`) and answers what a frame asks of a solver;
//! `inspect` is the kernel tests' view of it. [`cuda_ranks::CudaRanks`] runs several solvers as
//! the ranks of one run, each over its slab (`crate::dist`), with the ghost exchanges between their
//! phases; it asks each solver only what `as_rank` lets it (a rank's halo ends, its counts, its
//! particles for the carriers), never its buffers. [`interop`] registers the renderer's GL buffers with CUDA.

// The bottom: one GPU and the buffers it holds. None of these imports a kernel's host file.
pub mod bin_lists;
pub mod colliders;
pub mod counters;
pub mod flow;
pub mod gpu;
pub mod graph;
pub mod grid;
pub mod interop;
pub mod launch;
pub mod library;
pub mod modules;
mod nvrtc_search;
pub mod particles;
pub mod snapshot;
pub mod state;
pub mod timing;

// One host file per kernel file: kernels/X.cu is launched from X.rs alone.
pub mod bin_order;
pub mod bins;
pub mod bodies;
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
pub mod pbmpm;
pub mod push;
pub mod ranks;
pub mod render;
pub mod solid_laws;
pub mod spawn;
pub mod stats;
pub mod thickness;
pub mod volume;

// On top: the kernel table, which pipeline runs what in each phase, and the substep, on one GPU or
// as several ranks.
mod as_rank;
pub mod cuda_ranks;
mod inspect;
pub mod kernels;
mod pbmpm_substep;
pub mod pipelines;
mod setup;
pub mod solver;

pub use cuda_ranks::CudaRanks;
pub use gpu::{CudaOptions, FloatScatter, PHASE_SAMPLE};
pub use grid::{BYTES_PER_NODE, FIXED_BYTES_PER_NODE};
pub use launch::NvtxRange;
pub use modules::Origin as ModuleOrigin;
pub use particles::BYTES_PER_PARTICLE;
pub use solver::CudaSolver;
