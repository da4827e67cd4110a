# e37d80a (session 37's landed code): every one-GPU suite, in two groups at once, then the dam break
# on one GPU and on two ranks of it.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
export NCCL_NVLS_ENABLE=0
bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_bodies --out $OUT/tests-a --timeout 420 > $OUT/group-a.txt 2>&1 &
bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_bench,gpu_kernels,gpu_lifecycle,gpu_materials,gpu_nccl,gpu_pbmpm,gpu_physics,gpu_ranks,gpu_render,gpu_solids,headless_render --out $OUT/tests-b --timeout 300 > $OUT/group-b.txt 2>&1
wait
.gpu/bin/mpm bench --scene dam-break --steps 2000 --warmup 100 > $OUT/bench-dam.txt 2>&1
MPM_RANKS_HOST_TIMES=1 .gpu/bin/mpm bench --scene dam-break --ranks 2 --steps 800 --warmup 50 > $OUT/bench-dam-r2.txt 2>&1
