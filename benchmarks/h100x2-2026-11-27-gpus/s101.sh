#!/usr/bin/env bash
# s100's profile acted on (the ranks' kernels one by one): count_layers' shared atomics aggregated
# per warp (505 us a launch), bin_count's parked slots spread over 32 keys (1,172 us a rebin on a
# rank, against 162 on one GPU), the halo kernels in memory order (halo_pack_sums 92 us). Tests
# first, then mpm (these kernels) against mpm-old (s97's build, cd769e5) in one call.
M=$PWD/.gpu/bin/mpm O=$PWD/.gpu/bin/mpm-old G=$PWD/.gpu
export MPM_BIN=$M NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
bash .gpu/run true
for t in gpu_ranks_on_gpus gpu_ranks gpu_lifecycle gpu_kernels; do
  x=$(ls $G/tests/$t-*); timeout 120 $x > /tmp/$t.log 2>&1; echo "$t rc $? $(grep 'test result' /tmp/$t.log)" >> $S
  grep -E "panicked|FAILED" /tmp/$t.log | head -5 >> $S
done
cat /tmp/gpu_ranks_on_gpus.log /tmp/gpu_kernels.log > $OUT/tests.log
cd /tmp
for b in old new; do bin=$M; [ $b = old ] && bin=$O
  timeout 60 $bin run --backend cuda --scene fountain --scatter fixed-point --frames 30 --export f-$b > /dev/null 2>&1 || echo "fountain $b failed" >> $S
done
diff -rq f-old f-new > /dev/null && echo "fountain fixed point: $(ls f-new | wc -l) PLY files byte-identical, old vs new bins" >> $S || echo "fountain DIFFERS" >> $S
mkdir -p /tmp/b; cd /tmp/b
bench() { local name=$1 bin=$2; shift 2
  timeout 100 $bin bench --backend cuda "$@" --json $name.json > $name.txt 2>&1; echo "== $name rc $?: $*" >> $S
  grep -E "Wall clock|total|halo|migrate|one_pass" $name.txt | cut -c1-150 | head -6 >> $S
}
for r in 1 2; do
  bench dam2-old-$r $O --scene dam-break --steps 1000 --warmup 200 --gpus 2
  bench dam2-new-$r $M --scene dam-break --steps 1000 --warmup 200 --gpus 2
done
bench c16-2-old $O --particles 16777216 --grid 256 --steps 600 --warmup 50 --gpus 2
bench c16-2-new $M --particles 16777216 --grid 256 --steps 600 --warmup 50 --gpus 2
bench c33-2-old $O --particles 33554432 --grid 256 --steps 600 --warmup 50 --gpus 2
bench c33-2-new $M --particles 33554432 --grid 256 --steps 600 --warmup 50 --gpus 2
bench c16-1-new $M --particles 16777216 --grid 256 --steps 600 --warmup 50
tar cf $OUT/bench.tar *.json *.txt
