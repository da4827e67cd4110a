set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
peak() { # runs "$@", prints the highest memory.used (MiB) seen while it ran
  nvidia-smi --query-gpu=memory.used --format=csv,noheader,nounits -lms 100 > /tmp/mem.txt & local s=$!
  "$@"; kill $s; sort -n /tmp/mem.txt | tail -1
}
summ() { grep -E '\*\*total\*\*|Wall clock' "$1" | sed -E 's/\| \*\*total\*\* \| ([0-9.]+) .*/total median \1/; s/Wall clock: ([0-9.]+) ms.*/wall \1/' | tr '\n' ' '; }
for round in 1 2; do
 for b in mpm-old mpm; do
  m=$(peak .gpu/bin/$b bench --particles 16777216 --grid 320 --steps 150 --warmup 30 > $OUT/col16-$b-$round.txt 2>&1)
  echo "16.8M 1 GPU $b $round: $(summ $OUT/col16-$b-$round.txt) peak ${m} MiB"
  m=$(peak .gpu/bin/$b bench --particles 33554432 --grid 320 --ranks 2 --steps 150 --warmup 30 > $OUT/col33-r2-$b-$round.txt 2>&1)
  echo "33.5M ranks 2 $b $round: $(summ $OUT/col33-r2-$b-$round.txt) peak ${m} MiB"
 done
done
for b in mpm-old mpm; do
  .gpu/bin/$b bench --scene dam-break --ranks 3 --steps 800 --warmup 50 --scatter fixed-point > $OUT/dam-r3-$b.txt 2>&1
  echo "dam-break ranks 3 fixed $b: $(summ $OUT/dam-r3-$b.txt)"
done
