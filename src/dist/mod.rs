//! Several ranks (GPUs, or CPU threads) sharing one run: space is divided, not particles.
//!
//! - [`slabs`]: the grid cut along its longest axis into one slab of whole 4x4x4-node blocks per
//!   rank, each with one block of ghost planes on each inner face; the cuts move to balance the
//!   particle counts when the busiest rank holds more than 10 % above the mean.
//! - [`halo`]: per substep, ghost sums go to their owners after a scatter and the owners' values
//!   come back to the ghosts after the grid update (the `halo_sum` and `halo_fill` phases).
//! - [`migrate`]: at rebin time particles whose block left the slab move to its new owner, checked
//!   so that none is lost or held twice.
//! - [`comm`]: what carries it, a grouped send/recv and an all-gather; reductions are folded in
//!   rank order, so every rank gets the same bits.
//! - [`cpu_ranks`]: the CPU reference as N ranks in one process, the decomposition's oracle.

pub mod comm;
pub mod cpu_ranks;
pub mod halo;
pub mod migrate;
pub mod slabs;

pub use comm::{Comm, LocalComm};
pub use cpu_ranks::CpuRanks;
pub use slabs::Slabs;
