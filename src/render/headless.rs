//! Rendering without a window or X server: an OpenGL context on an EGL device (glutin's EGL device
//! platform; on an NVIDIA machine, the GPU itself), drawing into a framebuffer object that
//! glReadPixels reads back. `mpm render` and the GPU render tests use it.

use super::capture::Image;
use anyhow::{anyhow, bail, Context, Result};
use glow::HasContext;
use glutin::api::egl::context::PossiblyCurrentContext;
use glutin::api::egl::device::Device;
use glutin::api::egl::display::Display;
use glutin::config::{Api, ConfigSurfaceTypes, ConfigTemplateBuilder};
use glutin::context::PossiblyCurrentGlContext;
use glutin::context::{ContextApi, ContextAttributesBuilder, GlProfile, Version};
use glutin::display::GlDisplay;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// The EGL display of each device a context was made on, by the device's handle: initialized once and
/// kept until [`release_displays`] or the process's end. EGL hands out one display per device however
/// often it is asked, and glutin terminates its reference when a `Display` drops only where EGL
/// counts references, so a display is set up once and shared by every context made on its device.
static DEVICE_DISPLAYS: Mutex<Vec<(usize, Display)>> = Mutex::new(Vec::new());

/// `HeadlessGl`s alive: [`release_displays`] terminates nothing while one is.
static LIVE_CONTEXTS: AtomicUsize = AtomicUsize::new(0);

/// Terminates the EGL displays this process kept, where no `HeadlessGl` is alive (else it does
/// nothing and says so): the driver tears each down now, while the process is whole, instead of in
/// its handlers at exit. Left to those, Mesa's llvmpipe now and then aborted CI's run of
/// tests/headless_render.rs after every test had passed (a double free; then "malloc_consolidate():
/// invalid chunk size"): in one of six fresh-clone CI runs here, never in 16 runs of the test file
/// alone, so the exit-time teardown is the suspect, not a proven cause. A program done with headless
/// rendering calls it once, last.
pub fn release_displays() -> Result<()> {
    let live = LIVE_CONTEXTS.load(Ordering::SeqCst);
    if live > 0 {
        bail!("{live} headless GL context(s) still alive: their EGL displays stay");
    }
    let displays = std::mem::take(&mut *DEVICE_DISPLAYS.lock().unwrap_or_else(|e| e.into_inner()));
    for (_, display) in displays {
        // SAFETY: no context of this module is alive, and nothing else in mpm uses these displays.
        unsafe { display.terminate() };
    }
    Ok(())
}

/// An off-screen GL context and a framebuffer of a fixed size, bound for drawing.
pub struct HeadlessGl {
    gl: Arc<glow::Context>,
    /// Kept alive for `gl`; released and dropped after the GL objects.
    context: PossiblyCurrentContext,
    _display: Display,
    framebuffer: glow::Framebuffer,
    renderbuffers: [glow::Renderbuffer; 2],
    size: [u32; 2],
    /// "vendor, renderer, version", for messages.
    pub description: String,
}

impl HeadlessGl {
    /// A GL 4.5 core context (3.3 core where 4.5 is refused) on the first EGL device that gives one.
    pub fn new(width: u32, height: u32) -> Result<HeadlessGl> {
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            bail!("image size {width}x{height} is out of range (1..=16384 per side)");
        }
        let devices: Vec<Device> = Device::query_devices()
            .map_err(|e| {
                anyhow!(
                    "no EGL device platform ({e}); headless rendering needs libEGL.so.1 (glvnd, Debian/Ubuntu \
                     package libegl1) and a GPU driver's EGL (NVIDIA's, or Mesa's libegl-mesa0)"
                )
            })?
            .collect();
        if devices.is_empty() {
            bail!("EGL lists no devices: no GPU driver with EGL support is installed");
        }
        let mut failures = Vec::new();
        for device in &devices {
            match Self::on_device(device, width, height) {
                Ok(headless) => return Ok(headless),
                Err(why) => failures.push(format!(
                    "{}: {why:#}",
                    device.name().or(device.vendor()).unwrap_or("EGL device")
                )),
            }
        }
        bail!(
            "no EGL device gave an OpenGL 3.3+ core context:\n  {}",
            failures.join("\n  ")
        )
    }

    /// `device`'s display (`DEVICE_DISPLAYS`).
    fn device_display(device: &Device) -> Result<Display> {
        let key = device.raw_device() as usize;
        let mut displays = DEVICE_DISPLAYS.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, display)) = displays.iter().find(|(k, _)| *k == key) {
            return Ok(display.clone());
        }
        // SAFETY: no native display is involved (a device display).
        let display = unsafe { Display::with_device(device, None) }.context("eglGetPlatformDisplay")?;
        displays.push((key, display.clone()));
        Ok(display)
    }

    fn on_device(device: &Device, width: u32, height: u32) -> Result<HeadlessGl> {
        let display = Self::device_display(device)?;
        // A device display has no window configs: ask for pbuffer ones (docs/gpu.md).
        let template = ConfigTemplateBuilder::new()
            .with_surface_type(ConfigSurfaceTypes::PBUFFER)
            .with_api(Api::OPENGL)
            .build();
        // SAFETY: the display is live.
        let config = unsafe { display.find_configs(template) }
            .context("eglChooseConfig")?
            .next()
            .context("the device offers no OpenGL pbuffer config")?;
        let mut last_error = None;
        for version in [Version::new(4, 5), Version::new(3, 3)] {
            let attributes = ContextAttributesBuilder::new()
                .with_context_api(ContextApi::OpenGl(Some(version)))
                .with_profile(GlProfile::Core)
                .build(None);
            // SAFETY: config from this display.
            match unsafe { display.create_context(&config, &attributes) } {
                Ok(context) => {
                    let context = context
                        .make_current_surfaceless()
                        .context("making the context current (surfaceless)")?;
                    return Self::with_context(display, context, width, height);
                }
                Err(e) => last_error = Some(e),
            }
        }
        Err(anyhow!("eglCreateContext: {last_error:?}"))
    }

    fn with_context(
        display: Display,
        context: PossiblyCurrentContext,
        width: u32,
        height: u32,
    ) -> Result<HeadlessGl> {
        // SAFETY: the context is current; the loader is the display's.
        let gl = unsafe { glow::Context::from_loader_function_cstr(|s| display.get_proc_address(s)) };
        let gl = Arc::new(gl);
        // SAFETY: objects created and bound on the current context.
        unsafe {
            let description = format!(
                "{}, {}, OpenGL {}",
                gl.get_parameter_string(glow::VENDOR),
                gl.get_parameter_string(glow::RENDERER),
                gl.get_parameter_string(glow::VERSION)
            );
            let framebuffer = gl
                .create_framebuffer()
                .map_err(|e| anyhow!("glCreateFramebuffer: {e}"))?;
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(framebuffer));
            let colour = gl
                .create_renderbuffer()
                .map_err(|e| anyhow!("glCreateRenderbuffer: {e}"))?;
            gl.bind_renderbuffer(glow::RENDERBUFFER, Some(colour));
            gl.renderbuffer_storage(glow::RENDERBUFFER, glow::RGBA8, width as i32, height as i32);
            gl.framebuffer_renderbuffer(
                glow::FRAMEBUFFER,
                glow::COLOR_ATTACHMENT0,
                glow::RENDERBUFFER,
                Some(colour),
            );
            let depth = gl
                .create_renderbuffer()
                .map_err(|e| anyhow!("glCreateRenderbuffer: {e}"))?;
            gl.bind_renderbuffer(glow::RENDERBUFFER, Some(depth));
            gl.renderbuffer_storage(
                glow::RENDERBUFFER,
                glow::DEPTH_COMPONENT24,
                width as i32,
                height as i32,
            );
            gl.framebuffer_renderbuffer(
                glow::FRAMEBUFFER,
                glow::DEPTH_ATTACHMENT,
                glow::RENDERBUFFER,
                Some(depth),
            );
            let status = gl.check_framebuffer_status(glow::FRAMEBUFFER);
            if status != glow::FRAMEBUFFER_COMPLETE {
                bail!("the {width}x{height} framebuffer is incomplete (status {status:#x}); try a smaller --size");
            }
            LIVE_CONTEXTS.fetch_add(1, Ordering::SeqCst);
            Ok(HeadlessGl {
                gl,
                context,
                _display: display,
                framebuffer,
                renderbuffers: [colour, depth],
                size: [width, height],
                description,
            })
        }
    }

    pub fn gl(&self) -> &Arc<glow::Context> {
        &self.gl
    }

    pub fn size(&self) -> [u32; 2] {
        self.size
    }

    /// Waits for drawing to finish and reads the framebuffer, rows top to bottom.
    pub fn read_image(&self) -> Image {
        let [w, h] = self.size;
        let mut pixels = vec![0u8; 4 * w as usize * h as usize];
        // SAFETY: our framebuffer, the buffer has room for w x h RGBA8.
        unsafe {
            self.gl
                .bind_framebuffer(glow::READ_FRAMEBUFFER, Some(self.framebuffer));
            self.gl.pixel_store_i32(glow::PACK_ALIGNMENT, 1);
            self.gl.read_pixels(
                0,
                0,
                w as i32,
                h as i32,
                glow::RGBA,
                glow::UNSIGNED_BYTE,
                glow::PixelPackData::Slice(Some(&mut pixels)),
            );
        }
        Image::from_gl_rows(w, h, pixels)
    }

    /// glFinish: for timing, so a frame's GPU work is inside its measured time.
    pub fn finish(&self) {
        // SAFETY: the context is current.
        unsafe { self.gl.finish() };
    }
}

impl Drop for HeadlessGl {
    fn drop(&mut self) {
        LIVE_CONTEXTS.fetch_sub(1, Ordering::SeqCst);
        if !self.context.is_current() {
            // Dropped on another thread than the one drawing: its GL calls would go elsewhere.
            return;
        }
        // SAFETY: our objects; the context is still alive (fields drop after this).
        unsafe {
            self.gl.delete_framebuffer(self.framebuffer);
            for rb in self.renderbuffers {
                self.gl.delete_renderbuffer(rb);
            }
        }
        // Released before glutin destroys it: EGL frees a context destroyed while current only once
        // its thread lets go of it, and a thread that ends never does, so the context would be left
        // to the driver's teardown at exit.
        let _ = self.context.make_not_current_in_place();
    }
}
