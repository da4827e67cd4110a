//! `CudaRanks`: one run split into ranks, each a [`CudaSolver`] over its slab of the grid
//! (`crate::dist`), stepped phase by phase with the ghost exchanges between the phases. What it hands
//! over (particles slot by slot, extremes, checkpoints) is what one solver would; its statistics
//! too, their sums to rounding.
//!
//! | phase | every rank, fused pipeline |
//! |---|---|
//! | sort        | where the last g2p counted a particle that the next substep could carry past its rank's ghost planes, or every MIGRATION_INTERVAL substeps: rebalance the slabs and migrate; then bin where the rank's schedule says |
//! | p2g_init    | the first substep's scatter |
//! | halo_sum    | its ghost planes' sums packed, carried to their owner, added to its edge planes |
//! | grid_update | the walls' mirror of mass and momentum, the grid update |
//! | halo_fill   | its edge planes' velocities packed, carried to the neighbours' ghost planes |
//! | g2p         | one_pass (gather, advect, scatter the next substep), then count the strays |
//!
//! The fused pipeline scatters the next substep inside one_pass, so the ghost sums travel at the
//! start of the substep that uses them, before the walls' mirror.
//!
//! **Where the ranks run** (`Scene::gpus`). On one GPU every rank runs on device
//! `CudaOptions::device` and the carrier is a device copy between the ranks' halo buffers. On
//! several, rank r runs on device r and the halos travel by NCCL's send and receive, every rank's
//! posted in one group by the one thread that drives them all; the ranks' GPUs reach each other's
//! memory (peer access), which the particle moves below use.
//!
//! **Each rank holds its own particles**, with room for more (`with_room`), each carrying its slot in
//! the run, and keeps them in bin order as one GPU does: every binning gathers its live particles to
//! the front of its buffers. A migration (`move_owned`, kernels/ranks.cu, run on the sending rank's
//! GPU, launched from ranks.rs) appends each sender's leavers after the receiver's places in use
//! (`extents`), in places the host reserves for that sender from the layer counts (no atomics across
//! GPUs), and parks them on the sender; a receiver without the room grows first.
//!
//! **Readers** see one set of every slot on rank 0's GPU, made at the first read, into which
//! `take_owned` copies every rank's particles to their slots where something reads them: the
//! renderer (`Solver::publish_particles`, once a frame), exports and checkpoints. The statistics
//! are each rank's reduction over its own particles, joined (`Summary::of_parts`), so a run that
//! nothing reads never gathers its particles. The phases are timed by CUDA events on rank 0's
//! stream (timing.rs; `MPM_TIMED_RANK` picks another), each from the end of the one before, so an
//! exchange includes any wait for a slower neighbour, and the sort phase the host's turn between
//! substeps. The host waits for the ranks only where it must: for the stray counts before each
//! substep, around a migration and `take_owned`. The extremes come as one GPU's do,
//! requested in stream order and awaited a stretch later (`Solver::request_extremes`); on one GPU a
//! carry's copy waits for the sender's stream and the sender's next work for the copy, by stream
//! order, not by the host.

use super::gpu::CudaOptions;
use super::halo::{sum_words, HaloBuffers, HaloKernels, Planes, VELOCITY_WORDS, VOLUME_WORDS};
use super::launch::Launcher;
use super::particles::{DeviceParticles, STATE_BYTES_PER_PARTICLE};
use super::render::DeviceParticlesView;
use super::solver::CudaSolver;
use super::state::DeviceState;
use super::timing::PhaseEvents;
use crate::dist::migrate::{Migration, RankParticles};
use crate::dist::nccl::{Comm, DataType, Nccl};
use crate::dist::{check_ranks, starting_slabs, Slabs, MIGRATION_INTERVAL};
use crate::sim::colliders::ColliderFrame;
use crate::sim::phase::{Phase, PhaseTimings};
use crate::sim::ExtremesTicket;
use crate::sim::{
    Params, ParticleView, Particles, Pipeline, Push, ScatterMode, Scene, Solver, StepExtremes, Summary,
    SummaryTicket,
};
use anyhow::{bail, ensure, Context, Result};
use cudarc::driver::{sys, CudaSlice, DevicePtr};
use std::collections::VecDeque;
use std::ops::Range;

pub struct CudaRanks {
    /// Before the solvers: NCCL's communicators go while their devices are still open.
    carrier: Carrier,
    solvers: Vec<CudaSolver>,
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
    /// What `particles` shows before anything was published: nothing.
    unpublished: Particles,
    /// Per rank: the strays its last g2p counted.
    strays: Vec<CudaSlice<u32>>,
    /// The extremes requested and not yet waited for: each request's handle and every rank's ticket.
    extremes: VecDeque<(usize, Vec<ExtremesTicket>)>,
    extremes_requested: usize,
    /// Live particles per rank, as of the last substep.
    counts: Vec<usize>,
    /// Per rank, the places its live particles lie within: packed at its last binning, then grown
    /// by what it received since (a sender's leavers leave parked holes). Migrants go after them.
    extents: Vec<usize>,
    /// Times a rank received more particles than its buffers had room for and grew them.
    growths: u64,
    /// Live particles in the run, all ranks together: what every migration must leave.
    live: u64,
    /// The phases' events, on the timed rank's stream (`CudaOptions::timed_rank`).
    timing: PhaseEvents,
    timed: usize,
    substeps: u64,
    migrations: u64,
    migrated: Migration,
}

/// Below and above: a rank's two sides, its halo buffers' indices.
const SIDES: [Side; 2] = [Side::Below, Side::Above];

#[derive(Clone, Copy, PartialEq, Eq)]
enum Side {
    Below = 0,
    Above = 1,
}

/// What an exchange carries (`CudaRanks::exchange`).
#[derive(Clone, Copy)]
enum Exchange {
    /// The scatter's sums on the ghost planes, to their owner (halo_sum).
    Sums,
    /// The grid update's velocities on the edge planes, to the neighbours' ghosts (halo_fill).
    Velocities,
}

impl Exchange {
    /// 32-bit words a node takes packed under `params` (kernels/halo.cu): its sums in the scatter's
    /// width and its block mark, or one float4 of velocity and mass; and the grid's volume where the
    /// rest densities differ.
    fn words_per_node(self, params: &Params) -> usize {
        let words = match self {
            Exchange::Sums => sum_words(params.scatter_mode == ScatterMode::FixedPoint.code()),
            Exchange::Velocities => VELOCITY_WORDS,
        };
        let volume = match params.volume_density {
            0 => 0,
            _ => VOLUME_WORDS,
        };
        words + volume
    }
}

/// What carries the packed halos from rank to rank.
enum Carrier {
    /// Every rank on one GPU: a device copy into the neighbour's receive buffer.
    DeviceCopy,
    /// One rank per GPU: NCCL's send and receive between neighbours, rank r's communicator at r.
    Nccl(Vec<Comm>),
}

impl CudaRanks {
    /// `ranks` ranks of `particles` (every slot of `scene`'s run), the slabs balanced for them.
    pub fn new(scene: &Scene, particles: Particles, ranks: usize, options: CudaOptions) -> Result<CudaRanks> {
        ensure!(
            scene.method != crate::sim::Method::Pbmpm,
            "solver.method = \"pbmpm\" runs on one rank: drop --ranks and --gpus"
        );
        if let Some(note) = crate::dist::small_for_gpus(scene.gpus, particles.num_live()) {
            eprintln!("note: {note}");
        }
        let slabs = starting_slabs(scene, &particles, ranks)?;
        CudaRanks::with_slabs(scene, particles, slabs, options)
    }

    /// Ranks of `particles` (every slot) on the given slabs, whatever their balance: the next rebin
    /// moves them.
    pub fn with_slabs(
        scene: &Scene,
        particles: Particles,
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
        let devices = rank_devices(scene, slabs.ranks(), options.device)?;
        let mut solvers = Vec::new();
        let mut halos = Vec::new();
        let mut counts = Vec::new();
        let mut strays = Vec::new();
        for (rank, &device) in devices.iter().enumerate() {
            let RankParticles {
                particles: mut mine,
                id,
                ..
            } = RankParticles::share(&particles, &slabs, rank, params.inv_dx);
            counts.push(id.len());
            mine.park_more(with_room(id.len()) - id.len());
            // The binnings' gathers into bin order are what pack a rank's particles again after
            // its leavers parked (MPM_BIN_ORDER=0 is for timing one GPU).
            let packed = CudaOptions {
                device,
                bin_order: true,
                ..options
            };
            let mut solver = CudaSolver::from_particles(scene, &mine, packed)
                .with_context(|| format!("rank {rank} of {}", slabs.ranks()))?;
            ensure!(
                solver.keeps_bin_order(),
                "rank {rank} of {}: no room on its GPU for the second copy of its {} particle places that \
                 a rank packs them into at each binning; run on more GPUs (--gpus) or with fewer particles",
                slabs.ranks(),
                mine.len()
            );
            solver.state.particles.upload_slots(solver.gpu.stream(), &id)?;
            halos.push(HaloBuffers::allocate(&solver.gpu, scene.grid_res, slabs.axis)?);
            strays.push(
                solver
                    .stream()
                    .alloc_zeros::<u32>(1)
                    .context("allocating a stray counter")?,
            );
            solvers.push(solver);
        }
        let carrier = if scene.gpus > 1 {
            enable_peer_access(&solvers)?;
            let comms = Comm::init_all(Nccl::get()?, &devices)
                .with_context(|| format!("joining the {} GPUs in one NCCL communicator", devices.len()))?;
            Carrier::Nccl(comms)
        } else {
            Carrier::DeviceCopy
        };
        let timed = options.timed_rank;
        // Every substep's phases: the ranks' run no graphs, and their exchanges are what is watched.
        let timing = PhaseEvents::new(solvers[timed].gpu.ctx.clone(), 1);
        Ok(CudaRanks {
            carrier,
            solvers,
            halos,
            walls: (params.wall_mirror_lo, params.wall_mirror_hi[slabs.axis]),
            slabs,
            live: particles.num_live() as u64,
            extents: counts.clone(),
            growths: 0,
            counts,
            merged: None,
            slots: particles.len(),
            merged_stale: true,
            unpublished: Particles::default(),
            strays,
            extremes: VecDeque::new(),
            extremes_requested: 0,
            timing,
            timed,
            substeps: 0,
            migrations: 0,
            migrated: Migration::default(),
        })
    }

    /// What `--gpus` (`Scene::gpus` above 1) needs, checked before any particle is made: as many
    /// CUDA devices, a peer path between every two of them, and NCCL. Each missing piece is named
    /// with its fix.
    pub fn check_gpus(scene: &Scene) -> Result<()> {
        let gpus = scene.gpus;
        if gpus <= 1 {
            return Ok(());
        }
        let devices = super::library::devices()?;
        let count = devices.len();
        ensure!(
            gpus <= count,
            "--gpus {gpus}: this machine has {count} CUDA device{} (`mpm devices` lists them); ask \
             for at most {count}",
            if count == 1 { "" } else { "s" }
        );
        for (i, device) in devices.iter().take(gpus).enumerate() {
            if let Some(j) = (0..gpus).find(|&j| j != i && !device.peer_access[j]) {
                bail!(
                    "--gpus {gpus}: GPU {i} cannot reach GPU {j}'s memory (no peer access; `mpm \
                     devices` shows it), which ranks on the GPUs of one host move particles \
                     through; run on GPUs joined by NVLink or a PCIe switch with peer access, or \
                     on one GPU"
                );
            }
        }
        Nccl::get().map(drop)
    }

    /// The device's name, and how many ranks share it or how many GPUs the ranks run on.
    pub fn device_name(&self) -> String {
        let (name, ranks) = (self.solvers[0].device_name(), self.solvers.len());
        match self.carrier {
            Carrier::DeviceCopy => format!("{name}, {ranks} ranks"),
            Carrier::Nccl(_) => format!("{ranks} x {name}, a rank each (NCCL)"),
        }
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

    /// Per rank, the particles its buffers have room for, live and parked.
    pub fn capacities(&self) -> Vec<usize> {
        self.solvers.iter().map(CudaSolver::capacity).collect()
    }

    /// Times a rank received more particles than it had room for and grew its buffers.
    pub fn growths(&self) -> u64 {
        self.growths
    }

    /// The host waits for every rank's stream.
    fn wait_all(&self) -> Result<()> {
        wait_for(&self.solvers)
    }

    /// Every rank's launches of `phase` (no sort phase: its decision is each rank's), then its end.
    fn run_phase(&mut self, phase: Phase) -> Result<()> {
        for solver in &mut self.solvers {
            solver.run_phase(phase, false)?;
        }
        self.end_phase(phase)
    }

    /// Marks the end of `phase` on the timed rank's stream.
    fn end_phase(&mut self, phase: Phase) -> Result<()> {
        let stream = self.solvers[self.timed].stream().clone();
        self.timing.end_phase(&stream, phase, true)
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

    /// Every rank's links to its neighbours: what each exchange packs, carries and unpacks.
    fn links(&self) -> Vec<Link> {
        (0..self.solvers.len())
            .flat_map(|rank| SIDES.into_iter().filter_map(move |side| self.link(rank, side)))
            .collect()
    }

    /// What a halo kernel on `rank` launches with: the kernels, the rank's launcher, parameters and
    /// buffers.
    fn halo_launch(&self, rank: usize) -> (&HaloKernels, &Launcher, &Params, &DeviceState) {
        let solver = &self.solvers[rank];
        (
            &solver.kernels.halo,
            &solver.gpu.launcher,
            &solver.params,
            &solver.state,
        )
    }

    /// One exchange between every pair of neighbours: each rank packs its side of it into its send
    /// buffers, the carrier copies them across, each rank unpacks what arrived. The scatter's sums
    /// go from the ghost planes to the owner's edge, where they are added; the updated velocities
    /// from the edge back over the ghosts.
    fn exchange(&mut self, what: Exchange) -> Result<()> {
        let links = self.links();
        for link in &links {
            let (k, l, params, state) = self.halo_launch(link.rank);
            let out = &self.halos[link.rank].send[link.side as usize];
            match what {
                Exchange::Sums => k.pack_sums(l, params, &link.ghosts, state, out)?,
                Exchange::Velocities => k.pack_velocities(l, params, &link.edge, state, out)?,
            }
        }
        self.carry(&links, what)?;
        for link in &links {
            let (k, l, params, state) = self.halo_launch(link.rank);
            let got = &self.halos[link.rank].recv[link.side as usize];
            match what {
                Exchange::Sums => k.add_sums(l, params, &link.edge, got, state)?,
                Exchange::Velocities => k.fill_velocities(l, params, &link.ghosts, got, state)?,
            }
        }
        Ok(())
    }

    /// Carries every rank's packed send buffers to its neighbours' receive buffers: on one GPU a
    /// copy on the receiver's stream once every rank has packed; across GPUs NCCL's sends and
    /// receives on each rank's stream, after its packing and before its unpacking.
    fn carry(&mut self, links: &[Link], what: Exchange) -> Result<()> {
        let params = self.solvers[0].params;
        match &self.carrier {
            Carrier::DeviceCopy => {
                for link in links {
                    let (words, _) = link.words(what, &params);
                    let (from, to) = pair(&mut self.halos, link.rank, link.neighbour);
                    let src = from.send[link.side as usize].slice(..words);
                    let mut dst = to.recv[opposite(link.side) as usize].slice_mut(..words);
                    let (sender, receiver) = (
                        self.solvers[link.rank].stream(),
                        self.solvers[link.neighbour].stream(),
                    );
                    // The copy after the sender's packing; the sender's next packing after the copy.
                    receiver
                        .join(sender)
                        .context("ordering a halo's copy after its packing")?;
                    receiver
                        .memcpy_dtod(&src, &mut dst)
                        .context("carrying a halo between ranks")?;
                    sender
                        .join(receiver)
                        .context("ordering a halo's packing after its copy")?;
                }
                Ok(())
            }
            Carrier::Nccl(comms) => comms[0].nccl().group(|| {
                for (comm, (solver, halo)) in comms.iter().zip(self.solvers.iter().zip(&self.halos)) {
                    let stream = solver.stream();
                    let mut sends = Vec::new();
                    let mut recvs = Vec::new();
                    // The pointers stay valid: the buffers live as long as the ranks.
                    for link in links.iter().filter(|link| link.rank == comm.rank) {
                        let (send_words, recv_words) = link.words(what, &params);
                        let side = link.side as usize;
                        let (send, _) = halo.send[side].device_ptr(stream);
                        let (recv, _) = halo.recv[side].device_ptr(stream);
                        sends.push((link.neighbour, send, send_words));
                        recvs.push((link.neighbour, recv, recv_words));
                    }
                    // SAFETY: each buffer holds a block of planes of packed sums, more than either
                    // count; the neighbour posts the matching receive and send in this group, from
                    // its own side of the same link.
                    unsafe {
                        comm.send_recv(&sends, &recvs, DataType::U32, stream.cu_stream().cast())?;
                    }
                }
                Ok(())
            }),
        }
    }

    /// Particles the last g2p left where one more substep could carry them past their rank's ghost
    /// planes (`Slabs::keeps`), all ranks together.
    fn strays(&self) -> Result<u64> {
        let mut total = 0;
        for (solver, strays) in self.solvers.iter().zip(&self.strays) {
            total += u64::from(solver.gpu.download(strays)?[0]);
        }
        Ok(total)
    }

    /// Counts each rank's strays after its g2p.
    fn count_strays(&mut self) -> Result<()> {
        for (rank, (solver, strays)) in self.solvers.iter().zip(&mut self.strays).enumerate() {
            let kept = self.slabs.kept_bases(rank);
            let keep = (*kept.start(), *kept.end());
            solver
                .stream()
                .memset_zeros(strays)
                .context("zeroing the stray counter")?;
            let (k, l) = (&solver.kernels.ranks, &solver.gpu.launcher);
            k.count_strays(
                l,
                &solver.params,
                self.extents[rank],
                self.slabs.axis,
                keep,
                &solver.state.particles.x,
                strays,
            )?;
        }
        Ok(())
    }

    /// Live particles per block layer along the slab axis, per rank.
    fn layer_counts(&self) -> Result<Vec<Vec<u64>>> {
        let layers = self.slabs.blocks();
        let mut all = Vec::with_capacity(self.solvers.len());
        for (solver, &places) in self.solvers.iter().zip(&self.extents) {
            let (k, l) = (&solver.kernels.ranks, &solver.gpu.launcher);
            let mut counts = solver
                .stream()
                .alloc_zeros::<u32>(layers as usize)
                .context("allocating layer counts")?;
            k.count_layers(
                l,
                &solver.params,
                places,
                self.slabs.axis,
                layers,
                &solver.state.particles.x,
                &mut counts,
            )?;
            all.push(solver.gpu.download(&counts)?.into_iter().map(u64::from).collect());
        }
        Ok(all)
    }

    /// Moves the slabs if the counts are out of balance, then every live particle to the rank that
    /// owns its block layer, on the device, checking that each sender moved what its layer counts
    /// said it held of the others' layers. `last_dt`: the step of the substep whose scatter the
    /// grids hold, scattered again where the slabs moved.
    fn migrate(&mut self, last_dt: f32) -> Result<()> {
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
        let moved_slabs = match self.slabs.rebalanced(&per_layer, self.walls)? {
            Some(balanced) => {
                self.slabs = balanced;
                true
            }
            None => false,
        };
        // What each rank holds in the layers each rank owns now (the layer counts waited for every
        // rank: their streams are idle).
        let ranks = self.solvers.len();
        let layers_of =
            |owner: usize| self.slabs.bounds[owner] as usize..self.slabs.bounds[owner + 1] as usize;
        let held = |rank: usize, owner: usize| before[rank][layers_of(owner)].iter().sum::<u64>() as usize;
        // Each receiver's places for each sender's leavers, `arrivals[to][from]`: after its places
        // in use, senders in rank order.
        let arrivals: Vec<Vec<Range<usize>>> = (0..ranks)
            .map(|to| {
                let mut next = self.extents[to];
                (0..ranks)
                    .map(|from| {
                        let start = next;
                        next += if from == to { 0 } else { held(from, to) };
                        start..next
                    })
                    .collect()
            })
            .collect();
        let in_use = self.extents.clone();
        let mut grew = false;
        let ranks_places = self.solvers.iter_mut().zip(&mut self.extents);
        for (to, ((solver, extent), arriving)) in ranks_places.zip(&arrivals).enumerate() {
            let end = arriving.last().map_or(*extent, |last| last.end);
            if end > solver.capacity() {
                solver
                    .grow_particles(with_room(end))
                    .with_context(|| format!("rank {to} receiving {} particles", end - *extent))?;
                self.growths += 1;
                grew = true;
            }
            if end > *extent {
                // Its bins miss the particles it was given (a sender's still list the places it
                // parked, which its passes skip).
                solver.rebin_next();
            }
            *extent = end;
        }
        let moved = arrivals
            .iter()
            .flatten()
            .map(|range| range.len() as u64)
            .sum::<u64>();
        if moved > 0 {
            if grew {
                // The senders write into the grown buffers once their copies are done.
                self.wait_all()?;
            }
            self.move_owned(&in_use, &arrivals)?;
        }
        for (rank, solver) in self.solvers.iter_mut().enumerate() {
            self.counts[rank] = per_layer[layers_of(rank)].iter().sum::<u64>() as usize;
            // A rank's scatter lies in its old slab and ghost planes, which the new halo may miss.
            if moved_slabs {
                solver.discard_scatter(last_dt)?;
            }
        }
        self.migrated.sent += moved;
        self.migrated.received += moved;
        self.migrations += 1;
        Ok(())
    }

    /// Every rank's live particles (in its places `in_use`) in the others' layers appended to their
    /// owners, in `arrivals[to][from]` (reserved from the layer counts), each sender's GPU writing
    /// them into the receivers' memory, then waited for (the receivers' next work reads them); each
    /// sender's count to each receiver checked against its reservation.
    fn move_owned(&self, in_use: &[usize], arrivals: &[Vec<Range<usize>>]) -> Result<()> {
        let mut counters = Vec::new();
        for (to, arriving) in arrivals.iter().enumerate() {
            for (from, reserved) in arriving.iter().enumerate().filter(|(_, r)| !r.is_empty()) {
                let sender = &self.solvers[from];
                let (k, l) = (&sender.kernels.ranks, &sender.gpu.launcher);
                let mut moved = sender
                    .stream()
                    .alloc_zeros::<u32>(1)
                    .context("allocating the migration counter")?;
                let layers = self.slabs.bounds[to]..self.slabs.bounds[to + 1];
                let slab = (self.slabs.axis, self.slabs.blocks(), layers);
                let walked = (&sender.state.particles, in_use[from]);
                let receiver = (&self.solvers[to].state.particles, reserved.clone());
                k.move_owned(l, &sender.params, slab, walked, receiver, &mut moved)?;
                counters.push((from, to, reserved.len(), moved));
            }
        }
        self.wait_all()?;
        for (from, to, expected, moved) in counters {
            let moved = self.solvers[from].gpu.download(&moved)?[0] as usize;
            ensure!(
                moved == expected,
                "rank {from} moved {moved} particles to rank {to} where its layer counts hold \
                 {expected}: a migration lost or duplicated particles"
            );
        }
        Ok(())
    }

    /// Every rank's particles to their slots in `merged` (made on rank 0's GPU the first time)
    /// where a substep ran since the last time, each rank's from its own GPU once every rank is
    /// done, waited for (no rank may write its particles while they are read). Every slot is live on
    /// one rank, so every slot is written.
    fn take_owned(&mut self) -> Result<()> {
        let merged = match self.merged.take() {
            Some(merged) => merged,
            None => {
                let first = &self.solvers[0].gpu;
                first.ensure_fits(
                    self.slots * STATE_BYTES_PER_PARTICLE,
                    &format!(
                        "reading the {} particles of a run on several ranks (they are gathered on rank \
                         0's GPU)",
                        self.slots
                    ),
                    "run on more GPUs, with fewer particles, or without what reads them (the window, \
                     exports, checkpoints)",
                )?;
                self.merged_stale = true;
                DeviceParticles::allocate(first.stream(), self.slots, false)?
            }
        };
        let merged = self.merged.insert(merged);
        if self.merged_stale {
            wait_for(&self.solvers)?;
            for solver in &self.solvers {
                let (k, l) = (&solver.kernels.ranks, &solver.gpu.launcher);
                k.take_owned(l, &solver.state.particles, merged)?;
            }
            wait_for(&self.solvers)?;
            self.merged_stale = false;
        }
        Ok(())
    }
}

/// The host waits for every rank's stream.
fn wait_for(solvers: &[CudaSolver]) -> Result<()> {
    for solver in solvers {
        solver
            .stream()
            .synchronize()
            .context("waiting for a rank (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
    }
    Ok(())
}

/// The places a rank holding `live` particles allocates: an eighth more and a few blocks' worth,
/// room for the migrants of several migrations before it must grow (a growth copies its particles).
fn with_room(live: usize) -> usize {
    live + live / 8 + 1024
}

/// The device of each of `ranks` ranks: `one` for them all, or with `Scene::gpus` several, device r
/// for rank r, checked against the devices there are.
fn rank_devices(scene: &Scene, ranks: usize, one: usize) -> Result<Vec<usize>> {
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

/// Lets every rank's GPU read and write every other's memory, which migration and `take_owned`
/// do (`CudaRanks::check_gpus` made sure the hardware has a path for it).
fn enable_peer_access(solvers: &[CudaSolver]) -> Result<()> {
    for (i, a) in solvers.iter().enumerate() {
        for (j, b) in solvers.iter().enumerate().filter(|&(j, _)| j != i) {
            a.gpu.ctx.bind_to_thread().context("binding a rank's context")?;
            // SAFETY: the context bound above gains access to `b`'s; flags must be 0.
            match unsafe { sys::cuCtxEnablePeerAccess(b.gpu.ctx.cu_ctx(), 0) } {
                sys::CUresult::CUDA_SUCCESS | sys::CUresult::CUDA_ERROR_PEER_ACCESS_ALREADY_ENABLED => {}
                error => bail!("enabling GPU {i}'s access to GPU {j}'s memory: {error:?}"),
            }
            // The buffers come from `b`'s stream-ordered pool (cuMemAllocAsync), which the
            // context's peer access does not cover: the pool grants `a` access itself.
            let mut pool = std::ptr::null_mut();
            let access = sys::CUmemAccessDesc {
                location: sys::CUmemLocation {
                    type_: sys::CUmemLocationType::CU_MEM_LOCATION_TYPE_DEVICE,
                    id: a.gpu.ctx.ordinal() as std::ffi::c_int,
                },
                flags: sys::CUmemAccess_flags::CU_MEM_ACCESS_FLAGS_PROT_READWRITE,
            };
            // SAFETY: `pool` receives `b`'s current pool, which then takes one access descriptor.
            let granted = unsafe {
                match sys::cuDeviceGetMemPool(&mut pool, b.gpu.ctx.cu_device()) {
                    sys::CUresult::CUDA_SUCCESS => sys::cuMemPoolSetAccess(pool, &access, 1),
                    error => error,
                }
            };
            ensure!(
                granted == sys::CUresult::CUDA_SUCCESS,
                "granting GPU {i} access to GPU {j}'s memory pool: {granted:?}"
            );
        }
    }
    Ok(())
}

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
    /// The 32-bit words this rank sends and receives on the link for `what`: its ghost planes' sums go
    /// out and its edge planes' come in; its edge planes' velocities go out and its ghosts' come in.
    fn words(&self, what: Exchange, params: &Params) -> (usize, usize) {
        let res = params.grid_res;
        let (send, recv) = match what {
            Exchange::Sums => (&self.ghosts, &self.edge),
            Exchange::Velocities => (&self.edge, &self.ghosts),
        };
        let words = what.words_per_node(params);
        (words * send.nodes(res), words * recv.nodes(res))
    }
}

fn opposite(side: Side) -> Side {
    match side {
        Side::Below => Side::Above,
        Side::Above => Side::Below,
    }
}

/// Two distinct ranks' halo buffers, one to read and one to write.
fn pair(halos: &mut [HaloBuffers], from: usize, to: usize) -> (&HaloBuffers, &mut HaloBuffers) {
    if from < to {
        let (low, high) = halos.split_at_mut(to);
        (&low[from], &mut high[0])
    } else {
        let (low, high) = halos.split_at_mut(from);
        (&high[0], &mut low[to])
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
        // Recorded behind the last substep's work: the sort phase holds the host's turn between.
        let timed = self.solvers[self.timed].stream().clone();
        self.timing.begin_step(&timed)?;
        let last_dt = self.solvers[0].params.dt;
        self.substeps += 1;
        // Every particle starts on its owner; the strays were counted by the last substep's g2p.
        let due = self.substeps % u64::from(MIGRATION_INTERVAL) == 0;
        if self.substeps > 1 && (due || self.strays()? > 0) {
            self.migrate(last_dt)?;
        }
        for (rank, solver) in self.solvers.iter_mut().enumerate() {
            let mut own = *params;
            own.num_particles = solver.capacity() as u32;
            solver.accept(&own)?;
            let sort = solver.sort_due();
            solver.run_phase(Phase::Sort, sort)?;
            // A binning that gathers into bin order packs the live particles first.
            if sort && solver.keeps_bin_order() {
                self.extents[rank] = self.counts[rank];
            }
        }
        self.end_phase(Phase::Sort)?;
        self.run_phase(Phase::P2gInit)?;
        self.exchange(Exchange::Sums)?;
        self.end_phase(Phase::HaloSum)?;
        self.run_phase(Phase::GridUpdate)?;
        self.exchange(Exchange::Velocities)?;
        self.end_phase(Phase::HaloFill)?;
        for solver in &mut self.solvers {
            solver.run_phase(Phase::G2p, false)?;
        }
        self.count_strays()?;
        self.merged_stale = true;
        self.end_phase(Phase::G2p)
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

    /// Every rank's request, in stream order; nothing waits.
    fn request_extremes(&mut self) -> Result<ExtremesTicket> {
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
        let mut all = StepExtremes::default();
        for (solver, ticket) in self.solvers.iter_mut().zip(tickets) {
            all.merge(&solver.wait_extremes(ticket)?);
        }
        Ok(all)
    }

    fn take_step_timings(&mut self) -> Result<Option<Vec<PhaseTimings>>> {
        Ok(Some(self.timing.take_completed()?))
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
        self.take_owned()
    }

    /// The set of every slot as of the last `publish_particles`; nothing before the first.
    fn particles(&self) -> ParticleView<'_> {
        let rank0 = &self.solvers[0];
        match &self.merged {
            Some(merged) => ParticleView::Device(Box::new(DeviceParticlesView::new(
                &rank0.gpu,
                &rank0.kernels.render_attributes,
                merged,
            ))),
            None => ParticleView::Host(&self.unpublished),
        }
    }

    fn read_particles(&mut self) -> Result<Particles> {
        self.take_owned()?;
        let merged = self
            .merged
            .as_ref()
            .context("the ranks' particles were never gathered")?;
        merged.download(&self.solvers[0].gpu)
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
                let parts = self
                    .solvers
                    .iter_mut()
                    .map(|solver| solver.wait_summary(SummaryTicket::Pending))
                    .collect::<Result<Vec<_>>>()?;
                Ok(Summary::of_parts(&parts))
            }
        }
    }
}
