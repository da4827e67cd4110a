#!/usr/bin/env bash
# Experiment: particle state permuted into bin order at each binning (MPM_PERMUTE=1), same binary.
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
printf '#!/bin/sh\nMPM_PERMUTE=1 exec %s "$@"\n' $M > /tmp/mpm-permute; chmod +x /tmp/mpm-permute
mkdir -p $OUT/ab
(cd /tmp; for sc in dam-break; do for v in plain permute; do e=; [ $v = permute ] && e=MPM_PERMUTE=1
  env $e timeout 60 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export p-$v-$sc > /dev/null 2>&1 || echo "run $v $sc failed"; done
  python3 $OLDPWD/.gpu/scripts/plyset.py p-plain-$sc p-permute-$sc; cmp -s p-plain-$sc/frame_000060.ply p-permute-$sc/frame_000060.ply && echo "frame 60 byte-identical as files" || echo "frame 60 files differ (order)"; done) | tee $OUT/ply.txt
OUT=$OUT/ab bash scripts/bench-ab.sh $M /tmp/mpm-permute "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" 2>&1 | tee $OUT/ab.txt
python3 - $OUT/ab <<'PY'
import json, sys, glob, os
for f in sorted(glob.glob(sys.argv[1] + "/*.json")):
    d = json.load(open(f))
    for s in d["phases"]:
        ph = {k: v.get("median_ms") for k, v in s.items() if isinstance(v, dict) and "median_ms" in v}
        print(os.path.basename(f), s["scene"], " ".join(f"{k}={v:.4f}" for k, v in ph.items()))
PY
STEPS=300 WARMUP=100 OUT=$OUT/ab16 bash scripts/bench-ab.sh $M /tmp/mpm-permute "--particles 16777216 --grid 256" 2>&1 | tail -4 | tee -a $OUT/ab.txt
