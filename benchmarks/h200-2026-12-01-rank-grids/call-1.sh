set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
export NCCL_NVLS_ENABLE=0
bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_kernels --out $OUT/tests --timeout 280 2>&1 | tail -30
for round in 1 2; do
 for b in mpm-old mpm; do
  .gpu/bin/$b bench --scene dam-break --steps 2000 --warmup 100 > $OUT/bench-dam-$b-$round.txt 2>&1
  echo "dam-break $b $round: $(grep -iE 'total|median' $OUT/bench-dam-$b-$round.txt | head -3 | tr '\n' ' ')"
  .gpu/bin/$b bench --scene dam-break --ranks 2 --steps 800 --warmup 50 > $OUT/bench-r2-$b-$round.txt 2>&1
  echo "ranks2 $b $round: $(grep -iE 'total|median|wall|host' $OUT/bench-r2-$b-$round.txt | head -4 | tr '\n' ' ')"
 done
done
