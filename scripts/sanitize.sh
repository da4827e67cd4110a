#!/usr/bin/env bash
# compute-sanitizer over mpm runs: each TOOL on each CASE, one line each with the exit status and the
# tool's summary (memcheck's ERROR SUMMARY, racecheck's RACECHECK SUMMARY, ...).
#
#   scripts/sanitize.sh TOOLS CASE [CASE ...]
#
# TOOLS: memcheck, racecheck, initcheck or synccheck, comma-separated. A CASE is one quoted set of
# mpm arguments, command included: "run --backend cuda --scene dam-break --frames 2 --scatter
# fixed-point", "bench --scene bench-65k --steps 20 --warmup 0". Keep racecheck to small scenes or a
# frame or two: it keeps its records in host memory and outgrows a large machine on the 451,200-
# particle scenes (docs/profiling.md).
# Environment: MPM (the binary; .gpu/bin/mpm, else target/release/mpm), OUT (each run's log, in a
# new folder under /tmp unless given), TIMEOUT (seconds a run, 300), MPM_PTX_DIR as for mpm.
# Exits 0 when every run ended with status 0 and its summary reports 0 errors or hazards, 1 when
# one did not, 2 on a bad argument.
set -uo pipefail

fail() {
  echo "sanitize: $*" >&2
  exit 2
}
[[ ${1:-} == -h || ${1:-} == --help ]] && sed -n '2,/^set -uo/p' "$0" | sed '$d; s/^# \{0,1\}//' && exit 0
(($# >= 2)) || fail "usage: scripts/sanitize.sh TOOLS \"MPM ARGS\" [...] (--help says more)"
IFS=, read -ra tools <<<"$1"
shift
for t in "${tools[@]}"; do
  case $t in memcheck | racecheck | initcheck | synccheck) ;; *) fail "$t: not a compute-sanitizer tool (memcheck, racecheck, initcheck, synccheck)" ;; esac
done
mpm=${MPM:-}
if [[ -z $mpm ]]; then
  for m in .gpu/bin/mpm target/release/mpm; do [[ -x $m ]] && mpm=$m && break; done
fi
[[ -n $mpm && -x $mpm ]] || fail "no mpm binary (MPM=${MPM:-unset}; looked at .gpu/bin/mpm and target/release/mpm)"
limit=${TIMEOUT:-300}
[[ $limit =~ ^[1-9][0-9]*$ ]] || fail "TIMEOUT=$limit: give whole seconds"
sanitizer=$(command -v compute-sanitizer || ls /usr/local/cuda/bin/compute-sanitizer 2>/dev/null) ||
  fail "compute-sanitizer not found on PATH nor in /usr/local/cuda/bin (it comes with the CUDA toolkit)"
out=${OUT:-$(mktemp -d /tmp/sanitize.XXXXXX)}
mkdir -p "$out" || fail "cannot create $out"

status=0 n=0
for t in "${tools[@]}"; do
  for c in "$@"; do
    n=$((n + 1))
    log=$out/$n-$t.log
    # shellcheck disable=SC2086 # a case is a word list on purpose
    timeout -k 10 "$limit" "$sanitizer" --tool "$t" --error-exitcode 9 "$mpm" $c >"$log" 2>&1
    rc=$?
    summary=$(grep -E '(ERROR|RACECHECK|INITCHECK|SYNCCHECK) SUMMARY' "$log" | tail -n 1 | sed 's/^========= //')
    clean=0
    [[ $rc == 0 && $summary =~ SUMMARY:\ 0\ (errors|hazards) ]] && clean=1
    ((clean)) || status=1
    echo "$t mpm $c: rc=$rc ${summary:-no summary line}$( ((rc == 124 || rc == 137)) && echo " (past TIMEOUT=$limit s, or killed for memory)") (log: $log)"
  done
done
exit $status
