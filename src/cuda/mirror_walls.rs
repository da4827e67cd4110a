//! kernels/mirror_walls.cu: the walls' mirror image, added to the grid between the scatters and the
//! grid update so that fluid at a wall is not read as a free surface. All three axes in one launch,
//! one thread per reflection orbit. The fused pipeline adds the same images inside its grid update
//! (grid_update.rs), and shares this file's account of the walls' reach.

use super::launch::{host_kernel, Launcher};
use super::state::{DeviceState, StateArgs};
use crate::contract::{MIRROR_MASS, MIRROR_MOMENTUM, MIRROR_VOLUME, NODE_BLOCK_EDGE};
use crate::sim::params::gathers_volume;
use crate::sim::{Params, Pipeline};
use anyhow::{ensure, Result};
use cudarc::driver::{CudaSlice, PushKernelArg};

/// What is mirrored.
#[derive(Clone, Copy)]
pub enum MirrorQuantity {
    /// The image mass, between the mass scatter and p2g.
    Mass,
    /// The image momentum, wall-normal component reflected, between p2g and the grid update.
    Momentum,
    /// The image volume (kernels/volume.cu), before the density is gathered from it.
    Volume,
}

host_kernel!(MirrorWalls = "mirror_walls" / "mirror_walls");

impl MirrorWalls {
    /// Nothing where the mirror is off (`wall_mirror_lo == 0`), nor the volume's where the scene has
    /// one rest density. Whether it launched.
    pub fn launch(
        &self,
        l: &Launcher,
        pipeline: Pipeline,
        quantity: MirrorQuantity,
        params: &Params,
        d: &DeviceState,
    ) -> Result<bool> {
        let volume = matches!(quantity, MirrorQuantity::Volume);
        if params.wall_mirror_lo == 0 || (volume && !gathers_volume(params)) {
            return Ok(false);
        }
        let threads = orbits(params)?;
        let g = &d.grid;
        // The report's pipeline visits every orbit (null marks); the binned one skips untouched blocks.
        let null: u64 = 0;
        let quantity_code = match quantity {
            MirrorQuantity::Mass => MIRROR_MASS,
            MirrorQuantity::Momentum => MIRROR_MOMENTUM,
            MirrorQuantity::Volume => MIRROR_VOLUME,
        };
        // SAFETY: the arguments match mirror_walls; the marks, list and counts are this grid's (or null
        // pointers, which the kernel checks, for the report's pipeline and the volume, which no
        // grid update walks). The volume goes in the fixed-point mass's place, channel 0.
        unsafe {
            self.0.launch(l, l.cover(threads), |a| {
                a.arg(&params.kernel).arg(&quantity_code);
                if volume {
                    a.arg(&g.acc).arg(g.volume()).arg(g.fixed_momentum());
                } else {
                    a.accumulators(g);
                }
                if pipeline.is_binned() && !volume {
                    a.arg(&g.node_blocks.marks)
                        .arg(&g.node_blocks.list)
                        .arg(&g.work_counts);
                } else {
                    a.arg(&null).arg(&null).arg(&null);
                }
            })?;
        }
        Ok(true)
    }
}

impl MirrorWalls {
    /// The walls' images of one scalar field of fixed-point sums (`sums`, a u64 per node; the
    /// position-based solver's fill, liquid mass and volume error), added as the mass's are.
    /// Nothing where the mirror is off. Whether it launched.
    pub fn launch_sums(&self, l: &Launcher, params: &Params, sums: &CudaSlice<u64>) -> Result<bool> {
        if params.wall_mirror_lo == 0 {
            return Ok(false);
        }
        let threads = orbits(params)?;
        let null: u64 = 0;
        // SAFETY: the arguments match mirror_walls; `sums` holds a u64 per node and goes in the
        // fixed-point mass's place (channel 0, MIRROR_VOLUME: fixed point, the mass's image), the
        // float accumulators and momentum are not read for it, and the marks are null.
        unsafe {
            self.0.launch(l, l.cover(threads), |a| {
                a.arg(&params.kernel)
                    .arg(&MIRROR_VOLUME)
                    .arg(sums)
                    .arg(sums)
                    .arg(sums)
                    .arg(&null)
                    .arg(&null)
                    .arg(&null);
            })?;
        }
        Ok(true)
    }
}

/// One wall's mirror plane and reach along its axis (one side of the kernels' `MirrorAxis`).
pub struct WallReach {
    axis: usize,
    high: bool,
    plane: u32,
    reach: u32,
}

impl WallReach {
    /// The walls of `axis`, low and high.
    fn of_axis(params: &Params, axis: usize) -> [WallReach; 2] {
        let last = params.grid_res[axis] - 1;
        let (lo, hi) = (params.wall_mirror_lo, params.wall_mirror_hi[axis]);
        [(false, lo), (true, hi)].map(|(high, plane)| WallReach {
            axis,
            high,
            plane,
            reach: plane.min(last - plane),
        })
    }

    /// The walls whose reach spans two node blocks, where the fused pipeline's grid update leaves
    /// the crossing orbits' sums to clear_crossing_orbits (kernels/mirror.cuh,
    /// `mirror_crosses_blocks`); none where the mirror is off.
    pub fn crossing_blocks(params: &Params) -> Vec<WallReach> {
        if params.wall_mirror_lo == 0 {
            return Vec::new();
        }
        (0..3)
            .flat_map(|axis| WallReach::of_axis(params, axis))
            .filter(|w| (w.plane - w.reach) / NODE_BLOCK_EDGE != (w.plane + w.reach) / NODE_BLOCK_EDGE)
            .collect()
    }

    /// Whether the `b`th node block along this wall's axis lies between the grid's edge on this
    /// wall's side and the farthest block its reach meets (`node_block_on_a_wall` in
    /// kernels/mirror.cuh): with the reaches apart (`check_reach`), the blocks it meets.
    fn takes_node_block(&self, b: u32) -> bool {
        if self.high {
            b >= (self.plane - self.reach) / NODE_BLOCK_EDGE
        } else {
            b <= (self.plane + self.reach) / NODE_BLOCK_EDGE
        }
    }

    /// This wall's bit in clear_crossing_orbits' `walls`: 2 axis, plus 1 for the high wall.
    pub fn bit(&self) -> u32 {
        2 * self.axis as u32 + u32::from(self.high)
    }

    /// The nodes within the reach on both sides of the plane, across the other two axes of the
    /// grid's box.
    pub fn nodes(&self, params: &Params) -> usize {
        let across =
            params.box_res[(self.axis + 1) % 3] as usize * params.box_res[(self.axis + 2) % 3] as usize;
        (2 * self.reach as usize + 1) * across
    }
}

/// The node blocks of the grid's box that the scatters list with the walls
/// (`node_block_on_a_wall` in kernels/mirror.cuh): the most that the node-block list's wall part
/// can hold; none where the mirror is off.
pub fn node_blocks_on_walls(params: &Params) -> usize {
    if params.wall_mirror_lo == 0 {
        return 0;
    }
    let (mut all, mut away) = (1usize, 1usize);
    for axis in 0..3 {
        let walls = WallReach::of_axis(params, axis);
        let first = params.box_lo[axis] / NODE_BLOCK_EDGE;
        let blocks = first..first + params.box_res[axis].div_ceil(NODE_BLOCK_EDGE);
        let taken = blocks
            .clone()
            .filter(|&b| walls.iter().any(|w| w.takes_node_block(b)))
            .count();
        all *= blocks.len();
        away *= blocks.len() - taken;
    }
    // A block is the walls' where some axis's walls take it.
    all - away
}

/// Checks that the two walls' reaches of every axis are apart (the kernels tell them apart); nothing
/// to check where the mirror is off.
pub fn check_reach(params: &Params) -> Result<()> {
    if params.wall_mirror_lo == 0 {
        return Ok(());
    }
    orbits(params).map(|_| ())
}

/// The threads of one launch: each takes the fluid-side nodes of both walls of one axis within their
/// reach, across the other two axes. The two walls' reaches must not meet (the kernel tells them
/// apart).
fn orbits(params: &Params) -> Result<usize> {
    let res = params.grid_res;
    let mut threads = 0usize;
    for a in 0..3 {
        let [lo, hi] = WallReach::of_axis(params, a);
        ensure!(
            lo.plane + lo.reach < hi.plane - hi.reach,
            "the grid is too small for the wall mirror: {} nodes along axis {a}; use at least {}",
            res[a],
            2 * (lo.plane + lo.reach + 1)
        );
        let across = res[(a + 1) % 3] as usize * res[(a + 2) % 3] as usize;
        threads += (lo.reach + hi.reach + 2) as usize * across;
    }
    Ok(threads)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{presets, Scene};

    fn preset_params(name: &str, mirror: bool) -> Params {
        let mut scene = Scene::from_toml(presets::get(name).unwrap(), name).unwrap();
        scene.mirror_wall_mass = mirror;
        scene.params()
    }

    #[test]
    fn walls_whose_reach_spans_two_node_blocks() {
        // The dam break's 100 x 50 x 50 nodes: the high walls at node 48 reach 47 to 49, across the
        // blocks of nodes 44..47 and 48..51, in y and z; x's at 98 stays in 96..99.
        let bits: Vec<u32> = WallReach::crossing_blocks(&preset_params("dam-break", true))
            .iter()
            .map(WallReach::bit)
            .collect();
        assert_eq!(bits, vec![3, 5]);
        assert!(WallReach::crossing_blocks(&preset_params("bench-655k", true)).is_empty());
        assert!(WallReach::crossing_blocks(&preset_params("dam-break", false)).is_empty());
    }

    #[test]
    fn the_walls_blocks_are_those_a_reach_meets() {
        // Block by block: a block is the walls' where one of its nodes lies within a wall's reach
        // (`mirror_zone` in kernels/mirror.cuh) along some axis.
        for name in ["dam-break", "bench-65k", "bench-655k", "dam-break-1m"] {
            let params = preset_params(name, true);
            check_reach(&params).unwrap();
            let blocks = params.grid_res.map(|r| r.div_ceil(NODE_BLOCK_EDGE));
            let walls = [0, 1, 2].map(|a| WallReach::of_axis(&params, a));
            let within_reach = |a: usize, c: u32| {
                walls[a]
                    .iter()
                    .any(|w| c + w.reach >= w.plane && c <= w.plane + w.reach)
            };
            let meets = |a: usize, b: u32| {
                (NODE_BLOCK_EDGE * b..NODE_BLOCK_EDGE * (b + 1)).any(|c| within_reach(a, c))
            };
            let mut met = 0;
            for bz in 0..blocks[2] {
                for by in 0..blocks[1] {
                    for bx in 0..blocks[0] {
                        met += usize::from(meets(0, bx) || meets(1, by) || meets(2, bz));
                    }
                }
            }
            assert_eq!(node_blocks_on_walls(&params), met, "{name}");
            assert!(met > 0, "{name}");
            assert_eq!(node_blocks_on_walls(&preset_params(name, false)), 0, "{name}");
        }
        // The dam break's 100 x 50 x 50 nodes, walls at node 1 and at 98 (x) or 48 (y, z), each
        // reaching a node: blocks 0 and 24 of 25 along x; 0, 11 and 12 of 13 along y and z.
        let dam = preset_params("dam-break", true);
        assert_eq!(node_blocks_on_walls(&dam), 25 * 13 * 13 - 23 * 10 * 10);
    }

    #[test]
    fn the_reach_check_passes_with_the_mirror_off() {
        // The fused pipeline's grid update checks the walls whatever the scene: with the mirror off
        // there is nothing to check (it once refused such scenes as too small).
        check_reach(&preset_params("dam-break", false)).unwrap();
        check_reach(&preset_params("dam-break", true)).unwrap();
        let mut tiny = preset_params("dam-break", true);
        tiny.grid_res = [100, 50, 4];
        tiny.wall_mirror_hi[2] = 2;
        let err = check_reach(&tiny).unwrap_err().to_string();
        assert!(err.contains("too small for the wall mirror"), "{err}");
    }
}
