#!/usr/bin/env bash
# Gathers what scripts/view-on-gpu.sh needs to open a real X window on a GPU server that has no X
# server and no network: Xvfb, xkbcomp and the XKB data, Mesa's software GLX provider (Xvfb's GLX
# extension loads it; the viewer itself renders through the NVIDIA driver), and the X11 client
# libraries that winit opens at run time. Run it on a Debian/Ubuntu development machine (amd64), from
# the checkout:
#
#   scripts/pack-x11.sh
#
# It downloads the Debian packages with `apt-get download` (a private package list: nothing is
# installed here) into a cache outside the checkout, unpacks them into a staging folder, keeps only
# what the programs above need (documentation and unused executables and libraries go), and writes
#
#   .gpu/x11/root.tar.xz      the pruned folder tree (unpacked on the GPU machine into /tmp, never /)
#   .gpu/x11/packages.txt     the packages and versions it came from
#
# Why a pruned tarball rather than the .deb files: Xvfb's GLX provider is Mesa's swrast_dri.so, which
# links LLVM (with z3, libxml2 and ICU behind it): the packages alone are about 60 MiB, too much
# beside the mpm binary for a machine that takes 64 MiB of files per run. Pruned and packed with
# xz -9 they are about 47 MiB.
#
# Environment: MPM_X11_DEB_CACHE (default ~/.cache/mpm/x11-debs) for the downloaded packages.
set -euo pipefail
top=$(git rev-parse --show-toplevel)
cd "$top"
exclude=$(git rev-parse --git-path info/exclude) # also right in a worktree, where .git is a file
mkdir -p "$(dirname "$exclude")"
grep -qxF '/.gpu/' "$exclude" 2>/dev/null || echo '/.gpu/' >>"$exclude"

# What the GPU machine must get: the server and its helpers, and the client libraries.
roots=(
  xvfb                # the X server, drawing into memory
  x11-xkb-utils       # xkbcomp: Xvfb runs it to compile the keyboard map at start-up
  xkb-data            # the keyboard descriptions xkbcomp reads
  libgl1-mesa-dri     # swrast_dri.so: without it Xvfb has no GLX extension at all
  libglx-mesa0        # Mesa's GLX client: only for a dry run without an NVIDIA GPU (--vendor mesa)
  libgl1 libglx0      # glvnd's libGL/libGLX: vendor-neutral loaders; they pick NVIDIA's libGLX_nvidia
  libx11-6 libx11-xcb1 libxcursor1 libxrandr2 libxi6 libxkbcommon-x11-0 # winit opens these
)

# Packages the dependency closure names that are left out, because every Debian and Ubuntu system
# (a minimal container image included) has them, and the GPU machine's own, newer copies must not be
# shadowed by Debian 12's on LD_LIBRARY_PATH. view-on-gpu.sh checks with ldd that each one it needs is
# found, and names any that is missing.
excluded=(
  # the C and C++ runtime
  libc6 libgcc-s1 libstdc++6 gcc-12-base
  # libraries of the base system (apt, systemd, coreutils need them)
  zlib1g liblzma5 libzstd1 libbz2-1.0 liblz4-1 libselinux1 libpcre2-8-0 libaudit1 libaudit-common
  libcap-ng0 libcap2 libgcrypt20 libgpg-error0 libsystemd0 libmd0 libtinfo6 libuuid1 libffi8
  # another provider of libsystemd0's library, which base systems use instead
  libelogind0
  # shell scripts and init-system pieces: nothing that runs from a folder needs them
  sysvinit-utils lsb-base x11-common
  # Xvfb's common files: /etc scripts, a manual, a 2 MB changelog and protocol.txt (only used to
  # name requests in error messages)
  xserver-common
)

cache=${MPM_X11_DEB_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/mpm/x11-debs}
lists=$cache/lists
mkdir -p "$lists/partial" "$cache/debs" .gpu/x11
# (Sandbox::User=root: the private folders are root's, so apt's download user could not write them.)
apt_opts=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists="$lists"
  -oAPT::Sandbox::User=root)
echo "pack-x11: updating the package list (private: $lists)"
apt-get "${apt_opts[@]}" update -qq >/dev/null

# The closure: every package the roots depend on, recursively (hard dependencies only). Lines that
# start with a space are the dependencies themselves; `<name>` lines are virtual packages, which
# their providers (also listed) stand for.
mapfile -t closure < <(
  apt-cache "${apt_opts[@]}" depends --recurse --no-recommends --no-suggests --no-conflicts \
    --no-breaks --no-replaces --no-enhances "${roots[@]}" |
    grep -v '^ ' | grep -v '^<' | sort -u
)
packages=()
for p in "${closure[@]}"; do
  skip=0
  for x in "${excluded[@]}"; do [[ $p == "$x" ]] && skip=1 && break; done
  ((skip)) || packages+=("$p")
done
echo "pack-x11: ${#packages[@]} packages (${#closure[@]} in the closure, the base system's left out)"

# The exact versions this list names, so that a stale cache or a changed archive shows.
manifest=$(mktemp)
trap 'rm -f "$manifest"' EXIT
apt-cache "${apt_opts[@]}" show --no-all-versions "${packages[@]}" |
  awk '/^Package:/{p=$2} /^Version:/{print p, $2}' | sort -u >"$manifest"
if [[ -f .gpu/x11/root.tar.xz ]] && cmp -s "$manifest" .gpu/x11/packages.txt; then
  echo "pack-x11: .gpu/x11/root.tar.xz is up to date ($(du -h .gpu/x11/root.tar.xz | cut -f1))"
  exit 0
fi

(cd "$cache/debs" && apt-get "${apt_opts[@]}" download -qq "${packages[@]}")
staging=$(mktemp -d)
trap 'rm -f "$manifest"; rm -rf "$staging"' EXIT
while read -r name version; do
  # apt-get names the file name_version_arch.deb with the epoch's ':' written as %3a.
  deb=$(ls "$cache/debs/${name}_${version/:/%3a}_"*.deb 2>/dev/null | head -n1)
  [[ -n $deb ]] || {
    echo "pack-x11: $name $version was not downloaded" >&2
    exit 1
  }
  dpkg-deb -x "$deb" "$staging"
done <"$manifest"

# Keep what the entry points need: the executables, Mesa's driver, and the client libraries (by
# soname), with every shared library they load, found by following DT_NEEDED inside the tree.
python3 - "$staging" <<'PY'
import os, shutil, subprocess, sys

root = sys.argv[1]
lib = os.path.join(root, "usr/lib/x86_64-linux-gnu")
# Debian 12 still ships some libraries in /lib: one folder, as on a merged-/usr system.
old_lib = os.path.join(root, "lib/x86_64-linux-gnu")
if os.path.isdir(old_lib):
    for name in os.listdir(old_lib):
        os.replace(os.path.join(old_lib, name), os.path.join(lib, name))
entry_files = ["usr/bin/Xvfb", "usr/bin/xkbcomp", "usr/lib/x86_64-linux-gnu/dri/swrast_dri.so"]
entry_sonames = [
    # winit's X11 back end and the libraries they open
    "libX11.so.6", "libX11-xcb.so.1", "libXcursor.so.1", "libXrandr.so.2", "libXi.so.6",
    "libxkbcommon-x11.so.0", "libxkbcommon.so.0", "libXext.so.6", "libXrender.so.1",
    "libXfixes.so.3", "libxcb.so.1",
    # glvnd's GLX loaders (vendor-neutral), and Mesa's GLX vendor library for the dry run
    "libGL.so.1", "libGLX.so.0", "libGLdispatch.so.0", "libGLX_mesa.so.0",
]

def needed(path):
    out = subprocess.run(["readelf", "-d", path], capture_output=True, text=True, check=True).stdout
    return [line.split("[", 1)[1].split("]", 1)[0] for line in out.splitlines() if "(NEEDED)" in line]

todo = [os.path.join(root, f) for f in entry_files] + [os.path.join(lib, s) for s in entry_sonames]
missing = [t for t in todo if not os.path.exists(t)]
if missing:
    sys.exit("pack-x11: not in the packages: " + ", ".join(missing))
keep = set()  # real paths of the ELF files to keep
while todo:
    real = os.path.realpath(todo.pop())
    if real in keep:
        continue
    keep.add(real)
    # A soname not in the tree is the base system's (view-on-gpu.sh checks it is there).
    todo += [os.path.join(lib, s) for s in needed(real) if os.path.exists(os.path.join(lib, s))]

def is_elf(path):
    with open(path, "rb") as f:
        return f.read(4) == b"\x7fELF"

# Every ELF file nothing needs goes (Mesa's other driver names are hard links of the one kept).
dropped = 0
for dirpath, _, filenames in os.walk(root):
    for name in filenames:
        path = os.path.join(dirpath, name)
        if not os.path.islink(path) and path not in keep and is_elf(path):
            os.unlink(path)
            dropped += 1
# Documentation, manuals, translations, service configuration: not used from a folder.
for sub in ["usr/share/doc", "usr/share/man", "usr/share/info", "usr/share/locale",
            "usr/share/lintian", "usr/share/bug", "usr/share/bash-completion", "etc", "lib", "var",
            "usr/lib/systemd"]:
    shutil.rmtree(os.path.join(root, sub), ignore_errors=True)
# Symlinks left dangling (to dropped libraries; chains take more than one pass).
while dangling := [os.path.join(d, n) for d, _, names in os.walk(root) for n in names
                   if os.path.islink(os.path.join(d, n)) and not os.path.exists(os.path.join(d, n))]:
    for path in dangling:
        os.unlink(path)
print(f"pack-x11: kept {len(keep)} executables and libraries, dropped {dropped} that nothing needs")
PY
# Empty folders left by the pruning are not worth carrying.
find "$staging" -mindepth 1 -type d -empty -delete

echo "pack-x11: compressing (xz -9, a few minutes on a busy machine)"
tar -C "$staging" --owner=0 --group=0 -cf - . | xz -9 -T1 >.gpu/x11/root.tar.xz.part
mv .gpu/x11/root.tar.xz.part .gpu/x11/root.tar.xz
install -m 644 "$manifest" .gpu/x11/packages.txt
echo "pack-x11: wrote .gpu/x11/root.tar.xz ($(du -h .gpu/x11/root.tar.xz | cut -f1)) from $(wc -l <.gpu/x11/packages.txt) packages"
