//! GPU time per render pass, from OpenGL timer queries (GL_TIME_ELAPSED). A query's result arrives
//! some frames after the commands it wraps; reading it early would stall the CPU until the GPU caught
//! up. So each frame gets its own set of queries from a ring of [`FRAMES_IN_FLIGHT`], and a set is read
//! only once the driver says its results are available: the window never waits on them.

use glow::HasContext;
use std::sync::Arc;

/// The passes a frame is drawn in. Points and spheres draw `Scene`, `Particles`, `Legend`; the surface
/// draws `Scene` (into a texture), `Solids` (where the scene has any), `Depth`, `Thickness`,
/// `Smoothing`, `Shading`, `Legend`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pass {
    /// Clearing, the floor (surface) and the domain box.
    Scene,
    /// Surface: the solids' particles as sphere impostors into the scene texture.
    Solids,
    /// Points or sphere impostors straight into the frame.
    Particles,
    /// Surface: sphere impostors into the fluid depth texture.
    Depth,
    /// Surface: additive splats into the (quarter-resolution by default) thickness texture.
    Thickness,
    /// Surface: the narrow-range filter over the depth, horizontal then vertical.
    Smoothing,
    /// Surface: normals, Fresnel, refraction, absorption, specular, into the frame.
    Shading,
    /// The colour bar and its numbers.
    Legend,
}

impl Pass {
    pub const ALL: [Pass; 8] = [
        Pass::Scene,
        Pass::Solids,
        Pass::Particles,
        Pass::Depth,
        Pass::Thickness,
        Pass::Smoothing,
        Pass::Shading,
        Pass::Legend,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Pass::Scene => "scene",
            Pass::Solids => "solids",
            Pass::Particles => "particles",
            Pass::Depth => "depth",
            Pass::Thickness => "thickness",
            Pass::Smoothing => "smoothing",
            Pass::Shading => "shading",
            Pass::Legend => "legend",
        }
    }
}

/// Milliseconds of GPU time per pass; `None` for a pass the frame did not draw.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PassTimes {
    ms: [Option<f64>; Pass::ALL.len()],
}

impl PassTimes {
    /// The passes drawn, in order, with their milliseconds.
    pub fn iter(&self) -> impl Iterator<Item = (Pass, f64)> + '_ {
        Pass::ALL
            .iter()
            .zip(self.ms)
            .filter_map(|(&pass, ms)| ms.map(|ms| (pass, ms)))
    }

    pub fn get(&self, pass: Pass) -> Option<f64> {
        self.ms[pass as usize]
    }

    /// The sum over the passes drawn: the frame's GPU time for drawing.
    pub fn total(&self) -> f64 {
        self.iter().map(|(_, ms)| ms).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.ms.iter().all(Option::is_none)
    }

    /// Whether every pass's time could be a measurement (see [`MAX_PLAUSIBLE_PASS_MS`]).
    fn is_plausible(&self) -> bool {
        self.iter().all(|(_, ms)| ms <= MAX_PLAUSIBLE_PASS_MS)
    }
}

/// A pass's time above this is no measurement: Mesa's llvmpipe under Xvfb answered one frame's scene
/// pass with 13,430 s (a raw clock reading, as if the query's start had not been recorded), which
/// made the viewer's mean render total read 1.2 million ms. Such a frame's times are dropped.
const MAX_PLAUSIBLE_PASS_MS: f64 = 10_000.0;

/// Query sets in the ring: a frame's results are read up to this many frames later.
pub const FRAMES_IN_FLIGHT: usize = 4;

struct FrameQueries {
    queries: [glow::Query; Pass::ALL.len()],
    used: [bool; Pass::ALL.len()],
    /// Issued and not read yet.
    pending: bool,
}

pub struct GpuTimer {
    gl: Arc<glow::Context>,
    ring: Vec<FrameQueries>,
    /// The set this frame writes; the oldest pending set is the one after it.
    current: usize,
    running: Option<Pass>,
    latest: Option<PassTimes>,
    sums: [f64; Pass::ALL.len()],
    counts: [u64; Pass::ALL.len()],
    frames_summed: u64,
    /// Sets that were still pending when their turn came again (results lost, never waited for).
    dropped: u64,
}

impl GpuTimer {
    pub fn new(gl: Arc<glow::Context>) -> Result<GpuTimer, String> {
        let mut ring = Vec::with_capacity(FRAMES_IN_FLIGHT);
        for _ in 0..FRAMES_IN_FLIGHT {
            let mut queries = Vec::with_capacity(Pass::ALL.len());
            for _ in Pass::ALL {
                // SAFETY: the context is current (the renderer's constructor runs on its thread).
                queries.push(unsafe { gl.create_query()? });
            }
            ring.push(FrameQueries {
                queries: queries.try_into().expect("one query per pass"),
                used: [false; Pass::ALL.len()],
                pending: false,
            });
        }
        Ok(GpuTimer {
            gl,
            ring,
            current: 0,
            running: None,
            latest: None,
            sums: [0.0; Pass::ALL.len()],
            counts: [0; Pass::ALL.len()],
            frames_summed: 0,
            dropped: 0,
        })
    }

    /// Reads what has arrived, then takes the next set for this frame.
    pub fn begin_frame(&mut self) {
        self.collect();
        self.current = (self.current + 1) % self.ring.len();
        let set = &mut self.ring[self.current];
        if set.pending {
            self.dropped += 1;
        }
        set.pending = false;
        set.used = [false; Pass::ALL.len()];
    }

    /// Starts timing `pass` (ending the pass still running, if any: GL allows one at a time).
    pub fn begin(&mut self, pass: Pass) {
        self.end();
        let set = &mut self.ring[self.current];
        set.used[pass as usize] = true;
        // SAFETY: a query of this context; no other TIME_ELAPSED query is active (ended above).
        unsafe {
            self.gl
                .begin_query(glow::TIME_ELAPSED, set.queries[pass as usize])
        };
        self.running = Some(pass);
    }

    /// Ends the pass being timed.
    pub fn end(&mut self) {
        if self.running.take().is_some() {
            // SAFETY: a TIME_ELAPSED query is active (begun above).
            unsafe { self.gl.end_query(glow::TIME_ELAPSED) };
        }
    }

    pub fn end_frame(&mut self) {
        self.end();
        let set = &mut self.ring[self.current];
        set.pending = set.used.iter().any(|&u| u);
    }

    /// Reads every set whose results have all arrived, oldest first, without waiting for any.
    pub fn collect(&mut self) {
        let n = self.ring.len();
        for age in 1..=n {
            let index = (self.current + age) % n;
            let set = &self.ring[index];
            if !set.pending {
                continue;
            }
            let gl = &self.gl;
            // SAFETY: queries of this context that were ended; availability is asked before results.
            let ready = set.used.iter().zip(&set.queries).all(|(&used, &q)| {
                !used || unsafe { gl.get_query_parameter_u32(q, glow::QUERY_RESULT_AVAILABLE) != 0 }
            });
            if !ready {
                // Later sets finish later: stop at the first one not done.
                break;
            }
            let mut times = PassTimes::default();
            for (k, (&used, &q)) in set.used.iter().zip(&set.queries).enumerate() {
                if used {
                    let mut nanoseconds = 0u64;
                    // SAFETY: the result is available (checked above); with no buffer bound to
                    // GL_QUERY_BUFFER the "offset" is the address the u64 is written to.
                    unsafe {
                        gl.get_query_parameter_u64_with_offset(
                            q,
                            glow::QUERY_RESULT,
                            &mut nanoseconds as *mut u64 as usize,
                        )
                    };
                    times.ms[k] = Some(nanoseconds as f64 * 1e-6);
                }
            }
            self.ring[index].pending = false;
            if !times.is_plausible() {
                self.dropped += 1;
                continue;
            }
            for (k, ms) in times.ms.iter().enumerate() {
                if let Some(ms) = ms {
                    self.sums[k] += ms;
                    self.counts[k] += 1;
                }
            }
            self.frames_summed += 1;
            self.latest = Some(times);
        }
    }

    /// The newest frame whose times have arrived.
    pub fn latest(&self) -> Option<PassTimes> {
        self.latest
    }

    /// Mean milliseconds per pass over the frames read since the last [`reset_means`](Self::reset_means),
    /// and how many frames that is.
    pub fn means(&self) -> (u64, PassTimes) {
        let mut times = PassTimes::default();
        for k in 0..Pass::ALL.len() {
            if self.counts[k] > 0 {
                times.ms[k] = Some(self.sums[k] / self.counts[k] as f64);
            }
        }
        (self.frames_summed, times)
    }

    pub fn reset_means(&mut self) {
        self.sums = [0.0; Pass::ALL.len()];
        self.counts = [0; Pass::ALL.len()];
        self.frames_summed = 0;
    }

    /// Frames whose times were lost: the GPU had not finished them four frames later, or a pass's
    /// time was implausible ([`MAX_PLAUSIBLE_PASS_MS`]).
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    pub fn destroy(&mut self) {
        for set in &self.ring {
            for &q in &set.queries {
                // SAFETY: our queries, deleted once.
                unsafe { self.gl.delete_query(q) };
            }
        }
        self.ring.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_raw_clock_reading_is_no_pass_time() {
        let mut times = PassTimes::default();
        times.ms[Pass::Scene as usize] = Some(0.3);
        times.ms[Pass::Depth as usize] = Some(1.2);
        assert!(times.is_plausible());
        // What llvmpipe under Xvfb answered once for the scene pass: 13,430 s.
        times.ms[Pass::Scene as usize] = Some(13_430_425.352_158);
        assert!(!times.is_plausible());
    }
}
