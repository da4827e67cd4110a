#!/usr/bin/env bash
# The viewer windowed on the H200, fused (the default) and the binned pipeline as it stood before
# (main's kernels through MPM_PTX_DIR: .gpu/ptx-main as h200-fused.sh makes it), 300 frames each;
# then the points mode. Needs .gpu/x11 (scripts/pack-x11.sh).
set -uo pipefail
out=${OUT:?}
for who in fused before fused-points; do
  case $who in
    fused) unset MPM_PTX_DIR; extra=() ;;
    before) export MPM_PTX_DIR=$PWD/.gpu/ptx-main; extra=(-- --pipeline binned) ;;
    fused-points) unset MPM_PTX_DIR; extra=(-- --draw points) ;;
  esac
  bash scripts/view-on-gpu.sh --frames 300 --out "$out/view-$who" "${extra[@]}" > "$out/view-$who.txt" 2>&1
  echo "$who: exit $? $(grep -E 'mean draw interval' "$out/view-$who/view.log" | tail -1)"
done
unset MPM_PTX_DIR
