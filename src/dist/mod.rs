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
//! - [`cpu_ranks`]: the CPU reference as N ranks, threads of one process or a process each, the
//!   decomposition's oracle.
//! - [`nccl`]: NCCL found and loaded at run time, and the calls the ranks on several GPUs make.
//! - [`launch`]: a rank per process: its place from the launcher's environment, and the file
//!   rendezvous that hands every rank the NCCL id.
//! - [`sockets`]: the CPU ranks' processes of one host, joined by Unix sockets.
//! - [`share`]: what ranks start from, the run's particles or, for a process of one rank, its
//!   share of a scene's spawn alone.

pub mod comm;
pub mod cpu_ranks;
pub mod halo;
pub mod launch;
pub mod migrate;
pub mod nccl;
pub mod share;
pub mod slabs;
pub mod sockets;

/// Substeps between the ranks' rebalance and migration where no particle strays (every backend's
/// ranks, so the CPU ranks stay the CUDA ranks' oracle). A CUDA rank that receives particles
/// rebins at once; 16 measured the same as 8 on two H200s (BENCHMARKS.md M28).
pub const MIGRATION_INTERVAL: u32 = 8;

pub use comm::{Comm, LocalComm};
pub use cpu_ranks::CpuRanks;
pub use share::{Spawn, Start};
pub use slabs::Slabs;

use crate::sim::Scene;
use anyhow::{bail, Result};

/// The slabs a run on `ranks` ranks starts with: balanced for `particles` (to whole block layers)
/// where that keeps the walls' mirror pairs in the end slabs, else even.
pub fn starting_slabs(scene: &Scene, particles: &dyn Start, ranks: usize) -> Result<Slabs> {
    let even = Slabs::even(glam::UVec3::from(scene.grid_res), ranks)?;
    let params = scene.params();
    let balanced = even.balanced(&particles.layer_counts(&even, params.inv_dx)?)?;
    let walls = (params.wall_mirror_lo, params.wall_mirror_hi[even.axis]);
    Ok(if balanced.holds_mirror(walls.0, walls.1) {
        balanced
    } else {
        even
    })
}

/// Live particles below which a run steps slower on several GPUs than on one, estimated from
/// BENCHMARKS.md M28 (two H200s): the exchanges, migrations and the host's turns add 0.15 to 0.4 ms
/// to a substep, which halving a particle pass (about 0.11 ns a particle on one H200) pays back only
/// from a few million particles; the dam break's 451,200 took 0.21 ms a substep on two against 0.08
/// on one.
pub const FEWEST_PARTICLES_FOR_GPUS: usize = 4_000_000;

/// What a run on `gpus` GPUs of `live` particles says once where it is small enough to step slower
/// than on one GPU; `in_processes`: a GPU per process (`--processes`), not `--gpus`.
pub fn small_for_gpus(gpus: usize, in_processes: bool, live: usize) -> Option<String> {
    let (asked, instead) = if in_processes {
        (
            format!("{gpus} processes"),
            "run it as one process, without the launcher and --processes",
        )
    } else {
        (format!("--gpus {gpus}"), "drop --gpus for it")
    };
    (gpus > 1 && live < FEWEST_PARTICLES_FOR_GPUS).then(|| {
        format!(
            "{asked} with {live} particles: a run of a few million particles or fewer steps slower \
             on several GPUs than on one (the dam break's 451,200: 0.21 ms a substep on two H200s, \
             0.08 on one; docs/several-gpus.md); {instead}"
        )
    })
}

/// What a run on ranks cannot do yet, or on these slabs, refused before anything is allocated.
pub fn check_ranks(scene: &Scene, slabs: &Slabs) -> Result<()> {
    let params = scene.params();
    if !slabs.holds_mirror(params.wall_mirror_lo, params.wall_mirror_hi[slabs.axis]) {
        bail!(
            "{} ranks leave the walls' mirror layers ({} nodes) wider than an end slab: use fewer ranks",
            slabs.ranks(),
            params.wall_mirror_lo
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::small_for_gpus;

    #[test]
    fn small_runs_on_several_gpus_are_told_so() {
        let note = small_for_gpus(2, false, 451_200).expect("the dam break is small");
        assert!(note.contains("--gpus 2 with 451200 particles"), "{note}");
        assert!(note.contains("drop --gpus"), "{note}");
        let note = small_for_gpus(2, true, 451_200).expect("the dam break is small");
        assert!(note.contains("2 processes with 451200 particles"), "{note}");
        assert!(
            note.contains("run it as one process") && !note.contains("--gpus"),
            "{note}"
        );
        assert_eq!(small_for_gpus(1, false, 451_200), None, "one GPU says nothing");
        assert_eq!(
            small_for_gpus(2, false, 16_777_216),
            None,
            "16.8M gains from two GPUs"
        );
    }
}
