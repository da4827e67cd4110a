//! Which kernels each pipeline runs in each phase of the substep: the one table that the solver
//! steps through (`CudaSolver::run_phase`), that `mpm bench` labels its rows from, and that
//! docs/pipelines.md shows ([`markdown_table`], checked by a test). A phase the table leaves empty
//! enqueues nothing and reads 0 in the timings.

use super::bins::{BIN_ORDER_SORT_INTERVAL, SORT_INTERVAL};
use crate::sim::{Phase, Pipeline};

/// One piece of a phase's work: a kernel launch, or a kernel and the companion launch that always
/// follows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Launch {
    /// kernels/bins.cu's counting sort of the particle order by cell, where the schedule says.
    SortByCell,
    /// The same sort by node block, then cell, and the list of bins; also sooner than scheduled
    /// when a kernel flagged a particle that moved a cell.
    Rebin,
    /// `Rebin`, then bin_order.cu stores the particle state in that order.
    RebinInOrder,
    /// volume.cu's scatter_volume: the grid's volume, from which the density is gathered where the
    /// rest densities differ (nothing otherwise), every substep.
    ScatterVolume,
    /// mirror_walls.cu: the walls' image volume (where the rest densities differ).
    MirrorVolume,
    /// volume.cu's gather_volume_density: each particle's density from the volume, for the pass
    /// that takes it (where the rest densities differ).
    GatherVolumeDensity,
    /// p2g_init.cu: the mass scatter by warp-aggregated global atomics, every substep.
    P2gInit,
    /// g2p2g.cu's p2g_mass: the mass scatter through a tile per bin chunk, first substep only (g2p2g
    /// scatters it after).
    P2gMass,
    /// one_pass.cu without its gather: the mass and momentum scatter, first substep only (one_pass
    /// scatters them after).
    OnePassScatter,
    /// mirror_walls.cu: the walls' image mass.
    MirrorMass,
    /// p2g.cu: density gathered from the grid mass, pressure and stress, momentum scattered by warp
    /// runs and global atomics.
    P2g,
    /// p2g.cu for float momentum; p2g_tiled.cu, through a tile per bin chunk, for fixed point and for
    /// scenes with emitters or sinks.
    P2gOrTiled,
    /// mirror_walls.cu: the walls' image momentum.
    MirrorMomentum,
    /// grid_update.cu over every node.
    GridUpdate,
    /// grid_update_blocks (or _fixed) over the node blocks the scatters touched away from the walls,
    /// grid_update_wall_blocks over those at the walls beside it, then clear_crossing_orbits.
    GridUpdateBlocks,
    /// The same, each node near a wall adding its images itself (no mirror launch).
    GridUpdateBlocksMirrored,
    /// g2p.cu: velocity and C gathered, advection.
    G2p,
    /// g2p2g.cu: g2p, advection and the next substep's mass scatter.
    G2p2g,
    /// one_pass.cu: g2p, advection, the density and the next substep's whole scatter.
    OnePass,
}

/// The launches of `phase` in `pipeline`, in stream order.
pub const fn launches(pipeline: Pipeline, phase: Phase) -> &'static [Launch] {
    use Launch::*;
    match (pipeline, phase) {
        // Folded into the grid update, which zeroes what it reads; the exchanges are the ranks'.
        (_, Phase::GridClear | Phase::HaloSum | Phase::HaloFill) => &[],
        (Pipeline::Report, Phase::Sort) => &[SortByCell],
        (Pipeline::Binned, Phase::Sort) => &[Rebin],
        (Pipeline::Fused, Phase::Sort) => &[RebinInOrder],
        // The volume at the substep's starting positions, where p2g gathers the density; in the
        // fused pipeline where one_pass's gather is, mirrored after the ranks' ghost sums and
        // gathered after their fill.
        (Pipeline::Report, Phase::P2gInit) => &[
            ScatterVolume,
            MirrorVolume,
            GatherVolumeDensity,
            P2gInit,
            MirrorMass,
        ],
        (Pipeline::Binned, Phase::P2gInit) => &[
            ScatterVolume,
            MirrorVolume,
            GatherVolumeDensity,
            P2gMass,
            MirrorMass,
        ],
        (Pipeline::Fused, Phase::P2gInit) => &[ScatterVolume, OnePassScatter],
        (Pipeline::Report, Phase::P2g) => &[P2g],
        (Pipeline::Binned, Phase::P2g) => &[P2gOrTiled],
        (Pipeline::Fused, Phase::P2g) => &[],
        (Pipeline::Report, Phase::GridUpdate) => &[MirrorMomentum, GridUpdate],
        (Pipeline::Binned, Phase::GridUpdate) => &[MirrorMomentum, GridUpdateBlocks],
        (Pipeline::Fused, Phase::GridUpdate) => &[MirrorVolume, GridUpdateBlocksMirrored],
        (Pipeline::Report, Phase::G2p) => &[G2p],
        (Pipeline::Binned, Phase::G2p) => &[G2p2g],
        (Pipeline::Fused, Phase::G2p) => &[GatherVolumeDensity, OnePass],
    }
}

impl Launch {
    /// The kernels as Nsight names them, with what decides between them. `fixed_point`: the
    /// scatter of the run, where it decides (`None`: say both).
    pub fn label(self, fixed_point: Option<bool>) -> String {
        match self {
            Launch::SortByCell => "bins (by cell)".into(),
            Launch::Rebin => "bins (by node block, sooner when a particle moved a cell)".into(),
            Launch::RebinInOrder => {
                "bins (by node block, sooner when a particle moved a cell) + gather_into_bin_order".into()
            }
            Launch::ScatterVolume => "scatter_volume (several rest densities)".into(),
            Launch::MirrorVolume => "mirror_walls (volume; several rest densities)".into(),
            Launch::GatherVolumeDensity => "gather_volume_density (several rest densities)".into(),
            Launch::P2gInit => "p2g_init".into(),
            Launch::P2gMass => "p2g_mass (first substep only)".into(),
            Launch::OnePassScatter => "one_pass without its gather (first substep only)".into(),
            Launch::MirrorMass => "mirror_walls (mass)".into(),
            Launch::P2g => "p2g".into(),
            Launch::P2gOrTiled => match fixed_point {
                Some(true) => "p2g_tiled".into(),
                Some(false) => "p2g (warp runs, global atomics)".into(),
                None => "p2g (float) or p2g_tiled (fixed point, emitters or sinks)".into(),
            },
            Launch::MirrorMomentum => "mirror_walls (momentum)".into(),
            Launch::GridUpdate => "grid_update (every node)".into(),
            Launch::GridUpdateBlocks => {
                "grid_update_blocks (_fixed for fixed-point sums) + grid_update_wall_blocks (the walls' mirror \
                 on; with colliders both _colliders) + clear_crossing_orbits"
                    .into()
            }
            Launch::GridUpdateBlocksMirrored => {
                "grid_update_blocks (away from the walls; _fixed for fixed-point sums) + grid_update_wall_blocks \
                 (the walls' images inside; \
                 with colliders both _colliders, rigid bodies both _bodies, then step_bodies; Coulomb colliders \
                 at the walls grid_update_wall_blocks_friction) + clear_crossing_orbits"
                    .into()
            }
            Launch::G2p => "g2p".into(),
            Launch::G2p2g => "g2p2g (g2p + the next mass scatter)".into(),
            Launch::OnePass => "one_pass (g2p + density + the next whole scatter)".into(),
        }
    }
}

/// Substeps between scheduled binnings in `pipeline` where the fused one stores its particles in
/// bin order (the default).
fn default_sort_interval(pipeline: Pipeline) -> u32 {
    match pipeline {
        Pipeline::Fused => BIN_ORDER_SORT_INTERVAL,
        Pipeline::Report | Pipeline::Binned => SORT_INTERVAL,
    }
}

/// What `phase` holds in `pipeline`, for the bench tables: its launches, `fixed_point` deciding
/// the binned pipeline's momentum scatter (`None`: both named), `sort_interval` the substeps
/// between scheduled binnings.
pub fn phase_label(
    pipeline: Pipeline,
    phase: Phase,
    fixed_point: Option<bool>,
    sort_interval: u32,
) -> String {
    match phase {
        Phase::GridClear => return "grid_clear (inside the grid update on the GPU)".into(),
        Phase::HaloSum | Phase::HaloFill => return format!("{} (several ranks only)", phase.name()),
        _ => {}
    }
    let launches = launches(pipeline, phase);
    if launches.is_empty() {
        return "(none in this pipeline)".into();
    }
    let label = launches
        .iter()
        .map(|launch| launch.label(fixed_point))
        .collect::<Vec<_>>()
        .join(" + ");
    if phase == Phase::Sort {
        format!("{label}, every {sort_interval} substeps")
    } else {
        label
    }
}

/// The table of every phase's launches in every pipeline, as docs/pipelines.md shows it.
pub fn markdown_table() -> String {
    let pipelines = [Pipeline::Report, Pipeline::Binned, Pipeline::Fused];
    let mut table =
        String::from("| phase | `report` | `binned` | `fused` (the default) |\n|---|---|---|---|\n");
    for phase in Phase::ALL {
        let cells: Vec<String> = pipelines
            .iter()
            .map(|&p| phase_label(p, phase, None, default_sort_interval(p)))
            .collect();
        table += &format!("| `{}` | {} |\n", phase.name(), cells.join(" | "));
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_pipeline_gathers_once_and_scatters_the_first_substep() {
        for pipeline in [Pipeline::Report, Pipeline::Binned, Pipeline::Fused] {
            let all: Vec<Launch> = Phase::ALL
                .iter()
                .flat_map(|&phase| launches(pipeline, phase).iter().copied())
                .collect();
            let is_gather = |l: &&Launch| matches!(l, Launch::G2p | Launch::G2p2g | Launch::OnePass);
            assert_eq!(all.iter().filter(is_gather).count(), 1, "{pipeline:?}: {all:?}");
            assert_eq!(
                launches(pipeline, Phase::G2p).iter().filter(is_gather).count(),
                1,
                "{pipeline:?} gathers in its g2p phase"
            );
            assert!(
                launches(pipeline, Phase::P2gInit)
                    .iter()
                    .any(|l| matches!(l, Launch::P2gInit | Launch::P2gMass | Launch::OnePassScatter)),
                "{pipeline:?} has no mass scatter for a substep whose grid holds none"
            );
        }
    }

    /// docs/pipelines.md shows the table the solver steps through, not a copy that can drift.
    #[test]
    fn the_manual_shows_this_table() {
        let manual = include_str!("../../docs/pipelines.md");
        let table = markdown_table();
        assert!(
            manual.contains(&table),
            "docs/pipelines.md must hold the table of src/cuda/pipelines.rs as `markdown_table()` \
             writes it; paste this in its place:\n{table}"
        );
    }
}
