# 6005702 (the final code): the pile of ten cubes against its static twin, alternated twice, then every
# one-GPU suite in two groups at once.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
export NCCL_NVLS_ENABLE=0
mkdir -p $OUT/logs
for round in 1 2; do
  for s in bench-boxes-pile-static bench-boxes-pile; do
    .gpu/bin/mpm bench --scene benches/scenes/$s.toml --steps 1000 --warmup 100 > $OUT/logs/$s-$round.txt 2>&1
    echo "$s $round: $(grep -E '^\| \*\*total' $OUT/logs/$s-$round.txt | cut -d'|' -f3,5)"
  done
done
bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_bodies --out $OUT/logs/tests-a --timeout 400 > $OUT/logs/group-a.txt 2>&1 &
bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_bench,gpu_kernels,gpu_lifecycle,gpu_materials,gpu_nccl,gpu_pbmpm,gpu_physics,gpu_ranks,gpu_render,gpu_solids,headless_render --out $OUT/logs/tests-b --timeout 300 > $OUT/logs/group-b.txt 2>&1
wait
tail -14 $OUT/logs/group-b.txt; tail -3 $OUT/logs/group-a.txt
tar -czf $OUT/logs.tgz -C $OUT logs && rm -rf $OUT/logs
