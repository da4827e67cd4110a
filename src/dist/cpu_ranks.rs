//! The CPU reference split into ranks: each rank runs the reference's phases on its own slab's
//! particles, with the ghost exchange between the phases and migration at rebin time. The ranks are
//! threads of one process joined by channels, or with `--processes` a process each joined by Unix
//! sockets (`sockets`), launched as the CUDA ranks' processes are: the same launch, heartbeats and
//! outputs on a machine without a GPU. It is the decomposition's oracle: the same scene must give
//! what one rank gives, to float rounding (a node's sum adds the same terms in another order), and
//! byte for byte under the fixed-point scatter.

use super::comm::{all_gather, all_sum, any, Comm, LocalComm};
use super::halo::HaloNodes;
use super::launch::{Joining, RENDEZVOUS_WAIT};
use super::migrate::{base, layer, layer_counts, Migrant, Migration, RankParticles};
use super::slabs::Slabs;
use super::sockets::SocketComm;
use super::{check_ranks, starting_slabs};
use crate::sim::colliders::ColliderFrame;
use crate::sim::cpu::{is_fixed_point, CpuSolver, Grid, GridShape};
use crate::sim::flow::{Flow, FlowCounts, FlowState, Lifecycle, Slots};
use crate::sim::params::{gathers_volume, DensityRule, Params};
use crate::sim::phase::{Phase, PhaseClock, PhaseTimings};
use crate::sim::push::Push;
use crate::sim::solver::{push_step_timing, Holdings, RankHolding, Solver, StepExtremes};
use crate::sim::ParticleView;
use crate::sim::{Particles, Scene};
use anyhow::{anyhow, bail, ensure, Result};
use bytemuck::Zeroable;
use glam::UVec3;

/// One rank: the reference solver over its particles and a grid of its slab and ghost planes.
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
        let mut solver = CpuSolver::new(particles, scene.grid_res);
        solver.grid = Grid::new(held_shape(slabs, UVec3::from(scene.grid_res), rank));
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

    /// What it holds: its slab, particles and grid, and the host memory they take (its particles'
    /// ids and the walls' own sums with them).
    fn holding(&self) -> RankHolding {
        let (p, grid) = (&self.solver.particles, &self.solver.grid);
        let own = &self.solver.own;
        let bytes = p.bytes()
            + std::mem::size_of_val(self.store.id.as_slice())
            + grid.bytes()
            + std::mem::size_of_val(own.mass.as_slice())
            + std::mem::size_of_val(own.momentum.as_slice());
        RankHolding {
            rank: self.rank,
            slab: self.slabs.owned(self.rank),
            particles: p.num_live(),
            places: p.len(),
            grid_nodes: grid.shape.num_nodes(),
            bytes,
        }
    }

    /// Parks its live particles inside a sink of `flow`, as the reference's drain does after g2p,
    /// and names them.
    fn drain(&mut self, flow: &Flow) -> Vec<u32> {
        let (p, store) = (&mut self.solver.particles, &mut self.store);
        let mut drained = Vec::new();
        for i in 0..p.len() {
            if p.live[i] && flow.in_a_sink(p.x[i]) {
                p.live[i] = false;
                store.parked.push(i as u32);
                drained.push(store.id[i]);
            }
        }
        drained
    }

    /// Takes in new particles (an emission's, in its slabs), each into a parked slot or a new one.
    fn take_in(&mut self, arrivals: &[Migrant]) {
        self.store.particles = std::mem::take(&mut self.solver.particles);
        for m in arrivals {
            self.store.push(m);
        }
        self.solver.particles = std::mem::take(&mut self.store.particles);
    }

    /// Its live particles, by id.
    fn live(&self) -> Vec<Migrant> {
        let p = &self.solver.particles;
        (0..p.len())
            .filter(|&i| p.live[i])
            .map(|i| Migrant::of(p, i, self.store.id[i]))
            .collect()
    }

    /// What it hands over after a substep timed as `timings`, its particles in `flow`'s sinks
    /// drained first.
    fn handover(&mut self, timings: PhaseTimings, flow: Option<&Flow>) -> Result<Handover> {
        let drained = flow.map_or_else(Vec::new, |flow| self.drain(flow));
        Ok(Handover {
            particles: self.live(),
            drained,
            extremes: self.solver.take_extremes()?,
            timings,
        })
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
            // A grid of the new planes loses nothing: this substep's was cleared before the rebin.
            let shape = held_shape(&balanced, self.solver.grid.shape.res, self.rank);
            if shape != self.solver.grid.shape {
                self.solver.grid = Grid::new(shape);
            }
            self.halo = HaloNodes::new(&balanced, shape, self.rank);
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

/// What a rank's grid stores in a domain of `res` nodes: its slab and ghost planes (`Slabs::held`).
fn held_shape(slabs: &Slabs, res: UVec3, rank: usize) -> GridShape {
    GridShape::planes(res, slabs.axis, slabs.held(rank))
}

/// What a rank hands over after each substep: its live particles, by id (for readers, checkpoints
/// and the emitters' look at each nozzle point's last particle), the ids its sinks drained, its
/// extremes (the next time step's) and its phase times.
struct Handover {
    particles: Vec<Migrant>,
    drained: Vec<u32>,
    extremes: StepExtremes,
    timings: PhaseTimings,
}

/// The words of a handover before its phase times.
const HANDOVER_WORDS: usize = 6;

impl Handover {
    /// Everything but the particles, and their count, as words of one length on every rank.
    fn words(&self) -> Vec<u64> {
        let e = &self.extremes;
        let mut words = vec![
            self.particles.len() as u64,
            self.drained.len() as u64,
            u64::from(e.max_density.to_bits()),
            u64::from(e.max_speed.to_bits()),
            u64::from(e.max_signal_speed.to_bits()),
            e.backstop_pushes,
        ];
        words.extend(Phase::ALL.map(|phase| self.timings[phase].to_bits()));
        words
    }

    /// A handover from its `words`, its particles and drained ids to come (room for them made).
    fn from_words(words: &[u64]) -> Handover {
        let float = |w: u64| f32::from_bits(w as u32);
        let mut timings = PhaseTimings::one_step();
        for (phase, &bits) in Phase::ALL.into_iter().zip(&words[HANDOVER_WORDS..]) {
            timings[phase] = f64::from_bits(bits);
        }
        Handover {
            particles: vec![Migrant::zeroed(); words[0] as usize],
            drained: vec![0; words[1] as usize],
            extremes: StepExtremes {
                max_density: float(words[2]),
                max_speed: float(words[3]),
                max_signal_speed: float(words[4]),
                backstop_pushes: words[5],
            },
            timings,
        }
    }
}

/// Every process's handover, in rank order, given this process's: what one process of thread ranks
/// holds after a substep, each process holds.
fn handovers_of_processes(comm: &mut dyn Comm, mine: Handover) -> Result<Vec<Handover>> {
    let (me, size) = (comm.rank(), comm.size());
    let words = mine.words();
    let all = all_gather(comm, &words)?;
    let mut handovers: Vec<Handover> = all.chunks(words.len()).map(Handover::from_words).collect();
    // To each other process its particles, then what its sinks drained (each skipped where empty,
    // as every process knows from the words).
    let messages: [&[u8]; 2] = [
        bytemuck::cast_slice(&mine.particles),
        bytemuck::cast_slice(&mine.drained),
    ];
    let sends: Vec<(usize, &[u8])> = (0..size)
        .filter(|&to| to != me)
        .flat_map(|to| messages.iter().filter(|m| !m.is_empty()).map(move |m| (to, *m)))
        .collect();
    let mut recvs: Vec<(usize, &mut [u8])> = Vec::new();
    for (from, h) in handovers.iter_mut().enumerate().filter(|(from, _)| *from != me) {
        let particles: &mut [u8] = bytemuck::cast_slice_mut(h.particles.as_mut_slice());
        let drained: &mut [u8] = bytemuck::cast_slice_mut(h.drained.as_mut_slice());
        recvs.extend(
            [particles, drained]
                .into_iter()
                .filter(|m| !m.is_empty())
                .map(|m| (from, m)),
        );
    }
    comm.exchange(&sends, &mut recvs)?;
    handovers[me] = mine;
    Ok(handovers)
}

/// The CPU reference over `ranks` ranks: a [`Solver`] like any other, whose particles read back in
/// the one-rank run's slot order (by id). With `Scene::process` the ranks are processes, this one
/// drives its own, and after each substep every process holds what the others hand over (all the
/// particles, the extremes, the phase times), so every `Solver` call but the step is its own.
pub struct CpuRanks {
    /// This process's ranks: every rank of the run, or with a process per rank its one.
    ranks: Vec<Rank>,
    /// Their communicators, in the same order: channels between threads, or sockets to the other
    /// processes.
    comms: Vec<Box<dyn Comm>>,
    in_processes: bool,
    /// The one-rank run's slots: ids run over them.
    slots: usize,
    /// The particles as of the last substep, by id (for `Solver::particles`).
    gathered: Particles,
    /// The emitters and sinks, where the scene has them: the one-rank reference's state, the same
    /// in every process.
    lifecycle: Option<Lifecycle>,
    extremes: StepExtremes,
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
    /// With `Scene::process`, this process's rank, joined to the others'.
    pub fn with_slabs(scene: &Scene, particles: Particles, slabs: Slabs) -> Result<CpuRanks> {
        check_ranks(scene, &slabs)?;
        let params = scene.params();
        let ranks = slabs.ranks();
        let (mine, comms): (std::ops::Range<usize>, Vec<Box<dyn Comm>>) = match scene.process {
            Some(process) => {
                ensure!(
                    process.size == ranks,
                    "a run of {} processes splits into as many ranks, not {ranks}",
                    process.size
                );
                let Joining { run, watch, .. } = Joining::start(&process)?;
                let comm = SocketComm::join(&process, &run, watch, RENDEZVOUS_WAIT)?;
                (process.rank..process.rank + 1, vec![Box::new(comm)])
            }
            None => {
                let comms = LocalComm::group(ranks).into_iter();
                (0..ranks, comms.map(|c| Box::new(c) as Box<dyn Comm>).collect())
            }
        };
        Ok(CpuRanks {
            ranks: mine.map(|r| Rank::new(&particles, scene, &slabs, r)).collect(),
            comms,
            in_processes: scene.process.is_some(),
            slots: particles.len(),
            gathered: particles,
            lifecycle: None,
            extremes: StepExtremes::default(),
            timings: Vec::new(),
            inv_dx: params.inv_dx,
        })
    }

    /// The ranks with the scene's emitters and sinks, from a fresh run's or a checkpoint's state.
    pub fn with_lifecycle(mut self, lifecycle: Option<Lifecycle>) -> CpuRanks {
        self.lifecycle = lifecycle;
        self
    }

    /// The slabs as they stand (they move when the counts drift out of balance).
    pub fn slabs(&self) -> &Slabs {
        &self.ranks[0].slabs
    }

    /// Live particles per rank of this process.
    pub fn counts(&self) -> Vec<usize> {
        self.ranks.iter().map(|r| r.solver.particles.num_live()).collect()
    }

    /// Live particles per block layer along the slab axis, this process's ranks together.
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

    /// One substep of every rank, and what each handed over, in rank order.
    fn substep(&mut self, params: &Params) -> Result<Vec<Handover>> {
        // The sinks drain on the ranks, which hand over what they drained; the lifecycle's state
        // (the free slots, the nozzle points' last particles) is every process's own copy.
        let flow = self.lifecycle.as_ref().map(|l| l.flow.clone());
        let sinks = flow.as_deref().filter(|flow| !flow.sinks.is_empty());
        if self.in_processes {
            let (rank, comm) = (&mut self.ranks[0], self.comms[0].as_mut());
            let timings = rank.substep(comm, params)?;
            let mine = rank.handover(timings, sinks)?;
            return handovers_of_processes(comm, mine);
        }
        let results: Vec<Result<Handover>> = std::thread::scope(|s| {
            let running: Vec<_> = self
                .ranks
                .iter_mut()
                .zip(self.comms.iter_mut())
                .map(|(rank, comm)| {
                    s.spawn(move || {
                        let timings = rank.substep(comm.as_mut(), params)?;
                        rank.handover(timings, sinks)
                    })
                })
                .collect();
            running
                .into_iter()
                .map(|r| {
                    r.join()
                        .unwrap_or_else(|_| Err(anyhow!("a rank's thread panicked")))
                })
                .collect()
        });
        // A rank's own error comes first; the others' only say that it stopped.
        results.into_iter().collect()
    }

    /// Every rank's live particles at their ids' slots; a slot no rank holds stays parked.
    fn gather<'a>(&mut self, lists: impl Iterator<Item = &'a [Migrant]>) -> Result<()> {
        let g = &mut self.gathered;
        g.live.iter_mut().for_each(|l| *l = false);
        for m in lists.flatten() {
            let id = m.id as usize;
            if id >= self.slots || g.live[id] {
                bail!("particle {id} is held twice or out of range: the ranks disagree");
            }
            m.place(g, id);
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
        let handovers = self.substep(params)?;
        // The slowest rank sets each phase's pace.
        let mut step = PhaseTimings::one_step();
        for h in &handovers {
            for phase in Phase::ALL {
                step[phase] = step[phase].max(h.timings[phase]);
            }
            self.extremes.merge(&h.extremes);
        }
        push_step_timing(&mut self.timings, step);
        if let Some(lifecycle) = &mut self.lifecycle {
            // Sorted after the drains, as the reference sorts its own: the free slots do not
            // depend on which rank drained which particle.
            for &id in handovers.iter().flat_map(|h| &h.drained) {
                lifecycle.state.drain(id);
            }
            lifecycle.state.settle();
        }
        self.gather(handovers.iter().map(|h| h.particles.as_slice()))
    }

    /// The reference's emission, on the run's particles as of the last substep (each nozzle point
    /// looks at its last particle wherever it is), every process alike; each new particle then goes
    /// to the rank whose slab holds it.
    fn emit(&mut self, _params: &Params, mask: u32) -> Result<()> {
        let Some(lifecycle) = &mut self.lifecycle else {
            bail!("this solver has no emitters");
        };
        lifecycle.state.settle();
        // An emission pops at most a slot per nozzle point off the top of the free slots.
        let state = &lifecycle.state;
        let top: Vec<u32> = state.free.iter().rev().take(state.last.len()).copied().collect();
        let before = state.free.len();
        lifecycle.emit(Slots::of(&mut self.gathered), mask);
        let emitted = &top[..before - lifecycle.state.free.len()];
        let (g, inv_dx) = (&self.gathered, self.inv_dx);
        for rank in &mut self.ranks {
            let slabs = &rank.slabs;
            let mine: Vec<Migrant> = emitted
                .iter()
                .filter(|&&id| slabs.owner(layer(g.x[id as usize], slabs.axis, inv_dx)) == rank.rank)
                .map(|&id| Migrant::of(g, id as usize, id))
                .collect();
            rank.take_in(&mine);
        }
        Ok(())
    }

    fn flow_counts(&mut self) -> Result<Option<FlowCounts>> {
        Ok(self.lifecycle.as_ref().map(|l| l.state.counts))
    }

    fn flow_state(&mut self) -> Result<Option<FlowState>> {
        Ok(self.lifecycle.as_ref().map(|l| l.state.clone()))
    }

    fn resume_after(&mut self, last: &Params) {
        for rank in &mut self.ranks {
            rank.solver.resume_after(last);
        }
    }

    fn take_extremes(&mut self) -> Result<StepExtremes> {
        Ok(std::mem::take(&mut self.extremes))
    }

    fn set_colliders(&mut self, frame: &ColliderFrame) -> Result<()> {
        self.ranks
            .iter_mut()
            .try_for_each(|r| r.solver.set_colliders(frame))
    }

    fn holdings(&self) -> Option<Holdings> {
        let ranks = self.ranks.iter().map(Rank::holding).collect();
        let (migrations, migrated) = self.migrated();
        Some(Holdings {
            axis: self.slabs().axis,
            migrations,
            migrated: migrated.sent,
            ranks,
        })
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
        ensure!(
            !self.in_processes,
            "a push comes from the window, which steps one process's ranks"
        );
        self.ranks
            .iter_mut()
            .try_for_each(|r| r.solver.apply_push(push))?;
        let lists: Vec<Vec<Migrant>> = self.ranks.iter().map(Rank::live).collect();
        self.gather(lists.iter().map(Vec::as_slice))
    }
}
