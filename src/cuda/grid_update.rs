//! kernels/grid_update.cu: momentum to velocity, gravity, the boundary band and the colliders; each
//! accumulator read is zeroed (consume-and-zero, so no grid-clear launch). The report pipeline walks
//! the whole grid; the binned one the node blocks this substep's scatters listed. The fused pipeline's
//! update also adds the walls' mirror image (kernels/mirror.cuh), which the others add with
//! mirror_walls before it.

use super::bin_lists::NODE_BLOCK_NODES;
use super::grid::DeviceGrid;
use super::launch::{Kernel, Launcher};
use super::mirror_walls::{self, WallReach};
use super::modules::LoadedModules;
use super::state::{DeviceState, StateArgs};
use crate::sim::{Params, Pipeline};
use anyhow::{ensure, Result};
use cudarc::driver::PushKernelArg;

pub struct GridUpdate {
    whole_grid: Kernel,
    listed_blocks: Kernel,
    /// grid_update_blocks with the rigid bodies' exchange (kernels/grid_update.cu).
    listed_blocks_with_bodies: Kernel,
    /// grid_update_blocks with the walls' image push, which Coulomb colliders under the mirror read.
    listed_blocks_with_friction: Kernel,
    clear_crossing_orbits: Kernel,
}

impl GridUpdate {
    pub fn load(modules: &LoadedModules) -> Result<GridUpdate> {
        Ok(GridUpdate {
            whole_grid: Kernel::load(modules, "grid_update", "grid_update")?,
            listed_blocks: Kernel::load(modules, "grid_update", "grid_update_blocks")?,
            listed_blocks_with_bodies: Kernel::load(modules, "grid_update", "grid_update_blocks_bodies")?,
            listed_blocks_with_friction: Kernel::load(modules, "grid_update", "grid_update_blocks_friction")?,
            clear_crossing_orbits: Kernel::load(modules, "grid_update", "clear_crossing_orbits")?,
        })
    }

    /// The binned and fused pipelines' launch leaves every listed block unmarked and the list empty;
    /// where it mirrored, the caller then clears the orbits it left (`clear_crossing_orbits`).
    /// `mirror`: add the walls' images in this launch (the fused pipeline) instead of mirror_walls
    /// before it.
    pub fn launch(
        &self,
        l: &Launcher,
        pipeline: Pipeline,
        mirror: bool,
        params: &Params,
        d: &DeviceState,
    ) -> Result<()> {
        let g = &d.grid;
        ensure!(
            !mirror || pipeline.is_binned(),
            "the report's grid update walks the whole grid and does not mirror: run mirror_walls first"
        );
        if mirror {
            mirror_walls::check_reach(params)?;
        }
        match pipeline {
            // SAFETY: the arguments match grid_update in kernels/grid_update.cu.
            Pipeline::Report => unsafe {
                self.whole_grid.launch(l, l.cover(g.num_nodes()), |a| {
                    a.arg(&params.kernel)
                        .arg(&g.acc)
                        .arg(&g.vel)
                        .arg(g.fixed_mass())
                        .arg(g.fixed_momentum())
                        .arg(&d.counters.device);
                })
            },
            Pipeline::Fused | Pipeline::Binned => {
                let config = l.over_list(d.bins.num_bins(), NODE_BLOCK_NODES, 0);
                // The images join the sums here only where this launch mirrors. The bodies' kernel
                // has the image push too.
                let friction_under_mirror = mirror && params.wall_mirror_lo != 0 && d.colliders.friction;
                let kernel = match (&d.colliders.bodies, friction_under_mirror) {
                    (Some(_), _) => &self.listed_blocks_with_bodies,
                    (None, true) => &self.listed_blocks_with_friction,
                    (None, false) => &self.listed_blocks,
                };
                let mirror = u32::from(mirror);
                // SAFETY: the arguments match grid_update_blocks, grid_update_blocks_bodies and
                // grid_update_blocks_friction (the bodies' sums last: null without bodies); one thread
                // per node of a block.
                unsafe {
                    kernel.launch(l, config, |a| {
                        a.arg(&params.kernel)
                            .arg(&mirror)
                            .arg(&g.node_blocks.list)
                            .arg(&g.work_counts)
                            .arg(&g.node_blocks.marks)
                            .arg(&g.acc)
                            .arg(&g.vel)
                            .arg(g.fixed_mass())
                            .arg(g.fixed_momentum())
                            .arg(&d.counters.device)
                            .colliders(&d.colliders);
                    })
                }
            }
        }
    }

    /// After a launch over the list that mirrored: where some wall's reach spans two node blocks, the
    /// launch left those orbits' sums in place (two CUDA blocks read them), and clear_crossing_orbits
    /// zeroes them for the next substep's scatters. Elsewhere nothing is left to clear.
    pub fn clear_crossing_orbits(
        &self,
        l: &Launcher,
        mirror: bool,
        params: &Params,
        grid: &DeviceGrid,
    ) -> Result<()> {
        let crossing = if mirror {
            WallReach::crossing_blocks(params)
        } else {
            Vec::new()
        };
        if crossing.is_empty() {
            return Ok(());
        }
        let walls = crossing.iter().fold(0u32, |bits, w| bits | 1 << w.bit());
        let nodes = crossing.iter().map(|w| w.nodes(params)).sum();
        // SAFETY: the arguments match clear_crossing_orbits; the kernel covers the reaches of `walls`,
        // `nodes` nodes, all inside the grid.
        unsafe {
            self.clear_crossing_orbits.launch(l, l.cover(nodes), |a| {
                a.arg(&params.kernel)
                    .arg(&walls)
                    .arg(&grid.acc)
                    .arg(grid.fixed_mass())
                    .arg(grid.fixed_momentum());
            })
        }
    }
}
