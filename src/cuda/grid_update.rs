//! kernels/grid_update.cu: momentum to velocity, gravity, the boundary band and the colliders; each
//! accumulator read is zeroed (consume-and-zero, so no grid-clear launch). The report pipeline walks
//! the whole grid; the binned one the node blocks this substep's scatters listed.

use super::bins::NODE_BLOCK_NODES;
use super::launch::{Kernel, Launcher};
use super::modules::LoadedModules;
use super::state::{DeviceState, StateArgs};
use crate::sim::{Params, Pipeline};
use anyhow::Result;
use cudarc::driver::PushKernelArg;

pub struct GridUpdate {
    whole_grid: Kernel,
    listed_blocks: Kernel,
}

impl GridUpdate {
    pub fn load(modules: &LoadedModules) -> Result<GridUpdate> {
        Ok(GridUpdate {
            whole_grid: Kernel::load(modules, "grid_update", "grid_update")?,
            listed_blocks: Kernel::load(modules, "grid_update", "grid_update_blocks")?,
        })
    }

    /// The binned pipeline's launch leaves every listed block unmarked; the caller then empties the
    /// list (`DeviceGrid::clear_node_block_list`).
    pub fn launch(&self, l: &Launcher, pipeline: Pipeline, params: &Params, d: &DeviceState) -> Result<()> {
        let g = &d.grid;
        match pipeline {
            // SAFETY: the arguments match grid_update in kernels/grid_update.cu.
            Pipeline::Report => unsafe {
                self.whole_grid.launch(l, l.cover(g.num_nodes()), |a| {
                    a.arg(params)
                        .arg(&g.acc)
                        .arg(&g.vel)
                        .arg(g.fixed_mass())
                        .arg(g.fixed_momentum())
                        .arg(&d.counters.device);
                })
            },
            Pipeline::Fused | Pipeline::Binned => {
                let config = l.over_list(d.bins.num_bins(), NODE_BLOCK_NODES, 0);
                // SAFETY: the arguments match grid_update_blocks; one thread per node of a block.
                unsafe {
                    self.listed_blocks.launch(l, config, |a| {
                        a.arg(params)
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
}
