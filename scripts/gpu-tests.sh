#!/usr/bin/env bash
# Runs the built test executables on a machine without Rust (the GPU machine), the way
# `cargo test --release` would, and sums their results:
#
#   scripts/gpu-tests.sh [options] [-- TEST ARGUMENTS]
#
# Each executable in the folder (`cargo build --release --all-targets` makes them as
# target/release/deps/NAME-HASH; copy those of tests/*.rs to .gpu/tests/, docs/gpu.md) runs from the
# checkout's root with MPM_BIN naming the mpm binary (tests/common/mod.rs) and NVLink multicast off
# (NCCL_NVLS_ENABLE=0). TEST ARGUMENTS go to every executable (a name filter, --test-threads 1, ...).
# Prints one line an executable and the totals, then each failed test; exits 1 when a test failed or
# an executable ended without its result line (a crash, a time-out), 2 on a bad argument.
#
# Options (defaults in brackets):
#   --tests DIR     the test executables [.gpu/tests]
#   --mpm PATH      the binary the tests run [.gpu/bin/mpm, else target/release/mpm]
#   --only NAMES    only these executables, by the test file's name, comma-separated (gpu_kernels,...)
#   --out DIR       one log an executable [$OUT/tests, or ./gpu-tests-out]
#   --timeout S     limit for each executable [600]
set -uo pipefail

fail() {
  echo "gpu-tests: $*" >&2
  exit 2
}
tests=.gpu/tests mpm="" only="" out=${OUT:+$OUT/tests} limit=600 args=()
out=${out:-gpu-tests-out}
while (($#)); do
  case $1 in
  --tests | --mpm | --only | --out | --timeout)
    (($# >= 2)) || fail "$1 needs a value"
    case $1 in --tests) tests=$2 ;; --mpm) mpm=$2 ;; --only) only=$2 ;; --out) out=$2 ;; --timeout) limit=$2 ;; esac
    shift 2
    ;;
  --) shift && args=("$@") && break ;;
  -h | --help) sed -n '2,/^set -uo/p' "$0" | sed '$d; s/^# \{0,1\}//' && exit 0 ;;
  *) fail "unknown argument $1 (--help lists the options; test arguments go after --)" ;;
  esac
done

[[ -d $tests ]] || fail "$tests is not a folder of test executables: give --tests DIR (docs/gpu.md says how to make one)"
if [[ -z $mpm ]]; then
  for m in .gpu/bin/mpm target/release/mpm; do [[ -x $m ]] && mpm=$m && break; done
  [[ -n $mpm ]] || fail "no mpm binary at .gpu/bin/mpm or target/release/mpm: give --mpm PATH"
fi
[[ -x $mpm && -f $mpm ]] || fail "--mpm $mpm: not an executable file"
[[ $limit =~ ^[1-9][0-9]*$ ]] || fail "--timeout $limit: give whole seconds"
# The test file's name: cargo adds -HASH (16 hex digits) to it.
name_of() {
  local base=${1##*/}
  [[ $base =~ ^(.+)-[0-9a-f]{16}$ ]] && echo "${BASH_REMATCH[1]}" || echo "$base"
}
exes=()
for f in "$tests"/*; do
  [[ -f $f && -x $f ]] || continue
  name=$(name_of "$f")
  [[ -z $only || ",$only," == *",$name,"* ]] && exes+=("$f")
done
((${#exes[@]})) || fail "no test executable in $tests${only:+ named $only}"
if [[ -n $only ]]; then
  IFS=, read -ra wanted <<<"$only"
  for w in "${wanted[@]}"; do
    found=0
    for f in "${exes[@]}"; do [[ $(name_of "$f") == "$w" ]] && found=1; done
    ((found)) || fail "--only $w: no executable of that name in $tests"
  done
fi
mkdir -p "$out" || fail "cannot create $out"
mpm=$(realpath "$mpm")

passed=0 failed=0 ignored=0 broken=()
for f in "${exes[@]}"; do
  name=$(name_of "$f")
  log=$out/$name.log
  MPM_BIN=$mpm NCCL_NVLS_ENABLE=0 timeout -k 10 "$limit" "$f" "${args[@]}" >"$log" 2>&1
  rc=$?
  # One `test result:` line a test binary: "test result: ok. 12 passed; 0 failed; 3 ignored; ..."
  result=$(grep -E '^test result:' "$log" | tail -n 1)
  if [[ $result =~ ([0-9]+)\ passed\;\ ([0-9]+)\ failed\;\ ([0-9]+)\ ignored ]]; then
    p=${BASH_REMATCH[1]} x=${BASH_REMATCH[2]} i=${BASH_REMATCH[3]}
    passed=$((passed + p)) failed=$((failed + x)) ignored=$((ignored + i))
    echo "$name: $p passed, $x failed, $i ignored (exit $rc)"
    ((x == 0 && rc == 0)) || broken+=("$name")
  else
    echo "$name: no result line (exit $rc$( ((rc == 124 || rc == 137)) && echo ", past --timeout $limit s")); the end of $log:"
    tail -n 5 "$log"
    broken+=("$name")
  fi
done
echo "total: $passed passed, $failed failed, $ignored ignored in ${#exes[@]} executables (logs: $out)"
for name in "${broken[@]}"; do
  grep -E -- '^test .* FAILED$|panicked at' "$out/$name.log" | sed "s/^/$name: /" | head -n 20
done
((${#broken[@]} == 0))
