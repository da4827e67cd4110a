set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
export NCCL_NVLS_ENABLE=0
bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --out $OUT/tests --timeout 300 2>&1 | tail -20
summ() { grep -E '\*\*total\*\*|Wall clock' "$1" | sed -E 's/\| \*\*total\*\* \| ([0-9.]+) .*/total median \1/; s/Wall clock: ([0-9.]+) ms.*/wall \1/' | tr '\n' ' '; }
.gpu/bin/mpm bench --particles 33554432 --grid 320 --ranks 2 --steps 150 --warmup 30 --json $OUT/col33-r2.json > $OUT/col33-r2.txt 2>&1; echo "33.5M ranks 2: $(summ $OUT/col33-r2.txt)"; sed -n '/^Ranks/,$p' $OUT/col33-r2.txt
.gpu/bin/mpm bench --scene dam-break --ranks 2 --steps 800 --warmup 50 > $OUT/dam-r2.txt 2>&1; echo "dam ranks 2: $(summ $OUT/dam-r2.txt)"; sed -n '/^Ranks/,$p' $OUT/dam-r2.txt
.gpu/bin/mpm bench --scene dam-break --steps 1000 --warmup 100 > $OUT/dam.txt 2>&1; echo "dam 1 GPU: $(summ $OUT/dam.txt)"
