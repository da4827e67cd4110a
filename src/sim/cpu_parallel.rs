//! The multi-threaded CPU backend: the reference's per-particle and per-node math (`p2g_particle`,
//! `node_velocity`, `g2p_particle`, `mirror_walls` in `src/sim/cpu.rs`) run on every core with
//! rayon. The single-thread [`CpuSolver`](super::cpu::CpuSolver) stays the baseline and the tests'
//! oracle; this one is what `--backend auto` picks on a machine without a usable GPU.
//!
//! The gathers (the density in p2g, all of g2p) and the grid update are independent per particle
//! or node and simply run in parallel. The two scatters (mass, then momentum) are made race-free by
//! per-tile blocks:
//!
//! 1. **Bin** (the `sort` timing slot): each particle belongs to the 4x4x4-node tile of its stencil
//!    base node. A stable counting sort puts the particle indices in tile order (the particle arrays
//!    themselves never move).
//! 2. **Scatter into tile blocks**, one task per tile: a particle of a tile only touches the tile's
//!    nodes plus two more per axis, so each tile accumulates into a 6x6x6 block of its own. No two
//!    tasks write the same memory.
//! 3. **Merge**, one task per 4-node-thick z slab of the grid: the slab adds the blocks of the tiles
//!    in its own tile layer and the one below (whose 2-node overhang reaches into it). Each slab is
//!    a disjoint `&mut` part of the grid.
//!
//! Scenes under [`SEQUENTIAL_BELOW`] particles are stepped on one thread by the reference itself.
//!
//! Only the z slabs that hold particles' nodes (or the z walls' mirror) are written in a substep;
//! the next substep clears and updates just those, where the reference walks the whole grid.
//!
//! Every node's sum is taken in the same order whatever the number of threads (tiles in index order,
//! particles in index order within a tile), so a run is deterministic and independent of the thread
//! count. It therefore scatters floats whatever `--scatter` says (the reference's fixed-point mode
//! is for sums that must not depend on the order at all). The order differs from the reference's (particle index order), so results agree with the
//! reference to float rounding (tests/cpu_parallel.rs), not bit for bit.

use super::colliders::ColliderFrame;
use super::cpu::{
    advance_deformation, density_after_g2p, g2p_with_backstop, mirror_walls, momentum_image, node_velocity,
    p2g_particle, reported_density, step_phases, volume_units, CpuPhases, CpuSolver, DensitySource,
    GatherExtremes, Grid, GridShape, Stencil,
};
use super::flow::{FlowCounts, FlowState, Lifecycle};
use super::params::{gathers_volume, DensityRule, Material, Params, ScatterMode};
use super::phase::{Phase, PhaseTimings};
use super::push::Push;
use super::scene::Particles;
use super::solver::{Solver, StepExtremes};
use super::view::ParticleView;
use glam::{IVec3, UVec3, Vec3};
use rayon::iter::Either;
use rayon::prelude::*;

/// The tile key and rank of a parked slot: in no tile.
const PARKED: u32 = u32::MAX;
/// Tile edge, nodes.
const TILE: u32 = 4;
/// A tile's block: its nodes plus the 2-node overhang of its particles' stencils, per axis.
const BLOCK: u32 = TILE + 2;
const BLOCK_NODES: usize = (BLOCK * BLOCK * BLOCK) as usize;
const BLOCK_SHAPE: GridShape = GridShape::whole(UVec3::splat(BLOCK));
/// Particles or nodes per rayon task, at least: below this the task overhead dominates.
const MIN_PER_TASK: usize = 2048;

/// Particle indices in tile order, and where each occupied tile's run of them starts.
#[derive(Default)]
struct Bins {
    /// Tiles per axis.
    tiles: UVec3,
    /// Occupied tiles in ascending tile index (x fastest, then y, then z).
    active: Vec<u32>,
    /// `order[start[k]..start[k + 1]]` are the particles of `active[k]`, in index order.
    start: Vec<usize>,
    order: Vec<u32>,
    /// Position of each particle in `order`.
    rank: Vec<u32>,
    /// Per tile layer z: the range of `active` in that layer.
    layer: Vec<(usize, usize)>,
    /// Per 4-node z slab of the grid: written this substep (by a tile's block or the z-wall mirror).
    dirty: Vec<bool>,
    /// Scratch: the tile of each particle, and per-tile counts.
    key: Vec<u32>,
    count: Vec<u32>,
}

impl Bins {
    /// Parked slots (`live` false) go in no tile.
    fn build(&mut self, x: &[Vec3], live: &[bool], params: &Params, res: UVec3) {
        let inv_dx = params.inv_dx;
        self.tiles = (res + (TILE - 1)) / TILE;
        let tiles = self.tiles;
        // The stencil's base node, computed exactly as `Stencil::new` does.
        x.par_iter()
            .zip(live.par_iter())
            .with_min_len(MIN_PER_TASK)
            .map(|(&x, &live)| {
                if !live {
                    return PARKED;
                }
                let base = ((x * inv_dx) - 0.5)
                    .floor()
                    .as_ivec3()
                    .max(IVec3::ZERO)
                    .as_uvec3()
                    / TILE;
                base.x + tiles.x * (base.y + tiles.y * base.z)
            })
            .collect_into_vec(&mut self.key);
        self.count.clear();
        self.count.resize((tiles.x * tiles.y * tiles.z) as usize, 0);
        for &k in self.key.iter().filter(|&&k| k != PARKED) {
            self.count[k as usize] += 1;
        }
        self.active.clear();
        self.start.clear();
        let mut offset = 0usize;
        for (tile, count) in self.count.iter_mut().enumerate() {
            if *count > 0 {
                self.active.push(tile as u32);
                self.start.push(offset);
                let n = *count as usize;
                *count = offset as u32; // from here on: the next free slot of this tile
                offset += n;
            }
        }
        self.start.push(offset);
        self.order.resize(offset, 0);
        self.rank.clear();
        self.rank.resize(x.len(), PARKED);
        for (i, &k) in self.key.iter().enumerate().filter(|(_, &k)| k != PARKED) {
            let slot = &mut self.count[k as usize];
            self.order[*slot as usize] = i as u32;
            self.rank[i] = *slot;
            *slot += 1;
        }
        let per_layer = tiles.x * tiles.y;
        self.layer = (0..tiles.z)
            .map(|z| {
                let a = self.active.partition_point(|&t| t < z * per_layer);
                let b = self.active.partition_point(|&t| t < (z + 1) * per_layer);
                (a, b)
            })
            .collect();
        // A slab is written by its own tile layer and the one below; the z-wall mirror writes
        // nodes [0, 2 W] and [2 W' - (R - 1), R - 1].
        let slabs = res.z.div_ceil(TILE) as usize;
        let occupied = |z: usize| self.layer.get(z).is_some_and(|&(a, b)| b > a);
        let (lo, hi) = (params.wall_mirror_lo, params.wall_mirror_hi[2]);
        let lo_slab = (2 * lo / TILE) as usize;
        let hi_slab = ((2 * hi).saturating_sub(res.z - 1) / TILE) as usize;
        self.dirty = (0..slabs)
            .map(|k| occupied(k) || (k > 0 && occupied(k - 1)) || (lo > 0 && (k <= lo_slab || k >= hi_slab)))
            .collect();
    }

    fn tile_origin(&self, tile: u32) -> IVec3 {
        let t = self.tiles;
        let xyz = UVec3::new(tile % t.x, (tile / t.x) % t.y, tile / (t.x * t.y));
        (xyz * TILE).as_ivec3()
    }

    /// The particles of the k-th occupied tile.
    fn particles(&self, k: usize) -> &[u32] {
        &self.order[self.start[k]..self.start[k + 1]]
    }
}

/// One value per stencil node and particle, `contribution(particle, w)`, summed per tile block into
/// `blocks` (BLOCK_NODES values a block, in parallel), for [`merge`] to add to the grid.
fn scatter_blocks<T: Copy + Default + Send + std::ops::AddAssign>(
    bins: &Bins,
    particles: &Particles,
    params: &Params,
    blocks: &mut Vec<T>,
    contribution: impl Fn(usize, f32) -> T + Sync,
) {
    blocks.resize(bins.active.len() * BLOCK_NODES, T::default());
    blocks
        .par_chunks_mut(BLOCK_NODES)
        .enumerate()
        .for_each(|(k, block)| {
            block.fill(T::default());
            let origin = bins.tile_origin(bins.active[k]);
            for &p in bins.particles(k) {
                let p = p as usize;
                let st = Stencil::new(particles.x[p], params.inv_dx);
                in_block(&st, origin).for_each_node(BLOCK_SHAPE, |i, w, _| block[i] += contribution(p, w));
            }
        });
}

/// Adds the tiles' blocks into the grid, one task per 4-node z slab (see the module notes).
fn merge<T: Copy + Send + Sync + std::ops::AddAssign>(
    bins: &Bins,
    shape: GridShape,
    blocks: &[T],
    grid: &mut [T],
) {
    let res = shape.res;
    let slab_nodes = (res.x * res.y * TILE) as usize;
    grid.par_chunks_mut(slab_nodes)
        .enumerate()
        .for_each(|(slab, nodes)| {
            let slab = slab as u32;
            let z_lo = slab * TILE;
            for layer in [slab.checked_sub(1), Some(slab)].into_iter().flatten() {
                let (a, b) = bins.layer[layer as usize];
                for k in a..b {
                    let origin = bins.tile_origin(bins.active[k]).as_uvec3();
                    let block = &blocks[k * BLOCK_NODES..(k + 1) * BLOCK_NODES];
                    for lz in 0..BLOCK {
                        let z = origin.z + lz;
                        if z < z_lo || z >= (z_lo + TILE).min(res.z) {
                            continue;
                        }
                        for ly in 0..BLOCK {
                            let y = origin.y + ly;
                            if y >= res.y {
                                break;
                            }
                            let row = ((z - z_lo) * res.y + y) * res.x;
                            let local = ((lz * BLOCK + ly) * BLOCK) as usize;
                            for lx in 0..BLOCK.min(res.x - origin.x) {
                                nodes[(row + origin.x + lx) as usize] += block[local + lx as usize];
                            }
                        }
                    }
                }
            }
        });
}

/// The stencil relative to a tile's block.
#[inline(always)]
fn in_block(st: &Stencil, origin: IVec3) -> Stencil {
    Stencil {
        base: st.base - origin,
        ..*st
    }
}

/// Below this many particles the backend steps on one thread, as the reference does: waking the
/// threads and the tile blocks cost more than they save (3,264 particles: 1.2 ms a substep on two
/// threads, 0.8 ms on one; 26,112: 5 on two, 7 on one).
pub const SEQUENTIAL_BELOW: usize = 10_000;

pub struct ParallelCpuSolver {
    /// The particles and grid; also the single-thread path for small scenes.
    inner: CpuSolver,
    bins: Bins,
    block_mass: Vec<f32>,
    /// The grid's volume per tile block, where the rest densities differ (`scatter_volume`).
    block_volume: Vec<i64>,
    block_momentum: Vec<Vec3>,
    /// p2g's densities in tile order, before they go back to the particles.
    rho_binned: Vec<f32>,
    extremes: StepExtremes,
    timings: Vec<PhaseTimings>,
}

impl ParallelCpuSolver {
    pub fn new(particles: Particles, grid_res: [u32; 3]) -> ParallelCpuSolver {
        ParallelCpuSolver {
            inner: CpuSolver::new(particles, grid_res),
            bins: Bins::default(),
            block_mass: Vec::new(),
            block_volume: Vec::new(),
            block_momentum: Vec::new(),
            rho_binned: Vec::new(),
            extremes: StepExtremes::default(),
            timings: Vec::new(),
        }
    }

    /// The solver with emitters and sinks.
    pub fn with_lifecycle(mut self, lifecycle: Option<Lifecycle>) -> ParallelCpuSolver {
        self.inner.lifecycle = lifecycle;
        self
    }

    /// Parks the live particles inside a sink: a parallel test of every slot, then the drained slots
    /// in index order (the reference's order).
    fn drain(&mut self) {
        let Some(lifecycle) = &mut self.inner.lifecycle else {
            return;
        };
        if lifecycle.flow.sinks.is_empty() {
            return;
        }
        let p = &mut self.inner.particles;
        let flow = &lifecycle.flow;
        let drained: Vec<usize> = (0..p.len())
            .into_par_iter()
            .with_min_len(MIN_PER_TASK)
            .filter(|&i| p.live[i] && flow.in_a_sink(p.x[i]))
            .collect();
        for i in drained {
            p.live[i] = false;
            lifecycle.state.drain(i as u32);
        }
        lifecycle.state.settle();
    }

    /// Threads the backend runs on (rayon's pool: `RAYON_NUM_THREADS`, else one per core).
    pub fn threads() -> usize {
        rayon::current_num_threads()
    }

    pub fn particles(&self) -> &Particles {
        &self.inner.particles
    }

    pub fn grid(&self) -> &Grid {
        &self.inner.grid
    }

    /// Whether this scene is stepped on one thread (fewer than [`SEQUENTIAL_BELOW`] particles).
    pub fn sequential(&self) -> bool {
        self.inner.particles.len() < SEQUENTIAL_BELOW
    }

    /// Zeroes the slabs the last substep wrote (the rest of the grid is zero already).
    pub fn clear_grid(&mut self) {
        let slab = self.slab_nodes();
        let dirty = &self.bins.dirty;
        let Grid { mass, momentum, .. } = &mut self.inner.grid;
        mass.par_chunks_mut(slab)
            .zip(momentum.par_chunks_mut(slab))
            .zip(dirty.par_iter())
            .filter(|(_, &dirty)| dirty)
            .for_each(|((m, mv), _)| {
                m.fill(0.0);
                mv.fill(Vec3::ZERO);
            });
    }

    fn slab_nodes(&self) -> usize {
        let res = self.inner.grid.shape.res;
        (res.x * res.y * TILE) as usize
    }

    /// The particles in tile order (the `sort` slot of the timings).
    pub fn bin(&mut self, params: &Params) {
        self.bins.build(
            &self.inner.particles.x,
            &self.inner.particles.live,
            params,
            self.inner.grid.shape.res,
        );
    }

    /// m_i += w m_p, per tile block, then merged; then the walls' mirror mass. The volume too, where
    /// the rest densities differ.
    pub fn p2g_init(&mut self, params: &Params) {
        if gathers_volume(params) {
            self.scatter_volume(params);
        }
        let particles = &self.inner.particles;
        scatter_blocks(&self.bins, particles, params, &mut self.block_mass, |p, w| {
            w * Material::of(params, particles.material[p]).particle_mass
        });
        merge(
            &self.bins,
            self.inner.grid.shape,
            &self.block_mass,
            &mut self.inner.grid.mass,
        );
        self.inner.keep_own_mass(params);
        mirror_walls(
            self.inner.grid.shape,
            params,
            &mut self.inner.grid.mass,
            |_, m, _, _| m,
        );
    }

    /// The grid's volume (`CpuSolver::scatter_volume`) per tile block, merged, then its walls' image:
    /// integer sums, the reference's whatever the order.
    fn scatter_volume(&mut self, params: &Params) {
        let particles = &self.inner.particles;
        scatter_blocks(&self.bins, particles, params, &mut self.block_volume, |_, w| {
            volume_units(w)
        });
        let grid = &mut self.inner.grid;
        grid.volume.clear();
        grid.volume.resize(grid.shape.num_nodes(), 0);
        merge(&self.bins, grid.shape, &self.block_volume, &mut grid.volume);
        mirror_walls(grid.shape, params, &mut grid.volume, |_, v, _, _| v);
    }

    /// Density from grid mass, pressure and stress (`p2g_particle`), momentum per tile block, merged.
    pub fn p2g(&mut self, params: &Params) {
        let params = &self.inner.scatter_params(params);
        let bins = &self.bins;
        let (shape, source) = (&self.inner.grid.shape, DensitySource::of(&self.inner.grid));
        let p = &self.inner.particles;
        self.block_momentum
            .resize(bins.active.len() * BLOCK_NODES, Vec3::ZERO);
        self.rho_binned.resize(bins.order.len(), 0.0);
        // Each tile's densities are a run of `rho_binned`: split it into one slice per tile.
        let mut rho_runs = Vec::with_capacity(bins.active.len());
        let mut rest = self.rho_binned.as_mut_slice();
        for k in 0..bins.active.len() {
            let (run, tail) = rest.split_at_mut(bins.start[k + 1] - bins.start[k]);
            rho_runs.push(run);
            rest = tail;
        }
        let max_rho = self
            .block_momentum
            .par_chunks_mut(BLOCK_NODES)
            .zip(rho_runs.into_par_iter())
            .enumerate()
            .map(|(k, (block, rho_run))| {
                block.fill(Vec3::ZERO);
                let origin = bins.tile_origin(bins.active[k]);
                let mut max_rho = 0.0f32;
                for (&i, rho_out) in bins.particles(k).iter().zip(rho_run.iter_mut()) {
                    let i = i as usize;
                    let st = Stencil::new(p.x[i], params.inv_dx);
                    let material = p.material[i];
                    let (rho, mv, affine) = p2g_particle(
                        params,
                        &st,
                        *shape,
                        source,
                        p.rho[i],
                        p.v[i],
                        p.c[i],
                        material,
                        p.deformation.get(i),
                    );
                    *rho_out = rho;
                    max_rho = max_rho.max(reported_density(params, material, rho));
                    in_block(&st, origin)
                        .for_each_node(BLOCK_SHAPE, |n, w, d| block[n] += w * (mv + affine * d));
                }
                max_rho
            })
            .reduce(|| 0.0, f32::max);
        let (rank, binned) = (&self.bins.rank, &self.rho_binned);
        self.inner
            .particles
            .rho
            .par_iter_mut()
            .with_min_len(MIN_PER_TASK)
            .zip(rank.par_iter())
            .filter(|(_, &r)| r != PARKED)
            .for_each(|(rho, &r)| *rho = binned[r as usize]);
        merge(
            &self.bins,
            self.inner.grid.shape,
            &self.block_momentum,
            &mut self.inner.grid.momentum,
        );
        if DensityRule::of(params) == DensityRule::Gathered {
            self.extremes.max_density = self.extremes.max_density.max(max_rho);
        }
    }

    /// The walls' mirror momentum, then momentum to velocity per node (`node_velocity`).
    pub fn grid_update(&mut self, params: &Params) {
        self.inner.keep_own_momentum(params);
        mirror_walls(
            self.inner.grid.shape,
            params,
            &mut self.inner.grid.momentum,
            momentum_image,
        );
        let slab = self.slab_nodes();
        let dirty = &self.bins.dirty;
        let (colliders, own) = (&self.inner.colliders, &self.inner.own);
        let Grid {
            shape,
            mass,
            momentum,
            ..
        } = &mut self.inner.grid;
        let shape = *shape;
        momentum
            .par_chunks_mut(slab)
            .zip(mass.par_chunks(slab))
            .zip(dirty.par_iter())
            .enumerate()
            .filter(|(_, (_, &dirty))| dirty)
            .for_each(|(k, ((mv, m), _))| {
                for (j, (mv, &m)) in mv.iter_mut().zip(m).enumerate() {
                    if m > 0.0 {
                        let i = k * slab + j;
                        let (own_m, push) = own.at(i, m, *mv);
                        *mv = node_velocity(params, shape, i, m, own_m, push, *mv, colliders, &mut []);
                    }
                }
            });
    }

    /// Velocity and C from the grid, advection (`g2p_particle`), the density carried on
    /// (`density_after_g2p`), and the extremes.
    pub fn g2p(&mut self, params: &Params) {
        let grid = &self.inner.grid;
        let (shape, velocity, source) = (&grid.shape, &grid.momentum, DensitySource::of(grid));
        let colliders = &self.inner.colliders;
        let p = &mut self.inner.particles;
        // Each slot's deformation where the scene has solids; `None` for every slot where it has none.
        let deformations = match p.deformation.is_empty() {
            false => Either::Left(p.deformation.par_iter_mut().map(Some)),
            true => Either::Right((0..p.x.len()).into_par_iter().map(|_| None)),
        };
        let extremes =
            p.x.par_iter_mut()
                .with_min_len(MIN_PER_TASK)
                .zip(p.v.par_iter_mut())
                .zip(p.c.par_iter_mut())
                .zip(p.rho.par_iter_mut())
                .zip(p.live.par_iter().zip(p.material.par_iter()))
                .zip(deformations)
                .map(|(((((x, v), c), rho), (&live, &material)), deformation)| {
                    if !live {
                        return GatherExtremes::default();
                    }
                    let (x_new, v_new, c_new, moved) =
                        g2p_with_backstop(params, *shape, velocity, colliders, *x, 0.0, &mut []);
                    *rho = density_after_g2p(params, *shape, source, velocity, *x, *rho, material);
                    (*x, *v, *c) = (x_new, v_new, c_new);
                    let deformation = advance_deformation(params, material, c_new, deformation);
                    GatherExtremes::of(params, *v, *rho, material, moved, deformation)
                })
                .reduce(GatherExtremes::default, GatherExtremes::max);
        extremes.add_to(&mut self.extremes);
        self.inner.scatter_dt = Some(params.dt);
    }
}

impl CpuPhases for ParallelCpuSolver {
    fn run_phase(&mut self, phase: Phase, params: &Params) {
        match phase {
            Phase::GridClear => self.clear_grid(),
            Phase::Sort => self.bin(params),
            Phase::HaloSum | Phase::HaloFill => {} // one rank: `step_phases` skips them
            Phase::P2gInit => self.p2g_init(params),
            Phase::P2g => self.p2g(params),
            Phase::GridUpdate => self.grid_update(params),
            Phase::G2p => {
                self.g2p(params);
                self.drain();
            }
        }
    }

    fn pending_timings(&mut self) -> &mut Vec<PhaseTimings> {
        &mut self.timings
    }
}

impl Solver for ParallelCpuSolver {
    fn name(&self) -> &'static str {
        "cpu-parallel"
    }

    fn step(&mut self, params: &Params) -> anyhow::Result<()> {
        if self.sequential() {
            // Float sums whatever the scatter mode, as the tiles' (whose order is fixed already).
            let mut float = *params;
            float.scatter_mode = ScatterMode::Float.code();
            return self.inner.step(&float);
        }
        step_phases(self, params);
        Ok(())
    }

    fn resume_after(&mut self, last: &Params) {
        self.inner.resume_after(last);
    }

    fn take_extremes(&mut self) -> anyhow::Result<StepExtremes> {
        if self.sequential() {
            return self.inner.take_extremes();
        }
        Ok(std::mem::take(&mut self.extremes))
    }

    fn take_step_timings(&mut self) -> anyhow::Result<Option<Vec<PhaseTimings>>> {
        if self.sequential() {
            return self.inner.take_step_timings();
        }
        Ok(Some(std::mem::take(&mut self.timings)))
    }

    fn particles(&self) -> ParticleView<'_> {
        ParticleView::Host(&self.inner.particles)
    }

    fn read_particles(&mut self) -> anyhow::Result<Particles> {
        Ok(self.inner.particles.clone())
    }

    fn set_colliders(&mut self, frame: &ColliderFrame) -> anyhow::Result<()> {
        self.inner.set_colliders(frame)
    }

    fn apply_push(&mut self, push: &Push) -> anyhow::Result<()> {
        let p = &mut self.inner.particles;
        p.x.par_iter()
            .with_min_len(MIN_PER_TASK)
            .zip(p.v.par_iter_mut())
            .for_each(|(x, v)| *v += push.velocity_change(*x));
        Ok(())
    }

    fn emit(&mut self, params: &Params, mask: u32) -> anyhow::Result<()> {
        self.inner.emit(params, mask)
    }

    fn flow_counts(&mut self) -> anyhow::Result<Option<FlowCounts>> {
        self.inner.flow_counts()
    }

    fn flow_state(&mut self) -> anyhow::Result<Option<FlowState>> {
        self.inner.flow_state()
    }
}
