//! kernels/bin_order.cu: after each binning the fused pipeline and the position-based solver gather
//! their particles into the bins' order, in spare buffers, which the solver then swaps in
//! (`CudaSolver::swap_particle_buffers`), so that one_pass and the position-based passes read each
//! chunk's particles from consecutive memory. Each particle's slot travels with it, and its
//! deformation where the scene has solids, and the position-based solver's volume bias; so does the
//! lifecycle's slot -> place map where the scene has emitters or sinks.

use super::launch::{host_kernel, Launcher, OptionalArg};
use super::state::{DeviceState, StateArgs};
use anyhow::Result;
use cudarc::driver::{CudaSlice, PushKernelArg};

host_kernel!(GatherIntoBinOrder = "bin_order" / "gather_into_bin_order");

impl GatherIntoBinOrder {
    /// Gathers the particles into bin order in the spare buffers (and `bias`, the position-based
    /// volume biases, into its spare), leaving the bins' `order` the identity; nothing where the
    /// state keeps its particles in place. Whether it launched: the caller swaps the buffers then.
    pub fn launch(
        &self,
        l: &Launcher,
        state: &DeviceState,
        bias: Option<(&CudaSlice<f32>, &CudaSlice<f32>)>,
    ) -> Result<bool> {
        let Some(bin_order) = &state.bin_order else {
            return Ok(false);
        };
        let (from, to) = (&state.particles, &bin_order.spare);
        let n = from.count as u32;
        let live_only = u32::from(state.flow.as_ref().is_some_and(|flow| flow.shared));
        // SAFETY: the arguments match gather_into_bin_order; both particle sets hold n slots of
        // each array, `order` is a permutation of 0..n (the binning just wrote it), `position`
        // holds a place per slot of the run (or is null without a flow; a rank's writes only its
        // live particles' slots, each held once), both sets hold a deformation or
        // neither does (null, not read), and the biases, where given, hold n floats each.
        unsafe {
            self.0.launch(l, l.cover(from.count), |a| {
                a.arg(&n)
                    .arg(&state.bins.order)
                    .particle_state(from)
                    .arg(&from.slot)
                    .deformation(from)
                    .particle_state(to)
                    .arg(&to.slot)
                    .deformation(to)
                    .arg_or_null(state.flow.as_ref().map(|flow| &flow.position))
                    .arg(&live_only)
                    .arg_or_null(bias.map(|(from, _)| from))
                    .arg_or_null(bias.map(|(_, to)| to));
            })?;
        }
        Ok(true)
    }
}
