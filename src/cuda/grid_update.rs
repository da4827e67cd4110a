//! kernels/grid_update.cu: momentum to velocity, gravity, the boundary band and the colliders; each
//! accumulator read is zeroed (consume-and-zero, so no grid-clear launch). The report pipeline walks
//! the whole grid; the binned one the node blocks this substep's scatters listed, in two launches:
//! the blocks no wall's mirror reaches, then those a wall's reach meets, which the scatters list
//! apart. The fused pipeline's update also adds the walls' mirror image (kernels/mirror.cuh), which
//! the others add with mirror_walls before it.

use super::bin_lists::{bins_per_axis, NODE_BLOCK_EDGE, NODE_BLOCK_NODES};
use super::grid::DeviceGrid;
use super::launch::{Kernel, Launcher};
use super::mirror_walls::{self, WallReach};
use super::modules::LoadedModules;
use super::state::{DeviceState, StateArgs};
use crate::sim::{Params, Pipeline, ScatterMode};
use anyhow::{ensure, Result};
use cudarc::driver::PushKernelArg;

pub struct GridUpdate {
    whole_grid: Kernel,
    /// The kernels over the node-block list, a pair for each kind of scene: water alone, with no
    /// collider code; static colliders; rigid bodies, whose boundaries add up what they took from
    /// the nodes; Coulomb colliders under the walls' mirror, which read the images' push.
    listed_water: ListKernels,
    listed_with_colliders: ListKernels,
    listed_with_bodies: ListKernels,
    listed_with_friction: ListKernels,
    clear_crossing_orbits: Kernel,
}

/// The kernels over the node-block list's two parts (kernels/tiles.cuh, `list_node_block`): the
/// interior's, which has no mirror code and so few registers, for float sums and for fixed-point
/// sums (water's are two kernels, each with the registers of its own sums; the others one), and the
/// wall blocks'.
struct ListKernels {
    interior: Kernel,
    interior_fixed: Kernel,
    walls: Kernel,
}

impl ListKernels {
    fn load(
        modules: &LoadedModules,
        [interior, interior_fixed, walls]: [&'static str; 3],
    ) -> Result<ListKernels> {
        Ok(ListKernels {
            interior: Kernel::load(modules, "grid_update", interior)?,
            interior_fixed: Kernel::load(modules, "grid_update", interior_fixed)?,
            walls: Kernel::load(modules, "grid_update", walls)?,
        })
    }

    /// The interior's kernel for `params`' scatter.
    fn interior(&self, params: &Params) -> &Kernel {
        if params.scatter_mode == ScatterMode::FixedPoint.code() {
            &self.interior_fixed
        } else {
            &self.interior
        }
    }
}

impl GridUpdate {
    pub fn load(modules: &LoadedModules) -> Result<GridUpdate> {
        Ok(GridUpdate {
            whole_grid: Kernel::load(modules, "grid_update", "grid_update")?,
            listed_water: ListKernels::load(
                modules,
                [
                    "grid_update_blocks",
                    "grid_update_blocks_fixed",
                    "grid_update_wall_blocks",
                ],
            )?,
            listed_with_colliders: ListKernels::load(
                modules,
                [
                    "grid_update_blocks_colliders",
                    "grid_update_blocks_colliders",
                    "grid_update_wall_blocks_colliders",
                ],
            )?,
            listed_with_bodies: ListKernels::load(
                modules,
                [
                    "grid_update_blocks_bodies",
                    "grid_update_blocks_bodies",
                    "grid_update_wall_blocks_bodies",
                ],
            )?,
            // Away from the walls there is no push: the interior's kernel is the static colliders'.
            listed_with_friction: ListKernels::load(
                modules,
                [
                    "grid_update_blocks_colliders",
                    "grid_update_blocks_colliders",
                    "grid_update_wall_blocks_friction",
                ],
            )?,
            clear_crossing_orbits: Kernel::load(modules, "grid_update", "clear_crossing_orbits")?,
        })
    }

    /// The binned and fused pipelines' launches leave every listed block unmarked and both parts of
    /// the list empty; where they mirrored, the caller then clears the orbits they left
    /// (`clear_crossing_orbits`). `mirror`: add the walls' images in the wall blocks' launch (the
    /// fused pipeline) instead of mirror_walls before it.
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
                // The images join the sums here only where this launch mirrors. The bodies' kernel
                // has the image push too.
                let friction_under_mirror = mirror && params.wall_mirror_lo != 0 && d.colliders.friction;
                // The collider count is a kernel argument, part of a captured substep's key.
                let kernels = match (&d.colliders.bodies, friction_under_mirror, d.colliders.count) {
                    (Some(_), _, _) => &self.listed_with_bodies,
                    (None, true, _) => &self.listed_with_friction,
                    (None, false, 0) => &self.listed_water,
                    (None, false, _) => &self.listed_with_colliders,
                };
                // Each launch covers the most blocks its part of the list can hold, known from the
                // walls alone: the lengths stay on the device, and CUDA blocks past them idle. The
                // kernels take the list to hold a slot per node block of `params`' grid box.
                let slots: usize = bins_per_axis(params.box_res, NODE_BLOCK_EDGE)
                    .iter()
                    .map(|&b| b as usize)
                    .product();
                ensure!(
                    g.node_blocks.list.len() == slots,
                    "the node-block list holds {} slots for the grid's {slots} node blocks",
                    g.node_blocks.list.len()
                );
                let mirror = u32::from(mirror);
                let walk = |l: &Launcher, kernel: &Kernel, capacity: usize| {
                    // SAFETY: the arguments match every kernel over the list in grid_update.cu (the
                    // bodies' sums last: null without bodies); one thread per node of a block; the
                    // list has a slot per node block, as the kernels take it to.
                    unsafe {
                        kernel.launch(l, l.over_list(kernel, capacity, 0, NODE_BLOCK_NODES, 0)?, |a| {
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
                };
                let at_walls = mirror_walls::node_blocks_on_walls(params);
                let interior = |l: &Launcher| walk(l, kernels.interior(params), slots - at_walls);
                // No wall part where the mirror is off (kernels/mirror.cuh, node_block_on_a_wall).
                if params.wall_mirror_lo == 0 {
                    return interior(l);
                }
                // The two parts hold different blocks, so the launches run side by side: one after the
                // other, each launch's latency and tail lay on every substep's path, in a small scene
                // whose blocks nearly all meet a wall too (bench-65k +8.7 % against one launch,
                // +1.4 % side by side; BENCHMARKS.md M17).
                l.beside(|side| walk(side, &kernels.walls, at_walls), interior)
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
