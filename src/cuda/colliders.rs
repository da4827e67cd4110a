//! The colliders on the device (kernels/colliders.cuh): the states of the current substep, uploaded
//! when they change (every substep for moving colliders, once for static ones), and the mesh
//! colliders' distance samples, uploaded once; and the rigid bodies (bodies.rs), whose slots in the
//! states the device writes after the first upload.

use super::bodies::DeviceBodies;
use crate::sim::colliders::{ColliderFrame, ColliderState, MAX_COLLIDERS};
use crate::sim::flow::MAX_EMITTERS;
use anyhow::{ensure, Context, Result};
use cudarc::driver::{CudaSlice, CudaStream};
use std::borrow::Cow;
use std::sync::Arc;

/// The colliders, then the emitters' pipes.
const MAX_STATES: usize = MAX_COLLIDERS + MAX_EMITTERS;

pub struct DeviceColliders {
    pub states: CudaSlice<ColliderState>,
    /// Colliders the kernels loop over (a kernel argument: part of a captured substep's key).
    pub count: u32,
    /// What `states` holds, to skip uploads of an unchanged frame.
    uploaded: Vec<ColliderState>,
    pub sdf: CudaSlice<f32>,
    /// The host buffer `sdf` was copied from.
    sdf_source: Option<Arc<[f32]>>,
    /// The rigid bodies, where the scene has some.
    pub bodies: Option<DeviceBodies>,
    /// Whether a collider has Coulomb friction: under the walls' mirror the grid update then reads
    /// the nodes' own sums (`ColliderFrame::has_friction`).
    pub friction: bool,
}

impl DeviceColliders {
    pub fn allocate(stream: &Arc<CudaStream>) -> Result<DeviceColliders> {
        Ok(DeviceColliders {
            states: stream
                .alloc_zeros::<ColliderState>(MAX_STATES)
                .context("allocating the collider states")?,
            count: 0,
            uploaded: Vec::new(),
            sdf: stream
                .alloc_zeros::<f32>(1)
                .context("allocating the collider SDF")?,
            sdf_source: None,
            bodies: None,
            friction: false,
        })
    }

    /// Takes `bodies` (or none) as the rigid bodies from the next substep on, and makes the next
    /// upload a first one, which places every body's slot from the states just uploaded: a body
    /// dropped into a running scene has no slot on the device yet (step_bodies writes a slot's pose,
    /// never its shape, boundary or body index), and the slot it takes may have held an emitter's
    /// pipe. The bodies already there get their slots again from their states as read back, in the
    /// device's rounding: the same bits step_bodies left in them.
    pub fn set_bodies(&mut self, bodies: Option<DeviceBodies>) {
        self.bodies = bodies;
        self.uploaded.clear();
    }

    /// Uploads the states where they changed, and the mesh samples once (in stream order, so the
    /// substeps already enqueued keep the states they were launched with).
    pub fn set(&mut self, stream: &Arc<CudaStream>, frame: &ColliderFrame) -> Result<()> {
        ensure!(
            frame.states.len() <= MAX_STATES,
            "{} colliders and pipes, more than the {MAX_STATES} the kernels take",
            frame.states.len()
        );
        let sdf_is_new = self
            .sdf_source
            .as_ref()
            .is_none_or(|source| !Arc::ptr_eq(source, &frame.sdf));
        if sdf_is_new && !frame.sdf.is_empty() {
            self.sdf = stream
                .clone_htod(&frame.sdf[..])
                .context("uploading the mesh colliders' distance fields")?;
            self.sdf_source = Some(frame.sdf.clone());
        }
        if self.uploaded != frame.states {
            // The first upload puts each rigid body's slot where its uploaded state is (the start, or
            // a checkpoint's), as the host places it; step_bodies writes the slots from then on, so
            // later uploads send only the runs between bodies.
            let first = self.uploaded.is_empty();
            let placed: Cow<[ColliderState]> = match &self.bodies {
                Some(bodies) if first => {
                    let mut placed = frame.clone();
                    placed.place_bodies(&bodies.uploaded);
                    Cow::Owned(placed.states)
                }
                _ => Cow::Borrowed(&frame.states),
            };
            let mut start = 0;
            while start < placed.len() {
                let end = (start..placed.len())
                    .find(|&k| !first && placed[k].body != 0)
                    .unwrap_or(placed.len());
                if end > start {
                    stream
                        .memcpy_htod(&placed[start..end], &mut self.states.slice_mut(start..end))
                        .context("uploading the collider states")?;
                }
                start = end + 1;
            }
            self.uploaded.clone_from(&frame.states);
            self.count = frame.states.len() as u32;
            self.friction = frame.has_friction();
        }
        Ok(())
    }
}
