#!/usr/bin/env bash
# BENCHMARKS.md section 0e: the dam break's surge front and gauge heights under each pipeline and
# scatter mode, from exported frames (gauges.py), and the fused pipeline without its divergence term:
# .gpu/ptx-nodiv/one_pass.compute_90.ptx built with kernels/common.cuh's advected_density returning
# rho_grid (MPM_UPDATE_PTX=1 cargo build, then copy kernels/ptx/one_pass.compute_90.ptx).
set -uo pipefail
mpm=$PWD/.gpu/bin/mpm  # run from the checkout root: bash .gpu/run bash benchmarks/h200-2026-11-24-fused/gauges.sh
d=/tmp/g; rm -rf $d; mkdir -p $d
run() { name=$1; ptx=$2; shift 2; MPM_PTX_DIR=$ptx $mpm run --scene dam-break --frames 90 --every 3 --export $d/$name "$@" >/dev/null 2>&1 || echo "$name failed"; }
run binned-float none --pipeline binned
run binned-fixed none --pipeline binned --scatter fixed-point
run report-float none --pipeline report
run fused-float none --pipeline fused
run fused-fixed none --pipeline fused --scatter fixed-point
run fused-nodiv $PWD/.gpu/ptx-nodiv --pipeline fused
python3 benchmarks/h200-2026-11-24-fused/gauges.py binned-float=$d/binned-float binned-fixed=$d/binned-fixed report-float=$d/report-float fused-float=$d/fused-float fused-fixed=$d/fused-fixed fused-nodiv=$d/fused-nodiv
python3 benchmarks/h200-2026-11-24-fused/gauges.py fused-float=$d/fused-float fused-fixed=$d/fused-fixed
