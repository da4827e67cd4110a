//! kernels/mirror_walls.cu: the walls' mirror image, added to the grid between the scatters and the
//! grid update so that fluid at a wall is not read as a free surface. All three axes in one launch,
//! one thread per reflection orbit.

use super::launch::{host_kernel, Launcher};
use super::state::{DeviceState, StateArgs};
use crate::contract::{MIRROR_MASS, MIRROR_MASS_AND_MOMENTUM, MIRROR_MOMENTUM};
use crate::sim::{Params, Pipeline};
use anyhow::{ensure, Result};
use cudarc::driver::PushKernelArg;

/// What is mirrored.
#[derive(Clone, Copy)]
pub enum MirrorQuantity {
    /// The image mass, between the mass scatter and p2g.
    Mass,
    /// The image momentum, wall-normal component reflected, between p2g and the grid update.
    Momentum,
    /// Both in one launch, where nothing reads the mirrored mass before the momentum is scattered
    /// (the fused pipeline: one_pass scattered both). The same values as the two launches: each
    /// quantity's image reads that quantity alone.
    MassAndMomentum,
}

host_kernel!(MirrorWalls = "mirror_walls" / "mirror_walls");

impl MirrorWalls {
    /// Nothing where the mirror is off (`wall_mirror_lo == 0`).
    pub fn launch(
        &self,
        l: &Launcher,
        pipeline: Pipeline,
        quantity: MirrorQuantity,
        params: &Params,
        d: &DeviceState,
    ) -> Result<()> {
        if params.wall_mirror_lo == 0 {
            return Ok(());
        }
        let threads = orbits(params)?;
        let g = &d.grid;
        // The report's pipeline visits every orbit (null marks); the binned one skips untouched blocks.
        let null: u64 = 0;
        let quantity_code = match quantity {
            MirrorQuantity::Mass => MIRROR_MASS,
            MirrorQuantity::Momentum => MIRROR_MOMENTUM,
            MirrorQuantity::MassAndMomentum => MIRROR_MASS_AND_MOMENTUM,
        };
        // SAFETY: the arguments match mirror_walls; the marks, list and counts are this grid's (or null
        // pointers, which the kernel checks, for the report's pipeline).
        unsafe {
            self.0.launch(l, l.cover(threads), |a| {
                a.arg(params).arg(&quantity_code).accumulators(g);
                if pipeline.is_binned() {
                    a.arg(&g.node_blocks.marks)
                        .arg(&g.node_blocks.list)
                        .arg(&g.work_counts);
                } else {
                    a.arg(&null).arg(&null).arg(&null);
                }
            })
        }
    }
}

/// The threads of one launch: each takes the fluid-side nodes of both walls of one axis within their
/// reach, across the other two axes. The two walls' reaches must not meet (the kernel tells them
/// apart).
fn orbits(params: &Params) -> Result<usize> {
    let res = params.grid_res;
    let mut threads = 0usize;
    for a in 0..3 {
        let (lo, hi) = (params.wall_mirror_lo, params.wall_mirror_hi[a]);
        let (lo_reach, hi_reach) = (lo.min(res[a] - 1 - lo), hi.min(res[a] - 1 - hi));
        ensure!(
            lo + lo_reach < hi - hi_reach,
            "the grid is too small for the wall mirror: {} nodes along axis {a}; use at least {}",
            res[a],
            2 * (lo + lo_reach + 1)
        );
        let across = res[(a + 1) % 3] as usize * res[(a + 2) % 3] as usize;
        threads += (lo_reach + hi_reach + 2) as usize * across;
    }
    Ok(threads)
}
