#!/usr/bin/env bash
# Issue 47 (the grid update's wall blocks apart): fixed point must write the same bytes before and
# after. Runs each case with both builds (fixed-point scatter), exports every frame as PLY
# (position, velocity, density of every particle) and compares the files byte for byte. The cases
# cover each pair of list kernels: water (the dam break, whose y and z walls' reaches cross node
# blocks, and bench-65k), static colliders (dam-break-obstacle), a Coulomb collider at the mirror
# (wave-tank: the friction pair), rigid bodies (boats, ball-drop) and a solid on a friction floor
# (sand-column); the fused pipeline (the mirror inside the wall kernel) and the binned one (mirror_walls
# before, the wall kernel without the mirror). A case both builds refuse (the binned pipeline refuses
# a Coulomb collider at the mirror) is reported and skipped.
#
#   .gpu-exp/split-bytes.sh BEFORE_MPM AFTER_MPM [FRAMES]
#
# Either side may be MPM@PTX_DIR, as in scripts/bench-ab.sh. BACKEND (cuda) and OUT (a new folder
# under /tmp) may be set.
set -u
before=$1 after=$2 frames=${3:-6}
backend=${BACKEND:-cuda}
out=${OUT:-$(mktemp -d /tmp/split-bytes.XXXXXX)}/split-bytes
rm -rf "$out"; mkdir -p "$out"
cases=("dam-break fused" "dam-break binned" "bench-65k fused" "dam-break-obstacle fused"
       "dam-break-obstacle binned" "wave-tank fused" "boats fused" "ball-drop fused" "sand-column fused")
same=0 differ=0 refused=0
for c in "${cases[@]}"; do
    read -r scene pipeline <<< "$c"
    for side in before after; do
        spec=$before; [ $side = after ] && spec=$after
        bin=${spec%%@*} ptx_env=(-u MPM_PTX_DIR)
        [[ $spec == *@* ]] && ptx_env=("MPM_PTX_DIR=${spec#*@}")
        dir="$out/$scene-$pipeline-$side"
        env "${ptx_env[@]}" "$bin" run --backend "$backend" --scene "$scene" --pipeline "$pipeline" \
            --scatter fixed-point --frames "$frames" --export "$dir" > "$dir.log" 2>&1
        echo $? > "$dir.rc"
    done
    b="$out/$scene-$pipeline-before" a="$out/$scene-$pipeline-after"
    if [ "$(cat "$b.rc")" != 0 ] || [ "$(cat "$a.rc")" != 0 ]; then
        if [ "$(cat "$b.rc")" != 0 ] && [ "$(cat "$a.rc")" != 0 ]; then
            echo "$scene $pipeline: refused by both (rc $(cat "$b.rc")): $(grep -m1 -i error "$b.log")"
            refused=$((refused + 1))
        else
            echo "$scene $pipeline: DIFFERS: rc $(cat "$b.rc") before, $(cat "$a.rc") after (logs $b.log, $a.log)"
            differ=$((differ + 1))
        fi
        continue
    fi
    files=$(ls "$b" | wc -l)
    if [ "$files" -gt 0 ] && diff -rq "$b" "$a" > /dev/null; then
        echo "$scene $pipeline: the same bytes, $files frames"
        same=$((same + 1))
    else
        echo "$scene $pipeline: DIFFERS: $(diff -rq "$b" "$a" | head -3 | tr '\n' ' ')"
        differ=$((differ + 1))
    fi
done
echo "same $same, differ $differ, refused by both $refused (output: $out)"
[ "$differ" = 0 ]
