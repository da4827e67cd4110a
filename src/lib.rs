//! A real-time MLS-MPM fluid: a single-thread CPU reference and CUDA kernels behind one step API.

pub mod backend;
pub mod bench;
pub mod checkpoint;
pub mod contract;
pub mod cuda;
pub mod dist;
pub mod export;
pub mod render;
pub mod runner;
pub mod sim;
pub mod text;
