//! Inflow and drains: emitters (nozzles that add fluid), sinks (boxes that remove it), and the
//! particle lifecycle behind them.
//!
//! A scene with a flow allocates `capacity` particle slots up front. A slot is live or parked: parked
//! slots keep their index (particles are never compacted, so the order of every sum and the
//! fixed-point scatter's determinism are untouched) and take part in nothing: not the grid, the bins,
//! the statistics, the rendering or the export. The free slots form a stack:
//!
//! - A **sink** parks every live particle that ends a substep inside its box and pushes its slot on
//!   the stack. On the GPU this is a test inside g2p2g, which visits each live particle anyway (no
//!   pass over the slots of its own); the CPU backends test in a pass after g2p.
//! - An **emitter** is a nozzle, a disc or a rectangle of lattice points (spacing h = dx / particles
//!   per axis) facing along its normal. It emits a layer, one particle per point, each time the
//!   volume it has delivered falls a layer behind its rate (a phase the simulation keeps, the same on
//!   every backend); each point takes the top slot of the stack, in point order. A point whose last
//!   particle is still live and within [`CLEARANCE`] h of it skips its turn (the jet is stalled there):
//!   a stalled jet is not packed tighter. Only the point's own last particle is looked at, not fluid
//!   that arrives from elsewhere, so nozzles belong above the water they feed. A point that finds the stack empty is
//!   counted as exhausted and reported. Emission is O(points emitted), draining O(drained).
//! - After each substep's drains, the slots they pushed are sorted (highest first, so the lowest free
//!   index comes off first): which slot a new particle gets is then fixed by *which* particles drained,
//!   never by the order threads pushed them, and runs stay reproducible.

use glam::{DVec3, Vec3};
use serde::Serialize;

/// Emitters a scene may have (the per-substep emission mask is one 32-bit word).
pub const MAX_EMITTERS: usize = 32;
/// A nozzle point emits only once its last particle is this many particle spacings away.
pub const CLEARANCE: f32 = 0.75;
/// Marks a nozzle point that has not emitted yet.
pub use crate::contract::NO_PARTICLE;

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Nozzle {
    /// A disc of this radius, m.
    Disc { radius: f64 },
    /// A rectangle of these side lengths, m, along the two axes of [`frame`] across the normal.
    Rectangle { size: [f64; 2] },
}

#[derive(Debug, Clone, PartialEq)]
pub struct Emitter {
    pub nozzle: Nozzle,
    pub center: DVec3,
    /// Unit vector, the direction the fluid leaves in.
    pub normal: Vec3,
    /// m/s, along the normal.
    pub speed: f32,
    /// m^3/s of fluid at rest density.
    pub rate: f64,
    /// Where its particles appear: lattice points of the nozzle, h apart.
    pub points: Vec<Vec3>,
    /// The row of the material table it emits.
    pub material: u8,
    /// m past the nozzle that its pipe drives the liquid at `speed` (0: no pipe; `Colliders::set_pipes`).
    pub pipe_length: f64,
}

impl Emitter {
    /// Volume of one layer (a particle per point), m^3.
    pub fn layer_volume(&self, spacing: f64) -> f64 {
        self.points.len() as f64 * spacing.powi(3)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sink {
    pub min: Vec3,
    pub max: Vec3,
}

impl Sink {
    #[inline]
    pub fn contains(&self, x: Vec3) -> bool {
        x.cmpge(self.min).all() && x.cmplt(self.max).all()
    }
}

/// The validated flow of a scene. Without emitters and sinks, `capacity` is the initial particle
/// count and nothing is ever parked.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Flow {
    pub emitters: Vec<Emitter>,
    pub sinks: Vec<Sink>,
    /// Particle slots, live and parked.
    pub capacity: usize,
}

impl Flow {
    pub fn is_active(&self) -> bool {
        !self.emitters.is_empty() || !self.sinks.is_empty()
    }

    /// Whether `x` lies inside one of the sinks: a live particle that ends a substep there drains.
    #[inline]
    pub fn in_a_sink(&self, x: Vec3) -> bool {
        self.sinks.iter().any(|sink| sink.contains(x))
    }

    /// Nozzle points of all emitters, in emitter order.
    pub fn num_points(&self) -> usize {
        self.emitters.iter().map(|e| e.points.len()).sum()
    }
}

/// Two unit vectors across `normal`, with it a right-handed frame.
pub fn frame(normal: Vec3) -> (Vec3, Vec3) {
    normal.any_orthonormal_pair()
}

/// The nozzle's points at spacing `h`: a square lattice across the normal, centred on `center`,
/// those inside the disc or rectangle.
pub fn nozzle_points(nozzle: Nozzle, center: DVec3, normal: Vec3, h: f64) -> Vec<Vec3> {
    let (t1, t2) = frame(normal);
    let (t1, t2) = (t1.as_dvec3(), t2.as_dvec3());
    let (half_u, half_v) = match nozzle {
        Nozzle::Disc { radius } => (radius, radius),
        Nozzle::Rectangle { size } => (0.5 * size[0], 0.5 * size[1]),
    };
    let (nu, nv) = ((half_u / h).floor() as i64, (half_v / h).floor() as i64);
    let mut points = Vec::new();
    for j in -nv..nv {
        for i in -nu..nu {
            let (u, v) = ((i as f64 + 0.5) * h, (j as f64 + 0.5) * h);
            let inside = match nozzle {
                Nozzle::Disc { radius } => u * u + v * v <= radius * radius,
                Nozzle::Rectangle { .. } => u.abs() <= half_u && v.abs() <= half_v,
            };
            if inside {
                points.push((center + t1 * u + t2 * v).as_vec3());
            }
        }
    }
    points
}

/// What the lifecycle did, summed since the run began (a resumed run goes on counting).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct FlowCounts {
    /// Live particles now.
    pub live: u64,
    pub emitted: u64,
    pub drained: u64,
    /// Nozzle points that found no free slot (the scene's capacity was exhausted).
    pub exhausted: u64,
    /// Nozzle points that skipped their turn because their last particle had not moved clear.
    pub blocked: u64,
}

/// The lifecycle's state in a solver, besides the particles' live flags.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FlowState {
    /// Free slots, a stack: emission takes from the end.
    pub free: Vec<u32>,
    /// `free[..sorted]` is in canonical order; what sinks pushed since is sorted at the substep's end.
    pub sorted: usize,
    /// Per nozzle point (all emitters' in order): the slot it filled last, or [`NO_PARTICLE`].
    pub last: Vec<u32>,
    pub counts: FlowCounts,
}

impl FlowState {
    /// The state of a run's start: slots `[live, capacity)` free, the lowest on top.
    pub fn start(flow: &Flow, live: usize) -> FlowState {
        let free: Vec<u32> = (live as u32..flow.capacity as u32).rev().collect();
        FlowState {
            sorted: free.len(),
            free,
            last: vec![NO_PARTICLE; flow.num_points()],
            counts: FlowCounts {
                live: live as u64,
                ..FlowCounts::default()
            },
        }
    }

    /// Sorts the slots pushed since it last ran, highest first (after each substep's drains).
    pub fn settle(&mut self) {
        self.free[self.sorted..].sort_unstable_by(|a, b| b.cmp(a));
        self.sorted = self.free.len();
    }

    /// Parks the live particle in `slot`: what a sink does.
    pub fn drain(&mut self, slot: u32) {
        self.free.push(slot);
        self.counts.drained += 1;
        self.counts.live -= 1;
    }
}

/// Which emitters emit a layer in the next substep of `dt`: each emitter's phase (layers owed) grows
/// by rate dt / layer volume, and a layer is due once it reaches 1. Returns the mask (bit e for
/// emitter e) and the layers that were due beyond one in a substep (the jet cannot keep up at this
/// substep: counted, never silent).
pub fn schedule(flow: &Flow, spacing: f64, dt: f32, phases: &mut [f64]) -> (u32, u64) {
    let mut mask = 0u32;
    let mut late = 0u64;
    for (e, (emitter, phase)) in flow.emitters.iter().zip(phases.iter_mut()).enumerate() {
        *phase += emitter.rate * f64::from(dt) / emitter.layer_volume(spacing);
        if *phase >= 1.0 {
            mask |= 1 << e;
            *phase -= 1.0;
            if *phase >= 1.0 {
                late += phase.floor() as u64;
                *phase = phase.fract();
            }
        }
    }
    (mask, late)
}

/// A solver's lifecycle: the scene's flow and where it stands.
#[derive(Debug, Clone)]
pub struct Lifecycle {
    pub flow: std::sync::Arc<Flow>,
    pub state: FlowState,
    /// The particle spacing h, m.
    pub spacing: f32,
    /// Per row of the material table, its rest density: an emitted particle's first density.
    pub rest_densities: Vec<f32>,
    /// Per row, its deformation at rest, where a row carries one (`Scene::has_deformation`; empty
    /// otherwise): an emitted particle's first, whatever its slot held before.
    pub rest_deformations: Vec<super::scene::Deformation>,
}

impl Lifecycle {
    /// Where `particles` (live flags included) start: a fresh run's spawn or a checkpoint's state.
    pub fn new(scene: &super::Scene, state: FlowState) -> Lifecycle {
        Lifecycle {
            flow: std::sync::Arc::new(scene.flow.clone()),
            state,
            spacing: scene.lattice().spacing as f32,
            rest_densities: scene.materials.iter().map(|m| m.law.rest_density).collect(),
            rest_deformations: if scene.has_deformation() {
                scene
                    .materials
                    .iter()
                    .map(|m| super::scene::Deformation::at_rest(m.law.law))
                    .collect()
            } else {
                Vec::new()
            },
        }
    }

    /// Parks the particle in `slot` if it ended the substep at `x` inside a sink; true if it did.
    #[inline]
    pub fn drains(&mut self, slot: usize, x: Vec3) -> bool {
        if self.flow.in_a_sink(x) {
            self.state.drain(slot as u32);
            true
        } else {
            false
        }
    }

    pub fn emit(&mut self, slots: Slots<'_>, mask: u32) {
        emit(
            &self.flow,
            &mut self.state,
            slots,
            mask,
            self.spacing,
            &self.rest_densities,
            &self.rest_deformations,
        );
    }
}

/// The RGBA a renderer gets for a parked slot: NaN, which the particle shader clips.
pub const PARKED_RENDER_ATTRIBUTES: [f32; 4] = [f32::NAN; 4];

/// The particle slots as a solver holds them, for [`emit`].
pub struct Slots<'a> {
    pub x: &'a mut [Vec3],
    pub v: &'a mut [Vec3],
    pub c: &'a mut [glam::Mat3],
    pub rho: &'a mut [f32],
    pub material: &'a mut [u8],
    pub live: &'a mut [bool],
    /// Empty where no material carries a deformation.
    pub deformation: &'a mut [super::scene::Deformation],
}

impl<'a> Slots<'a> {
    /// The slots of `particles`.
    pub fn of(particles: &'a mut super::Particles) -> Slots<'a> {
        Slots {
            x: &mut particles.x,
            v: &mut particles.v,
            c: &mut particles.c,
            rho: &mut particles.rho,
            material: &mut particles.material,
            live: &mut particles.live,
            deformation: &mut particles.deformation,
        }
    }
}

/// One emission: each point of each emitter in `mask`, in order, that is not blocked takes the top
/// free slot; whether a point is blocked is judged on the state before the emission. The reference of
/// kernels/lifecycle.cu's `emit_particles`; the CPU backends call it as it is.
pub fn emit(
    flow: &Flow,
    state: &mut FlowState,
    slots: Slots<'_>,
    mask: u32,
    spacing: f32,
    rest_densities: &[f32],
    rest_deformations: &[super::scene::Deformation],
) {
    state.settle();
    let clearance_sq = (CLEARANCE * spacing) * (CLEARANCE * spacing);
    let mut wants = Vec::with_capacity(state.last.len());
    let mut point = 0usize;
    for (e, emitter) in flow.emitters.iter().enumerate() {
        let due = mask & (1 << e) != 0;
        for &at in &emitter.points {
            let last = state.last[point];
            point += 1;
            let clear = last == NO_PARTICLE
                || !slots.live[last as usize]
                || (slots.x[last as usize] - at).length_squared() >= clearance_sq;
            if due && !clear {
                state.counts.blocked += 1;
            }
            wants.push(due && clear);
        }
    }
    let points = flow.emitters.iter().flat_map(|e| {
        e.points
            .iter()
            .map(move |&at| (at, e.normal * e.speed, e.material))
    });
    for (point, ((at, velocity, material), _)) in points.zip(&wants).enumerate().filter(|(_, (_, &w))| w) {
        let Some(slot) = state.free.pop() else {
            state.counts.exhausted += 1;
            continue;
        };
        let s = slot as usize;
        slots.x[s] = at;
        slots.v[s] = velocity;
        slots.c[s] = glam::Mat3::ZERO;
        slots.rho[s] = rest_densities[usize::from(material)];
        if let Some(deformation) = slots.deformation.get_mut(s) {
            *deformation = rest_deformations[usize::from(material)];
        }
        slots.material[s] = material;
        slots.live[s] = true;
        state.last[point] = slot;
        state.counts.emitted += 1;
        state.counts.live += 1;
    }
    state.sorted = state.free.len();
}
