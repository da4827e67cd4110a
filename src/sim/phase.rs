//! The substep's phases, in step order: the one list that names and times them. The CUDA backend's
//! NVTX ranges and timing events, the CPU backends' clocks, [`PhaseTimings`], the viewer's panel, the
//! bench tables and the JSON keys all follow [`Phase::ALL`]; a new phase is one variant here and its
//! work in each backend.

use super::params::Pipeline;
use serde::ser::{Serialize, SerializeStruct, Serializer};
use std::ops::{Index, IndexMut};
use std::time::Instant;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Phase {
    /// Zeroing the grid's accumulators. The GPU folds it into the grid update (consume-and-zero).
    GridClear,
    /// Binning the particles: the GPU's counting sort by cell or node block, every few substeps;
    /// cpu-parallel's binning by tile; none in the CPU reference.
    Sort,
    /// The mass scatter, m_i += w m_p, and the walls' image mass.
    P2gInit,
    /// Density from the grid mass, pressure and stress, the momentum scatter.
    P2g,
    /// Several ranks only: the partial sums on each rank's ghost planes, sent to the planes' owner and
    /// added there (`dist::halo`).
    HaloSum,
    /// The walls' image momentum, momentum to velocity, gravity, boundaries and colliders.
    GridUpdate,
    /// Several ranks only: the owners' updated nodes, sent back to the ranks that hold them as ghosts.
    HaloFill,
    /// Velocity and C from the grid, advection, boundaries, sinks.
    G2p,
}

impl Phase {
    pub const COUNT: usize = 8;
    pub const ALL: [Phase; Phase::COUNT] = [
        Phase::GridClear,
        Phase::Sort,
        Phase::P2gInit,
        Phase::P2g,
        Phase::HaloSum,
        Phase::GridUpdate,
        Phase::HaloFill,
        Phase::G2p,
    ];

    /// The key in tables and JSON, and the NVTX range's name.
    pub const fn name(self) -> &'static str {
        match self {
            Phase::GridClear => "grid_clear",
            Phase::Sort => "sort",
            Phase::P2gInit => "p2g_init",
            Phase::P2g => "p2g",
            Phase::HaloSum => "halo_sum",
            Phase::GridUpdate => "grid_update",
            Phase::HaloFill => "halo_fill",
            Phase::G2p => "g2p",
        }
    }

    /// Whether the CUDA backend runs (and times) the phase with work of its own: all but grid_clear,
    /// which is folded into the grid update there (the halo exchanges have work only on ranks).
    pub const fn runs_on_gpu(self) -> bool {
        !matches!(self, Phase::GridClear)
    }

    /// Whether the phase is one of the exchanges between ranks.
    pub const fn is_exchange(self) -> bool {
        matches!(self, Phase::HaloSum | Phase::HaloFill)
    }

    /// The least device-memory traffic of the phase per substep, bytes: every particle array a kernel
    /// must read or write, once, and every grid array a grid-wide kernel walks, once. The scatter's and
    /// gather's grid traffic is left out: at the report's sizes the touched part of the grid stays in
    /// L2 (the float4 accumulators of a 100^3 grid are 16 MB; the H200's L2 holds 50 MB). Hence a
    /// floor, not an estimate of the traffic.
    ///
    /// The report's pipeline:
    /// - sort (every `sort_interval` substeps, amortised): key from x (16 B) -> key, rank (8 B);
    ///   scatter (key, rank 8 B -> order 4 B); per node: clear, count scan read + write, start read
    ///   (16 B).
    /// - p2g_init: order (4 B) and x (16 B) per particle.
    /// - p2g: order, x, v, C (3 float4), rho written: 4 + 16 + 16 + 48 + 4 = 88 B per particle.
    /// - grid_update: accumulators read and zeroed, velocities written: 3 x 16 B per node (float
    ///   scatter; fixed point reads and zeroes 32 B and writes 16 B: 80 B).
    /// - g2p: x read and written, v and C written: 16 + 16 + 16 + 48 = 96 B per particle.
    ///
    /// The binned pipeline walks only the nodes the fluid covers, at least one per 8 particles (rest
    /// density); the grid update's per-node bytes are as above, over those nodes:
    /// - sort (rebinning, when a particle moved about a cell): its cadence depends on the flow, so no
    ///   floor is claimed for it.
    /// - p2g_init (the mirror passes over the wall slabs only): no floor claimed.
    /// - p2g (p2g_tiled): as the report's, 88 B per particle.
    /// - g2p (g2p2g): order, x and rho read, x, v, C written: 4 + 16 + 4 + 16 + 16 + 48 = 104 B per
    ///   particle.
    ///
    /// The fused pipeline is the binned one with the p2g pass gone:
    /// - p2g: nothing.
    /// - g2p (one_pass): order and x read, x, v, C and rho written: 4 + 16 + 16 + 16 + 48 + 4 = 104 B
    ///   per particle: the whole substep's particle traffic.
    pub fn traffic_floor(self, t: &Traffic) -> f64 {
        let (n, g) = (t.particles as f64, t.nodes as f64);
        let grid_update_per_node = if t.fixed_point { 80.0 } else { 48.0 };
        match (t.pipeline, self) {
            (_, Phase::GridClear | Phase::HaloSum | Phase::HaloFill) => 0.0,
            (Pipeline::Report, Phase::Sort) => (36.0 * n + 16.0 * g) / f64::from(t.sort_interval),
            (Pipeline::Report, Phase::P2gInit) => 20.0 * n,
            (Pipeline::Report, Phase::GridUpdate) => grid_update_per_node * g,
            (Pipeline::Report, Phase::G2p) => 96.0 * n,
            (Pipeline::Binned | Pipeline::Fused, Phase::Sort | Phase::P2gInit) => 0.0,
            (Pipeline::Binned | Pipeline::Fused, Phase::GridUpdate) => {
                grid_update_per_node * (n / 8.0).min(g)
            }
            (Pipeline::Binned | Pipeline::Fused, Phase::G2p) => 104.0 * n,
            (Pipeline::Fused, Phase::P2g) => 0.0,
            (_, Phase::P2g) => 88.0 * n,
        }
    }

    /// What the phase holds on a CPU backend, for the bench tables.
    pub fn cpu_label(self) -> String {
        match self {
            Phase::Sort => {
                "sort (cpu-parallel's binning; the ranks' migration; none in the reference)".into()
            }
            Phase::HaloSum | Phase::HaloFill => format!("{} (several ranks only)", self.name()),
            phase => phase.name().into(),
        }
    }
}

/// What a GPU substep's traffic floor depends on (`Phase::traffic_floor`).
pub struct Traffic {
    pub particles: usize,
    pub nodes: usize,
    pub fixed_point: bool,
    pub pipeline: Pipeline,
    /// Substeps between sorts (the report pipeline's sort is amortised over them).
    pub sort_interval: u32,
}

/// Time per phase, summed over `steps` substeps, in milliseconds. The one record of timings that the
/// runner, the viewer's HUD and the benches read. The CPU measures with a host clock (its phases are
/// synchronous, [`PhaseClock`]); the CUDA backend with events. A phase a backend does not run stays 0.
/// Of the `steps`, `unphased` were timed whole, without their phases (the CUDA backend times the
/// phases of a sample of its substeps, src/cuda/timing.rs): their time is `unphased_ms`, and the
/// phases' times are the other substeps'.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PhaseTimings {
    pub steps: u32,
    ms: [f64; Phase::COUNT],
    pub unphased: u32,
    pub unphased_ms: f64,
}

impl Index<Phase> for PhaseTimings {
    type Output = f64;
    fn index(&self, phase: Phase) -> &f64 {
        &self.ms[phase as usize]
    }
}

impl IndexMut<Phase> for PhaseTimings {
    fn index_mut(&mut self, phase: Phase) -> &mut f64 {
        &mut self.ms[phase as usize]
    }
}

impl PhaseTimings {
    /// A record of one substep, every phase at 0 ms.
    pub fn one_step() -> PhaseTimings {
        PhaseTimings {
            steps: 1,
            ..PhaseTimings::default()
        }
    }

    /// A record of one substep timed whole: `ms` from its start to its end.
    pub fn one_unphased_step(ms: f64) -> PhaseTimings {
        PhaseTimings {
            steps: 1,
            unphased: 1,
            unphased_ms: ms,
            ..PhaseTimings::default()
        }
    }

    pub fn accumulate(&mut self, other: &PhaseTimings) {
        self.steps += other.steps;
        for phase in Phase::ALL {
            self[phase] += other[phase];
        }
        self.unphased += other.unphased;
        self.unphased_ms += other.unphased_ms;
    }

    /// The substeps whose phases were timed (those the phases' times are of).
    pub fn phased(&self) -> u32 {
        self.steps - self.unphased
    }

    /// Each phase with its time, in step order.
    pub fn iter(&self) -> impl Iterator<Item = (Phase, f64)> + '_ {
        Phase::ALL.into_iter().map(|phase| (phase, self[phase]))
    }

    /// Every substep's time, phased or not.
    pub fn total(&self) -> f64 {
        self.ms.iter().sum::<f64>() + self.unphased_ms
    }

    /// Milliseconds per substep of the whole step.
    pub fn per_step(&self) -> f64 {
        if self.steps == 0 {
            0.0
        } else {
            self.total() / f64::from(self.steps)
        }
    }

    /// The sum of per-substep records.
    pub fn sum(records: &[PhaseTimings]) -> PhaseTimings {
        let mut total = PhaseTimings::default();
        for record in records {
            total.accumulate(record);
        }
        total
    }
}

/// `{"steps": n, "grid_clear": ms, "sort": ms, ..., "unphased_steps": k, "unphased_ms": ms}`: the
/// phases' names as keys, in step order, then the substeps timed whole (their phases' times are
/// those of the other n - k).
impl Serialize for PhaseTimings {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut record = serializer.serialize_struct("PhaseTimings", 3 + Phase::COUNT)?;
        record.serialize_field("steps", &self.steps)?;
        for (phase, ms) in self.iter() {
            record.serialize_field(phase.name(), &ms)?;
        }
        record.serialize_field("unphased_steps", &self.unphased)?;
        record.serialize_field("unphased_ms", &self.unphased_ms)?;
        record.end()
    }
}

/// The CPU backends' timer: a substep's phases run synchronously, so the host clock between two laps
/// is the phase's time.
pub struct PhaseClock {
    last: Instant,
    times: PhaseTimings,
}

impl PhaseClock {
    pub fn start() -> PhaseClock {
        PhaseClock {
            last: Instant::now(),
            times: PhaseTimings::one_step(),
        }
    }

    /// The time since the last lap (or the start) was `phase`'s.
    pub fn lap(&mut self, phase: Phase) {
        let now = Instant::now();
        self.times[phase] += (now - self.last).as_secs_f64() * 1e3;
        self.last = now;
    }

    /// The substep's record.
    pub fn finish(self) -> PhaseTimings {
        self.times
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_phases_are_listed_once_in_step_order_with_distinct_names() {
        for (i, phase) in Phase::ALL.into_iter().enumerate() {
            assert_eq!(phase as usize, i, "{phase:?} out of step order");
        }
        let mut names: Vec<&str> = Phase::ALL.iter().map(|p| p.name()).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), Phase::COUNT);
    }

    #[test]
    fn substeps_timed_whole_count_in_the_total_not_in_the_phases() {
        let mut phased = PhaseTimings::one_step();
        phased[Phase::G2p] = 2.0;
        phased[Phase::GridUpdate] = 0.5;
        let sum = PhaseTimings::sum(&[
            phased,
            PhaseTimings::one_unphased_step(2.25),
            PhaseTimings::one_unphased_step(2.5),
        ]);
        assert_eq!((sum.steps, sum.phased(), sum.unphased), (3, 1, 2));
        assert_eq!(sum[Phase::G2p], 2.0);
        assert_eq!(sum.total(), 7.25);
        assert_eq!(sum.per_step(), 7.25 / 3.0);
    }

    #[test]
    fn timings_serialise_with_the_phase_names_as_keys() {
        let mut t = PhaseTimings::one_step();
        t[Phase::P2g] = 1.5;
        let json = serde_json::to_string(&t).unwrap();
        assert_eq!(
            json,
            r#"{"steps":1,"grid_clear":0.0,"sort":0.0,"p2g_init":0.0,"p2g":1.5,"halo_sum":0.0,"grid_update":0.0,"halo_fill":0.0,"g2p":0.0,"unphased_steps":0,"unphased_ms":0.0}"#
        );
    }
}
