#!/usr/bin/env bash
# Before/after timing of two mpm builds on one machine, the way BENCHMARKS.md's comparisons are made:
# each case is benched with BEFORE, then AFTER, then again (RUNS rounds, interleaved, so that clock
# and thermal drift fall on both), and the table gives each run's median substep, the change of
# the mean of the medians, and the change of the mean substep (which counts the binnings between
# substeps that the median skips).
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

def runs_of(case, side):
    """(scene, device, median, mean) of each run of one side of a case."""
    values = []
    for run in range(1, runs + 1):
        with open(f"{out}/case{case}-{side}-{run}.json") as f:
            for scene in json.load(f)["phases"]:
                total = scene["total"]
                values.append((scene["scene"], scene["device"], total["median_ms"], total["mean_ms"]))
    return values

def change(after, before):
    return (sum(after) / len(after)) / (sum(before) / len(before)) - 1.0

print(f"before: {before}\nafter:  {after}\n")
# The median is a substep between binnings; the mean spreads the binnings (and anything else rare)
# over every substep, so it is what a run costs.
print("| case | device | before, median ms per substep | after | change | mean change |")
print("|---|---|---:|---:|---:|---:|")
for c, args in enumerate(cases):
    b, a = runs_of(c, "before"), runs_of(c, "after")
    # One case may bench several scenes: group each scene's runs.
    for scene in dict.fromkeys(r[0] for r in b):
        bs = [r for r in b if r[0] == scene]
        as_ = [r for r in a if r[0] == scene]
        device = as_[0][1]
        medians = change([r[2] for r in as_], [r[2] for r in bs])
        means = change([r[3] for r in as_], [r[3] for r in bs])
        label = args if len(set(r[0] for r in b)) == 1 else f"{args} ({scene})"
        print(f"| `{label}` | {device} | {', '.join(f'{r[2]:.4f}' for r in bs)} | "
              f"{', '.join(f'{r[2]:.4f}' for r in as_)} | {100 * medians:+.1f} % | {100 * means:+.1f} % |")
print(f"\nraw output: {out}")
EOF
