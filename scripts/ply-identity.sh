#!/usr/bin/env bash
# Proof that a change moved no particle: runs scenes in fixed point (`--scatter fixed-point`, whose
# sums do not depend on the order of the atomics, so a run repeats byte for byte) with two mpm builds,
# exports the particles every K frames, and compares the PLY files byte for byte.
#
#   scripts/ply-identity.sh BIN_A BIN_B OUT [options] [-- MORE MPM RUN ARGUMENTS]
#
# Prints one line a file (identical, or different with the first differing byte) and one a scene,
# and exits 0 when every file of every scene is identical, 1 when any differs or is missing on one
# side, 2 when an argument is wrong or a run fails. BIN_A and BIN_B may be the same binary (does a
# run repeat itself?). Either may be MPM@PTX_DIR: that build with its kernels loaded from PTX_DIR
# (MPM_PTX_DIR, docs/profiling.md); a side without @ runs with MPM_PTX_DIR unset.
#
# Options (defaults in brackets):
#   --scenes "S:F ..."   scenes (presets or files) and their frames [dam-break:60 fountain:120 tap:120]
#   --every K            export every K-th frame, and the initial state [10]
#   --backend B          cuda, cpu or cpu-parallel [cuda]
#   --keep               keep the PLY files (by default each side's are removed once compared; their
#                        SHA-256 sums stay in OUT/SCENE-a.sha256 and -b.sha256)
#
# OUT (created; must not hold a summary.txt) gets summary.txt (what was printed), each run's log
# (SCENE-a.log, SCENE-b.log) and the sums. A dry run without a GPU:
#   scripts/ply-identity.sh target/release/mpm target/release/mpm /tmp/ply --backend cpu-parallel \
#       --scenes "dam-break-coarse:6" --every 3
set -uo pipefail

fail() {
  echo "ply-identity: $*" >&2
  exit 2
}
usage="scripts/ply-identity.sh BIN_A BIN_B OUT [--scenes \"S:F ...\"] [--every K] [--backend B] [--keep] [-- ARGS]"
sides=() out="" scenes="dam-break:60 fountain:120 tap:120" every=10 backend=cuda keep=0 extra=()
while (($#)); do
  case $1 in
  --scenes | --every | --backend)
    (($# >= 2)) || fail "$1 needs a value"
    case $1 in --scenes) scenes=$2 ;; --every) every=$2 ;; --backend) backend=$2 ;; esac
    shift 2
    ;;
  --keep) keep=1 && shift ;;
  --) shift && extra=("$@") && break ;;
  -h | --help) sed -n '2,/^set -uo/p' "$0" | sed '$d; s/^# \{0,1\}//' && exit 0 ;;
  -*) fail "unknown option $1 (--help lists the options)" ;;
  *)
    if ((${#sides[@]} < 2)); then sides+=("$1"); elif [[ -z $out ]]; then out=$1; else fail "one more argument than $usage takes: $1"; fi
    shift
    ;;
  esac
done

# Everything is checked before the first run.
((${#sides[@]} == 2)) && [[ -n $out ]] || fail "usage: $usage"
for side in "${sides[@]}"; do
  bin=${side%%@*}
  [[ -x $bin && -f $bin ]] || fail "$bin is not an executable mpm (build it, or give its path)"
  if [[ $side == *@* ]]; then
    [[ -d ${side#*@} ]] || fail "${side#*@} (after @ in $side) is not a folder of PTX files"
  fi
done
[[ $every =~ ^[1-9][0-9]*$ ]] || fail "--every $every: give a whole number of frames from 1 up"
case $backend in cuda | cpu | cpu-parallel) ;; *) fail "--backend $backend: give cuda, cpu or cpu-parallel (fixed point repeats on each)" ;; esac
read -ra runs <<<"$scenes"
((${#runs[@]})) || fail "--scenes is empty: give SCENE:FRAMES pairs, e.g. \"dam-break:60\""
for run in "${runs[@]}"; do
  [[ $run =~ ^([^:]+):([1-9][0-9]*)$ ]] || fail "--scenes: '$run' is not SCENE:FRAMES (e.g. dam-break:60)"
  scene=${BASH_REMATCH[1]}
  if [[ $scene == *.toml ]]; then
    [[ -f $scene ]] || fail "--scenes: the scene file $scene does not exist"
  else
    "${sides[0]%%@*}" scenes --show "$scene" >/dev/null 2>&1 || fail "--scenes: $scene is not a preset (\`mpm scenes\` lists them)"
  fi
done
[[ ! -e $out/summary.txt ]] || fail "$out/summary.txt exists already; not overwriting it: give another OUT"
mkdir -p "$out" || fail "cannot create $out"
out=$(realpath "$out")
command -v sha256sum >/dev/null || fail "sha256sum is needed (coreutils)"

say() { echo "$*" | tee -a "$out/summary.txt"; }
say "A: ${sides[0]}"
say "B: ${sides[1]}"
say "device: $(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null | head -1 || echo "no nvidia-smi") ($backend backend), $(date -u +%Y-%m-%dT%H:%M:%SZ)"

# One side's run of one scene into OUT/SCENE-a or -b; the mpm command is said in the summary.
run_side() {
  local spec=$1 tag=$2 scene=$3 frames=$4 bin ptx_env=(-u MPM_PTX_DIR)
  bin=$(realpath "${spec%%@*}")
  [[ $spec == *@* ]] && ptx_env=("MPM_PTX_DIR=$(realpath "${spec#*@}")")
  local args=(run --backend "$backend" --scene "$scene" --frames "$frames" --scatter fixed-point
    --export "$out/$tag" --every "$every" "${extra[@]}")
  local shown="mpm ${args[*]}"
  [[ $spec == *@* ]] && shown="${ptx_env[0]} $shown"
  say "  $tag: ${shown//$out/OUT}"
  env "${ptx_env[@]}" "$bin" "${args[@]}" >"$out/$tag.log" 2>&1
}

status=0
for run in "${runs[@]}"; do
  scene=${run%:*} frames=${run##*:}
  name=$(basename "$scene" .toml)
  say "== $name, $frames frames, fixed point, every $every"
  for i in 0 1; do
    tag=$name-$([[ $i == 0 ]] && echo a || echo b)
    [[ ! -e $out/$tag ]] || fail "$out/$tag exists already (a scene twice in --scenes?)"
    if ! run_side "${sides[$i]}" "$tag" "$scene" "$frames"; then
      say "  $tag: the run failed; the end of $out/$tag.log:"
      tail -n 5 "$out/$tag.log" | tee -a "$out/summary.txt"
      exit 2
    fi
    (cd "$out/$tag" && sha256sum -- *.ply >"$out/$tag.sha256")
  done
  files=0 same=0
  # Every file of either side, so that a frame only one side wrote counts as a difference.
  for f in $( (cd "$out/$name-a" && ls -- *.ply; cd "$out/$name-b" && ls -- *.ply) | sort -u); do
    files=$((files + 1))
    a=$out/$name-a/$f b=$out/$name-b/$f
    if [[ ! -f $a || ! -f $b ]]; then
      say "  $f: missing on side $([[ -f $a ]] && echo B || echo A)"
    elif where=$(cmp -- "$a" "$b" 2>&1); then
      same=$((same + 1))
      say "  $f: identical"
    else
      say "  $f: different (${where##*: })"
    fi
  done
  if ((files > 0 && same == files)); then
    say "$name: $same of $files files identical"
  else
    say "$name: DIFFERENT: $same of $files files identical"
    status=1
  fi
  ((keep)) || rm -rf -- "${out:?}/$name-a" "${out:?}/$name-b"
done
((status == 0)) && say "every file identical" || say "some files differ"
exit $status
