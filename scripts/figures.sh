#!/usr/bin/env bash
# Measures the current figures, the README's "How fast" table and BENCHMARKS.md's current one, in one
# sitting on one device, and writes them from the raw output, so that no figure is copied by hand:
#
#   scripts/figures.sh OUT [options]
#
# OUT (created; must not hold an earlier figures.json) then holds
#   figures.json   every raw number, with the command that made it, the device, the date and the commit
#   figures.md     the table: one figure per cell, each row with its command
#   raw/           each command's output (logs, `mpm bench --json`, `mpm render --timings`)
#
# The set: `mpm bench --steps 2000 --warmup 200` of bench-655k, bench-65k and the dam break (median ms
# a substep), bench-655k with --scatter fixed-point (its ratio to the float step), 16.8M particles
# on a 256^3 grid (`--steps 300 --warmup 100`: ms a substep, ns a particle-step), `mpm render
# --frames 90 --no-images` of the dam break and dam-break-1m at 960x540 (ms a frame: simulation +
# render) and of the dam break at 1920x1080 (the surface's GPU ms a frame), `mpm run --frames 300`
# (wall time against the summed GPU step time), and the viewer's window under Xvfb
# (scripts/view-on-gpu.sh: FPS stepping one frame a draw, and with the viewer's own pacing).
#
# Options (defaults in brackets):
#   --mpm PATH         the binary [.gpu/bin/mpm, else target/release/mpm]
#   --commit HASH      the commit the binary was built from [git rev-parse --short HEAD, where git works]
#   --backend B        cuda, cpu-parallel or cpu [cuda]; a CPU backend is for a dry run of this script
#   --quick            few substeps and frames, smaller sizes: checks the script, measures nothing
#   --only IDS         only these figures, comma-separated (ids: bench-655k bench-65k dam-break
#                      fixed-point 16m render-dam-break render-1m surface-1080 run viewer)
#   --skip-viewer      leave out the viewer (it needs .gpu/x11/root.tar.xz: scripts/pack-x11.sh)
#   --x11 TARBALL      the X11 tree for the viewer [.gpu/x11/root.tar.xz]
#
# On the GPU machine, from the checkout with .gpu/bin/mpm (no Rust, no network needed):
#   bash scripts/figures.sh figures-out
# A dry run without a GPU:
#   scripts/figures.sh /tmp/fig --backend cpu-parallel --quick --only bench-65k,run --skip-viewer
# A figure whose command fails is written as failed, with its log; the others still run, and the
# script then exits 1. Needs python3 (scripts/figures.py writes the JSON and the table).
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
all_ids="bench-655k bench-65k dam-break fixed-point 16m render-dam-break render-1m surface-1080 run viewer"

fail() {
  echo "figures: $*" >&2
  exit 2
}
out="" mpm="" commit="" backend=cuda quick=0 only="" skip_viewer=0 x11=.gpu/x11/root.tar.xz
while (($#)); do
  case $1 in
  --mpm | --commit | --backend | --only | --x11)
    (($# >= 2)) || fail "$1 needs a value"
    case $1 in
    --mpm) mpm=$2 ;; --commit) commit=$2 ;; --backend) backend=$2 ;; --only) only=$2 ;; --x11) x11=$2 ;;
    esac
    shift 2
    ;;
  --quick) quick=1 && shift ;;
  --skip-viewer) skip_viewer=1 && shift ;;
  -h | --help) sed -n '2,/^set -uo/p' "$0" | sed '$d; s/^# \{0,1\}//' && exit 0 ;;
  -*) fail "unknown option $1 (--help lists the options)" ;;
  *)
    [[ -z $out ]] || fail "one output folder only ($out, then $1)"
    out=$1 && shift
    ;;
  esac
done

# Everything is checked before the first measurement.
[[ -n $out ]] || fail "give the output folder: scripts/figures.sh OUT [options] (--help lists them)"
case $backend in cuda | cpu-parallel | cpu) ;; *) fail "--backend $backend: give cuda, cpu-parallel or cpu" ;; esac
if [[ -z $mpm ]]; then
  for m in .gpu/bin/mpm target/release/mpm; do [[ -x $m ]] && mpm=$m && break; done
  [[ -n $mpm ]] || fail "no mpm binary at .gpu/bin/mpm or target/release/mpm: build it, or give --mpm PATH"
fi
[[ -x $mpm ]] || fail "--mpm $mpm: not an executable file"
mpm=$(realpath "$mpm")
command -v python3 >/dev/null || fail "python3 is needed to write the table (apt install python3)"
ids=()
if [[ -n $only ]]; then
  IFS=, read -ra ids <<<"$only"
  for id in "${ids[@]}"; do
    [[ " $all_ids " == *" $id "* ]] || fail "--only $id: not a figure; the ids are: $all_ids"
  done
else
  read -ra ids <<<"$all_ids"
fi
if ((skip_viewer)); then
  kept=()
  for id in "${ids[@]}"; do [[ $id == viewer ]] || kept+=("$id"); done
  ids=("${kept[@]}")
fi
# The fixed-point figure is a ratio to bench-655k's float substep, measured in the same call.
if [[ " ${ids[*]} " == *" fixed-point "* && " ${ids[*]} " != *" bench-655k "* ]]; then
  ids=(bench-655k "${ids[@]}")
fi
((${#ids[@]})) || fail "nothing left to measure (--only and --skip-viewer left out every figure)"
[[ ! -e $out/figures.json ]] || fail "$out/figures.json exists already; not overwriting it: give another folder"
mkdir -p "$out/raw" || fail "cannot create the output folder $out"
out=$(realpath "$out")
if [[ -z $commit ]]; then
  commit=$(git -C "$here/.." rev-parse --short HEAD 2>/dev/null) || commit=unknown
fi

# The lengths: the figures' own, or a few substeps and frames for --quick (a dry run on a CPU).
if ((quick)); then
  bench_len=(--steps 10 --warmup 2) big=(--particles 262144 --grid 64) big_len=(--steps 5 --warmup 1)
  frames=5 run_frames=2 view_frames=30
else
  bench_len=(--steps 2000 --warmup 200) big=(--particles 16777216 --grid 256) big_len=(--steps 300 --warmup 100)
  frames=90 run_frames=300 view_frames=300
fi

# The machine, as the driver and mpm see it.
date -u +%Y-%m-%dT%H:%M:%SZ >"$out/raw/date.txt"
"$mpm" devices >"$out/raw/devices.txt" 2>&1
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader >"$out/raw/nvidia-smi.txt" 2>&1 ||
  echo "nvidia-smi not found" >"$out/raw/nvidia-smi.txt"
: >"$out/raw/commands.tsv"

# One measurement: its id, then the command. Output goes to raw/ID.log; the command, its exit status
# and its start and end (wall clock, s) to raw/commands.tsv, which figures.py reads.
measure() {
  local id=$1 start rc
  shift
  echo "figures: $id: ${*/#$mpm/mpm}" >&2
  start=$EPOCHREALTIME
  "$@" >"$out/raw/$id.log" 2>&1
  rc=$?
  printf '%s\t%s\t%s\t%s\t%s\n' "$id" "$rc" "$start" "$EPOCHREALTIME" "${*/#$mpm/mpm}" >>"$out/raw/commands.tsv"
  ((rc == 0)) || { echo "figures: $id failed (exit $rc); the end of raw/$id.log:" >&2 && tail -n 5 "$out/raw/$id.log" >&2; }
}
bench() {
  local id=$1
  shift
  measure "$id" "$mpm" bench --backend "$backend" "$@" --json "$out/raw/$id.json"
}
render() {
  local id=$1
  shift
  measure "$id" "$mpm" render --backend "$backend" "$@" --frames "$frames" --no-images --timings "$out/raw/$id.json"
}

for id in "${ids[@]}"; do
  case $id in
  bench-655k | bench-65k | dam-break) bench "$id" --scene "$id" "${bench_len[@]}" ;;
  fixed-point) bench "$id" --scene bench-655k --scatter fixed-point "${bench_len[@]}" ;;
  16m) bench "$id" "${big[@]}" "${big_len[@]}" ;;
  render-dam-break) render "$id" --scene dam-break --size 960x540 ;;
  render-1m) render "$id" --scene dam-break-1m --size 960x540 ;;
  surface-1080) render "$id" --scene dam-break --size 1920x1080 ;;
  run) measure run "$mpm" run --backend "$backend" --scene dam-break --frames "$run_frames" ;;
  viewer)
    # Stepping one 60 Hz frame a draw, then with the viewer's own (real-time) pacing.
    if [[ ! -f $x11 ]]; then
      echo "figures: viewer skipped: $x11 not found (make it with scripts/pack-x11.sh on a development machine and carry .gpu/x11/ along)" |
        tee "$out/raw/viewer-skipped.txt" >&2
      continue
    fi
    vendor=nvidia
    [[ $backend == cuda ]] || vendor=mesa
    for pacing in 1 0; do
      frames_now=$view_frames
      ((pacing == 0)) && frames_now=$((view_frames * 4 / 3))
      measure "viewer-fixed-$pacing" bash "$here/view-on-gpu.sh" --mpm "$mpm" --x11 "$x11" --vendor "$vendor" \
        --backend "$backend" --scene dam-break --frames "$frames_now" --fixed-frames "$pacing" \
        --out "$out/raw/viewer-fixed-$pacing"
    done
    ;;
  esac
done

python3 "$here/figures.py" "$out" --commit "$commit" --backend "$backend" --quick "$quick"
