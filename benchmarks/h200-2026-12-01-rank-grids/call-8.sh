set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
export NCCL_NVLS_ENABLE=0
bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --out $OUT/tests --timeout 240 2>&1 | tail -20
