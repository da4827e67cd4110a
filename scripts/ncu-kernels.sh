#!/usr/bin/env bash
# Nsight Compute of chosen kernels in one mpm run, at the GPU's own clocks, kept as text beside a
# benchmark: the report, its details page, and (with the full set) where the warps wait.
#
#   scripts/ncu-kernels.sh NAME KERNELS [options] -- MPM ARGS
#
# NAME names the files; KERNELS is ncu's kernel filter: a name (one_pass_float_planes) or
# regex:... (regex:^(p2g|g2p)$). MPM ARGS is the mpm command line after the binary ("bench --scene
# bench-655k --steps 400 --warmup 10"); run from the checkout so that ncu finds kernels/ for the
# source view.
#
# Options (defaults in brackets):
#   --skip N        launches of the kernels to skip first (module load, the ordered first state) [100]
#   --count N       launches to profile [1]
#   --set S         ncu's section set [full]; with full, OUT/NAME-stalls.txt gets the warp-stall
#                   shares by reason and opcode (scripts/ncu-stalls.py)
#   --sections A,B  these sections instead of a set (SpeedOfLight,Occupancy,LaunchStats,...)
#   --metrics M     only these metrics, as a CSV of the raw page (e.g. gpu__time_duration.sum), no report
#   --mpm PATH      the binary [.gpu/bin/mpm, else target/release/mpm]
#   --out DIR       where the files go [$OUT, else ./ncu-out]
#   --timeout S     limit for the profiled run [300]
# Writes OUT/NAME.ncu-rep, NAME-details.txt (or NAME-metrics.csv), NAME.log, and prints each kernel's
# duration, registers, occupancy and throughputs. Exits non-zero when ncu fails (its log's end shown).
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)

fail() {
  echo "ncu-kernels: $*" >&2
  exit 2
}
[[ ${1:-} == -h || ${1:-} == --help ]] && sed -n '2,/^set -uo/p' "$0" | sed '$d; s/^# \{0,1\}//' && exit 0
(($# >= 2)) || fail "usage: scripts/ncu-kernels.sh NAME KERNELS [options] -- MPM ARGS (--help says more)"
name=$1 kernels=$2
shift 2
skip=100 count=1 set=full sections="" metrics="" mpm="" out=${OUT:-ncu-out} limit=300 args=()
while (($#)); do
  case $1 in
  --skip | --count | --set | --sections | --metrics | --mpm | --out | --timeout)
    (($# >= 2)) || fail "$1 needs a value"
    case $1 in
    --skip) skip=$2 ;; --count) count=$2 ;; --set) set=$2 ;; --sections) sections=$2 ;; --metrics) metrics=$2 ;;
    --mpm) mpm=$2 ;; --out) out=$2 ;; --timeout) limit=$2 ;;
    esac
    shift 2
    ;;
  --) shift && args=("$@") && break ;;
  *) fail "unknown argument $1 (the mpm arguments go after --)" ;;
  esac
done
[[ $name =~ ^[A-Za-z0-9._-]+$ ]] || fail "NAME $name: letters, digits, . _ - only (it names files)"
((${#args[@]})) || fail "give the mpm command line after --, e.g. -- bench --scene bench-655k --steps 400 --warmup 10"
[[ $skip =~ ^[0-9]+$ ]] || fail "--skip $skip: give a whole number"
[[ $count =~ ^[1-9][0-9]*$ ]] || fail "--count $count: give a whole number from 1 up"
[[ $limit =~ ^[1-9][0-9]*$ ]] || fail "--timeout $limit: give whole seconds"
if [[ -z $mpm ]]; then
  for m in .gpu/bin/mpm target/release/mpm; do [[ -x $m ]] && mpm=$m && break; done
  [[ -n $mpm ]] || fail "no mpm binary at .gpu/bin/mpm or target/release/mpm: give --mpm PATH"
fi
[[ -x $mpm && -f $mpm ]] || fail "--mpm $mpm: not an executable file"
ncu=$(command -v ncu || ls /usr/local/cuda/bin/ncu 2>/dev/null) ||
  fail "ncu not found on PATH nor in /usr/local/cuda/bin (Nsight Compute comes with the CUDA toolkit)"
mkdir -p "$out" || fail "cannot create $out"
[[ ! -e $out/$name.ncu-rep && ! -e $out/$name.log ]] || fail "$out/$name.* exists already; give another NAME or --out"

common=(--clock-control none -k "$kernels" --launch-skip "$skip" --launch-count "$count")
if [[ -n $metrics ]]; then
  timeout -k 10 "$limit" "$ncu" "${common[@]}" --metrics "$metrics" --csv --page raw "$mpm" "${args[@]}" \
    >"$out/$name-metrics.csv" 2>"$out/$name.log"
  rc=$?
  ((rc == 0)) || { tail -n 5 "$out/$name.log" >&2 && fail "ncu exited with $rc (log: $out/$name.log)"; }
  echo "ncu-kernels: $out/$name-metrics.csv"
  exit 0
fi
what=(--set "$set")
if [[ -n $sections ]]; then
  what=()
  IFS=, read -ra list <<<"$sections"
  for s in "${list[@]}"; do what+=(--section "$s"); done
fi
timeout -k 10 "$limit" "$ncu" "${common[@]}" "${what[@]}" --import-source yes --source-folders kernels \
  -o "$out/$name" "$mpm" "${args[@]}" >"$out/$name.log" 2>&1
rc=$?
((rc == 0)) || { tail -n 5 "$out/$name.log" >&2 && fail "ncu exited with $rc (log: $out/$name.log)"; }
"$ncu" -i "$out/$name.ncu-rep" --page details >"$out/$name-details.txt" 2>&1
grep -E '^  [a-z_0-9]+.*\(|^\s+(Duration|Registers Per Thread|Achieved Occupancy|Memory Throughput|DRAM Throughput|Compute \(SM\) Throughput)\s' \
  "$out/$name-details.txt" | tr -s ' '
if [[ $set == full && -z $sections ]]; then
  "$ncu" -i "$out/$name.ncu-rep" --page source --csv --print-source sass >"$out/$name-sass.csv" 2>&1 &&
    python3 "$here/ncu-stalls.py" "$out/$name-sass.csv" >"$out/$name-stalls.txt" 2>&1 &&
    echo "ncu-kernels: warp stalls in $out/$name-stalls.txt" && rm -f "$out/$name-sass.csv"
fi
echo "ncu-kernels: $out/$name.ncu-rep, $out/$name-details.txt"
