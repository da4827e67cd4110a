#!/usr/bin/env bash
# GPU milliseconds per render pass for each draw mode (points, spheres, surface), scene (65,536,
# 451,200 and 655,360 particles) and size (1920x1080, 3840x2160): the table of BENCHMARKS.md, section
# "Render passes". Each cell is one `mpm render --no-images --timings FILE` run (CUDA backend, interop);
# the per-pass times are OpenGL timer queries averaged over the frames after the warm-up.
#
#   OUT=results/ bash scripts/render-passes.sh          # on the GPU machine, from the repo root
#
# Environment: OUT (required; a folder for the JSON and logs, created, never overwritten), MPM (the
# binary; default .gpu/bin/mpm as docs/gpu.md lays it out, else target/release/mpm), FRAMES (60
# frames after the initial state; 4 are warm-up), BACKEND (cuda), SCENES and SIZES (space-separated,
# to try the script on a smaller set: `BACKEND=cpu-parallel SCENES=dam-break-coarse SIZES=320x180
# FRAMES=6` runs on a machine without a GPU, through Mesa). Prints the markdown table on stdout and
# writes it to $OUT/render-passes.md.
set -euo pipefail

out=${OUT:?set OUT to a folder for the results}
mpm=${MPM:-}
if [[ -z $mpm ]]; then
  if [[ -x .gpu/bin/mpm ]]; then mpm=.gpu/bin/mpm; else mpm=target/release/mpm; fi
fi
[[ -x $mpm ]] || { echo "no mpm binary at $mpm: build it (cargo build --release) or set MPM" >&2; exit 1; }
frames=${FRAMES:-60}
mkdir -p "$out"
if compgen -G "$out/render-*.json" >/dev/null; then
  echo "$out already holds render-*.json from an earlier run; choose an empty OUT" >&2
  exit 1
fi

read -r -a scenes <<<"${SCENES:-bench-65k dam-break bench-655k}"
read -r -a sizes <<<"${SIZES:-1920x1080 3840x2160}"
backend=${BACKEND:-cuda}
modes=(points spheres surface)
for scene in "${scenes[@]}"; do
  for size in "${sizes[@]}"; do
    for mode in "${modes[@]}"; do
      name="render-$scene-$size-$mode"
      echo "== $scene $size $mode" >&2
      "$mpm" render --scene "$scene" --frames "$frames" --size "$size" --backend "$backend" --no-images \
        --draw "$mode" --timings "$out/$name.json" | tee "$out/$name.log" >&2
    done
  done
done

python3 - "$out" "${scenes[*]}" "${sizes[*]}" "${modes[*]}" <<'PY' | tee "$out/render-passes.md"
import json, re, sys
out, scenes, sizes, modes = sys.argv[1], *(a.split() for a in sys.argv[2:5])
passes = ["scene", "particles", "depth", "thickness", "smoothing", "shading", "legend"]
print("| particles | size | draw | " + " | ".join(passes) + " | GPU total | wall render |")
print("|---:|---|---|" + "---:|" * (len(passes) + 2))
target = None
for scene in scenes:
    for size in sizes:
        for mode in modes:
            name = f"{out}/render-{scene}-{size}-{mode}"
            report = json.load(open(name + ".json"))
            count = re.search(r"(\d+) particles", open(name + ".log").read()).group(1)
            t = report["timings"]
            cells = [f"{t['gpu_passes_ms'][p]:.3f}" if p in t["gpu_passes_ms"] else "" for p in passes]
            print(f"| {int(count):,} | {size} | {mode} | " + " | ".join(cells)
                  + f" | **{t['gpu_render_ms']:.3f}** | {t['render_ms']:.3f} |")
            if scene == "dam-break" and size == "1920x1080" and mode == "surface":
                target = t["gpu_render_ms"]
print()
print("GPU milliseconds per frame (OpenGL timer queries, means over the frames after 4 warm-up);")
print("'wall render' is the host's clock around feeding the particles (interop), drawing and glFinish.")
if target is not None:
    verdict = "met" if target <= 2.5 else "NOT met"
    print(f"Target: the surface at 1920x1080 with the 451,200-particle dam break <= 2.5 ms: {target:.3f} ms, {verdict}.")
PY
