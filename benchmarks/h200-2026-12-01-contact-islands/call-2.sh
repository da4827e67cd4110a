# mpm: 4a58b07 with the first island variant of step_bodies (a lane per chain, in one warp); mpm-old:
# 4a58b07. Every one-GPU suite on mpm, then the PLY identity of the two builds in fixed point and their
# timings, alternated.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
export NCCL_NVLS_ENABLE=0
mkdir -p $OUT/logs
bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_bodies --out $OUT/logs/tests-a --timeout 420 > $OUT/logs/group-a.txt 2>&1 &
bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_bench,gpu_kernels,gpu_lifecycle,gpu_materials,gpu_nccl,gpu_pbmpm,gpu_physics,gpu_ranks,gpu_render,gpu_solids,headless_render --out $OUT/logs/tests-b --timeout 300 > $OUT/logs/group-b.txt 2>&1
wait
bash scripts/ply-identity.sh .gpu/bin/mpm-old .gpu/bin/mpm $OUT/logs/ply --scenes "benches/scenes/bench-boxes-pile.toml:20 boats:60 water-wheel:60" --every 10 > $OUT/logs/ply.txt 2>&1
STEPS=1000 WARMUP=100 RUNS=2 OUT=$OUT/logs/ab bash scripts/bench-ab.sh .gpu/bin/mpm-old .gpu/bin/mpm "--scene benches/scenes/bench-boxes-pile.toml" "--scene benches/scenes/bench-boxes-bodies.toml" "--scene dam-break" > $OUT/logs/ab.txt 2>&1
tar -czf $OUT/logs.tgz -C $OUT logs && rm -rf $OUT/logs
