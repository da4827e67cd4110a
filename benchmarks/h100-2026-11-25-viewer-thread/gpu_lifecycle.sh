#!/usr/bin/env bash
set -u
export MPM_BIN=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
bash .gpu/run .gpu/tests/gpu_lifecycle 2>&1 | tail -15
