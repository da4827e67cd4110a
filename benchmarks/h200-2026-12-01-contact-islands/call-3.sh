# mpm: this change (islands and chains, each on a warp of its own); mpm-old: 4a58b07. gpu_bodies on
# mpm beside the PLY identity of the two builds in fixed point, then their timings, alternated.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/logs
bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_bodies --out $OUT/logs/tests-a --timeout 400 > $OUT/logs/group-a.txt 2>&1 &
bash scripts/ply-identity.sh .gpu/bin/mpm-old .gpu/bin/mpm $OUT/logs/ply --scenes "benches/scenes/bench-boxes-pile.toml:30 boats:60 water-wheel:60" --every 10 > $OUT/logs/ply.txt 2>&1; echo "ply-identity rc $?"; grep -v "^  " $OUT/logs/ply.txt | tail -8
wait
tail -3 $OUT/logs/group-a.txt
STEPS=1000 WARMUP=100 RUNS=2 OUT=$OUT/logs/ab bash scripts/bench-ab.sh .gpu/bin/mpm-old .gpu/bin/mpm "--scene benches/scenes/bench-boxes-pile.toml" "--scene benches/scenes/bench-boxes-bodies.toml" "--scene boats" "--scene dam-break" > $OUT/logs/ab.txt 2>&1; tail -10 $OUT/logs/ab.txt
tar -czf $OUT/logs.tgz -C $OUT logs && rm -rf $OUT/logs
