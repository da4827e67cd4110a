//! NCCL on the GPU machine (`mpm::dist::nccl`): found, loaded, and a communicator of one rank on
//! device 0 that reduces and sends to itself, in stream order. One rank is what one GPU allows (NCCL
//! refuses two ranks on one device); the exchanges between GPUs are not built yet
//! (docs/several-gpus.md). Where no CUDA device or no NCCL is found, every test is reported as
//! ignored, with the reason (tests/harness: `harness = false`).

use cudarc::driver::{CudaContext, DevicePtr};
use mpm::dist::nccl::{Comm, DataType, Nccl, Reduction};
use std::time::Instant;

mod common;
mod harness;

fn main() -> std::process::ExitCode {
    harness::run(
        "GPU and NCCL",
        harness::cuda_device_and_nccl,
        harness::tests![
            a_one_rank_communicator_reduces_and_sends_to_itself,
            devices_lists_the_gpu_and_nccl
        ],
    )
}

fn a_one_rank_communicator_reduces_and_sends_to_itself() {
    let nccl = Nccl::get().unwrap();
    println!("NCCL {} from {}", nccl.version_text(), nccl.path);
    let ctx = CudaContext::new(0).unwrap();
    ctx.bind_to_thread().unwrap();
    let stream = ctx.new_stream().unwrap();
    let comm = Comm::init(nccl, nccl.unique_id().unwrap(), 0, 1).unwrap();
    let values: Vec<f32> = (0..1000).map(|i| i as f32 * 0.5).collect();
    let send = stream.clone_htod(&values).unwrap();
    let reduced = stream.alloc_zeros::<f32>(values.len()).unwrap();
    let received = stream.alloc_zeros::<f32>(values.len()).unwrap();
    let raw = stream.cu_stream() as *mut std::ffi::c_void;
    {
        let (s, _s) = send.device_ptr(&stream);
        let (r, _r) = reduced.device_ptr(&stream);
        let (q, _q) = received.device_ptr(&stream);
        // SAFETY: three buffers of values.len() floats on device 0, alive past the synchronize below.
        unsafe {
            comm.all_reduce((s, r), values.len(), DataType::F32, Reduction::Sum, raw)
                .unwrap();
            comm.send_recv(
                &[(0, s, values.len())],
                &[(0, q, values.len())],
                DataType::F32,
                raw,
            )
            .unwrap();
        }
    }
    stream.synchronize().unwrap();
    assert_eq!(
        stream.clone_dtoh(&reduced).unwrap(),
        values,
        "a one-rank sum is the input"
    );
    assert_eq!(
        stream.clone_dtoh(&received).unwrap(),
        values,
        "what was sent to itself arrived"
    );
    // The cost of a collective with nothing to carry: one float, enqueued back to back.
    const CALLS: u32 = 1000;
    let started = Instant::now();
    {
        let (s, _s) = send.device_ptr(&stream);
        let (r, _r) = reduced.device_ptr(&stream);
        for _ in 0..CALLS {
            // SAFETY: as above.
            unsafe {
                comm.all_reduce((s, r), 1, DataType::F32, Reduction::Max, raw)
                    .unwrap()
            };
        }
    }
    stream.synchronize().unwrap();
    let us = started.elapsed().as_secs_f64() * 1e6 / f64::from(CALLS);
    println!("all-reduce of one float on one rank: {us:.1} us a call, enqueued back to back");
    comm.abort().unwrap();
}

fn devices_lists_the_gpu_and_nccl() {
    let out = std::process::Command::new(common::mpm_binary())
        .arg("devices")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    println!("{text}");
    assert!(out.status.success());
    assert!(text.contains("  device 0: NVIDIA"), "{text}");
    assert!(
        text.contains(&format!("NCCL: {}", Nccl::get().unwrap().version_text())),
        "{text}"
    );
}
