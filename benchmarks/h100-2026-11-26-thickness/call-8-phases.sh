#!/usr/bin/env bash
# Why one_pass without barriers ran 5x slower: the phase tables, embedded PTX / HEAD's PTX by override / the new PTX.
M=$PWD/.gpu/bin/mpm
for d in none ptx-old ptx-nobar; do
  echo "== $d"
  if [ $d = none ]; then unset MPM_PTX_DIR; else export MPM_PTX_DIR=$PWD/.gpu/$d; fi
  timeout 60 $M bench --scene dam-break --steps 500 --warmup 100 2>&1 | grep -E "^\||module|PTX|ptx" | head -14
done
