#!/usr/bin/env bash
# Runs the windowed viewer in a real X window on a GPU server that has no display: starts a private
# Xvfb (unpacked from .gpu/x11/root.tar.xz, made by scripts/pack-x11.sh), runs
# `mpm view --quit-after N --final-screenshot` in it with OpenGL from the NVIDIA driver (GLX,
# `__GLX_VENDOR_LIBRARY_NAME=nvidia`) and CUDA-GL interop on the window's context, stops Xvfb, and
# checks the last frame and the log (scripts/window_check.py). Exits non-zero when a check fails.
#
# On the GPU machine, as root, from the checkout with .gpu/bin/mpm and .gpu/x11/ (the tree brings
# glvnd's GL loaders along; the machine needs python3 and the NVIDIA driver):
#   bash scripts/view-on-gpu.sh                  (results in $OUT, or ./view-on-gpu-out)
# A dry run on a machine without an NVIDIA GPU (Mesa's software GLX, the CPU backend):
#   bash scripts/view-on-gpu.sh --vendor mesa --backend cpu-parallel --scene dam-break-coarse
#
# Options (defaults in brackets):
#   --vendor nvidia|mesa   GLX vendor library for the viewer [nvidia]
#   --backend B            mpm's backend [cuda]
#   --scene S              scene preset or file [dam-break]
#   --frames N             drawn frames before quitting [240]
#   --fixed-frames K       60 Hz frames stepped per drawn frame, 0 for the viewer's own real-time
#                          pacing (simulated time follows wall time) [1]
#   --size WxH             the window, and the X screen around it [1280x720]
#   --mpm PATH             the binary [.gpu/bin/mpm, else target/release/mpm]
#   --x11 TARBALL          the X11 tree [.gpu/x11/root.tar.xz]
#   --out DIR              where the results go [$OUT or ./view-on-gpu-out]: window.png (the viewer's
#                          last frame), screen.png (the X screen near the end), view.log, xvfb.log, check.txt
#   --timeout S            limit for the viewer run [300]
#   --min-fluid F          least fraction of the frame that must show fluid [0.02]
#   -- ARGS...             more arguments for `mpm view` (e.g. --draw points)
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)

vendor=nvidia backend=cuda scene=dam-break frames=240 fixed=1 size=1280x720
mpm="" nvidia_dir="" x11=.gpu/x11/root.tar.xz out=${OUT:-view-on-gpu-out} view_timeout=300 min_fluid=0.02 extra=()
fail() {
  echo "view-on-gpu: $*" >&2
  exit 2
}
while (($#)); do
  case $1 in
  --vendor | --backend | --scene | --frames | --fixed-frames | --size | --mpm | --x11 | --out | --timeout | --min-fluid)
    (($# >= 2)) || fail "$1 needs a value"
    case $1 in
    --vendor) vendor=$2 ;; --backend) backend=$2 ;; --scene) scene=$2 ;; --frames) frames=$2 ;;
    --fixed-frames) fixed=$2 ;; --size) size=$2 ;; --mpm) mpm=$2 ;; --x11) x11=$2 ;; --out) out=$2 ;;
    --timeout) view_timeout=$2 ;; --min-fluid) min_fluid=$2 ;;
    esac
    shift 2
    ;;
  --) shift && extra=("$@") && break ;;
  -h | --help) sed -n '2,/^set -uo/p' "$0" | sed '$d; s/^# \{0,1\}//' && exit 0 ;;
  *) fail "unknown argument $1 (--help lists the options)" ;;
  esac
done

# Everything is checked before anything starts.
case $vendor in
nvidia) renderer_re=NVIDIA ;;
mesa) renderer_re='llvmpipe|softpipe|Mesa' ;;
*) fail "--vendor $vendor: give nvidia (the GPU) or mesa (a dry run with software GL)" ;;
esac
[[ $frames =~ ^[1-9][0-9]*$ ]] || fail "--frames $frames: give a whole number from 1 up"
[[ $fixed =~ ^[0-9][0-9]?$ ]] && ((fixed <= 60)) || fail "--fixed-frames $fixed: give 1 to 60, or 0 for real-time pacing"
pacing=(--fixed-frames "$fixed")
((fixed == 0)) && pacing=()
case $backend in auto | cpu | cpu-parallel | cuda) ;; *) fail "--backend $backend: give cuda, cpu-parallel, cpu or auto" ;; esac
[[ $view_timeout =~ ^[1-9][0-9]*$ ]] || fail "--timeout $view_timeout: give whole seconds"
[[ $min_fluid =~ ^(0(\.[0-9]+)?|1(\.0+)?)$ ]] || fail "--min-fluid $min_fluid: give a fraction from 0 to 1"
[[ $size =~ ^([1-9][0-9]*)x([1-9][0-9]*)$ ]] || fail "--size $size: write WIDTHxHEIGHT, e.g. 1280x720"
if [[ -z $mpm ]]; then
  for m in .gpu/bin/mpm target/release/mpm; do [[ -x $m ]] && mpm=$m && break; done
  [[ -n $mpm ]] || fail "no mpm binary in .gpu/bin or target/release: build it, or give --mpm PATH"
fi
[[ -x $mpm ]] || fail "--mpm $mpm: not an executable file"
mpm=$(realpath "$mpm")
[[ -f $x11 ]] || fail "$x11 not found: make it on a development machine with scripts/pack-x11.sh and carry it along"
x11=$(realpath "$x11")
command -v python3 >/dev/null || fail "python3 is needed (scripts/window_check.py)"
mkdir -p "$out" || fail "cannot create the output folder $out"
out=$(realpath "$out")
for f in window.png screen.png view.log xvfb.log check.txt; do
  [[ ! -e $out/$f ]] || fail "$out/$f exists already; not overwriting it: give another --out"
done
# The transfer the log must name: CUDA-GL interop on the CUDA backend, a host copy on the CPU (auto:
# either, as the machine decides).
case $backend in
cuda) transfer='CUDA-GL interop' ;;
auto) transfer='' ;;
*) transfer='host copy' ;;
esac

say() { echo "view-on-gpu: $*" | tee -a "$out/check.txt" >&2; }

# glvnd opens the vendor library by name: from the loader's cache, or a driver folder put on the path.
if [[ $vendor == nvidia ]] && ! ldconfig -p | grep -q 'libGLX_nvidia\.so\.0 '; then
  found=""
  for d in /usr/local/nvidia/lib64 /usr/local/nvidia/lib /usr/lib/x86_64-linux-gnu /usr/lib64; do
    [[ -e $d/libGLX_nvidia.so.0 ]] && found=$d && break
  done
  [[ -n $found ]] || fail "the NVIDIA driver's GLX library libGLX_nvidia.so.0 is not installed (not in ldconfig -p nor the usual folders)"
  nvidia_dir=$found
fi

# Cleanup on every exit: the viewer if still running, the X server (SIGTERM so that it removes its
# lock file and socket; SIGKILL after 5 s), the xkbcomp link if this script made it, the unpacked tree.
root="" xvfb_pid="" view_pid="" made_link=""
cleanup() {
  if [[ -n $view_pid ]] && kill -0 "$view_pid" 2>/dev/null; then
    kill -TERM "$view_pid" 2>/dev/null # `timeout`, which passes it on to mpm
    wait "$view_pid" 2>/dev/null
  fi
  if [[ -n $xvfb_pid ]] && kill -0 "$xvfb_pid" 2>/dev/null; then
    kill -TERM "$xvfb_pid" 2>/dev/null
    for _ in $(seq 50); do kill -0 "$xvfb_pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$xvfb_pid" 2>/dev/null
  fi
  if [[ -n $made_link ]]; then rm -f "$made_link"; fi
  if [[ -n $root ]]; then rm -rf "$root"; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

root=$(mktemp -d /tmp/mpm-x11.XXXXXX)
timeout 120 python3 "$here/window_check.py" unpack "$x11" "$root" || fail "unpacking $x11 failed"
lib=$root/usr/lib/x86_64-linux-gnu
# The viewer gets the X11 client libraries and glvnd's vendor-neutral GL loaders from the tree, never
# Mesa's GLX vendor library or its helpers (with --vendor nvidia they would not be used anyway, but
# nothing of Mesa should be within reach of a run that is meant to prove the NVIDIA path).
client=$root/client-lib
mkdir -p "$client"
for f in "$lib"/*.so*; do
  case ${f##*/} in
  libGLX_mesa* | libGLX_indirect* | libglapi* | libgallium* | libEGL_mesa* | libgbm* | libLLVM* | libz3* | libicu* | libxml2* | libdrm* | libsensors* | libelf*) ;;
  *) ln -s "$f" "$client/" ;;
  esac
done
client_path=$client
[[ $vendor == mesa ]] && client_path=$client:$lib
if [[ -n $nvidia_dir ]]; then
  client_path+=:$nvidia_dir
  say "libGLX_nvidia.so.0 is not in the loader's cache; using it from $nvidia_dir"
fi

# Every shared library the programs need must resolve: the tree's own, or the machine's for the few
# pack-x11.sh leaves out (libc, zlib, ...). Name the missing ones rather than fail obscurely later.
missing=""
for f in "$root/usr/bin/Xvfb" "$root/usr/bin/xkbcomp" "$lib/dri/swrast_dri.so"; do
  m=$(LD_LIBRARY_PATH=$lib timeout 20 ldd "$f" 2>&1 | awk '/not found/{print $1}')
  [[ -z $m ]] || missing+=" ${f#$root/}: $(echo $m)"
done
for f in "$client"/libX11.so.6 "$client"/libX11-xcb.so.1 "$client"/libXcursor.so.1 "$client"/libXrandr.so.2 \
  "$client"/libXi.so.6 "$client"/libxkbcommon-x11.so.0 "$client"/libGL.so.1; do
  m=$(LD_LIBRARY_PATH=$client timeout 20 ldd "$f" 2>&1 | awk '/not found/{print $1}')
  [[ -z $m ]] || missing+=" ${f##*/}: $(echo $m)"
done
[[ -z $missing ]] || fail "libraries not found on this machine:$missing"

# Xvfb runs `/usr/bin/xkbcomp` to compile the keyboard map: the folder is compiled into the server
# (XKB_BIN_DIRECTORY) and no option or variable changes it (`-xkbdir` moves only the data). Where the
# machine has no xkbcomp, link the tree's there for this run; an existing one is never replaced.
if [[ ! -e /usr/bin/xkbcomp ]]; then
  ln -s "$root/usr/bin/xkbcomp" /usr/bin/xkbcomp || fail "cannot link /usr/bin/xkbcomp (Xvfb runs it from there)"
  made_link=/usr/bin/xkbcomp
  say "linked /usr/bin/xkbcomp -> the tree's for this run (removed afterwards)"
else
  say "using this machine's /usr/bin/xkbcomp (Xvfb runs it from there)"
fi

# The X server, all from the tree: libraries, Mesa's swrast_dri.so for its GLX extension
# (LIBGL_DRIVERS_PATH), the keyboard data (-xkbdir), built-in fonts only. -displayfd: it picks a free
# display number and writes it when it accepts connections.
[[ $size =~ ^([0-9]+)x([0-9]+)$ ]]
width=${BASH_REMATCH[1]} height=${BASH_REMATCH[2]}
display_file=$root/display
: >"$display_file"
mkdir -p "$root/fb" # -fbdir: the screen's pixels live in a file there (XWD), for the screen dump
env LD_LIBRARY_PATH="$lib" LIBGL_DRIVERS_PATH="$lib/dri" XLOCALEDIR="$root/usr/share/X11/locale" \
  "$root/usr/bin/Xvfb" -displayfd 3 -screen 0 "${width}x${height}x24" -nolisten tcp -noreset \
  +extension GLX -xkbdir "$root/usr/share/X11/xkb" -fp built-ins -fbdir "$root/fb" \
  3>"$display_file" >"$out/xvfb.log" 2>&1 &
xvfb_pid=$!
display=$(timeout 30 python3 "$here/window_check.py" wait-x "$display_file" "$xvfb_pid" 20 2>>"$out/check.txt") || {
  tail -n 20 "$out/xvfb.log" >&2
  fail "the X server did not come up (above: the end of $out/xvfb.log; $out/check.txt)"
}
tail -n1 "$out/check.txt" >&2
exe=$(readlink "/proc/$xvfb_pid/exe")
say "X server: pid $xvfb_pid, $exe, display $display, screen ${width}x${height}x24"
[[ $exe == "$root"/* ]] || fail "the X server running is $exe, not the tree's"

# The viewer, in a window as large as the screen.
say "running: mpm view --backend $backend --scene $scene --size $size --no-vsync ${pacing[*]} --quit-after $frames ${extra[*]}"
say "  with DISPLAY=$display __GLX_VENDOR_LIBRARY_NAME=$vendor"
start=$(date +%s)
env -u WAYLAND_DISPLAY DISPLAY="$display" __GLX_VENDOR_LIBRARY_NAME="$vendor" \
  LD_LIBRARY_PATH="$client_path${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" LIBGL_DRIVERS_PATH="$lib/dri" \
  XLOCALEDIR="$root/usr/share/X11/locale" XKB_CONFIG_ROOT="$root/usr/share/X11/xkb" \
  timeout -k 10 "$view_timeout" "$mpm" view --backend "$backend" --scene "$scene" --size "$size" \
  --no-vsync "${pacing[@]}" --quit-after "$frames" --final-screenshot "$out/window.png" \
  --capture-dir "$root" "${extra[@]}" >"$out/view.log" 2>&1 &
view_pid=$!
# While the viewer runs, copy the X screen every half second; a copy counts once the viewer is seen
# still drawing after it, so the last such copy shows the window's last frames. Still drawing: alive,
# and its exit line ("N frames drawn") not yet in the log, since it closes its window after that line
# but lives on a while (releasing CUDA), and a copy then shows an empty screen.
while kill -0 "$view_pid" 2>/dev/null; do
  sleep 0.5
  cp "$root/fb/Xvfb_screen0" "$root/screen.part" 2>/dev/null &&
    kill -0 "$view_pid" 2>/dev/null && ! grep -q "frames\{0,1\} drawn, particles by" "$out/view.log" &&
    mv "$root/screen.part" "$root/screen.xwd"
done
wait "$view_pid"
status=$?
say "mpm view exited with status $status after $(($(date +%s) - start)) s (log: $out/view.log)"
((status == 124 || status == 137)) && say "mpm view ran past --timeout $view_timeout s and was stopped"
tail -n 15 "$out/view.log" >&2

if [[ -f $root/screen.xwd ]]; then
  timeout 60 python3 "$here/window_check.py" xwd2png "$root/screen.xwd" "$out/screen.png" ||
    say "could not convert the X screen dump"
fi
cleanup
view_pid="" xvfb_pid="" made_link="" root=""
timeout 120 python3 "$here/window_check.py" check --shot "$out/window.png" --log "$out/view.log" \
  --screen "$out/screen.png" --renderer "$renderer_re" --transfer "$transfer" --min-fluid "$min_fluid" |
  tee -a "$out/check.txt"
checked=${PIPESTATUS[0]}
((status == 0)) || say "FAILED: mpm view exited with status $status"
((status == 0 && checked == 0))
