//! kernels/bodies.cu: the rigid bodies on the device. Their states, contact features and fixed-point
//! impulse sums live here from the start of a run; the grid update adds each body's impulse, and
//! step_bodies (after it, in the grid update phase) moves the bodies and writes each one's collider
//! state into its slot, so no substep waits for the host.

use super::colliders::DeviceColliders;
use super::launch::{host_kernel, Launcher};
use crate::contract::{BodyContact, BodyMotion, BodyWalls, ContactFeature, RigidBody, MAX_BODY_CONTACTS};
use crate::sim::colliders::bodies::BodiesState;
use crate::sim::Params;
use anyhow::{Context, Result};
use cudarc::driver::{CudaSlice, CudaStream, LaunchConfig, PushKernelArg};
use std::sync::Arc;

host_kernel!(StepBodies = "bodies" / "step_bodies");

pub struct DeviceBodies {
    pub states: CudaSlice<RigidBody>,
    pub count: u32,
    features: CudaSlice<ContactFeature>,
    /// Six fixed-point sums per body (`BODY_IMPULSE_UNITS`, two's complement): the grid update and
    /// the particle backstop add, step_bodies reads and zeroes.
    pub impulses: CudaSlice<u64>,
    walls: BodyWalls,
    /// step_bodies' scratch: each body's motion over the substep, its contacts
    /// (`MAX_BODY_CONTACTS` each) and how many it found.
    motions: CudaSlice<BodyMotion>,
    contacts: CudaSlice<BodyContact>,
    contact_counts: CudaSlice<u32>,
    /// The states uploaded: where the first upload of the collider states puts the bodies' slots
    /// (colliders.rs), which step_bodies writes from then on.
    pub uploaded: Vec<RigidBody>,
}

impl DeviceBodies {
    /// `bodies`: their states and pending impulse sums, at the start or a checkpoint's.
    pub fn upload(
        stream: &Arc<CudaStream>,
        bodies: &BodiesState,
        features: &[ContactFeature],
        walls: BodyWalls,
    ) -> Result<DeviceBodies> {
        bodies.check()?;
        let features = if features.is_empty() {
            stream.alloc_zeros::<ContactFeature>(1)
        } else {
            stream.clone_htod(features)
        }
        .context("uploading the rigid bodies' contact features")?;
        let impulses: &[u64] = bytemuck::cast_slice(&bodies.impulses);
        Ok(DeviceBodies {
            states: stream
                .clone_htod(&bodies.states)
                .context("uploading the rigid bodies")?,
            count: bodies.states.len() as u32,
            features,
            impulses: stream
                .clone_htod(impulses)
                .context("uploading the rigid bodies' impulse sums")?,
            walls,
            motions: stream
                .alloc_zeros::<BodyMotion>(bodies.states.len())
                .context("allocating the rigid bodies' motions")?,
            contacts: stream
                .alloc_zeros::<BodyContact>(bodies.states.len() * MAX_BODY_CONTACTS as usize)
                .context("allocating the rigid bodies' contacts")?,
            contact_counts: stream
                .alloc_zeros::<u32>(bodies.states.len())
                .context("allocating the rigid bodies' contact counts")?,
            uploaded: bodies.states.clone(),
        })
    }

    /// The bodies as they are now (waits for the stream).
    pub fn read(&self, stream: &Arc<CudaStream>) -> Result<Vec<RigidBody>> {
        stream
            .clone_dtoh(&self.states)
            .context("reading the rigid bodies back")
    }

    /// Their impulse sums as they are now (waits for the stream).
    pub fn read_impulses(&self, stream: &Arc<CudaStream>) -> Result<Vec<[i64; 6]>> {
        let sums = stream
            .clone_dtoh(&self.impulses)
            .context("reading the rigid bodies' impulse sums back")?;
        Ok(sums
            .chunks_exact(6)
            .map(|row| std::array::from_fn(|k| row[k] as i64))
            .collect())
    }
}

impl StepBodies {
    /// One block, a warp per body (a scene has at most `MAX_COLLIDERS` of them), over the
    /// colliders' states as this substep left them; each body's state goes into its slot.
    pub fn launch(&self, l: &Launcher, params: &Params, colliders: &DeviceColliders) -> Result<()> {
        let Some(bodies) = &colliders.bodies else {
            return Ok(());
        };
        let config = LaunchConfig {
            grid_dim: (1, 1, 1),
            block_dim: (32 * bodies.count, 1, 1),
            shared_mem_bytes: 0,
        };
        // SAFETY: the arguments match step_bodies; each body's slot and features lie in the buffers
        // (Colliders::rigid_bodies laid them out), the scratch holds a row per body.
        unsafe {
            self.0.launch(l, config, |a| {
                a.arg(&params.kernel)
                    .arg(&bodies.walls)
                    .arg(&bodies.count)
                    .arg(&bodies.states)
                    .arg(&bodies.features)
                    .arg(&bodies.impulses)
                    .arg(&colliders.states)
                    .arg(&colliders.count)
                    .arg(&colliders.sdf)
                    .arg(&bodies.motions)
                    .arg(&bodies.contacts)
                    .arg(&bodies.contact_counts);
            })
        }
    }
}
