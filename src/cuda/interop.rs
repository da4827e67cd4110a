//! CUDA-OpenGL interop: an OpenGL buffer object registered with CUDA, so a kernel writes the vertex
//! data that GL then draws, with no host round trip.
//!
//! cudarc's bindings carry the map/unmap/unregister calls but not `cuGraphicsGLRegisterBuffer` (it is
//! declared in cudaGL.h), so that one symbol is resolved from the same libcuda handle cudarc uses.
//!
//! Lifetime: register once per GL buffer; map before the kernel writes and unmap before GL draws (every
//! frame); drop the registration before the GL buffer is deleted or reallocated (resize, reset, exit).

use anyhow::{anyhow, bail, Context, Result};
use cudarc::driver::sys::{self, CUdeviceptr, CUgraphicsResource, CUresult};
use cudarc::driver::{CudaContext, CudaStream};
use std::sync::Arc;

/// `CU_GRAPHICS_REGISTER_FLAGS_WRITE_DISCARD`: CUDA overwrites the whole buffer each time it maps it,
/// so the driver need not preserve the old contents.
const REGISTER_WRITE_DISCARD: u32 = 2;

type RegisterBufferFn = unsafe extern "C" fn(*mut CUgraphicsResource, u32, u32) -> CUresult;

/// A GL buffer registered with CUDA. Unregistered on drop (the GL buffer itself stays GL's).
pub struct GlBufferResource {
    ctx: Arc<CudaContext>,
    resource: CUgraphicsResource,
    mapped: bool,
}

/// The device address and size of a mapped buffer, valid until `unmap`.
#[derive(Debug, Clone, Copy)]
pub struct MappedBuffer {
    pub ptr: CUdeviceptr,
    pub bytes: usize,
}

fn check(what: &str, result: CUresult) -> Result<()> {
    if result == CUresult::CUDA_SUCCESS {
        Ok(())
    } else {
        bail!("{what} failed: {result:?}")
    }
}

impl GlBufferResource {
    /// Registers GL buffer object `gl_buffer` (a name from glGenBuffers/glCreateBuffers, with storage)
    /// with CUDA context `ctx`.
    ///
    /// # Safety
    /// The GL context that owns `gl_buffer` must be current on this thread, on the same GPU as `ctx`,
    /// and the buffer must outlive the returned registration.
    pub unsafe fn register(ctx: &Arc<CudaContext>, gl_buffer: u32) -> Result<GlBufferResource> {
        super::library::ensure_driver()?;
        ctx.bind_to_thread().context("binding the CUDA context")?;
        // SAFETY: the symbol has this signature in cudaGL.h (CUresult (CUgraphicsResource*, GLuint,
        // unsigned int)); the library is cudarc's own handle, loaded for the process's lifetime.
        let register: RegisterBufferFn = unsafe {
            let symbol = sys::culib()
                .get::<RegisterBufferFn>(b"cuGraphicsGLRegisterBuffer\0")
                .map_err(|e| {
                    anyhow!("libcuda has no cuGraphicsGLRegisterBuffer ({e}); update the NVIDIA driver")
                })?;
            *symbol
        };
        let mut resource: CUgraphicsResource = std::ptr::null_mut();
        // SAFETY: out-pointer to a local; the caller vouches for the buffer and the current GL context.
        check(
            "cuGraphicsGLRegisterBuffer (is the GL context on the CUDA device, and current?)",
            unsafe { register(&mut resource, gl_buffer, REGISTER_WRITE_DISCARD) },
        )?;
        Ok(GlBufferResource {
            ctx: ctx.clone(),
            resource,
            mapped: false,
        })
    }

    /// Maps the buffer for CUDA on `stream` (ordered after GL's use of it) and returns its address.
    pub fn map(&mut self, stream: &CudaStream) -> Result<MappedBuffer> {
        if self.mapped {
            bail!("the GL buffer is already mapped for CUDA");
        }
        self.ctx.bind_to_thread().context("binding the CUDA context")?;
        // SAFETY: `resource` is a live registration; one resource, the stream is of this context.
        check("cuGraphicsMapResources", unsafe {
            sys::cuGraphicsMapResources(1, &mut self.resource, stream.cu_stream())
        })?;
        self.mapped = true;
        let mut ptr: CUdeviceptr = 0;
        let mut bytes = 0usize;
        // SAFETY: the resource is mapped (above).
        check("cuGraphicsResourceGetMappedPointer", unsafe {
            sys::cuGraphicsResourceGetMappedPointer_v2(&mut ptr, &mut bytes, self.resource)
        })?;
        Ok(MappedBuffer { ptr, bytes })
    }

    /// Hands the buffer back to GL; GL's next use waits for the work queued on `stream` before this.
    pub fn unmap(&mut self, stream: &CudaStream) -> Result<()> {
        if !self.mapped {
            return Ok(());
        }
        self.ctx.bind_to_thread().context("binding the CUDA context")?;
        // SAFETY: the resource is mapped on this context.
        check("cuGraphicsUnmapResources", unsafe {
            sys::cuGraphicsUnmapResources(1, &mut self.resource, stream.cu_stream())
        })?;
        self.mapped = false;
        Ok(())
    }
}

impl Drop for GlBufferResource {
    fn drop(&mut self) {
        // Errors here cannot be returned; the registration dies with the context anyway.
        if self.ctx.bind_to_thread().is_err() {
            return;
        }
        // SAFETY: a live registration of this context; unmapped first if still mapped.
        unsafe {
            if self.mapped {
                let _ = sys::cuGraphicsUnmapResources(1, &mut self.resource, std::ptr::null_mut());
            }
            let _ = sys::cuGraphicsUnregisterResource(self.resource);
        }
    }
}
