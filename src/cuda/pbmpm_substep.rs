//! The position-based substep (`solver.method = "pbmpm"`; src/sim/pbmpm.rs is its CPU reference and
//! docs/physics.md, "Position-based MPM", its scheme), read top to bottom: the sort, the warm start
//! with the walls' images of its sums and the liquids' volume targets, `iterations` passes of
//! constraints, scatter and grid, and the last gather with the integration. Timed as four phases:
//! the sort, p2g_init (the start), p2g (the iterations' passes and grids), g2p (the last pass).

use super::launch::NvtxRange;
use super::mirror_walls::MirrorQuantity;
use super::pbmpm::{fixed_point, ScatterPass};
use super::solver::CudaSolver;
use crate::sim::{Phase, Pipeline};
use anyhow::{Context, Result};

impl CudaSolver {
    /// One position-based substep, enqueued launch by launch (`sort`: the schedule's decision), or
    /// into a graph capture (`CudaSolver::step`).
    pub(super) fn enqueue_pbmpm_substep(&mut self, sort: bool) -> Result<()> {
        let stream = self.gpu.stream().clone();
        self.timing.begin_step(&stream)?;
        {
            let _range = NvtxRange::new(Phase::Sort.name());
            if sort {
                self.sort()?;
            }
            self.schedule.note_substep();
            self.timing.end_phase(&stream, Phase::Sort, sort)?;
        }
        let params = fixed_point(&self.params);
        let pbmpm = self
            .pbmpm
            .as_mut()
            .context("a position-based substep without its buffers")?;
        let (k, l, d) = (&self.kernels, &self.gpu.launcher, &mut self.state);
        // The mirror visits every orbit (the report pipeline's way: this substep lists no node blocks).
        let mirror = |quantity, d: &_| k.mirror_walls.launch(l, Pipeline::Report, quantity, &params, d);

        let range = NvtxRange::new(Phase::P2gInit.name());
        pbmpm.begin(&k.pbmpm, l, &params, d)?;
        mirror(MirrorQuantity::Mass, d)?;
        for sums in pbmpm.volume_sums() {
            k.mirror_walls.launch_sums(l, &params, sums)?;
        }
        pbmpm.volume_targets(&k.pbmpm, l, &params, d)?;
        self.timing.end_phase(&stream, Phase::P2gInit, true)?;
        drop(range);

        let range = NvtxRange::new(Phase::P2g.name());
        for iteration in 0..pbmpm.settings.iterations {
            let pass = if iteration == 0 {
                ScatterPass::First
            } else {
                ScatterPass::Gathered
            };
            pbmpm.scatter(&k.pbmpm, l, pass, &params, d)?;
            pbmpm.own_displacement_before_images(&stream, d)?;
            mirror(MirrorQuantity::Momentum, d)?;
            pbmpm.grid(&k.pbmpm, l, &params, d)?;
        }
        self.timing.end_phase(&stream, Phase::P2g, true)?;
        drop(range);

        let _range = NvtxRange::new(Phase::G2p.name());
        pbmpm.integrate(&k.pbmpm, l, &params, d)?;
        self.timing.end_phase(&stream, Phase::G2p, true)?;
        self.timing.end_step(&stream)
    }
}
