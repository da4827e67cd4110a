//! Making a [`CudaSolver`] for a scene: its particles spawned on the device, or uploaded (a scene
//! with emitters, sinks or colliders, a test's state, a checkpoint). `CudaSolver::allocate` checks
//! the scene, opens the GPU, loads its kernels and allocates every buffer first.

use super::gpu::CudaOptions;
use super::grid::GridBox;
use super::solver::CudaSolver;
use super::spawn::spawn_on_device;
use crate::sim::flow::FlowState;
use crate::sim::{Particles, Scene};
use anyhow::{ensure, Result};

impl CudaSolver {
    /// Spawns `scene`'s particles on the device, in the order of `Scene::spawn()`. A scene with
    /// emitters or sinks is spawned on the host (its parked slots with it) and uploaded, and so is one
    /// with colliders (the device lattice knows nothing of colliders, whose insides get no fluid),
    /// and one with solids (their deformation starts at rest on the host).
    pub fn new(scene: &Scene, options: CudaOptions) -> Result<CudaSolver> {
        if scene.flow.is_active() || !scene.colliders.is_empty() || scene.has_deformation() {
            return CudaSolver::restore(scene, &scene.spawn(), None, options);
        }
        let solver = CudaSolver::allocate(
            scene,
            (scene.slots(), GridBox::whole(scene.grid_res)),
            None,
            options,
        )?;
        spawn_on_device(&solver.gpu, &solver.kernels.spawn, scene, &solver.state.particles)?;
        Ok(solver)
    }

    /// Uploads `particles` (for tests: any state, not only a spawned one) into a solver for `scene`'s
    /// grid, material and pipeline.
    pub fn from_particles(scene: &Scene, particles: &Particles, options: CudaOptions) -> Result<CudaSolver> {
        CudaSolver::restore(scene, particles, None, options)
    }

    /// Uploads a saved state: `particles` (every slot) and, for a scene with emitters or sinks, the
    /// lifecycle's `flow` state (`None`: the scene's start).
    pub fn restore(
        scene: &Scene,
        particles: &Particles,
        flow: Option<&FlowState>,
        options: CudaOptions,
    ) -> Result<CudaSolver> {
        if scene.flow.is_active() {
            ensure!(
                particles.len() == scene.slots(),
                "{} particle slots for a scene of {}",
                particles.len(),
                scene.slots()
            );
        }
        CudaSolver::upload(scene, (particles, GridBox::whole(scene.grid_res)), flow, options)
    }

    /// A rank's solver (cuda_ranks.rs): `share` at its places, each carrying its slot in the run
    /// (`slots`), on a grid of the nodes of `held` (its slab and ghost planes); where the scene has
    /// emitters or sinks, the run's lifecycle in `flow`, whose free slots and nozzle points name the
    /// run's slots, and each held slot's place in `position`.
    pub(super) fn rank(
        scene: &Scene,
        (share, slots): (&Particles, &[u32]),
        held: GridBox,
        flow: Option<&FlowState>,
        options: CudaOptions,
    ) -> Result<CudaSolver> {
        let mut solver = CudaSolver::upload(scene, (share, held), flow, options)?;
        let stream = solver.gpu.stream().clone();
        solver.state.particles.upload_slots(&stream, slots)?;
        if let Some(flow) = &mut solver.state.flow {
            flow.share_with_ranks(&stream, slots)?;
        }
        Ok(solver)
    }

    /// `particles` at their places, in a solver of as many places; the lifecycle in `flow`.
    fn upload(
        scene: &Scene,
        (particles, held): (&Particles, GridBox),
        flow: Option<&FlowState>,
        options: CudaOptions,
    ) -> Result<CudaSolver> {
        let mut scene = scene.clone();
        if !scene.flow.is_active() {
            scene.num_particles = particles.len();
            scene.flow.capacity = particles.len();
        }
        let mut solver = CudaSolver::allocate(&scene, (particles.len(), held), flow, options)?;
        solver.state.particles.upload(solver.gpu.stream(), particles)?;
        if let Some(pbmpm) = &mut solver.pbmpm {
            pbmpm.upload_bias(solver.gpu.stream(), particles)?;
        }
        Ok(solver)
    }
}
