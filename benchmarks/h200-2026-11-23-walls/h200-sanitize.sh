#!/usr/bin/env bash
# GPU machine side: compute-sanitizer on the rewritten mirror_walls kernel (dam-break-coarse, 3 frames,
# both pipelines and scatter modes), and issue 17 item 7 (racecheck of dam-break-obstacle in fixed
# point over 3 frames, which had exited with an error and no message). Set OUT to a folder.
set -uo pipefail
export PATH=$PATH:/usr/local/cuda/bin
mpm=.gpu/bin/mpm
out=${OUT:?set OUT to a folder for the results}
for tool in memcheck racecheck; do
  for variant in "--pipeline binned --scatter float" "--pipeline binned --scatter fixed-point" "--pipeline report --scatter fixed-point"; do
    compute-sanitizer --tool $tool --print-limit 10 $mpm run --backend cuda --scene dam-break-coarse --frames 3 $variant \
      >/tmp/san.log 2>&1
    echo "$tool, dam-break-coarse $variant: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log | tr '\n' ' ')"
  done
done
echo "=== item 7: racecheck, dam-break-obstacle, 3 frames, fixed point"
start=$(date +%s)
timeout 300 compute-sanitizer --tool racecheck --print-limit 10 $mpm run --backend cuda --scene dam-break-obstacle --frames 3 \
  --scatter fixed-point >$out/racecheck-obstacle.log 2>&1
echo "rc=$? after $(( $(date +%s) - start )) s"
tail -15 $out/racecheck-obstacle.log
