#!/usr/bin/env bash
# Session 28 call 10: no over-relaxation at one iteration. The same bytes as before at 2 and 4
# iterations (mpm-old: 995cc2f's mpm); gpu_pbmpm; which one-iteration settings now hold, and their
# frame cost; the best at 1M in the window (--max-fps 60, real-time pacing).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0
L=/tmp/logs; rm -rf $L /tmp/bytes /tmp/win-*; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
S=benchmarks/h200-2026-11-30-pbmpm-stable/scenes
for s in pbmpm-dam-break $S/pb-jd-s8.toml $S/pb-1m-s8-i1.toml; do
  b=$(basename $s .toml)
  for m in mpm-old mpm; do timeout 60 $P/$m run --backend cuda --scene $s --frames 24 --export /tmp/bytes/$b-$m > $L/bytes-$b-$m.log 2>&1; done
  n=$(ls /tmp/bytes/$b-mpm | wc -l)
  if [ "$n" -gt 0 ] && diff -rq /tmp/bytes/$b-mpm-old /tmp/bytes/$b-mpm > /dev/null; then echo "bytes $b: the same, $n files"; else echo "bytes $b: DIFFER ($n files)"; fi
  rm -rf /tmp/bytes
done
timeout 200 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
echo "gpu_pbmpm: $(grep 'test result' $L/gpu_pbmpm.log)"; grep -E "^test .*(FAILED|ignored)|panicked|RESULT pbmpm GPU pbmpm-1m|Martin" $L/gpu_pbmpm.log | head
go() { # scene frames
  local b=$(basename $1 .toml)
  timeout 100 $P/mpm run --backend cuda --scene $1 --frames $2 > $L/run-$b.log 2>&1; local rc=$?
  echo "== $b rc $rc $(grep -c '^frame' $L/run-$b.log) frames; $(grep -o 'the substeps. own timing [0-9.]* s' $L/run-$b.log); densest $(grep '^frame' $L/run-$b.log | sed -E 's/.*rho\/rho0=\[[0-9.]+ ([0-9.]+) ([0-9.]+)\].*/\2/' | sort -g | tail -1), largest mean $(grep '^frame' $L/run-$b.log | sed -E 's/.*rho\/rho0=\[[0-9.]+ ([0-9.]+) ([0-9.]+)\].*/\1/' | sort -g | tail -1), fastest $(grep '^frame' $L/run-$b.log | sed -E 's/.*\|v\|max=([0-9.]+).*/\1/' | sort -g | tail -1)"
}
for s in pb-1m-s4-i1 pb-1m-s8-i1 pb-1m-s12-i1; do go $S/$s.toml 300; done
for s in pb-3m-s8-i1 pb-3m-s12-i1 pb-10m-s16-i1 pb-10m-s24-i1; do go $S/$s.toml 150; done
timeout 100 bash scripts/view-on-gpu.sh --scene $S/pb-1m-s8-i1.toml --frames 600 --fixed-frames 0 --mpm $P/mpm --x11 .gpu/x11/root.tar.xz --out /tmp/win-1m --timeout 90 -- --max-fps 60 > $L/window-pb-1m-s8-i1.txt 2>&1
echo "== window pb-1m-s8-i1 rc=$?"; grep -E "^viewer: (timed|mean|the stepping)" /tmp/win-1m/view.log; cp /tmp/win-1m/view.log $L/view-pb-1m-s8-i1.log; cp /tmp/win-1m/window.png $OUT/ 2>/dev/null
tar -czf $OUT/logs.tgz -C /tmp logs
