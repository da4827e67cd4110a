#!/usr/bin/env bash
# GPU machine side: compute-sanitizer memcheck and racecheck on the fused pipeline's kernels (one_pass,
# the emission that now scatters momentum): dam-break-coarse in both scatter modes, the fountain
# (emitters and sinks; racecheck over 1 frame), and memcheck of dam-break-obstacle (colliders; 2 frames,
# racecheck outgrows the machine at that size, docs/profiling.md). Run from the checkout with .gpu/.
set -uo pipefail
export PATH=$PATH:/usr/local/cuda/bin
mpm=.gpu/bin/mpm
check() { tool=$1; shift; timeout 400 compute-sanitizer --tool $tool --print-limit 10 --error-exitcode 9 $mpm run --backend cuda "$@" >/tmp/san.log 2>&1
  echo "$tool $*: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log | tr '\n' ' ')"; }
for tool in memcheck racecheck; do
  for sc in float fixed-point; do check $tool --scene dam-break-coarse --frames 3 --scatter $sc; done
  check $tool --scene fountain --frames 1 --scatter fixed-point
done
check memcheck --scene dam-break-obstacle --frames 2
