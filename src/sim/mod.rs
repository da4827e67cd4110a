//! The simulation core: parameters, scenes, the CPU reference and the step API.
//! It knows nothing of windows, GL or files beyond scene text.

pub mod colliders;
pub mod cpu;
pub mod cpu_parallel;
pub mod dropped;
pub mod flow;
pub mod gpu_gate;
pub mod material;
pub mod mesh;
pub mod params;
pub mod pbmpm;
pub mod phase;
pub mod presets;
pub mod push;
pub mod scene;
pub mod simulation;
pub mod solid;
pub mod solver;
pub mod summary;
pub mod svd;
pub mod view;

pub use colliders::{ColliderFrame, Colliders};
pub use params::{DensityRule, Material, Method, Params, Pipeline, ScatterMode, FRAME_DT};
pub use phase::{Phase, PhaseClock, PhaseTimings, Traffic};
pub use push::Push;
pub use scene::{Deformation, Particles, Scene, SceneError};
pub use simulation::{BodyPose, FrameStats, FrameSteps, RunClock, Simulation};
pub use solver::{
    ExtremesTicket, Holdings, ParticleSnapshot, PendingParticles, RankHolding, Solver, StepExtremes,
    SummaryTicket, MAX_PENDING_STEP_TIMINGS, SNAPSHOTS_IN_FLIGHT,
};
pub use summary::Summary;
pub use view::{ColourBy, DeviceParticleView, ParticleView};
