//! A gate between the simulation's stepping and another user of its GPU. The viewer steps the next
//! frame on one thread while it draws the last on another, and on one GPU the draw's OpenGL work and
//! the stepping's CUDA work come from two contexts, which the GPU does not run side by side. While
//! the stepping kept the CUDA queue full, the draw's work waited behind nearly all of it (BENCHMARKS.md
//! M19). So the viewer closes the gate over its draw, and the stepping enqueues no new stretch of
//! substeps until the draw's work is done: the GPU runs the draw as one block, between stretches.
//! Where a stretch is a whole frame (a fixed step, as the position-based solver's), the stepping
//! passes the gate before each substep and keeps no more than one substep queued (`Solver::pace`):
//! otherwise the draw waited behind a frame of work (M25).

use std::sync::{Condvar, Mutex, MutexGuard};

#[derive(Default)]
pub struct GpuGate {
    closed: Mutex<bool>,
    opened: Condvar,
}

/// The gate held closed; dropping it opens the gate (also where the drawing fails part-way).
pub struct Closed<'a> {
    gate: &'a GpuGate,
}

impl GpuGate {
    fn state(&self) -> MutexGuard<'_, bool> {
        // A thread that panicked while holding the lock left a plain bool behind: still valid.
        self.closed
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Closes the gate until the returned guard goes.
    pub fn close(&self) -> Closed<'_> {
        *self.state() = true;
        Closed { gate: self }
    }

    /// Returns once the gate is open.
    pub fn pass(&self) {
        let mut closed = self.state();
        while *closed {
            closed = self
                .opened
                .wait(closed)
                .unwrap_or_else(|poisoned| poisoned.into_inner());
        }
    }
}

impl Drop for Closed<'_> {
    fn drop(&mut self) {
        *self.gate.state() = false;
        self.gate.opened.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::time::{Duration, Instant};

    #[test]
    fn a_closed_gate_holds_the_stepping_until_it_opens() {
        let gate = Arc::new(GpuGate::default());
        gate.pass(); // open: passes at once
        let closed = gate.close();
        let waiter = {
            let gate = gate.clone();
            std::thread::spawn(move || {
                let start = Instant::now();
                gate.pass();
                start.elapsed()
            })
        };
        std::thread::sleep(Duration::from_millis(50));
        drop(closed);
        let waited = waiter.join().unwrap();
        assert!(
            waited >= Duration::from_millis(40),
            "passed a closed gate after {waited:?}"
        );
    }
}
