//! `CudaRanks`: one run split into ranks, each a [`CudaSolver`] over its slab of the grid
//! (`crate::dist`), stepped phase by phase with the ghost exchanges between the phases. What it hands
//! over (particles slot by slot, extremes, checkpoints) is what one solver would; its statistics
//! too, their sums to rounding.
//!
//! | phase | every rank, fused pipeline |
//! |---|---|
//! | sort        | where the last g2p counted a particle that the next substep could carry past its rank's ghost planes, or every MIGRATION_INTERVAL substeps: rebalance the slabs and migrate (where the cuts move, the ranks beside them take grids of their new planes and the scatter follows the cuts: `carry_old_scatter`); then bin where the rank's schedule says |
//! | p2g_init    | the first substep's scatter |
//! | halo_sum    | its ghost planes' sums packed, carried to their owner, added to its edge planes |
//! | grid_update | the walls' mirror of mass and momentum, the grid update |
//! | halo_fill   | its edge planes' velocities packed, carried to the neighbours' ghost planes |
//! | g2p         | one_pass (gather, advect, drain into the sinks, scatter the next substep), every rank's drains onto every rank's free slots, then count the strays |
//!
//! The fused pipeline scatters the next substep inside one_pass, so the ghost sums travel at the
//! start of the substep that uses them, before the walls' mirror.
//!
//! **Where the ranks run** (`Scene::gpus`, `Scene::process`), and what joins them (the `Transport`,
//! cuda_ranks/transport.rs). On one GPU every rank runs on device `CudaOptions::device`, joined by
//! device copies on the receiver's stream. On several GPUs of this process, rank r runs on device
//! r; with `--processes`, this process drives its one rank on the GPU of its local rank. Between
//! GPUs everything travels by NCCL's send and receive (every rank's of this process posted in one
//! group by the one thread that drives them): halos, migrants, the readers' set. Each rank is asked
//! for its part through its solver (as_rank.rs), never reached into.
//!
//! **The host's exchanges between processes.** What the host decides from every rank's numbers
//! (the stray counts, the layer counts a migration is planned from, the statistics) comes from an
//! all-gather, on each process alike, so each plans the same migration; the extremes the time step
//! is chosen from are all-reduced on the device, in stream order, before their copy to the host
//! (`Transport::reduce_counters`), so each picks the same step. Each exchange starts with a word
//! saying what it is for (`Turn`): rank 0 alone writes the outputs, and calls the others to send it
//! their particles (`Turn::Gather`) at whichever exchange they wait in next; every substep opens
//! with one, so the others are called before they step on. A process waiting on the others
//! watches their heartbeats (`dist::launch::Watch`) and stops, naming the rank, when one dies.
//!
//! **Each rank's grid holds its slab and ghost planes** (`GridBox`, grid.rs), and the whole grid along
//! the other two axes: the kernels address a node by it; all else sees the domain's coordinates.
//!
//! **Each rank holds its own particles**, with room for more (`with_room`), each carrying its slot in
//! the run, and keeps them in bin order as one GPU does: every binning gathers its live particles to
//! the front of its buffers. A migration (`move_owned`, kernels/ranks.cu, launched from ranks.rs)
//! packs each sender's leavers for each receiver into a buffer of their own, parking them on the
//! sender, and the transport appends them after the receiver's places in use (`extents`), in places
//! the receiver reserves for that sender from the layer counts every rank has; a receiver without
//! the room grows first.
//!
//! **Emitters and sinks** (`SharedFlow`, cuda_ranks/flow.rs): every rank keeps the run's lifecycle
//! alike, the free slots and each nozzle point's last slot. A substep's drains are gathered from
//! every rank onto every rank's stack before it is sorted; an emission ORs every rank's look at the
//! nozzle points' last particles, then every rank runs it alike and keeps the new particles its slab
//! holds, appended after its places in use (kernels/lifecycle.cu).
//!
//! **Readers** see one set of every slot on rank 0's GPU, made at the first read, into which
//! `take_owned` copies every rank's particles to their slots where something reads them: the
//! renderer (`Solver::publish_particles`, once a frame), exports and checkpoints. The statistics
//! are each rank's reduction over its own particles, joined (`Summary::of_parts`), so a run that
//! nothing reads never gathers its particles. The phases are timed by CUDA events on rank 0's
//! stream (timing.rs; `MPM_TIMED_RANK` picks another; with `--processes` each process times its
//! own), each from the end of the one before, so an exchange includes any wait for a slower
//! neighbour, and the sort phase the host's turn between substeps. The host waits for the ranks
//! only where it must: for the stray counts before each substep, around a migration and
//! `take_owned`. The extremes come as one GPU's do, requested in stream order and awaited a
//! stretch later (`Solver::request_extremes`); on one GPU a carry's copy waits for the sender's
//! stream and the sender's next work for the copy, by stream order, not by the host.

use super::gpu::CudaOptions;
use super::grid::{DeviceGrid, GridBox};
use super::halo::{Exchange, HaloBuffers, Planes};
use super::launch::NvtxRange;
use super::particles::{state_bytes, DeviceParticles};
use super::solver::CudaSolver;
use super::timing::PhaseEvents;
use crate::dist::launch::{self, Process, Watch};
use crate::dist::migrate::{Migration, RankParticles};
use crate::dist::nccl::{Comm, Nccl, UniqueId};
use crate::dist::slabs::BLOCK;
use crate::dist::{check_ranks, starting_slabs, Slabs, Spawn, Start, MIGRATION_INTERVAL};
use crate::sim::colliders::ColliderFrame;
use crate::sim::flow::{FlowCounts, FlowState};
use crate::sim::phase::{Phase, PhaseTimings};
use crate::sim::ExtremesTicket;
use crate::sim::{
    Deformation, Holdings, Params, ParticleView, Particles, Pipeline, Push, RankHolding, Scene, Solver,
    StepExtremes, Summary, SummaryTicket,
};
use anyhow::{bail, ensure, Context, Result};
use cudarc::driver::CudaSlice;
use std::collections::{HashMap, VecDeque};
use std::ops::Range;
use std::time::{Duration, Instant};

mod flow;
mod transport;
use flow::SharedFlow;
use transport::{DeviceCopies, NcclInProcess, NcclPerProcess, Transport};

pub struct CudaRanks {
    /// What joins the ranks (transport.rs). Before the solvers: NCCL's communicators go while their
    /// devices are still open.
    transport: Box<dyn Transport>,
    /// The ranks this process drives: every rank of the run, or with `--processes` its one.
    solvers: Vec<CudaSolver>,
    /// The run's rank of `solvers[0]`: the others follow it.
    first: usize,
    halos: Vec<HaloBuffers>,
    slabs: Slabs,
    /// The walls' mirror planes along the slab axis, low and high (`Slabs::rebalanced`).
    walls: (u32, u32),
    /// Every slot, each from the rank that owns it, on rank 0's device (`Solver::particles`), as of
    /// the last `take_owned`; made at the first, since a run that nothing reads (a benchmark) needs
    /// no room for it.
    merged: Option<DeviceParticles>,
    /// The run's slots (live and parked), as many as `merged` holds.
    slots: usize,
    /// Whether the ranks stepped (or were pushed) since `merged` was taken.
    merged_stale: bool,
    /// On rank 0, where another GPU's rank lands on its way into `merged`; kept from one read to
    /// the next, grown when short.
    landing: Option<DeviceParticles>,
    /// Per (sender, receiver) of this process's senders: where a migration packs the leavers, kept
    /// from one migration to the next (grown when short), so a migration allocates nothing.
    packing: HashMap<(usize, usize), DeviceParticles>,
    /// What `particles` shows before anything was published: nothing.
    unpublished: Particles,
    /// Per rank of this process: the strays its last g2p counted, and of them those whose stencil
    /// left its grid's box (`count_strays` in kernels/ranks.cu).
    strays: Vec<CudaSlice<u32>>,
    /// The extremes requested and not yet waited for: each request's handle and every rank's ticket.
    extremes: VecDeque<(usize, Vec<ExtremesTicket>)>,
    extremes_requested: usize,
    /// Live particles per rank of the run, as of the last substep.
    counts: Vec<usize>,
    /// Per rank of this process, the places its live particles lie within: packed at its last
    /// binning, then grown by what it received since (a sender's leavers leave parked holes).
    /// Migrants go after them.
    extents: Vec<usize>,
    /// Times a rank of this process received more particles than its buffers had room for and
    /// grew them.
    growths: u64,
    /// Live particles in the run, all ranks together: what every migration must leave.
    live: u64,
    /// The phases' events, on the timed rank's stream (`CudaOptions::timed_rank`).
    timing: PhaseEvents,
    timed: usize,
    substeps: u64,
    migrations: u64,
    migrated: Migration,
    /// `MPM_RANKS_HOST_TIMES=1`: where this process's host thread spends its time, told at the end.
    host_times: Option<HostTimes>,
    /// The emitters and sinks, where the scene has them.
    flow: Option<SharedFlow>,
}

/// Where the host thread of a run on ranks spends its time, summed over the run and printed when
/// the ranks are dropped (`MPM_RANKS_HOST_TIMES=1`): inside the substeps, between them, and waiting
/// in the exchanges with the other processes.
#[derive(Default)]
struct HostTimes {
    substeps: u64,
    in_step: Duration,
    between_steps: Duration,
    in_turns: Duration,
    in_extremes: Duration,
    last_return: Option<Instant>,
}

impl HostTimes {
    fn from_env() -> Option<HostTimes> {
        (std::env::var("MPM_RANKS_HOST_TIMES").as_deref() == Ok("1")).then(HostTimes::default)
    }

    fn report(&self, rank: usize) -> String {
        let per = |d: Duration| d.as_secs_f64() * 1e3 / self.substeps.max(1) as f64;
        format!(
            "rank {rank}: host time over {} substeps, ms a substep: in step {:.4} (exchanges with the \
             other processes {:.4}), between steps {:.4} (waiting for extremes {:.4})",
            self.substeps,
            per(self.in_step),
            per(self.in_turns),
            per(self.between_steps),
            per(self.in_extremes)
        )
    }
}

/// Below and above: a rank's two sides, its halo buffers' indices.
const SIDES: [Side; 2] = [Side::Below, Side::Above];

#[derive(Clone, Copy, PartialEq, Eq)]
enum Side {
    Below = 0,
    Above = 1,
}

impl Side {
    fn opposite(self) -> Side {
        match self {
            Side::Below => Side::Above,
            Side::Above => Side::Below,
        }
    }
}

/// What a host-side exchange between the processes of a run is for, its first word: each process
/// must come to the same one, except that rank 0 may call the others to a gather at any of theirs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Turn {
    /// Before a substep: the stray counts.
    Step = 1,
    /// The statistics of a frame.
    Summary = 2,
    /// Rank 0 reads the particles: every rank sends it its own.
    Gather = 3,
    /// Rank 0 ended the run.
    Done = 4,
    /// Before an emission: the ranks' looks at the nozzle points follow.
    Emit = 5,
}

impl Turn {
    fn of(word: u64) -> Option<Turn> {
        [Turn::Step, Turn::Summary, Turn::Gather, Turn::Done, Turn::Emit]
            .into_iter()
            .find(|turn| *turn as u64 == word)
    }
}

/// The words of a turn: its kind and what it carries (a summary's nine at most).
const TURN_WORDS: usize = 10;

/// One run of particles carried between two ranks: its sender and receiver, and at each end of it
/// this process drives, the set and places it leaves or lands in (of one length).
struct Run<'a> {
    from: usize,
    to: usize,
    sent: Option<(&'a DeviceParticles, Range<usize>)>,
    landed: Option<(&'a DeviceParticles, Range<usize>)>,
}

impl CudaRanks {
    /// `scene`'s start on `ranks` ranks: spawned whole where this process drives every rank; with a
    /// process per rank (`Scene::process`), walked for this process's share alone.
    pub fn spawn(scene: &Scene, ranks: usize, options: CudaOptions) -> Result<CudaRanks> {
        match scene.process {
            Some(_) => CudaRanks::new(scene, &Spawn::new(scene), None, ranks, options),
            None => CudaRanks::new(scene, &scene.spawn(), None, ranks, options),
        }
    }

    /// `ranks` ranks of `particles` (every slot of `scene`'s run, or what gives each rank its
    /// share), the slabs balanced for them; where the scene has emitters or sinks, their lifecycle
    /// in `flow` (a checkpoint's; `None`: the scene's start).
    pub fn new(
        scene: &Scene,
        particles: &dyn Start,
        flow: Option<&FlowState>,
        ranks: usize,
        options: CudaOptions,
    ) -> Result<CudaRanks> {
        ensure!(
            scene.method != crate::sim::Method::Pbmpm,
            "solver.method = \"pbmpm\" runs on one rank: drop --ranks and --gpus"
        );
        let gpus = scene.process.map_or(scene.gpus, |p| p.size);
        let live = particles.live() as usize;
        if let Some(note) = crate::dist::small_for_gpus(gpus, scene.process.is_some(), live) {
            if scene.process.is_none_or(|p| p.rank == 0) {
                eprintln!("note: {note}");
            }
        }
        let slabs = starting_slabs(scene, particles, ranks)?;
        CudaRanks::with_slabs(scene, particles, flow, slabs, options)
    }

    /// Ranks of `particles` (and the lifecycle in `flow`, as `new` takes them) on the given slabs,
    /// whatever their balance: the next rebin moves them. With `Scene::process`, only this
    /// process's rank.
    pub fn with_slabs(
        scene: &Scene,
        particles: &dyn Start,
        flow: Option<&FlowState>,
        slabs: Slabs,
        options: CudaOptions,
    ) -> Result<CudaRanks> {
        check_ranks(scene, &slabs)?;
        ensure!(
            options.timed_rank < slabs.ranks(),
            "MPM_TIMED_RANK={}: a run of {} ranks has ranks 0 to {}",
            options.timed_rank,
            slabs.ranks(),
            slabs.ranks() - 1
        );
        ensure!(
            scene.pipeline == Pipeline::Fused,
            "scene {}: several ranks run the fused pipeline (the default); drop --pipeline {} or run on one rank",
            scene.source,
            scene.pipeline.name()
        );
        let params = scene.params();
        let mine = match scene.process {
            Some(process) => {
                ensure!(
                    process.size == slabs.ranks(),
                    "a run of {} processes splits into as many ranks, not {}",
                    process.size,
                    slabs.ranks()
                );
                process.rank..process.rank + 1
            }
            None => 0..slabs.ranks(),
        };
        let devices = rank_devices(scene, slabs.ranks(), options.device)?;
        let flow_start;
        let flow = match flow {
            Some(state) => Some(state),
            None if scene.flow.is_active() => {
                flow_start = FlowState::start(&scene.flow, scene.num_particles);
                Some(&flow_start)
            }
            None => None,
        };
        let mut solvers = Vec::new();
        let mut halos = Vec::new();
        let mut counts = vec![0usize; slabs.ranks()];
        let mut extents = Vec::new();
        let mut strays = Vec::new();
        for (rank, &device) in mine.clone().zip(&devices) {
            let RankParticles {
                particles: mut share,
                id,
                ..
            } = particles.share(&slabs, rank, params.inv_dx)?;
            extents.push(id.len());
            share.park_more(with_room(id.len()) - id.len());
            if scene.has_deformation() {
                // A share that starts empty still carries a deformation per place.
                share.deformation.resize(share.len(), Deformation::at_rest(0));
            }
            // The binnings' gathers into bin order are what pack a rank's particles again after
            // its leavers parked (MPM_BIN_ORDER=0 is for timing one GPU).
            let packed = CudaOptions {
                device,
                bin_order: true,
                ..options
            };
            let held = GridBox::planes(scene.grid_res, slabs.axis, slabs.held(rank));
            let solver = CudaSolver::rank(scene, (&share, &id), held, flow, packed)
                .with_context(|| format!("rank {rank} of {}", slabs.ranks()))?;
            ensure!(
                solver.keeps_bin_order(),
                "rank {rank} of {}: no room on its GPU for the second copy of its {} particle places that \
                 a rank packs them into at each binning; run on more GPUs (--gpus) or with fewer particles",
                slabs.ranks(),
                share.len()
            );
            halos.push(solver.halo_buffers(slabs.axis)?);
            strays.push(
                solver
                    .stream()
                    .alloc_zeros::<u32>(2)
                    .context("allocating a stray counter")?,
            );
            solvers.push(solver);
        }
        let flow = match scene.flow.is_active() {
            true => Some(SharedFlow::allocate(&solvers, !scene.flow.sinks.is_empty())?),
            false => None,
        };
        let layers = particles.layer_counts(&slabs, params.inv_dx)?;
        for (rank, count) in counts.iter_mut().enumerate() {
            let owned = slabs.bounds[rank] as usize..slabs.bounds[rank + 1] as usize;
            *count = layers[owned].iter().sum::<u64>() as usize;
        }
        let transport: Box<dyn Transport> = match scene.process {
            Some(process) => {
                let (comm, watch) = join_processes(&process, &solvers[0])?;
                Box::new(NcclPerProcess::new(comm, watch))
            }
            None if scene.gpus > 1 => {
                let comms = Comm::init_all(Nccl::get()?, &devices).with_context(|| {
                    format!("joining the {} GPUs in one NCCL communicator", devices.len())
                })?;
                Box::new(NcclInProcess { comms })
            }
            None => Box::new(DeviceCopies),
        };
        // The timed rank is one of this process's: with a process per rank, its own.
        let timed = options
            .timed_rank
            .checked_sub(mine.start)
            .filter(|&t| t < solvers.len())
            .unwrap_or(0);
        // Every substep's phases: the ranks' run no graphs, and their exchanges are what is watched.
        let timing = PhaseEvents::new(solvers[timed].context().clone(), 1);
        Ok(CudaRanks {
            transport,
            solvers,
            first: mine.start,
            halos,
            walls: (params.wall_mirror_lo, params.wall_mirror_hi[slabs.axis]),
            slabs,
            live: particles.live(),
            extents,
            growths: 0,
            counts,
            merged: None,
            slots: particles.slots(),
            merged_stale: true,
            landing: None,
            packing: HashMap::new(),
            unpublished: Particles::default(),
            strays,
            extremes: VecDeque::new(),
            extremes_requested: 0,
            timing,
            timed,
            substeps: 0,
            migrations: 0,
            migrated: Migration::default(),
            host_times: HostTimes::from_env(),
            flow,
        })
    }

    /// What `--gpus` (`Scene::gpus` above 1) needs, checked before any particle is made: as many
    /// CUDA devices and NCCL; with `--processes`, the GPU of this process's local rank and NCCL.
    /// Each missing piece is named with its fix.
    pub fn check_gpus(scene: &Scene) -> Result<()> {
        if let Some(process) = scene.process {
            process_device(&process, super::library::devices()?.len())?;
            return Nccl::get().map(drop);
        }
        let gpus = scene.gpus;
        if gpus <= 1 {
            return Ok(());
        }
        let count = super::library::devices()?.len();
        ensure!(
            gpus <= count,
            "--gpus {gpus}: this machine has {count} CUDA device{} (`mpm devices` lists them); ask \
             for at most {count}",
            if count == 1 { "" } else { "s" }
        );
        Nccl::get().map(drop)
    }

    /// The device's name, and how many ranks share it or how many GPUs the ranks run on.
    pub fn device_name(&self) -> String {
        let (name, ranks) = (self.solvers[0].device_name(), self.slabs.ranks());
        self.transport.joined(&name, ranks, self.first)
    }

    /// The slabs as they stand (they move when the counts drift out of balance).
    pub fn slabs(&self) -> &Slabs {
        &self.slabs
    }

    /// Live particles per rank, as of the last substep.
    pub fn counts(&self) -> &[usize] {
        &self.counts
    }

    /// Migrations so far, and what they moved (summed over the ranks).
    pub fn migrated(&self) -> (u64, Migration) {
        (self.migrations, self.migrated)
    }

    /// Per rank of this process, the particles its buffers have room for, live and parked.
    pub fn capacities(&self) -> Vec<usize> {
        self.solvers.iter().map(CudaSolver::capacity).collect()
    }

    /// Times a rank of this process received more particles than it had room for and grew its
    /// buffers.
    pub fn growths(&self) -> u64 {
        self.growths
    }

    /// Whether this process drives every rank of the run.
    fn in_one_process(&self) -> bool {
        self.transport.in_one_process()
    }

    /// This process's ranks, as the run numbers them.
    fn mine(&self) -> Range<usize> {
        self.first..self.first + self.solvers.len()
    }

    /// Every rank's launches of `phase` (not the sort phase: its decision is each rank's): whether
    /// any rank enqueued work.
    fn run_phase(&mut self, phase: Phase) -> Result<bool> {
        let mut ran = false;
        for solver in &mut self.solvers {
            ran |= solver.run_phase(phase, false)?;
        }
        Ok(ran)
    }

    /// Where rank `rank` meets its neighbour on `side`; `None` at the domain's ends.
    fn link(&self, rank: usize, side: Side) -> Option<Link> {
        let slabs = &self.slabs;
        let (neighbour, ghosts, edge) = match side {
            Side::Below => {
                let below = rank.checked_sub(1)?;
                (below, slabs.low_ghost(rank), slabs.high_ghost(below))
            }
            Side::Above if rank + 1 < slabs.ranks() => {
                (rank + 1, slabs.high_ghost(rank), slabs.low_ghost(rank + 1))
            }
            Side::Above => return None,
        };
        let planes = |range| Planes {
            axis: slabs.axis,
            range,
        };
        Some(Link {
            rank,
            side,
            neighbour,
            ghosts: planes(ghosts),
            edge: planes(edge),
        })
    }

    /// The links of this process's ranks to their neighbours: what each exchange packs, carries
    /// and unpacks.
    fn links(&self) -> Vec<Link> {
        self.mine()
            .flat_map(|rank| SIDES.into_iter().filter_map(move |side| self.link(rank, side)))
            .collect()
    }

    /// One exchange between every pair of neighbours: each rank packs its side of it into its send
    /// buffers, the transport carries them across, each rank unpacks what arrived. The scatter's sums
    /// go from the ghost planes to the owner's edge, where they are added; the updated velocities
    /// from the edge back over the ghosts.
    fn exchange(&mut self, what: Exchange) -> Result<()> {
        let links = self.links();
        self.exchange_over(&links, what, &HashMap::new())
    }

    /// `what` over `links` (this process's ranks' ends of them): each end packs its planes, the
    /// transport carries them, each end unpacks what arrived. An end without planes does neither.
    /// A rank in `replaced` packs from the grid it held before (`CudaSolver::rebox`).
    fn exchange_over(&mut self, links: &[Link], what: Exchange, replaced: &Replaced) -> Result<()> {
        for link in links {
            let (packed, _) = link.planes(what);
            if !packed.range.is_empty() {
                let out = &self.halos[link.rank - self.first].send[link.side as usize];
                let solver = &self.solvers[link.rank - self.first];
                match replaced.get(&link.rank) {
                    Some(old) => solver.pack_old_sums(old, packed, out)?,
                    None => solver.pack_halo(what, packed, out)?,
                }
            }
        }
        self.transport
            .carry_halos(&self.solvers, &mut self.halos, links, what)?;
        for link in links {
            let (_, unpacked) = link.planes(what);
            if !unpacked.range.is_empty() {
                let got = &self.halos[link.rank - self.first].recv[link.side as usize];
                self.solvers[link.rank - self.first].unpack_halo(what, unpacked, got)?;
            }
        }
        Ok(())
    }

    /// After the cuts moved (`old` the slabs before): the grid holds the last one_pass's scatter,
    /// each rank's from its particles before they migrated, on its old slab and ghost planes. Each
    /// rank whose slab and ghost planes moved takes a grid of its new ones (`CudaSolver::rebox`).
    /// Each rank's sums on the nodes another rank owns now go to that rank, a block of planes at a
    /// time, and are added there (the sender's zeroed), and a rank with a new grid carries its sums
    /// on the planes it still owns into it; so the halo exchange and the grid update that follow see
    /// the sums one GPU would, bit for bit in fixed point. Scattering again from the migrated
    /// particles would not: a plastic solid's scatter takes the stress its pass's return mapping
    /// gave, which a scatter alone computes anew from the deformation, to other rounding.
    fn carry_old_scatter(&mut self, old: &Slabs) -> Result<()> {
        let (new, ranks) = (self.slabs.clone(), self.slabs.ranks());
        let grid_res = self.solvers[0].params().grid_res;
        let mut replaced = Replaced::new();
        for rank in self.mine() {
            let held = GridBox::planes(grid_res, new.axis, new.held(rank));
            let solver = &mut self.solvers[rank - self.first];
            if solver.held() != held {
                let grid = solver
                    .rebox(held)
                    .with_context(|| format!("rank {rank}: the slabs moved"))?;
                replaced.insert(rank, grid);
            }
        }
        let planes = |range: Range<u32>| Planes {
            axis: new.axis,
            range,
        };
        for (from, to) in (0..ranks).flat_map(|from| (0..ranks).map(move |to| (from, to))) {
            let (held, owned) = (old.held(from), new.owned(to));
            if held.end <= owned.start || owned.end <= held.start {
                continue;
            }
            if from == to {
                if let Some(grid) = replaced.get(&from) {
                    self.carry_into_new_grid(
                        from,
                        grid,
                        held.start.max(owned.start)..held.end.min(owned.end),
                    )?;
                }
                continue;
            }
            let side = if to > from { Side::Above } else { Side::Below };
            let mut at = held.start.max(owned.start);
            while at < held.end.min(owned.end) {
                let chunk = at..(at + BLOCK).min(held.end.min(owned.end));
                at = chunk.end;
                let none = planes(chunk.start..chunk.start);
                let mut links = Vec::new();
                if self.mine().contains(&from) {
                    links.push(Link {
                        rank: from,
                        side,
                        neighbour: to,
                        ghosts: planes(chunk.clone()),
                        edge: none.clone(),
                    });
                }
                if self.mine().contains(&to) {
                    links.push(Link {
                        rank: to,
                        side: side.opposite(),
                        neighbour: from,
                        ghosts: none,
                        edge: planes(chunk),
                    });
                }
                self.exchange_over(&links, Exchange::Sums, &replaced)?;
            }
        }
        Ok(())
    }

    /// Rank `rank`'s sums on the planes `kept` of the grid it held before (`old`) added into the
    /// grid it holds now, a block of planes at a time through its send buffer.
    fn carry_into_new_grid(
        &mut self,
        rank: usize,
        old: &(DeviceGrid, Params),
        kept: Range<u32>,
    ) -> Result<()> {
        let (solver, buffer) = (
            &self.solvers[rank - self.first],
            &self.halos[rank - self.first].send[0],
        );
        let mut at = kept.start;
        while at < kept.end {
            let chunk = Planes {
                axis: self.slabs.axis,
                range: at..(at + BLOCK).min(kept.end),
            };
            at = chunk.range.end;
            solver.pack_old_sums(old, &chunk, buffer)?;
            solver.unpack_halo(Exchange::Sums, &chunk, buffer)?;
        }
        Ok(())
    }

    /// A host-side exchange of `turn` between this process's ranks and the others: every rank's
    /// `payload` (one per rank of this process, at most TURN_WORDS - 1 words each), in rank order.
    /// Rank 0 may call the others to a gather at any turn of theirs: they send it their particles
    /// and come again. Processes that come to different turns ran apart, and stop.
    fn turn(&mut self, turn: Turn, payload: Vec<Vec<u64>>) -> Result<Vec<Vec<u64>>> {
        if self.in_one_process() {
            return Ok(payload);
        }
        let len = payload[0].len();
        ensure!(len < TURN_WORDS, "a turn of {len} words");
        let started = Instant::now();
        let agreed = self.agree(turn, payload, len);
        if let Some(times) = &mut self.host_times {
            times.in_turns += started.elapsed();
        }
        agreed
    }

    /// `turn`'s exchange, until every process came to it (after any gathers rank 0 called).
    fn agree(&mut self, turn: Turn, payload: Vec<Vec<u64>>, len: usize) -> Result<Vec<Vec<u64>>> {
        loop {
            let mut words = vec![0; TURN_WORDS];
            words[0] = turn as u64;
            words[1..=len].copy_from_slice(&payload[0]);
            let all = self
                .transport
                .gather_words(&self.solvers, self.first, vec![words])?;
            let called = Turn::of(all[0][0]);
            if called == Some(Turn::Gather) && turn != Turn::Gather {
                self.take_owned()?;
                continue;
            }
            if called == Some(Turn::Done) && turn != Turn::Done {
                bail!(
                    "rank {}: rank 0 ended the run where this rank came to {turn:?}: the processes ran \
                     apart (every process must run the same command)",
                    self.first
                );
            }
            // Rank 0's call to a gather meets the others wherever they are.
            let differs = |w: &&Vec<u64>| turn != Turn::Gather && w[0] != turn as u64;
            if let Some((rank, other)) = all.iter().enumerate().find(|(_, w)| differs(w)) {
                bail!(
                    "rank {} came to {turn:?} where rank {rank} came to {:?}: the processes ran apart \
                     (every process must run the same command)",
                    self.first,
                    Turn::of(other[0])
                );
            }
            return Ok(all.into_iter().map(|w| w[1..=len].to_vec()).collect());
        }
    }

    /// Particles the last g2p left where one more substep could carry them past their rank's ghost
    /// planes (`Slabs::keeps`), all ranks together: the step's turn.
    /// A particle that left its rank's grid (more than a cell in a substep, which the time step's
    /// CFL bound rules out) stops the run: its sums lay outside the nodes the grid holds.
    fn strays(&mut self) -> Result<u64> {
        self.transport.wait_watched(&self.solvers)?;
        let mut counts = Vec::new();
        for (solver, strays) in self.solvers.iter().zip(&self.strays) {
            counts.push(solver.download(strays)?.into_iter().map(u64::from).collect());
        }
        let counts = self.turn(Turn::Step, counts)?;
        if let Some((rank, count)) = counts.iter().enumerate().find(|(_, count)| count[1] > 0) {
            bail!(
                "rank {rank}: {} particles moved past its ghost planes in one substep, more than a \
                 cell, so their sums left the grid it holds; the time step is too long for the flow: \
                 lower time_step.cfl or time_step.dt",
                count[1]
            );
        }
        Ok(counts.iter().map(|count| count[0]).sum())
    }

    /// Counts the strays of each rank of this process after its g2p.
    fn count_strays(&mut self) -> Result<()> {
        for (local, (solver, strays)) in self.solvers.iter().zip(&mut self.strays).enumerate() {
            let kept = self.slabs.kept_bases(self.first + local);
            let keep = (*kept.start(), *kept.end());
            solver.count_strays(self.extents[local], self.slabs.axis, keep, strays)?;
        }
        Ok(())
    }

    /// Live particles per block layer along the slab axis, per rank of the run.
    fn layer_counts(&self) -> Result<Vec<Vec<u64>>> {
        let layers = self.slabs.blocks();
        let mut mine = Vec::with_capacity(self.solvers.len());
        for (solver, &places) in self.solvers.iter().zip(&self.extents) {
            mine.push(solver.layer_counts(places, self.slabs.axis, layers)?);
        }
        self.transport.gather_words(&self.solvers, self.first, mine)
    }

    /// Moves the slabs if the counts are out of balance, then every live particle to the rank that
    /// owns its block layer, checking that each sender moved what its layer counts said it held of
    /// the others' layers. Every process plans the same migration from every rank's layer counts.
    /// Where the slabs moved, the scatter the grids hold follows them (`carry_old_scatter`).
    fn migrate(&mut self) -> Result<()> {
        let before = self.layer_counts()?;
        let per_layer: Vec<u64> = (0..self.slabs.blocks() as usize)
            .map(|layer| before.iter().map(|rank| rank[layer]).sum())
            .collect();
        let live_before = per_layer.iter().sum::<u64>();
        ensure!(
            live_before == self.live,
            "the ranks hold {live_before} live particles, the run {}: a migration lost or duplicated some",
            self.live
        );
        let old = self.slabs.clone();
        let moved_slabs = match self.slabs.rebalanced(&per_layer, self.walls)? {
            Some(balanced) => {
                self.slabs = balanced;
                true
            }
            None => false,
        };
        // What each rank holds in the layers each rank owns now.
        let ranks = self.slabs.ranks();
        let slabs = self.slabs.clone();
        let layers_of = |owner: usize| slabs.bounds[owner] as usize..slabs.bounds[owner + 1] as usize;
        let held = |rank: usize, owner: usize| before[rank][layers_of(owner)].iter().sum::<u64>() as usize;
        let leavers = |from: usize, to: usize| if from == to { 0 } else { held(from, to) };
        // Each receiver of this process reserves places for each sender's leavers after its places
        // in use, senders in rank order: `arrivals[local][from]`.
        let in_use = self.extents.clone();
        let mut arrivals: Vec<Vec<Range<usize>>> = Vec::new();
        for (local, solver) in self.solvers.iter_mut().enumerate() {
            let to = self.first + local;
            let extent = &mut self.extents[local];
            let mut next = *extent;
            let arriving: Vec<Range<usize>> = (0..ranks)
                .map(|from| {
                    let start = next;
                    next += leavers(from, to);
                    start..next
                })
                .collect();
            if next > solver.capacity() {
                solver
                    .grow_particles(with_room(next))
                    .with_context(|| format!("rank {to} receiving {} particles", next - *extent))?;
                self.growths += 1;
            }
            if next > *extent {
                // Its bins miss the particles it was given (a sender's still list the places it
                // parked, which its passes skip).
                solver.rebin_next();
            }
            *extent = next;
            arrivals.push(arriving);
        }
        let moved = (0..ranks)
            .flat_map(|from| (0..ranks).map(move |to| (from, to)))
            .map(|(from, to)| leavers(from, to) as u64)
            .sum::<u64>();
        if moved > 0 {
            self.move_owned(&slabs, &leavers, &in_use, &arrivals)?;
        }
        for (rank, count) in self.counts.iter_mut().enumerate() {
            *count = per_layer[layers_of(rank)].iter().sum::<u64>() as usize;
        }
        // A rank's scatter lies in its old slab and ghost planes, which the new halo may miss.
        if moved_slabs {
            self.carry_old_scatter(&old)?;
        }
        self.migrated.sent += moved;
        self.migrated.received += moved;
        self.migrations += 1;
        Ok(())
    }

    /// Each sender of this process packs its live particles (in its places in use) of each other
    /// rank's layers into its buffer for that rank (`packing`), parking them, and the transport
    /// appends them to their owners in `arrivals` (each receiver's of this process, reserved from
    /// the layer counts; `in_use` their places in use before); waited for, each sender's count to
    /// each receiver checked against `leavers`.
    fn move_owned(
        &mut self,
        slabs: &Slabs,
        leavers: &dyn Fn(usize, usize) -> usize,
        in_use: &[usize],
        arrivals: &[Vec<Range<usize>>],
    ) -> Result<()> {
        let ranks = slabs.ranks();
        let pairs: Vec<(usize, usize)> = self
            .mine()
            .flat_map(|from| (0..ranks).map(move |to| (from, to)))
            .filter(|&(from, to)| leavers(from, to) > 0)
            .collect();
        for &(from, to) in &pairs {
            let count = leavers(from, to);
            if self
                .packing
                .get(&(from, to))
                .is_none_or(|buffer| buffer.count < count)
            {
                let buffer = self.solvers[from - self.first].allocate_like_owned(with_room(count))?;
                self.packing.insert((from, to), buffer);
            }
        }
        let mut packed = Vec::new();
        for &(from, to) in &pairs {
            let (sender, count) = (&self.solvers[from - self.first], leavers(from, to));
            let buffer = &self.packing[&(from, to)];
            let layers = slabs.bounds[to]..slabs.bounds[to + 1];
            let slab = (slabs.axis, slabs.blocks(), layers);
            let moved = sender.pack_leavers(slab, in_use[from - self.first], buffer, count)?;
            packed.push((from, to, buffer, moved));
        }
        let mut runs = Vec::new();
        for (from, to, buffer, _) in &packed {
            let landed = self.mine().contains(to).then(|| {
                let reserved = arrivals[to - self.first][*from].clone();
                (self.solvers[to - self.first].owned(), reserved)
            });
            runs.push(Run {
                from: *from,
                to: *to,
                sent: Some((buffer, 0..leavers(*from, *to))),
                landed,
            });
        }
        // Runs from the other processes' ranks to this one's.
        for (local, arriving) in arrivals.iter().enumerate() {
            let to = self.first + local;
            for from in (0..ranks).filter(|from| !self.mine().contains(from) && leavers(*from, to) > 0) {
                let particles = self.solvers[local].owned();
                runs.push(Run {
                    from,
                    to,
                    sent: None,
                    landed: Some((particles, arriving[from].clone())),
                });
            }
        }
        self.transport.carry_particles(&self.solvers, self.first, &runs)?;
        self.transport.wait_all(&self.solvers)?;
        for (from, to, _, moved) in &packed {
            let moved = self.solvers[from - self.first].read_count(moved)? as usize;
            let expected = leavers(*from, *to);
            ensure!(
                moved == expected,
                "rank {from} moved {moved} particles to rank {to} where its layer counts hold \
                 {expected}: a migration lost or duplicated particles"
            );
        }
        Ok(())
    }

    /// One substep, as the table at the top of this file lists its phases: `Phase::ALL` in step
    /// order as one GPU walks it (`CudaSolver::enqueue_substep`), every rank's launches of a phase
    /// (pipelines.rs) enqueued before the next, the exchanges in their phases.
    fn step_ranks(&mut self, params: &Params) -> Result<()> {
        // Recorded behind the last substep's work: the sort phase holds the host's turn between.
        let timed = self.solvers[self.timed].stream().clone();
        self.timing.begin_step(&timed)?;
        self.substeps += 1;
        // Every substep starts with the host's turn (across processes, where rank 0 may call the
        // others to a gather before anything moves). Every particle starts on its owner; the
        // strays were counted by the last substep's g2p.
        let strays = self.strays()?;
        let due = self.substeps % u64::from(MIGRATION_INTERVAL) == 0;
        if self.substeps > 1 && (due || strays > 0) {
            self.migrate()?;
        }
        for solver in &mut self.solvers {
            let mut own = *params;
            own.num_particles = solver.capacity() as u32;
            solver.accept(&own)?;
        }
        for phase in Phase::ALL.into_iter().filter(|p| p.runs_on_gpu()) {
            let _range = NvtxRange::new(phase.name());
            let ran = match (phase, Exchange::of(phase)) {
                (_, Some(what)) => self.exchange(what).map(|()| true)?,
                (Phase::Sort, _) => self.sort_ranks()?,
                (Phase::G2p, _) => {
                    self.run_phase(phase)?;
                    if self.flow.as_ref().is_some_and(|flow| flow.sinks) {
                        self.share_drains()?;
                    }
                    self.count_strays()?;
                    self.merged_stale = true;
                    true
                }
                _ => self.run_phase(phase)?,
            };
            self.timing.end_phase(&timed, phase, ran)?;
        }
        self.timing.end_step(&timed)
    }

    /// Each rank's sort phase, where its own schedule says (a rank binning that gathers into bin
    /// order packs its live particles to the front of its places). Timed always: it holds the
    /// host's turn and any migration.
    fn sort_ranks(&mut self) -> Result<bool> {
        for (local, solver) in self.solvers.iter_mut().enumerate() {
            let sort = solver.sort_due();
            solver.run_phase(Phase::Sort, sort)?;
            if sort && solver.keeps_bin_order() {
                self.extents[local] = self.counts[self.first + local];
            }
        }
        Ok(true)
    }

    /// Every rank's particles to their slots in `merged` (made on rank 0's GPU the first time):
    /// rank 0's, and on one GPU every rank's, straight from its own set; the others' carried to rank
    /// 0 first, one rank at a time. Each process's part is waited for (no rank may write its
    /// particles while they are read). Every slot is live on one rank, so every slot is written.
    /// With a process per rank, every process comes here together (`Turn::Gather`).
    fn take_owned(&mut self) -> Result<()> {
        let extents = self.transport.gather_words(
            &self.solvers,
            self.first,
            self.extents.iter().map(|&e| vec![e as u64]).collect(),
        )?;
        let root_here = self.first == 0;
        if root_here && self.merged.is_none() {
            let first = &self.solvers[0];
            first.ensure_fits(
                self.slots * state_bytes(first.owned().deformation.is_some()),
                &format!(
                    "reading the {} particles of a run on several ranks (they are gathered on rank \
                     0's GPU)",
                    self.slots
                ),
                "run on more GPUs, with fewer particles, or without what reads them (the window, \
                 exports, checkpoints)",
            )?;
            self.merged = Some(first.allocate_like_owned(self.slots)?);
        }
        // Slots that no rank holds (drained, or never emitted yet) read as parked.
        if let (true, Some(merged), Some(_)) = (root_here, &self.merged, &self.flow) {
            self.solvers[0].park_readers(merged)?;
        }
        let direct = self.transport.reads_in_place();
        let extents: Vec<usize> = extents.iter().map(|e| e[0] as usize).collect();
        let carried = (1..extents.len())
            .filter(|_| !direct)
            .map(|rank| extents[rank])
            .max();
        if let (true, Some(most)) = (root_here, carried) {
            if self.landing.as_ref().is_none_or(|landing| landing.count < most) {
                self.landing = Some(self.solvers[0].allocate_like_owned(with_room(most))?);
            }
        }
        self.transport.wait_all(&self.solvers)?;
        for (rank, &extent) in extents.iter().enumerate() {
            let here = self.mine().contains(&rank);
            if !root_here && !here {
                continue;
            }
            let root = &self.solvers[0];
            if root_here && (rank == 0 || direct) {
                let merged = self.merged.as_ref().context("the readers' set is made above")?;
                root.take_into_readers(self.solvers[rank].owned(), extent, merged)?;
                continue;
            }
            let landing = self.landing.as_ref().filter(|_| root_here);
            let sent = here.then(|| (self.solvers[rank - self.first].owned(), 0..extent));
            let run = Run {
                from: rank,
                to: 0,
                sent,
                landed: landing.map(|set| (set, 0..extent)),
            };
            self.transport
                .carry_particles(&self.solvers, self.first, &[run])?;
            if let (Some(landing), Some(merged)) = (landing, &self.merged) {
                root.take_into_readers(landing, extent, merged)?;
            }
            // The landing set is free again once its copy into `merged` is done.
            self.transport.wait_all(&self.solvers)?;
        }
        self.transport.wait_all(&self.solvers)?;
        self.merged_stale = false;
        Ok(())
    }

    /// What a host reader takes in one process: each rank's live particles downloaded from its own
    /// GPU and written over their slots, one rank at a time, so no GPU holds every slot (a run too
    /// large for rank 0's GPU to, the billion particles of two GPUs, still exports and
    /// checkpoints). Slots no rank holds (drained, or never emitted) read as parked, at rest at the
    /// origin.
    fn read_rank_by_rank(&mut self) -> Result<Particles> {
        let mut all = Particles::default();
        all.park_more(self.slots);
        all.c = vec![glam::Mat3::ZERO; self.slots];
        if self.solvers[0].owned().deformation.is_some() {
            all.deformation = vec![Deformation::at_rest(0); self.slots];
        }
        let mut written = 0;
        for (solver, &places) in self.solvers.iter().zip(&self.extents) {
            written += solver.place_owned_into(places, &mut all)?;
        }
        ensure!(
            written as u64 == self.live,
            "the ranks hold {written} live particles, the run {}: a migration lost or duplicated some",
            self.live
        );
        Ok(all)
    }

    /// Rank 0's read of every particle: the others called to it where they run in processes of
    /// their own. Nothing where nothing stepped since the last.
    fn read_all(&mut self) -> Result<()> {
        if !self.merged_stale && self.merged.is_some() {
            return Ok(());
        }
        ensure!(
            self.first == 0,
            "rank {}: only rank 0 reads the run's particles (it writes every output)",
            self.first
        );
        let none = vec![Vec::new(); self.solvers.len()];
        self.turn(Turn::Gather, none)?;
        self.take_owned()
    }
}

/// The places a rank holding `live` particles allocates: an eighth more and a few blocks' worth,
/// room for the migrants of several migrations before it must grow (a growth copies its particles).
fn with_room(live: usize) -> usize {
    live + live / 8 + 1024
}

/// The device of each of `ranks` ranks: `one` for them all, or with `Scene::gpus` several, device r
/// for rank r, checked against the devices there are; with a process per rank, this process's.
fn rank_devices(scene: &Scene, ranks: usize, one: usize) -> Result<Vec<usize>> {
    if let Some(process) = scene.process {
        CudaRanks::check_gpus(scene)?;
        return Ok(vec![process_device(&process, super::library::devices()?.len())?]);
    }
    if scene.gpus <= 1 {
        return Ok(vec![one; ranks]);
    }
    ensure!(
        scene.gpus == ranks,
        "{} ranks on {} GPUs: one rank per GPU runs, so ask for as many ranks as GPUs",
        ranks,
        scene.gpus
    );
    CudaRanks::check_gpus(scene)?;
    Ok((0..ranks).collect())
}

/// The GPU a process drives among the `visible` it sees: its local rank's, or the one it sees
/// where the launcher gave each process its own (`CUDA_VISIBLE_DEVICES`).
fn process_device(process: &Process, visible: usize) -> Result<usize> {
    match visible {
        0 => bail!("rank {}: this process sees no CUDA device", process.rank),
        1 => Ok(0),
        _ if process.local_rank < visible => Ok(process.local_rank),
        _ => bail!(
            "rank {} is local rank {} on its host, which shows this process {visible} GPUs: start \
             at most {visible} processes a host (mpirun --npernode, srun --ntasks-per-node), or give \
             each its own GPU (srun --gpus-per-task 1)",
            process.rank,
            process.local_rank
        ),
    }
}

/// This process's rank joins the others: the rendezvous hands it rank 0's NCCL id, the heartbeats
/// start, and NCCL joins them in one communicator (on `solver`'s device).
fn join_processes(process: &Process, solver: &CudaSolver) -> Result<(Comm, Watch)> {
    let launch::Joining { folder, run, watch } = launch::Joining::start(process)?;
    let file = launch::rendezvous_file(&folder, &run);
    let nccl = Nccl::get()?;
    let id = if process.rank == 0 {
        let id = nccl.unique_id()?;
        let bytes: Vec<u8> = id.internal.iter().map(|&b| b as u8).collect();
        launch::publish_id(&file, &bytes)?;
        id
    } else {
        let bytes = launch::read_id(&file, 128, launch::launch_time(), launch::RENDEZVOUS_WAIT)?;
        let mut id = UniqueId { internal: [0; 128] };
        for (to, from) in id.internal.iter_mut().zip(bytes) {
            *to = from as std::ffi::c_char;
        }
        id
    };
    solver.bind_to_thread()?;
    let comm = Comm::init(nccl, id, process.rank, process.size).with_context(|| {
        format!(
            "rank {} of {} joining the others ({}, rendezvous {})",
            process.rank,
            process.size,
            process.launcher,
            file.display()
        )
    })?;
    if process.rank == 0 {
        // Every rank has joined: the id is spent.
        let _ = std::fs::remove_file(&file);
    }
    Ok((comm, watch))
}

/// The grids that ranks of this process held before the slabs moved, with the parameters their
/// kernels ran on them (`CudaSolver::rebox`), by rank.
type Replaced = HashMap<usize, (DeviceGrid, Params)>;

/// Where two neighbouring ranks meet, seen from one of them: this rank's ghost planes there (the
/// neighbour's edge) and its edge planes there (the neighbour's ghosts).
struct Link {
    rank: usize,
    side: Side,
    neighbour: usize,
    ghosts: Planes,
    edge: Planes,
}

impl Link {
    /// The planes this rank packs for the link in `what` and those it unpacks into: its ghost
    /// planes' sums go out and come in on its edge planes; its edge planes' velocities go out and
    /// come in over its ghosts.
    fn planes(&self, what: Exchange) -> (&Planes, &Planes) {
        match what {
            Exchange::Sums => (&self.ghosts, &self.edge),
            Exchange::Velocities => (&self.edge, &self.ghosts),
        }
    }

    /// The 32-bit words this rank sends and receives on the link for `what`.
    fn words(&self, what: Exchange, params: &Params) -> (usize, usize) {
        let res = params.box_res;
        let (send, recv) = self.planes(what);
        let words = what.words_per_node(params);
        (words * send.nodes(res), words * recv.nodes(res))
    }
}

/// A rank's statistics as the words of a turn, and back.
fn summary_words(s: &Summary) -> Vec<u64> {
    let bits = |x: f32| u64::from(x.to_bits());
    let mut words = vec![
        s.particles as u64,
        bits(s.max_speed),
        bits(s.density_ratio_min),
        bits(s.density_ratio_mean),
        bits(s.density_ratio_max),
        s.kinetic_energy.to_bits(),
    ];
    words.extend(s.centre_of_mass.iter().map(|c| c.to_bits()));
    words
}

fn summary_of(words: &[u64]) -> Summary {
    let float = |w: u64| f32::from_bits(w as u32);
    Summary {
        particles: words[0] as usize,
        max_speed: float(words[1]),
        density_ratio_min: float(words[2]),
        density_ratio_mean: float(words[3]),
        density_ratio_max: float(words[4]),
        kinetic_energy: f64::from_bits(words[5]),
        centre_of_mass: [6, 7, 8].map(|i| f64::from_bits(words[i])),
    }
}

impl Drop for CudaRanks {
    /// `MPM_RANKS_HOST_TIMES=1`: where the host's time went. (A process's communicator is aborted
    /// by its transport.)
    fn drop(&mut self) {
        if let Some(times) = &self.host_times {
            eprintln!("{}", times.report(self.first));
        }
    }
}

impl Solver for CudaRanks {
    /// The CUDA backend's name: what the ranks hand over is what one solver would.
    fn name(&self) -> &'static str {
        "cuda"
    }

    /// Every rank's context is current on the thread in turn; each rank's work binds its own again.
    fn bind_to_thread(&self) -> Result<()> {
        self.solvers.iter().try_for_each(|solver| solver.bind_to_thread())
    }

    /// One substep, as the table at the top of this file lists its phases.
    fn step(&mut self, params: &Params) -> Result<()> {
        let entered = Instant::now();
        if let Some(times) = &mut self.host_times {
            if let Some(left) = times.last_return {
                times.between_steps += entered - left;
            }
        }
        let stepped = self.step_ranks(params);
        if let Some(times) = &mut self.host_times {
            times.substeps += 1;
            times.in_step += entered.elapsed();
            times.last_return = Some(Instant::now());
        }
        stepped
    }

    fn holdings(&self) -> Option<Holdings> {
        let ranks = self
            .solvers
            .iter()
            .enumerate()
            .map(|(local, solver)| {
                let rank = self.first + local;
                RankHolding {
                    rank,
                    slab: self.slabs.owned(rank),
                    particles: self.counts[rank],
                    places: solver.capacity(),
                    grid_nodes: solver.held().nodes(),
                    bytes: solver.device_bytes(),
                }
            })
            .collect();
        Some(Holdings {
            axis: self.slabs.axis,
            migrations: self.migrations,
            migrated: self.migrated.sent,
            ranks,
        })
    }

    fn ends_frame_next(&mut self) {
        for solver in &mut self.solvers {
            solver.ends_frame_next();
        }
    }

    fn resume_after(&mut self, last: &Params) {
        for solver in &mut self.solvers {
            solver.resume_after(last);
        }
    }

    fn take_extremes(&mut self) -> Result<StepExtremes> {
        let ticket = self.request_extremes()?;
        self.wait_extremes(ticket)
    }

    /// Every rank's request, in stream order; nothing waits. With a process per rank, the ranks'
    /// counters are reduced over NCCL first, in stream order, so each rank's copy holds the run's.
    fn request_extremes(&mut self) -> Result<ExtremesTicket> {
        if !self.in_one_process() {
            self.transport.reduce_counters(&self.solvers)?;
        }
        let tickets = self
            .solvers
            .iter_mut()
            .map(|solver| solver.request_extremes())
            .collect::<Result<Vec<_>>>()?;
        self.extremes_requested += 1;
        let handle = self.extremes_requested;
        self.extremes.push_back((handle, tickets));
        Ok(ExtremesTicket::Pending(handle))
    }

    /// Every rank's extremes of that request, merged; each rank's wait is for its own copy only.
    fn wait_extremes(&mut self, ticket: ExtremesTicket) -> Result<StepExtremes> {
        let handle = match ticket {
            ExtremesTicket::Ready(extremes) => return Ok(extremes),
            ExtremesTicket::Pending(handle) => handle,
        };
        let at = self
            .extremes
            .iter()
            .position(|&(pending, _)| pending == handle)
            .context("the ranks' extremes awaited twice, or never requested")?;
        let (_, tickets) = self.extremes.remove(at).context("no pending extremes")?;
        if !self.in_one_process() {
            // Reduced on the device (`Transport::reduce_counters`): this rank's copy is the run's.
            let ticket = tickets.into_iter().next().context("a rank's extremes ticket")?;
            let solver = &self.solvers[0];
            let started = Instant::now();
            self.transport
                .watch_until(&mut || solver.extremes_ready(&ticket))?;
            if let Some(times) = &mut self.host_times {
                times.in_extremes += started.elapsed();
            }
            return self.solvers[0].wait_extremes(ticket);
        }
        let mut all = StepExtremes::default();
        for (solver, ticket) in self.solvers.iter_mut().zip(tickets) {
            all.merge(&solver.wait_extremes(ticket)?);
        }
        Ok(all)
    }

    fn take_step_timings(&mut self) -> Result<Option<Vec<PhaseTimings>>> {
        Ok(Some(self.timing.take_completed()?))
    }

    fn emit(&mut self, params: &Params, mask: u32) -> Result<()> {
        self.emit_on_ranks(params, mask)
    }

    /// Every rank keeps the run's lifecycle alike: this process's first rank's is the run's.
    fn flow_counts(&mut self) -> Result<Option<FlowCounts>> {
        self.transport.wait_watched(&self.solvers)?;
        self.solvers[0].flow_counts()
    }

    fn flow_state(&mut self) -> Result<Option<FlowState>> {
        self.transport.wait_watched(&self.solvers)?;
        self.solvers[0].flow_state()
    }

    fn set_colliders(&mut self, frame: &ColliderFrame) -> Result<()> {
        self.solvers.iter_mut().try_for_each(|s| s.set_colliders(frame))
    }

    fn apply_push(&mut self, push: &Push) -> Result<()> {
        self.solvers.iter_mut().try_for_each(|s| s.apply_push(push))?;
        self.merged_stale = true;
        Ok(())
    }

    /// Gathers every rank's particles into the one set `particles` shows.
    fn publish_particles(&mut self) -> Result<()> {
        self.read_all()
    }

    /// The set of every slot as of the last `publish_particles`; nothing before the first.
    fn particles(&self) -> ParticleView<'_> {
        let rank0 = &self.solvers[0];
        match &self.merged {
            Some(merged) => ParticleView::Device(Box::new(rank0.view_of(merged))),
            None => ParticleView::Host(&self.unpublished),
        }
    }

    /// In one process, rank by rank on the host (`read_rank_by_rank`); with a process per rank,
    /// gathered into the readers' set on rank 0's GPU first.
    fn read_particles(&mut self) -> Result<Particles> {
        if self.in_one_process() {
            return self.read_rank_by_rank();
        }
        self.read_all()?;
        let merged = self
            .merged
            .as_ref()
            .context("the ranks' particles were never gathered")?;
        self.solvers[0].download_set(merged)
    }

    /// Each rank's statistics kernel over its own particles, on its GPU, in stream order: the
    /// particles never leave their ranks.
    fn summary(&mut self, table: &Params) -> Result<Summary> {
        let ticket = self.request_summary(table)?;
        self.wait_summary(ticket)
    }

    fn request_summary(&mut self, table: &Params) -> Result<SummaryTicket> {
        for solver in &mut self.solvers {
            solver.request_summary(table)?;
        }
        Ok(SummaryTicket::Pending)
    }

    /// The ranks' statistics joined (`Summary::of_parts`): counts, extremes and energy as one
    /// solver's; means and the centre of mass to rounding.
    fn wait_summary(&mut self, ticket: SummaryTicket) -> Result<Summary> {
        match ticket {
            SummaryTicket::Ready(summary) => Ok(summary),
            SummaryTicket::Pending => {
                self.transport.wait_watched(&self.solvers)?;
                let mut mine = Vec::new();
                for solver in &mut self.solvers {
                    mine.push(summary_words(&solver.wait_summary(SummaryTicket::Pending)?));
                }
                let parts: Vec<Summary> = self
                    .turn(Turn::Summary, mine)?
                    .iter()
                    .map(|words| summary_of(words))
                    .collect();
                Ok(Summary::of_parts(&parts))
            }
        }
    }

    /// With a process per rank: rank 0 tells the others the run has ended; they send it their
    /// particles for as long as it reads them, until then.
    fn finish(&mut self) -> Result<()> {
        let none = vec![Vec::new(); self.solvers.len()];
        self.turn(Turn::Done, none).map(drop)
    }
}
