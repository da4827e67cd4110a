//! NCCL, the collectives library the ranks on several GPUs are to exchange over, found and loaded at
//! run time, and the few calls they need.
//!
//! **Where NCCL is looked for**, in order: `MPM_NCCL_LIB` (the library file itself); `libnccl.so.2`
//! on the loader path (a distribution's package, or `LD_LIBRARY_PATH`); the `nvidia/nccl/lib` folder
//! of `python3`'s `nvidia.nccl` package (`pip install nvidia-nccl-cu13`, or the copy PyTorch brings).
//!
//! **Why not cudarc's `nccl` module:** its loader opens NCCL by bare names (`libnccl.so`,
//! `libnccl.so.13`, `.12`, ...) and never `libnccl.so.2`, the only name NCCL's packages install (pip's
//! wheel and Debian's `libnccl2` alike), and it panics where none opens; the calls bound here are the
//! handful the ranks use, each checked.

use anyhow::{anyhow, bail, Context, Result};
use std::ffi::{c_char, c_int, c_void, CStr};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// `ncclUniqueId`: what rank 0 makes and every rank passes to `ncclCommInitRank`.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct UniqueId {
    pub internal: [c_char; 128],
}

type NcclResult = c_int;
type RawComm = *mut c_void;
type Stream = *mut c_void;

/// `ncclDataType_t` values of the types the ranks send.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(i32)]
pub enum DataType {
    U32 = 3,
    U64 = 5,
    F32 = 7,
}

/// `ncclRedOp_t` values of the reductions the ranks use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(i32)]
pub enum Reduction {
    Sum = 0,
    Max = 2,
}

struct Functions {
    get_version: unsafe extern "C" fn(*mut c_int) -> NcclResult,
    get_unique_id: unsafe extern "C" fn(*mut UniqueId) -> NcclResult,
    comm_init_rank: unsafe extern "C" fn(*mut RawComm, c_int, UniqueId, c_int) -> NcclResult,
    comm_init_all: unsafe extern "C" fn(*mut RawComm, c_int, *const c_int) -> NcclResult,
    comm_destroy: unsafe extern "C" fn(RawComm) -> NcclResult,
    comm_abort: unsafe extern "C" fn(RawComm) -> NcclResult,
    error_string: unsafe extern "C" fn(NcclResult) -> *const c_char,
    all_reduce:
        unsafe extern "C" fn(*const c_void, *mut c_void, usize, c_int, c_int, RawComm, Stream) -> NcclResult,
    all_gather: unsafe extern "C" fn(*const c_void, *mut c_void, usize, c_int, RawComm, Stream) -> NcclResult,
    send: unsafe extern "C" fn(*const c_void, usize, c_int, c_int, RawComm, Stream) -> NcclResult,
    recv: unsafe extern "C" fn(*mut c_void, usize, c_int, c_int, RawComm, Stream) -> NcclResult,
    group_start: unsafe extern "C" fn() -> NcclResult,
    group_end: unsafe extern "C" fn() -> NcclResult,
}

/// NCCL, loaded: where from, its version, its functions.
pub struct Nccl {
    pub path: String,
    /// As NCCL reports it: major * 10000 + minor * 100 + patch (2.28.9: 22809).
    pub version: i32,
    functions: Functions,
    /// Kept open for `functions`.
    _library: libloading::Library,
}

impl Nccl {
    /// NCCL, loaded once per process; the error names every place looked in and the fix.
    pub fn get() -> Result<&'static Nccl> {
        static NCCL: OnceLock<Result<Nccl, String>> = OnceLock::new();
        NCCL.get_or_init(|| Nccl::load().map_err(|e| format!("{e:#}")))
            .as_ref()
            .map_err(|e| anyhow!("{e}"))
    }

    /// "2.28.9".
    pub fn version_text(&self) -> String {
        let v = self.version;
        format!("{}.{}.{}", v / 10000, (v / 100) % 100, v % 100)
    }

    fn load() -> Result<Nccl> {
        let (library, path) = open_library()?;
        // SAFETY: each symbol is looked up by its NCCL name and given NCCL's C signature (nccl.h).
        let functions = unsafe {
            Functions {
                get_version: *library.get(b"ncclGetVersion\0")?,
                get_unique_id: *library.get(b"ncclGetUniqueId\0")?,
                comm_init_rank: *library.get(b"ncclCommInitRank\0")?,
                comm_init_all: *library.get(b"ncclCommInitAll\0")?,
                comm_destroy: *library.get(b"ncclCommDestroy\0")?,
                comm_abort: *library.get(b"ncclCommAbort\0")?,
                error_string: *library.get(b"ncclGetErrorString\0")?,
                all_reduce: *library.get(b"ncclAllReduce\0")?,
                all_gather: *library.get(b"ncclAllGather\0")?,
                send: *library.get(b"ncclSend\0")?,
                recv: *library.get(b"ncclRecv\0")?,
                group_start: *library.get(b"ncclGroupStart\0")?,
                group_end: *library.get(b"ncclGroupEnd\0")?,
            }
        };
        let mut nccl = Nccl {
            path,
            version: 0,
            functions,
            _library: library,
        };
        let mut version = 0;
        // SAFETY: writes one int.
        nccl.check(
            unsafe { (nccl.functions.get_version)(&mut version) },
            "ncclGetVersion",
        )?;
        nccl.version = version;
        if version < MIN_VERSION {
            bail!(
                "NCCL {} at {} is older than 2.18, the oldest these calls were written for; install \
                 a newer one (pip install nvidia-nccl-cu13) and point MPM_NCCL_LIB at it",
                nccl.version_text(),
                nccl.path
            );
        }
        Ok(nccl)
    }

    fn check(&self, result: NcclResult, call: &str) -> Result<()> {
        if result == 0 {
            return Ok(());
        }
        // SAFETY: NCCL returns a static string for any result code.
        let text = unsafe { CStr::from_ptr((self.functions.error_string)(result)) };
        bail!("{call} failed: {} (NCCL error {result})", text.to_string_lossy())
    }

    /// A new id for a communicator, made by one rank and handed to the others.
    pub fn unique_id(&self) -> Result<UniqueId> {
        let mut id = UniqueId { internal: [0; 128] };
        // SAFETY: writes the 128-byte id.
        self.check(
            unsafe { (self.functions.get_unique_id)(&mut id) },
            "ncclGetUniqueId",
        )?;
        Ok(id)
    }

    /// Runs `post` as one NCCL group: the sends, receives and collectives it posts, on any of the
    /// communicators, start together at the group's end. One thread driving several devices must
    /// post their matching calls in one group, or the first would wait for a peer never posted.
    pub fn group<T>(&self, post: impl FnOnce() -> Result<T>) -> Result<T> {
        let f = &self.functions;
        // SAFETY: no arguments; every start is paired with the end below.
        self.check(unsafe { (f.group_start)() }, "ncclGroupStart")?;
        let posted = post();
        // SAFETY: ends the group started above.
        let ended = self.check(unsafe { (f.group_end)() }, "ncclGroupEnd");
        let posted = posted?;
        ended.map(|()| posted)
    }
}

/// The oldest NCCL whose ncclSend/ncclRecv and ncclCommAbort these bindings were checked against.
const MIN_VERSION: i32 = 21800;

/// One rank's membership of a communicator, on the device whose context is current on the thread
/// that made it. Dropping it destroys the communicator.
pub struct Comm {
    nccl: &'static Nccl,
    raw: RawComm,
    pub rank: usize,
    pub size: usize,
}

impl Comm {
    /// Joins communicator `id` as `rank` of `size` (every rank calls it, each on its own device,
    /// made current on the calling thread first).
    pub fn init(nccl: &'static Nccl, id: UniqueId, rank: usize, size: usize) -> Result<Comm> {
        let mut raw: RawComm = std::ptr::null_mut();
        // SAFETY: `raw` receives the communicator; the id is passed by value as nccl.h declares.
        let result = unsafe { (nccl.functions.comm_init_rank)(&mut raw, size as c_int, id, rank as c_int) };
        nccl.check(result, &format!("ncclCommInitRank (rank {rank} of {size})"))?;
        Ok(Comm {
            nccl,
            raw,
            rank,
            size,
        })
    }

    /// The NCCL library this communicator was made by (what `Nccl::group` is called on).
    pub fn nccl(&self) -> &'static Nccl {
        self.nccl
    }

    /// One communicator per device of `devices`, all in this process, rank i on `devices[i]`: what
    /// one thread driving every GPU of a host holds (ncclCommInitAll).
    pub fn init_all(nccl: &'static Nccl, devices: &[usize]) -> Result<Vec<Comm>> {
        let size = devices.len();
        let list: Vec<c_int> = devices.iter().map(|&d| d as c_int).collect();
        let mut raw: Vec<RawComm> = vec![std::ptr::null_mut(); size];
        // SAFETY: `raw` receives one communicator per entry of `list`, both `size` long.
        let result =
            unsafe { (nccl.functions.comm_init_all)(raw.as_mut_ptr(), size as c_int, list.as_ptr()) };
        nccl.check(result, &format!("ncclCommInitAll (devices {devices:?})"))?;
        Ok(raw
            .into_iter()
            .enumerate()
            .map(|(rank, raw)| Comm {
                nccl,
                raw,
                rank,
                size,
            })
            .collect())
    }

    /// Reduces `count` values of `data_type` at device address `send` into `recv` on every rank,
    /// in `stream`'s order.
    ///
    /// # Safety
    /// `send` and `recv` must be device buffers of at least `count` values of `data_type`, on this
    /// communicator's device, alive until `stream` has run the reduction.
    pub unsafe fn all_reduce(
        &self,
        (send, recv): (u64, u64),
        count: usize,
        data_type: DataType,
        op: Reduction,
        stream: Stream,
    ) -> Result<()> {
        // SAFETY: the caller vouches for the buffers and the stream.
        let result = unsafe {
            (self.nccl.functions.all_reduce)(
                send as *const c_void,
                recv as *mut c_void,
                count,
                data_type as c_int,
                op as c_int,
                self.raw,
                stream,
            )
        };
        self.nccl.check(result, "ncclAllReduce")
    }

    /// Gathers `count` values of `data_type` at device address `send` from every rank into `recv`,
    /// rank r's at r * count, on every rank, in `stream`'s order.
    ///
    /// # Safety
    /// `send` must be a device buffer of at least `count` values of `data_type` and `recv` of
    /// `size * count`, on this communicator's device, alive until `stream` has run the gather.
    pub unsafe fn all_gather(
        &self,
        (send, recv): (u64, u64),
        count: usize,
        data_type: DataType,
        stream: Stream,
    ) -> Result<()> {
        // SAFETY: the caller vouches for the buffers and the stream.
        let result = unsafe {
            (self.nccl.functions.all_gather)(
                send as *const c_void,
                recv as *mut c_void,
                count,
                data_type as c_int,
                self.raw,
                stream,
            )
        };
        self.nccl.check(result, "ncclAllGather")
    }

    /// Sends and receives, as one NCCL group: `sends` are (peer, device address, count), `recvs` the
    /// same, all of `data_type`, in `stream`'s order.
    ///
    /// # Safety
    /// Every address must be a device buffer of at least its count of `data_type` on this
    /// communicator's device, alive until `stream` has run the transfers, and every peer must post
    /// the matching receive or send.
    pub unsafe fn send_recv(
        &self,
        sends: &[(usize, u64, usize)],
        recvs: &[(usize, u64, usize)],
        data_type: DataType,
        stream: Stream,
    ) -> Result<()> {
        let f = &self.nccl.functions;
        self.nccl.group(|| {
            let posts = sends.iter().map(|&post| (post, true));
            for ((peer, buffer, count), send) in posts.chain(recvs.iter().map(|&post| (post, false))) {
                let (dt, rank) = (data_type as c_int, peer as c_int);
                // SAFETY: the caller vouches for the buffer, the peer and the stream.
                let result = unsafe {
                    if send {
                        (f.send)(buffer as *const c_void, count, dt, rank, self.raw, stream)
                    } else {
                        (f.recv)(buffer as *mut c_void, count, dt, rank, self.raw, stream)
                    }
                };
                let what = if send { "ncclSend to" } else { "ncclRecv from" };
                self.nccl.check(result, &format!("{what} rank {peer}"))?;
            }
            Ok(())
        })
    }

    /// Tears the communicator down without waiting for the other ranks (a rank that failed): what
    /// they have in flight with it fails instead of hanging.
    pub fn abort(mut self) -> Result<()> {
        let raw = std::mem::replace(&mut self.raw, std::ptr::null_mut());
        // SAFETY: `raw` is a live communicator, aborted once; Drop then sees null.
        self.nccl
            .check(unsafe { (self.nccl.functions.comm_abort)(raw) }, "ncclCommAbort")
    }
}

// SAFETY: NCCL lets a communicator move between threads as long as no two call it at once; `Comm`
// is not `Sync`, so only the one thread that holds it can.
unsafe impl Send for Comm {}

impl Drop for Comm {
    fn drop(&mut self) {
        if !self.raw.is_null() {
            // SAFETY: a live communicator, destroyed once. An error here has no one to report to.
            let _ = unsafe { (self.nccl.functions.comm_destroy)(self.raw) };
        }
    }
}

/// Opens NCCL from the first place that has it (the module's list), or says where it looked.
fn open_library() -> Result<(libloading::Library, String)> {
    if let Some(path) = std::env::var_os("MPM_NCCL_LIB").map(PathBuf::from) {
        if !path.is_file() {
            bail!(
                "MPM_NCCL_LIB={} is not a file: point it at libnccl.so.2 (pip install \
                 nvidia-nccl-cu13 puts one in site-packages/nvidia/nccl/lib), or unset it",
                path.display()
            );
        }
        return open(&path).map(|lib| (lib, path.display().to_string()));
    }
    // SAFETY: NCCL's initialisers only register its plugins' defaults.
    if let Ok(lib) = unsafe { libloading::Library::new("libnccl.so.2") } {
        return Ok((lib, "libnccl.so.2 on the loader path".into()));
    }
    let python = python_nccl_folder();
    if let Ok(folder) = &python {
        let path = folder.join("lib/libnccl.so.2");
        if path.is_file() {
            return open(&path).map(|lib| (lib, path.display().to_string()));
        }
    }
    bail!(
        "NCCL not found: MPM_NCCL_LIB is unset, libnccl.so.2 is not on the loader path, and python3's \
         nvidia.nccl package {}. Install it (pip install nvidia-nccl-cu13, or your distribution's \
         libnccl2) or set MPM_NCCL_LIB to the libnccl.so.2 file",
        match python {
            Ok(folder) => format!("at {} holds no lib/libnccl.so.2", folder.display()),
            Err(why) => format!("is missing ({why})"),
        }
    )
}

fn open(path: &Path) -> Result<libloading::Library> {
    // SAFETY: as in `open_library`.
    unsafe { libloading::Library::new(path) }
        .with_context(|| format!("cannot load NCCL from {}", path.display()))
}

/// The folder of python3's `nvidia.nccl` package.
fn python_nccl_folder() -> Result<PathBuf, String> {
    let out = std::process::Command::new("python3")
        .args(["-c", "import nvidia.nccl; print(list(nvidia.nccl.__path__)[0])"])
        .output()
        .map_err(|e| format!("python3 did not run: {e}"))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(err.lines().last().unwrap_or("python3 failed").trim().to_string());
    }
    Ok(PathBuf::from(String::from_utf8_lossy(&out.stdout).trim()))
}
