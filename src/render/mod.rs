//! The viewer: everything that draws. The simulation core (`crate::sim`) knows nothing of this.
//!
//! - [`camera`]: orbit/pan/zoom camera (glam) that frames the domain.
//! - [`renderer`]: points, sphere impostors, domain wireframe, colour bar (glow); shared by the
//!   window and the headless path.
//! - [`colliders`]: the colliders drawn solid and shaded, and dragged with the mouse.
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
pub mod headless;
pub mod hud;
pub mod offline;
pub mod renderer;

pub use camera::OrbitCamera;
pub use feed::{ParticleFeed, Transfer};
pub use renderer::{Colouring, DrawMode, RenderSettings, Renderer, Viewport};
