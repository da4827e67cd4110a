//! `CudaRanks`: one run split into ranks, each a [`CudaSolver`] over its slab of the grid
//! (`crate::dist`), stepped phase by phase with the ghost exchanges between the phases. What it hands
//! over (particles slot by slot, extremes, statistics, checkpoints) is what one solver would.
//!
//! | phase | every rank, fused pipeline |
//! |---|---|
//! | sort        | where the last g2p counted a particle that the next substep could carry past its rank's ghost planes, or every SORT_INTERVAL substeps: rebalance the slabs and migrate; then bin where the rank's schedule says |
//! | p2g_init    | the first substep's scatter |
//! | halo_sum    | its ghost planes' sums packed, carried to their owner, added to its edge planes |
//! | grid_update | the walls' mirror of mass and momentum, the grid update |
//! | halo_fill   | its edge planes' velocities packed, carried to the neighbours' ghost planes |
//! | g2p         | one_pass (gather, advect, scatter the next substep), then count the strays |
//!
//! The fused pipeline scatters the next substep inside one_pass, so the ghost sums travel at the
//! start of the substep that uses them, before the walls' mirror.
//!
//! **On one GPU.** Every rank runs on device `CudaOptions::device` and the carrier is a device copy
//! between the ranks' halo buffers; NCCL's send/recv between GPUs takes its place when it is built
//! (docs/several-gpus.md). Every rank holds every particle slot, live where it owns the particle and
//! parked elsewhere (the kernels skip parked slots), so a migration (`move_owned`, kernels/ranks.cu
//! beside this file) copies the moved slots and flips their flags, and a slot's index never changes;
//! after each substep `take_owned` copies every rank's own slots into one set, which readers see.
//! The host waits for every rank at the end of each phase: that orders the exchanges between the
//! ranks' streams and times the phases.

use super::gpu::CudaOptions;
use super::halo::{HaloBuffers, HaloKernels, Planes};
use super::launch::{Kernel, Launcher};
use super::modules::LoadedModules;
use super::particles::{DeviceParticles, DeviceParticlesView};
use super::solver::CudaSolver;
use super::state::{DeviceState, StateArgs};
use super::SORT_INTERVAL;
use crate::dist::migrate::{layer, Migration};
use crate::dist::{check_ranks, starting_slabs, Slabs};
use crate::sim::colliders::ColliderFrame;
use crate::sim::phase::{Phase, PhaseClock, PhaseTimings};
use crate::sim::solver::push_step_timing;
use crate::sim::{Params, ParticleView, Particles, Pipeline, Push, Scene, Solver, StepExtremes};
use anyhow::{ensure, Context, Result};
use cudarc::driver::{CudaSlice, LaunchConfig, PushKernelArg};
use std::ops::Range;

pub struct CudaRanks {
    solvers: Vec<CudaSolver>,
    halos: Vec<HaloBuffers>,
    slabs: Slabs,
    /// The walls' mirror planes along the slab axis, low and high (`Slabs::rebalanced`).
    walls: (u32, u32),
    /// Every slot as of the last substep, each from the rank that owns it, on rank 0's device
    /// (`Solver::particles`).
    merged: DeviceParticles,
    /// Per rank: the strays its last g2p counted.
    strays: Vec<CudaSlice<u32>>,
    /// Live particles per rank, as of the last substep.
    counts: Vec<usize>,
    /// Live particles in the run, all ranks together: what every migration must leave.
    live: u64,
    timings: Vec<PhaseTimings>,
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

impl CudaRanks {
    /// `ranks` ranks of `particles` (every slot of `scene`'s run), the slabs balanced for them.
    pub fn new(scene: &Scene, particles: Particles, ranks: usize, options: CudaOptions) -> Result<CudaRanks> {
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
            scene.pipeline == Pipeline::Fused,
            "scene {}: several ranks run the fused pipeline (the default); drop --pipeline {} or run on one rank",
            scene.source,
            scene.pipeline.name()
        );
        let params = scene.params();
        let mut solvers = Vec::new();
        let mut halos = Vec::new();
        let mut counts = Vec::new();
        let mut strays = Vec::new();
        for rank in 0..slabs.ranks() {
            let mine = owned_by(&particles, &slabs, rank, params.inv_dx);
            counts.push(mine.num_live());
            // Every rank holds every slot at its own place (migration and take_owned copy slot p to
            // slot p), so the ranks keep their particles where they are, out of bin order.
            let in_place = CudaOptions {
                bin_order: false,
                ..options
            };
            let solver = CudaSolver::from_particles(scene, &mine, in_place)
                .with_context(|| format!("rank {rank} of {}", slabs.ranks()))?;
            halos.push(HaloBuffers::allocate(&solver.gpu, scene.grid_res, slabs.axis)?);
            strays.push(
                solver
                    .stream()
                    .alloc_zeros::<u32>(1)
                    .context("allocating a stray counter")?,
            );
            solvers.push(solver);
        }
        let mut merged = DeviceParticles::allocate(solvers[0].stream(), particles.len())?;
        merged.upload(solvers[0].stream(), &particles)?;
        Ok(CudaRanks {
            solvers,
            halos,
            walls: (params.wall_mirror_lo, params.wall_mirror_hi[slabs.axis]),
            slabs,
            live: particles.num_live() as u64,
            counts,
            merged,
            strays,
            timings: Vec::new(),
            substeps: 0,
            migrations: 0,
            migrated: Migration::default(),
        })
    }

    /// The device's name, and how many ranks share it.
    pub fn device_name(&self) -> String {
        format!("{}, {} ranks", self.solvers[0].device_name(), self.solvers.len())
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

    /// The host waits for every rank's stream.
    fn wait_all(&self) -> Result<()> {
        for solver in &self.solvers {
            solver
                .stream()
                .synchronize()
                .context("waiting for a rank (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
        }
        Ok(())
    }

    /// The host waits for every rank, then the time since the last lap was `phase`'s.
    fn lap(&self, clock: &mut PhaseClock, phase: Phase) -> Result<()> {
        self.wait_all()?;
        clock.lap(phase);
        Ok(())
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
            &solver.gpu.kernels.halo,
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
        self.carry(&links)?;
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

    /// The carrier on one GPU: every rank's send buffers, once packed, copied into its neighbours'
    /// receive buffers on the receiver's stream.
    fn carry(&mut self, links: &[Link]) -> Result<()> {
        self.wait_all()?; // every rank's packing
        for link in links {
            let (from, to) = pair(&mut self.halos, link.rank, link.neighbour);
            let (src, dst) = (
                &from.send[link.side as usize],
                &mut to.recv[opposite(link.side) as usize],
            );
            self.solvers[link.neighbour]
                .stream()
                .memcpy_dtod(src, dst)
                .context("carrying a halo between ranks")?;
        }
        Ok(())
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
            let (k, l) = (&solver.gpu.kernels.ranks, &solver.gpu.launcher);
            k.count_strays(
                l,
                &solver.params,
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
        for solver in &self.solvers {
            let (k, l) = (&solver.gpu.kernels.ranks, &solver.gpu.launcher);
            let mut counts = solver
                .stream()
                .alloc_zeros::<u32>(layers as usize)
                .context("allocating layer counts")?;
            k.count_layers(
                l,
                &solver.params,
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
    /// owns its block layer, on the device, checking that none was lost or held twice. `last_dt`:
    /// the step of the substep whose scatter the grids hold, scattered again where the slabs moved.
    fn migrate(&mut self, last_dt: f32) -> Result<()> {
        let before = self.layer_counts()?;
        let per_layer: Vec<u64> = (0..self.slabs.blocks() as usize)
            .map(|layer| before.iter().map(|rank| rank[layer]).sum())
            .collect();
        let moved_slabs = match self.slabs.rebalanced(&per_layer, self.walls)? {
            Some(balanced) => {
                self.slabs = balanced;
                true
            }
            None => false,
        };
        self.wait_all()?;
        let first = &self.solvers[0];
        let (k, l) = (&first.gpu.kernels.ranks, &first.gpu.launcher);
        let mut moved = first
            .stream()
            .alloc_zeros::<u32>(1)
            .context("allocating the migration counter")?;
        for to in 0..self.solvers.len() {
            let layers = self.slabs.bounds[to]..self.slabs.bounds[to + 1];
            for from in (0..self.solvers.len()).filter(|&from| from != to) {
                let (source, dest) = (
                    &self.solvers[from].state.particles,
                    &self.solvers[to].state.particles,
                );
                let slab = (self.slabs.axis, self.slabs.blocks(), layers.clone());
                k.move_owned(l, &first.params, slab, source, dest, &mut moved)?;
            }
        }
        let moved = u64::from(first.gpu.download(&moved)?[0]);
        let after = self.layer_counts()?;
        let live = |counts: &[Vec<u64>]| counts.iter().flatten().sum::<u64>();
        let migration = Migration {
            sent: moved,
            received: moved,
            live_before: live(&before),
            live_after: live(&after),
        };
        // A slot live on two ranks, or on none, changes the sum over the ranks.
        ensure!(
            migration.live_before == self.live && migration.live_after == self.live,
            "a migration lost or duplicated particles: {} live before, {} after, {} in the run \
             ({moved} moved)",
            migration.live_before,
            migration.live_after,
            self.live
        );
        for (rank, solver) in self.solvers.iter_mut().enumerate() {
            self.counts[rank] = after[rank].iter().sum::<u64>() as usize;
            if moved > 0 {
                solver.rebin_next();
            }
            // A rank's scatter lies in its old slab and ghost planes, which the new halo may miss.
            if moved_slabs {
                solver.discard_scatter(last_dt)?;
            }
        }
        self.migrated.sent += migration.sent;
        self.migrated.received += migration.received;
        self.migrations += 1;
        Ok(())
    }

    /// Every rank's own slots into `merged`, on rank 0's stream once every rank is done, waited for
    /// (no rank may write its particles while they are read).
    fn take_owned(&mut self) -> Result<()> {
        self.wait_all()?;
        let first = &self.solvers[0];
        let (k, l) = (&first.gpu.kernels.ranks, &first.gpu.launcher);
        for solver in &self.solvers {
            k.take_owned(l, &solver.state.particles, &self.merged)?;
        }
        self.wait_all()
    }
}

/// The slots of `all` that `slabs` gives to `rank` live, every other slot parked.
fn owned_by(all: &Particles, slabs: &Slabs, rank: usize, inv_dx: f32) -> Particles {
    let mut mine = all.clone();
    for (live, x) in mine.live.iter_mut().zip(&all.x) {
        *live &= slabs.owner(layer(*x, slabs.axis, inv_dx)) == rank;
    }
    mine
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
        let mut clock = PhaseClock::start();
        let last_dt = self.solvers[0].params.dt;
        self.substeps += 1;
        // Every particle starts on its owner; the strays were counted by the last substep's g2p.
        let due = self.substeps % u64::from(SORT_INTERVAL) == 0;
        if self.substeps > 1 && (due || self.strays()? > 0) {
            self.migrate(last_dt)?;
        }
        for solver in &mut self.solvers {
            solver.accept(params)?;
            let sort = solver.sort_due();
            solver.sort_phase(sort)?;
        }
        self.lap(&mut clock, Phase::Sort)?;
        for solver in &mut self.solvers {
            solver.scatter_first()?;
        }
        self.lap(&mut clock, Phase::P2gInit)?;
        self.exchange(Exchange::Sums)?;
        self.lap(&mut clock, Phase::HaloSum)?;
        for solver in &mut self.solvers {
            solver.mirror_and_update_grid()?;
        }
        self.lap(&mut clock, Phase::GridUpdate)?;
        self.exchange(Exchange::Velocities)?;
        self.lap(&mut clock, Phase::HaloFill)?;
        for solver in &mut self.solvers {
            solver.gather()?;
        }
        self.count_strays()?;
        self.take_owned()?; // waits for every rank: the lap need not
        clock.lap(Phase::G2p);
        push_step_timing(&mut self.timings, clock.finish());
        Ok(())
    }

    fn resume_after(&mut self, last: &Params) {
        for solver in &mut self.solvers {
            solver.resume_after(last);
        }
    }

    fn take_extremes(&mut self) -> Result<StepExtremes> {
        let mut all = StepExtremes::default();
        for solver in &mut self.solvers {
            all.merge(&solver.take_extremes()?);
        }
        Ok(all)
    }

    fn take_step_timings(&mut self) -> Result<Option<Vec<PhaseTimings>>> {
        Ok(Some(std::mem::take(&mut self.timings)))
    }

    fn set_colliders(&mut self, frame: &ColliderFrame) -> Result<()> {
        self.solvers.iter_mut().try_for_each(|s| s.set_colliders(frame))
    }

    fn apply_push(&mut self, push: &Push) -> Result<()> {
        self.solvers.iter_mut().try_for_each(|s| s.apply_push(push))?;
        self.take_owned()
    }

    fn particles(&self) -> ParticleView<'_> {
        ParticleView::Device(DeviceParticlesView {
            gpu: &self.solvers[0].gpu,
            particles: &self.merged,
        })
    }

    fn read_particles(&mut self) -> Result<Particles> {
        self.merged.download(&self.solvers[0].gpu)
    }
}

/// The kernels of kernels/ranks.cu.
pub struct RanksKernels {
    count_strays: Kernel,
    count_layers: Kernel,
    move_owned: Kernel,
    take_owned: Kernel,
}

impl RanksKernels {
    pub fn load(modules: &LoadedModules) -> Result<RanksKernels> {
        Ok(RanksKernels {
            count_strays: Kernel::load(modules, "ranks", "count_strays")?,
            count_layers: Kernel::load(modules, "ranks", "count_layers")?,
            move_owned: Kernel::load(modules, "ranks", "move_owned")?,
            take_owned: Kernel::load(modules, "ranks", "take_owned")?,
        })
    }

    /// Adds to `strays` the live particles of `x` whose stencil base along `axis` lies outside
    /// `keep` (`Slabs::keeps`).
    fn count_strays(
        &self,
        l: &Launcher,
        params: &Params,
        axis: usize,
        keep: (i32, i32),
        x: &CudaSlice<f32>,
        strays: &CudaSlice<u32>,
    ) -> Result<()> {
        let axis = axis as u32;
        // SAFETY: the arguments match count_strays; x holds num_particles float4.
        unsafe {
            self.count_strays
                .launch(l, l.cover(params.num_particles as usize), |a| {
                    a.arg(params)
                        .arg(&axis)
                        .arg(&keep.0)
                        .arg(&keep.1)
                        .arg(x)
                        .arg(strays);
                })
        }
    }

    /// Adds the live particles of `x` per block layer along `axis` (`layers` of them) to `counts`.
    fn count_layers(
        &self,
        l: &Launcher,
        params: &Params,
        axis: usize,
        layers: u32,
        x: &CudaSlice<f32>,
        counts: &mut CudaSlice<u32>,
    ) -> Result<()> {
        let axis = axis as u32;
        let config = LaunchConfig {
            shared_mem_bytes: 4 * layers,
            ..l.cover(params.num_particles as usize)
        };
        // SAFETY: the arguments match count_layers; x holds num_particles float4, counts `layers`
        // u32, and the shared histogram is sized for them.
        unsafe {
            self.count_layers.launch(l, config, |a| {
                a.arg(params).arg(&axis).arg(&layers).arg(x).arg(counts);
            })
        }
    }

    /// Moves the slots live in `from` whose block layer lies in `slab` (axis, layers of the grid,
    /// the receiving rank's layers) to `to`, counting them in `moved`.
    fn move_owned(
        &self,
        l: &Launcher,
        params: &Params,
        (axis, layers, mine): (usize, u32, Range<u32>),
        from: &DeviceParticles,
        to: &DeviceParticles,
        moved: &mut CudaSlice<u32>,
    ) -> Result<()> {
        ensure!(from.count == to.count, "{} slots for {}", from.count, to.count);
        let axis = axis as u32;
        // SAFETY: the arguments match move_owned; both hold num_particles slots of each array.
        unsafe {
            self.move_owned
                .launch(l, l.cover(params.num_particles as usize), |a| {
                    a.arg(params)
                        .arg(&axis)
                        .arg(&layers)
                        .arg(&mine.start)
                        .arg(&mine.end)
                        .particle_state(from)
                        .particle_state(to)
                        .arg(moved);
                })
        }
    }

    /// Copies the slots live in `rank` into `out` (as many slots).
    fn take_owned(&self, l: &Launcher, rank: &DeviceParticles, out: &DeviceParticles) -> Result<()> {
        ensure!(rank.count == out.count, "{} slots for {}", rank.count, out.count);
        let n = rank.count as u32;
        // SAFETY: the arguments match take_owned; both hold `count` slots of each array.
        unsafe {
            self.take_owned.launch(l, l.cover(rank.count), |a| {
                a.arg(&n).particle_state(rank).particle_state(out);
            })
        }
    }
}
