//! The viewer: everything that draws. The simulation core (`crate::sim`) knows nothing of this.
//!
//! - [`camera`]: orbit/pan/zoom camera (glam) that frames the domain.
//! - [`renderer`]: the draw modes (surface, points, spheres), domain box, floor; shared by the window
//!   and the headless path. [`surface`]: the screen-space water surface; [`legend`]: the colour bar
//!   and its numbers; [`timer`]: GPU time per pass; [`program`]: GLSL compiling and uniforms.
//! - [`colliders`]: the colliders drawn solid and shaded in the scene pass, and dragged with the mouse.
//! - [`flow`]: the emitters' nozzles and the sinks' boxes outlined in the scene pass.
//! - [`feed`]: the particle state into the GL buffer: CUDA-GL interop, or a host copy.
//! - [`capture`]: PNG screenshots and frame sequences, never overwriting.
//! - [`headless`]: an EGL device context and framebuffer (no X server).
//! - [`offline`]: `mpm render`, frames to PNG (and MP4).
//! - [`clock`]: simulated time following wall time, with a cap (slow motion) or fixed per frame.
//! - [`app`]: the window (winit + glutin) and its event loop; [`hud`]: the egui panel.

pub mod app;
pub mod camera;
pub mod capture;
pub mod clock;
pub mod colliders;
pub mod feed;
pub mod flow;
pub mod headless;
pub mod hud;
pub mod legend;
pub mod offline;
mod program;
pub mod renderer;
pub mod surface;
pub mod timer;

/// The quantity particles are coloured by, a property of the particles (`sim`), which the device
/// layer writes too.
pub use crate::sim::ColourBy;
pub use camera::OrbitCamera;
pub use feed::{Fed, ParticleFeed, Transfer};
pub use renderer::{Colouring, DrawMode, RenderSettings, Renderer, Viewport};
pub use surface::SurfaceSettings;
pub use timer::{Pass, PassTimes};
