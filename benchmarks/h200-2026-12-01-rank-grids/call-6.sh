set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
bash scripts/ncu-kernels.sh ranks2 regex:^one_pass --skip 200 --count 2 --set full --timeout 280 -- bench --particles 33554432 --grid 320 --ranks 2 --steps 150 --warmup 10 2>&1 | tail -12
bash scripts/ncu-kernels.sh one regex:^one_pass --skip 100 --count 1 --set full --timeout 200 -- bench --particles 16777216 --grid 320 --steps 150 --warmup 10 2>&1 | tail -8
rm -f $OUT/*.ncu-rep $OUT/*-sass.csv
