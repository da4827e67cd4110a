#!/usr/bin/env bash
# Before/after timing of two mpm builds on one machine, the way BENCHMARKS.md's comparisons are made:
# each case is benched with BEFORE, then AFTER, then again (RUNS rounds, interleaved, so that clock
# and thermal drift fall on both), and the table gives each run's median substep and the change of
# the mean of the medians.
#
#   scripts/bench-ab.sh BEFORE_MPM AFTER_MPM [CASE ...]
#
# Either side may be MPM@PTX_DIR: that build with its kernels loaded from PTX_DIR (MPM_PTX_DIR, see
# docs/profiling.md), to time a kernel variant, or an older commit's kernels, without another build.
# A side without @ runs with MPM_PTX_DIR unset, whatever the environment holds.
# A CASE is the arguments of one `mpm bench` run, quoted ("--scene dam-break --scatter fixed-point");
# default: bench-65k, the dam break and bench-655k. STEPS (2000), WARMUP (200) and RUNS (2) set the
# length; EXTRA adds arguments to every run (EXTRA="--backend cpu-parallel" on a machine without a
# GPU). Each run's JSON is kept under OUT (default: a new folder under /tmp) for the record. Needs
# python3 for the table.
set -euo pipefail

usage() {
    echo "usage: $0 BEFORE_MPM AFTER_MPM [CASE ...]   (a CASE is one quoted set of mpm bench arguments)" >&2
    exit 2
}
[ $# -ge 2 ] || usage
before=$1 after=$2
shift 2
for side in "$before" "$after"; do
    bin=${side%%@*}
    [ -x "$bin" ] || { echo "$0: $bin is not an executable mpm (build it, or give its path)" >&2; exit 2; }
    if [[ $side == *@* ]]; then
        ptx=${side#*@}
        [ -d "$ptx" ] || { echo "$0: $ptx (after @ in $side) is not a directory of PTX files" >&2; exit 2; }
    fi
done
command -v python3 > /dev/null || { echo "$0: python3 is needed for the table (apt install python3)" >&2; exit 2; }
cases=("$@")
[ ${#cases[@]} -gt 0 ] || cases=("--scene bench-65k" "--scene dam-break" "--scene bench-655k")
steps=${STEPS:-2000} warmup=${WARMUP:-200} runs=${RUNS:-2}
out=${OUT:-$(mktemp -d /tmp/bench-ab.XXXXXX)}
mkdir -p "$out"

for c in "${!cases[@]}"; do
    for run in $(seq 1 "$runs"); do
        for side in before after; do
            spec=$before
            [ $side = after ] && spec=$after
            bin=${spec%%@*} ptx_env=(-u MPM_PTX_DIR)
            [[ $spec == *@* ]] && ptx_env=("MPM_PTX_DIR=${spec#*@}")
            json="$out/case$c-$side-$run.json"
            # shellcheck disable=SC2086 # a case and EXTRA are word lists on purpose
            if ! env "${ptx_env[@]}" "$bin" bench ${cases[$c]} ${EXTRA:-} --steps "$steps" --warmup "$warmup" \
                --json "$json" > "$out/case$c-$side-$run.log" 2>&1; then
                echo "$0: '$bin bench ${cases[$c]}' failed; its output: $out/case$c-$side-$run.log" >&2
                tail -5 "$out/case$c-$side-$run.log" >&2
                exit 1
            fi
        done
    done
done

python3 - "$out" "$runs" "$before" "$after" "${cases[@]}" <<'EOF'
import json, sys
out, runs, before, after, cases = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5:]

def medians(case, side):
    values = []
    for run in range(1, runs + 1):
        with open(f"{out}/case{case}-{side}-{run}.json") as f:
            for scene in json.load(f)["phases"]:
                values.append((scene["scene"], scene["device"], scene["total"]["median_ms"]))
    return values

print(f"before: {before}\nafter:  {after}\n")
print("| case | device | before, ms per substep | after | change |")
print("|---|---|---:|---:|---:|")
for c, args in enumerate(cases):
    b, a = medians(c, "before"), medians(c, "after")
    # One case may bench several scenes: group each scene's runs.
    for scene in dict.fromkeys(s for s, _, _ in b):
        bs = [m for s, _, m in b if s == scene]
        as_ = [m for s, _, m in a if s == scene]
        device = next(d for s, d, _ in a if s == scene)
        change = (sum(as_) / len(as_)) / (sum(bs) / len(bs)) - 1.0
        label = args if len(set(s for s, _, _ in b)) == 1 else f"{args} ({scene})"
        print(f"| `{label}` | {device} | {', '.join(f'{m:.4f}' for m in bs)} | "
              f"{', '.join(f'{m:.4f}' for m in as_)} | {100 * change:+.1f} % |")
print(f"\nraw output: {out}")
EOF
