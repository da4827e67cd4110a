//! NCCL between two GPUs of one host (`mpm::dist::nccl`): a communicator of two ranks, one per device,
//! each driven by its own thread as the several-GPU design has it, sums and exchanges across the
//! pair exactly, and prints what the transfers cost (the figures the halo exchange will be judged
//! against, docs/several-gpus.md). Where fewer than two CUDA devices or no NCCL are found, the test
//! is reported as not run, with the reason (tests/harness: `harness = false`).

use cudarc::driver::{CudaContext, DevicePtr};
use mpm::dist::nccl::{Comm, DataType, Nccl, Reduction, UniqueId};
use std::time::Instant;

mod harness;

fn main() -> std::process::ExitCode {
    harness::run(
        "two-GPU and NCCL",
        harness::two_cuda_devices_and_nccl,
        harness::tests![two_ranks_on_two_gpus_sum_and_exchange],
    )
}

/// What one rank measured: microseconds per call of each timed exchange.
struct RankTimes {
    rank: usize,
    lines: Vec<String>,
}

fn two_ranks_on_two_gpus_sum_and_exchange() {
    let nccl = Nccl::get().unwrap();
    println!("NCCL {} from {}", nccl.version_text(), nccl.path);
    let id = nccl.unique_id().unwrap();
    // ncclCommInitRank blocks until every rank has called it: one thread per rank.
    let times: Vec<RankTimes> = std::thread::scope(|scope| {
        let ranks: Vec<_> = (0..2)
            .map(|rank| scope.spawn(move || rank_main(nccl, id, rank)))
            .collect();
        ranks.into_iter().map(|r| r.join().unwrap()).collect()
    });
    for t in times {
        for line in t.lines {
            println!("rank {}: {line}", t.rank);
        }
    }
}

fn rank_main(nccl: &'static Nccl, id: UniqueId, rank: usize) -> RankTimes {
    let ctx = CudaContext::new(rank).unwrap();
    ctx.bind_to_thread().unwrap();
    let stream = ctx.new_stream().unwrap();
    let comm = Comm::init(nccl, id, rank, 2).unwrap();
    let peer = 1 - rank;
    let raw = stream.cu_stream() as *mut std::ffi::c_void;

    // Exactness first: each rank's values are distinct integers, so every sum and copy is exact.
    let n = 4096;
    let mine: Vec<f32> = (0..n).map(|i| (i + rank * n) as f32).collect();
    let send = stream.clone_htod(&mine).unwrap();
    let summed = stream.alloc_zeros::<f32>(n).unwrap();
    let received = stream.alloc_zeros::<f32>(n).unwrap();
    {
        let (s, _s) = send.device_ptr(&stream);
        let (r, _r) = summed.device_ptr(&stream);
        let (q, _q) = received.device_ptr(&stream);
        // SAFETY: three buffers of n floats on this rank's device, alive past the synchronize below.
        unsafe {
            comm.all_reduce((s, r), n, DataType::F32, Reduction::Sum, raw)
                .unwrap();
            comm.send_recv(&[(peer, s, n)], &[(peer, q, n)], DataType::F32, raw)
                .unwrap();
        }
    }
    stream.synchronize().unwrap();
    let expected_sum: Vec<f32> = (0..n).map(|i| (2 * i + n) as f32).collect();
    assert_eq!(
        stream.clone_dtoh(&summed).unwrap(),
        expected_sum,
        "rank {rank}: the sum over both GPUs"
    );
    let theirs: Vec<f32> = (0..n).map(|i| (i + peer * n) as f32).collect();
    assert_eq!(
        stream.clone_dtoh(&received).unwrap(),
        theirs,
        "rank {rank}: what the other GPU sent"
    );

    // Costs: enqueued back to back, the mean per call once the stream has drained.
    let mut lines = Vec::new();
    let mut time = |what: String, calls: u32, call: &mut dyn FnMut()| {
        for _ in 0..10 {
            call(); // warm-up: connections are set up on first use
        }
        stream.synchronize().unwrap();
        let started = Instant::now();
        for _ in 0..calls {
            call();
        }
        stream.synchronize().unwrap();
        let us = started.elapsed().as_secs_f64() * 1e6 / f64::from(calls);
        lines.push(format!("{what}: {us:.1} us a call"));
    };
    let one = stream.alloc_zeros::<f32>(1).unwrap();
    let (o, _o) = one.device_ptr(&stream);
    time("all-reduce (max) of one float".into(), 1000, &mut || {
        // SAFETY: one float on this rank's device, alive for the scope.
        unsafe {
            comm.all_reduce((o, o), 1, DataType::F32, Reduction::Max, raw)
                .unwrap()
        }
    });
    for mib in [1usize, 64] {
        let len = mib << 18; // floats in `mib` MiB
        let out = stream.alloc_zeros::<f32>(len).unwrap();
        let inb = stream.alloc_zeros::<f32>(len).unwrap();
        let (s, _s) = out.device_ptr(&stream);
        let (r, _r) = inb.device_ptr(&stream);
        let calls = if mib == 1 { 200 } else { 50 };
        time(
            format!("send and receive {mib} MiB both ways"),
            calls,
            &mut || {
                // SAFETY: two buffers of `len` floats on this rank's device, alive for the loop.
                unsafe {
                    comm.send_recv(&[(peer, s, len)], &[(peer, r, len)], DataType::F32, raw)
                        .unwrap()
                }
            },
        );
    }
    drop(_o);
    comm.abort().unwrap();
    RankTimes { rank, lines }
}
