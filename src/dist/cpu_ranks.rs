//! The CPU reference split into ranks: each rank a thread running the reference's phases on its own
//! slab's particles, with the ghost exchange between the phases and migration at rebin time, over
//! the in-process communicator. It is the decomposition's oracle: the same scene must give what one
//! rank gives, to float rounding (a node's sum adds the same terms in another order).

use super::comm::{all_sum, any, Comm, LocalComm};
use super::halo::HaloNodes;
use super::migrate::{base, layer_counts, Migration, RankParticles};
use super::slabs::Slabs;
use super::{check_ranks, starting_slabs};
use crate::sim::colliders::ColliderFrame;
use crate::sim::cpu::{is_fixed_point, CpuSolver};
use crate::sim::params::{gathers_volume, DensityRule, Params};
use crate::sim::phase::{Phase, PhaseClock, PhaseTimings};
use crate::sim::push::Push;
use crate::sim::solver::{push_step_timing, Solver, StepExtremes};
use crate::sim::ParticleView;
use crate::sim::{Particles, Scene};
use anyhow::{anyhow, bail, Result};

/// One rank: the reference solver over its particles and a grid in the domain's node numbering, of
/// which it touches its slab and ghost planes.
pub struct Rank {
    rank: usize,
    solver: CpuSolver,
    /// Ids and parked slots of `solver.particles` (which `RankParticles::particles` stands in for
    /// only while migrating).
    store: RankParticles,
    slabs: Slabs,
    halo: HaloNodes,
    /// The walls' mirror planes along the slab axis, low and high (`Slabs::holds_mirror`).
    mirror_walls: (u32, u32),
    /// What this rank's migrations moved, summed over the ranks.
    pub migrated: Migration,
    pub migrations: u64,
    substeps: u64,
}

impl Rank {
    pub fn new(all: &Particles, scene: &Scene, slabs: &Slabs, rank: usize) -> Rank {
        let params = scene.params();
        let mut store = RankParticles::share(all, slabs, rank, params.inv_dx);
        let particles = std::mem::take(&mut store.particles);
        let solver = CpuSolver::new(particles, scene.grid_res);
        let halo = HaloNodes::new(slabs, solver.grid.shape, rank);
        Rank {
            mirror_walls: (params.wall_mirror_lo, params.wall_mirror_hi[slabs.axis]),
            rank,
            solver,
            store,
            slabs: slabs.clone(),
            halo,
            migrated: Migration::default(),
            migrations: 0,
            substeps: 0,
        }
    }

    /// One substep of the reference, its phases in step order, the ghost exchanges between them.
    /// Scatters are summed over the ranks before they become floats (`CpuSolver::settle_mass`), so
    /// the fixed-point scatter's integer sums reach every owner whole.
    pub fn substep(&mut self, comm: &mut dyn Comm, params: &Params) -> Result<PhaseTimings> {
        // The gathered density reads the grid mass in p2g, so mass is summed and filled before it;
        // the advected one needs it only in g2p, so both quantities travel together after p2g.
        let gathered = DensityRule::of(params) == DensityRule::Gathered;
        let mut clock = PhaseClock::start();
        self.solver.clear_grid();
        clock.lap(Phase::GridClear);
        self.rebin(comm, params.inv_dx)?;
        clock.lap(Phase::Sort);
        self.solver.scatter_mass(params);
        clock.lap(Phase::P2gInit);
        if gathered {
            self.sum_mass(comm, params)?;
            clock.lap(Phase::HaloSum);
            self.solver.settle_mass(params);
            self.solver.mirror_mass(params);
            clock.lap(Phase::P2gInit);
            self.fill_mass(comm, params)?;
            clock.lap(Phase::HaloFill);
        }
        self.solver.scatter_momentum(params);
        clock.lap(Phase::P2g);
        if !gathered {
            self.sum_mass(comm, params)?;
        }
        self.sum_momentum(comm, params)?;
        clock.lap(Phase::HaloSum);
        if !gathered {
            self.solver.settle_mass(params);
            self.solver.mirror_mass(params);
        }
        self.solver.settle_momentum(params);
        self.solver.mirror_momentum(params);
        self.solver.grid_update(params);
        clock.lap(Phase::GridUpdate);
        if !gathered {
            self.fill_mass(comm, params)?;
        }
        let (halo, grid) = (&self.halo, &mut self.solver.grid);
        halo.fill_ghosts(comm, &mut grid.momentum)?; // velocities by now
        clock.lap(Phase::HaloFill);
        self.solver.g2p(params);
        clock.lap(Phase::G2p);
        Ok(clock.finish())
    }

    /// The mass scatter's ghost sums to their owners: its integer units under the fixed-point
    /// scatter, else the float mass; and the volume's, where the rest densities differ.
    fn sum_mass(&mut self, comm: &mut dyn Comm, params: &Params) -> Result<()> {
        let grid = &mut self.solver.grid;
        if gathers_volume(params) {
            self.halo.sum_into_owners(comm, &mut grid.volume)?;
        }
        if is_fixed_point(params) {
            self.halo.sum_into_owners(comm, &mut grid.fixed_mut().mass)
        } else {
            self.halo.sum_into_owners(comm, &mut grid.mass)
        }
    }

    /// The owners' settled, mirrored mass over their neighbours' ghosts; and the volume, where the
    /// rest densities differ.
    fn fill_mass(&mut self, comm: &mut dyn Comm, params: &Params) -> Result<()> {
        let grid = &mut self.solver.grid;
        if gathers_volume(params) {
            self.halo.fill_ghosts(comm, &mut grid.volume)?;
        }
        self.halo.fill_ghosts(comm, &mut grid.mass)
    }

    /// The momentum scatter's ghost sums to their owners, as `sum_mass`.
    fn sum_momentum(&mut self, comm: &mut dyn Comm, params: &Params) -> Result<()> {
        let grid = &mut self.solver.grid;
        if is_fixed_point(params) {
            self.halo.sum_into_owners(comm, &mut grid.fixed_mut().momentum)
        } else {
            self.halo.sum_into_owners(comm, &mut grid.momentum)
        }
    }

    /// Every [`MIGRATION_INTERVAL`](super::MIGRATION_INTERVAL) substeps, or where any rank holds a
    /// particle that could step out of its slab and ghosts in the next substep: the slabs move if the
    /// counts are out of balance, then particles go to their owners.
    fn rebin(&mut self, comm: &mut dyn Comm, inv_dx: f32) -> Result<()> {
        self.substeps += 1;
        let due = self.substeps % u64::from(super::MIGRATION_INTERVAL) == 0;
        let (slabs, p) = (&self.slabs, &self.solver.particles);
        let stays = (0..p.len())
            .filter(|&i| p.live[i])
            .all(|i| slabs.keeps(self.rank, base(p.x[i], slabs.axis, inv_dx)));
        // Every rank takes the same branch: `due` counts the same substeps everywhere.
        if !due && !any(comm, !stays)? {
            return Ok(());
        }
        let per_layer = all_sum(comm, &layer_counts(&self.solver.particles, &self.slabs, inv_dx))?;
        if let Some(balanced) = self.slabs.rebalanced(&per_layer, self.mirror_walls)? {
            self.halo = HaloNodes::new(&balanced, self.solver.grid.shape, self.rank);
            self.slabs = balanced;
        }
        self.store.particles = std::mem::take(&mut self.solver.particles);
        let moved = self.store.migrate(comm, &self.slabs, inv_dx);
        self.solver.particles = std::mem::take(&mut self.store.particles);
        let moved = moved?;
        self.migrated.sent += moved.sent;
        self.migrated.received += moved.received;
        self.migrations += 1;
        Ok(())
    }
}

/// The CPU reference over `ranks` thread ranks: a [`Solver`] like any other, whose particles read
/// back in the one-rank run's slot order (by id).
pub struct CpuRanks {
    ranks: Vec<Rank>,
    comms: Vec<LocalComm>,
    /// The one-rank run's slots: ids run over them.
    slots: usize,
    /// The particles as of the last substep, by id (for `Solver::particles`).
    gathered: Particles,
    timings: Vec<PhaseTimings>,
    inv_dx: f32,
}

impl CpuRanks {
    /// `ranks` ranks, the slabs balanced for `particles` (to whole block layers).
    pub fn new(scene: &Scene, particles: Particles, ranks: usize) -> Result<CpuRanks> {
        let slabs = starting_slabs(scene, &particles, ranks)?;
        CpuRanks::with_slabs(scene, particles, slabs)
    }

    /// Ranks on the given slabs (one per slab), whatever their balance: the next rebin moves them.
    pub fn with_slabs(scene: &Scene, particles: Particles, slabs: Slabs) -> Result<CpuRanks> {
        check_ranks(scene, &slabs)?;
        let params = scene.params();
        let ranks = slabs.ranks();
        let per_rank = (0..ranks)
            .map(|r| Rank::new(&particles, scene, &slabs, r))
            .collect();
        Ok(CpuRanks {
            ranks: per_rank,
            comms: LocalComm::group(ranks),
            slots: particles.len(),
            gathered: particles,
            timings: Vec::new(),
            inv_dx: params.inv_dx,
        })
    }

    /// The slabs as they stand (they move when the counts drift out of balance).
    pub fn slabs(&self) -> &Slabs {
        &self.ranks[0].slabs
    }

    /// Live particles per rank.
    pub fn counts(&self) -> Vec<usize> {
        self.ranks.iter().map(|r| r.solver.particles.num_live()).collect()
    }

    /// Live particles per block layer along the slab axis, all ranks together.
    pub fn layer_counts(&self) -> Vec<u64> {
        let slabs = self.slabs();
        let inv_dx = self.inv_dx;
        let mut all = vec![0u64; slabs.blocks() as usize];
        for rank in &self.ranks {
            for (a, n) in all
                .iter_mut()
                .zip(layer_counts(&rank.solver.particles, slabs, inv_dx))
            {
                *a += n;
            }
        }
        all
    }

    /// Rebins so far, and what they moved (summed over the ranks).
    pub fn migrated(&self) -> (u64, Migration) {
        (self.ranks[0].migrations, self.ranks[0].migrated)
    }

    /// Every rank's live particles at their ids' slots; a slot no rank holds stays parked.
    fn gather(&mut self) -> Result<()> {
        let g = &mut self.gathered;
        g.live.iter_mut().for_each(|l| *l = false);
        for rank in &self.ranks {
            let p = &rank.solver.particles;
            for i in (0..p.len()).filter(|&i| p.live[i]) {
                let id = rank.store.id[i] as usize;
                if id >= self.slots || g.live[id] {
                    bail!("particle {id} is held twice or out of range: the ranks disagree");
                }
                (g.x[id], g.v[id], g.c[id], g.rho[id], g.live[id]) = (p.x[i], p.v[i], p.c[i], p.rho[i], true);
                g.material[id] = p.material[i];
            }
        }
        Ok(())
    }
}

impl Solver for CpuRanks {
    /// The reference's name: what the ranks hand over (particles by id, extremes, checkpoints) is
    /// what one rank would, so a checkpoint of theirs resumes on the reference.
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn step(&mut self, params: &Params) -> Result<()> {
        let results: Vec<Result<PhaseTimings>> = std::thread::scope(|s| {
            let running: Vec<_> = self
                .ranks
                .iter_mut()
                .zip(self.comms.iter_mut())
                .map(|(rank, comm)| s.spawn(move || rank.substep(comm, params)))
                .collect();
            running
                .into_iter()
                .map(|r| {
                    r.join()
                        .unwrap_or_else(|_| Err(anyhow!("a rank's thread panicked")))
                })
                .collect()
        });
        // The slowest rank sets each phase's pace. A rank's own error comes first; the others' only
        // say that it stopped.
        let mut step = PhaseTimings::one_step();
        for result in results {
            let t = result?;
            for phase in Phase::ALL {
                step[phase] = step[phase].max(t[phase]);
            }
        }
        push_step_timing(&mut self.timings, step);
        self.gather()
    }

    fn resume_after(&mut self, last: &Params) {
        for rank in &mut self.ranks {
            rank.solver.resume_after(last);
        }
    }

    fn take_extremes(&mut self) -> Result<StepExtremes> {
        let mut all = StepExtremes::default();
        for rank in &mut self.ranks {
            all.merge(&rank.solver.take_extremes()?);
        }
        Ok(all)
    }

    fn set_colliders(&mut self, frame: &ColliderFrame) -> Result<()> {
        self.ranks
            .iter_mut()
            .try_for_each(|r| r.solver.set_colliders(frame))
    }

    fn take_step_timings(&mut self) -> Result<Option<Vec<PhaseTimings>>> {
        Ok(Some(std::mem::take(&mut self.timings)))
    }

    fn particles(&self) -> ParticleView<'_> {
        ParticleView::Host(&self.gathered)
    }

    fn read_particles(&mut self) -> Result<Particles> {
        Ok(self.gathered.clone())
    }

    fn apply_push(&mut self, push: &Push) -> Result<()> {
        self.ranks
            .iter_mut()
            .try_for_each(|r| r.solver.apply_push(push))?;
        self.gather()
    }
}
