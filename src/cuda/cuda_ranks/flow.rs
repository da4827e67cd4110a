//! The emitters' and sinks' lifecycle on the CUDA ranks (the parent module's `SharedFlow`): each
//! substep's drains shared by every rank before their free slots are sorted, and an emission every
//! rank runs alike (kernels/lifecycle.cu says how each kernel takes its part).

use super::{with_room, CudaRanks, Turn};
use crate::cuda::lifecycle::RankEmission;
use crate::cuda::solver::CudaSolver;
use crate::sim::Params;
use anyhow::{Context, Result};
use cudarc::driver::CudaSlice;

/// The emitters' and sinks' lifecycle on the ranks. Every rank keeps the run's free slots and nozzle
/// points alike (kernels/lifecycle.cu): after each substep every rank's drains go onto every rank's
/// stack and are settled there; an emission takes every rank's look at the nozzle points' last
/// particles, OR'd, and every rank then runs it alike, writing only the particles its slab holds.
pub(super) struct SharedFlow {
    /// Whether the scene has sinks (without, no substep drains anything).
    pub sinks: bool,
    points: usize,
    /// Per rank of this process: its look at the nozzle points, then the run's.
    looks: Vec<CudaSlice<u32>>,
    /// Per rank of this process: the particles the last emission gave it.
    appended: Vec<CudaSlice<u32>>,
}

impl CudaRanks {
    /// Every rank's drains of this substep onto every rank's free stack, in rank order, then
    /// settled there (sorted: which slot an emission takes never depends on which rank drained
    /// what); the live counts follow. A rank's drains are the slots its sinks pushed since its
    /// stack was last settled.
    pub(super) fn share_drains(&mut self) -> Result<()> {
        self.transport.wait_watched(&self.solvers)?;
        let mut unsettled = Vec::new();
        for solver in &self.solvers {
            unsettled.push(solver.unsettled_drains()?);
        }
        let lengths = self.transport.gather_words(
            &self.solvers,
            self.first,
            unsettled.iter().map(|(_, own)| vec![own.len() as u64]).collect(),
        )?;
        let lengths: Vec<usize> = lengths.iter().map(|l| l[0] as usize).collect();
        let longest = lengths.iter().copied().max().unwrap_or(0);
        if longest == 0 {
            return Ok(());
        }
        let padded = unsettled
            .iter()
            .map(|(_, own)| {
                let mut words: Vec<u64> = own.iter().map(|&slot| u64::from(slot)).collect();
                words.resize(longest, 0);
                words
            })
            .collect();
        let all = self.transport.gather_words(&self.solvers, self.first, padded)?;
        let drained: Vec<u32> = all
            .iter()
            .zip(&lengths)
            .flat_map(|(words, &len)| words[..len].iter().map(|&slot| slot as u32))
            .collect();
        for (solver, (counters, own)) in self.solvers.iter_mut().zip(unsettled) {
            solver.settle_drains(counters, own.len(), &drained)?;
        }
        for (count, len) in self.counts.iter_mut().zip(&lengths) {
            *count -= len;
        }
        self.live -= drained.len() as u64;
        Ok(())
    }

    /// One emission of the emitters in `mask`, every rank alike (`SharedFlow`): each rank of this
    /// process looks at the nozzle points' last particles it holds, the looks are OR'd over the
    /// run's ranks, and each rank writes the new particles its slab holds after its places in use
    /// (grown first where the nozzle points could outgrow them).
    pub(super) fn emit_on_ranks(&mut self, params: &Params, mask: u32) -> Result<()> {
        // With a process per rank, rank 0 may call the others to a gather at this turn.
        self.turn(Turn::Emit, vec![Vec::new(); self.solvers.len()])?;
        let flow = self.flow.as_mut().context("this run has no emitters")?;
        let points = flow.points;
        let mut looks = Vec::new();
        for (local, solver) in self.solvers.iter_mut().enumerate() {
            let mut own = *params;
            own.num_particles = solver.capacity() as u32;
            solver.accept(&own)?;
            let look = solver.look_at_nozzles(mask, self.extents[local], &mut flow.looks[local])?;
            looks.push(pack_bits(&look));
        }
        let looks = self.transport.gather_words(&self.solvers, self.first, looks)?;
        let blocked: Vec<u32> = (0..points)
            .map(|g| u32::from(looks.iter().any(|bits| bits[g / 64] >> (g % 64) & 1 == 1)))
            .collect();
        let flow = self.flow.as_mut().context("this run has no emitters")?;
        let axis = self.slabs.axis;
        let layers = self.slabs.blocks();
        for (local, solver) in self.solvers.iter_mut().enumerate() {
            let rank = self.first + local;
            let extent = self.extents[local];
            if extent + points > solver.capacity() {
                solver
                    .grow_particles(with_room(extent + points))
                    .with_context(|| format!("rank {rank} making room for an emission"))?;
                self.growths += 1;
                let mut own = *params;
                own.num_particles = solver.capacity() as u32;
                solver.accept(&own)?;
            }
            let stream = solver.stream().clone();
            stream
                .memcpy_htod(&blocked, &mut flow.looks[local])
                .context("uploading the ranks' looks at the nozzle points")?;
            stream
                .memset_zeros(&mut flow.appended[local])
                .context("zeroing the emission's count")?;
            let emission = RankEmission {
                blocked: &flow.looks[local],
                axis,
                layers,
                own: self.slabs.bounds[rank]..self.slabs.bounds[rank + 1],
                append_at: extent,
                appended: &flow.appended[local],
            };
            solver.emit_into(mask, Some(&emission))?;
        }
        let mut appended = Vec::new();
        for (solver, count) in self.solvers.iter().zip(&flow.appended) {
            appended.push(vec![u64::from(solver.read_count(count)?)]);
        }
        let appended = self.transport.gather_words(&self.solvers, self.first, appended)?;
        for (local, extent) in self.extents.iter_mut().enumerate() {
            *extent += appended[self.first + local][0] as usize;
        }
        for (count, new) in self.counts.iter_mut().zip(&appended) {
            *count += new[0] as usize;
        }
        self.live += appended.iter().map(|new| new[0]).sum::<u64>();
        self.merged_stale = true;
        Ok(())
    }
}

impl SharedFlow {
    /// The look and count buffers of each of `solvers`, ranks of a scene with emitters or sinks.
    pub(super) fn allocate(solvers: &[CudaSolver], sinks: bool) -> Result<SharedFlow> {
        let points = solvers[0].nozzle_points()?;
        let mut flow = SharedFlow {
            sinks,
            points,
            looks: Vec::new(),
            appended: Vec::new(),
        };
        for solver in solvers {
            let stream = solver.stream();
            let alloc = |len: usize| stream.alloc_zeros::<u32>(len.max(1));
            flow.looks
                .push(alloc(points).context("allocating the nozzle points' looks")?);
            flow.appended
                .push(alloc(1).context("allocating an emission's count")?);
        }
        Ok(flow)
    }
}

/// `flags` (0 or 1 each) as bits, 64 a word.
fn pack_bits(flags: &[u32]) -> Vec<u64> {
    let mut words = vec![0u64; flags.len().div_ceil(64)];
    for (i, &flag) in flags.iter().enumerate() {
        words[i / 64] |= u64::from(flag != 0) << (i % 64);
    }
    words
}
