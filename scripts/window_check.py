#!/usr/bin/env python3
"""Helpers of scripts/view-on-gpu.sh, standard library only (the GPU machine has python3 and no
packages):

  window_check.py unpack TARBALL DEST
      Unpacks the tarball that scripts/pack-x11.sh made (no xz program needed).
  window_check.py wait-x DISPLAY_FILE SERVER_PID TIMEOUT_S
      Waits until the X server started with `-displayfd` has written its display number, connects
      to it (the X11 connection handshake) and asks whether it has the GLX extension. Prints the
      display (`:N`) on stdout; fails if the server dies, refuses, lacks GLX or takes too long.
  window_check.py xwd2png XWD PNG
      Converts Xvfb's screen (the file `-fbdir` keeps, in XWD format) into a PNG.
  window_check.py check --shot PNG --log LOG [--screen PNG] [--renderer REGEX] [--transfer WORDS]
                        [--min-fluid F]
      Checks the viewer's last frame and log: enough of the frame shows fluid, the OpenGL renderer
      the viewer reported matches REGEX, and the particles reached OpenGL by the expected path; with
      --screen, that the X server's screen shows the fluid too (the frames were presented to the
      window, not only drawn).
"""

import argparse
import os
import re
import socket
import struct
import sys
import tarfile
import time
import zlib

# The viewer's clear colour (src/render/renderer.rs BACKGROUND, 0..1) in 0..255.
BACKGROUND = tuple(round(c * 255) for c in (0.09, 0.10, 0.12))


def unpack(tarball, dest):
    with tarfile.open(tarball, "r:xz") as tar:
        if hasattr(tarfile, "data_filter"):
            tar.extractall(dest, filter="tar")  # keeps symlinks and modes, refuses paths out of dest
        else:
            tar.extractall(dest)


def x_handshake(number):
    """Opens the X11 connection to display :number, then asks for GLX. Returns (vendor, release,
    has_glx)."""
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.settimeout(5)
    try:
        sock.connect(f"/tmp/.X11-unix/X{number}")
        # Little-endian byte order, protocol 11.0, no authorisation.
        sock.sendall(struct.pack("<cxHHHHxx", b"l", 11, 0, 0, 0))
        head = recv_exactly(sock, 8)
        status, _, major, minor, extra_words = struct.unpack("<BBHHH", head)
        body = recv_exactly(sock, 4 * extra_words)
        if status != 1:
            reason = body[: head[1]].decode(errors="replace") if status == 0 else "authentication required"
            raise RuntimeError(f"the X server refused the connection: {reason}")
        release, vendor_len = struct.unpack_from("<I", body, 0)[0], struct.unpack_from("<H", body, 16)[0]
        vendor = body[32 : 32 + vendor_len].decode(errors="replace")
        # QueryExtension (opcode 98) "GLX".
        name = b"GLX"
        padded = name + b"\0" * (-len(name) % 4)
        sock.sendall(struct.pack("<BxHHxx", 98, 2 + len(padded) // 4, len(name)) + padded)
        reply = recv_exactly(sock, 32)
        if reply[0] != 1:
            raise RuntimeError(f"QueryExtension failed (X error {reply[1]})")
        return vendor, release, bool(reply[8])
    finally:
        sock.close()


def recv_exactly(sock, n):
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise RuntimeError("the X server closed the connection")
        data += chunk
    return data


def wait_x(display_file, pid, timeout):
    deadline = time.monotonic() + timeout
    number = None
    while time.monotonic() < deadline:
        if not os.path.exists(f"/proc/{pid}") or open(f"/proc/{pid}/stat").read().split()[2] == "Z":
            sys.exit("wait-x: the X server exited during start-up (its log says why)")
        text = open(display_file).read().strip() if os.path.exists(display_file) else ""
        if text.isdigit():
            number = int(text)
            try:
                vendor, release, has_glx = x_handshake(number)
                break
            except (OSError, RuntimeError) as e:
                last = e
        time.sleep(0.1)
    else:
        what = f"display :{number} did not answer ({last})" if number is not None else "no display number"
        sys.exit(f"wait-x: {what} within {timeout} s")
    print(f"wait-x: display :{number} answers: {vendor}, release {release}, "
          f"GLX extension {'present' if has_glx else 'MISSING'}", file=sys.stderr)
    if not has_glx:
        sys.exit("wait-x: the X server has no GLX extension (its log says why: usually swrast_dri.so "
                 "could not be loaded)")
    print(f":{number}")


def read_png(path):
    """Decodes an 8-bit RGB or RGBA PNG (what `mpm` writes) into (width, height, channels, rows)."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path} is not a PNG file")
    pos, idat, header = 8, [], None
    while pos < len(data):
        length, kind = struct.unpack_from(">I4s", data, pos)
        chunk = data[pos + 8 : pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", chunk)
        elif kind == b"IDAT":
            idat.append(chunk)
        elif kind == b"IEND":
            break
    width, height, depth, colour, _, _, interlace = header
    channels = {2: 3, 6: 4}.get(colour)
    if depth != 8 or channels is None or interlace:
        raise ValueError(f"{path}: only 8-bit RGB/RGBA non-interlaced PNGs are read here")
    raw = zlib.decompress(b"".join(idat))
    stride = width * channels
    rows, previous = [], bytearray(stride)
    for y in range(height):
        filter_type = raw[y * (stride + 1)]
        row = bytearray(raw[y * (stride + 1) + 1 : (y + 1) * (stride + 1)])
        if filter_type == 1:  # Sub
            for i in range(channels, stride):
                row[i] = (row[i] + row[i - channels]) & 255
        elif filter_type == 2:  # Up
            row = bytearray((a + b) & 255 for a, b in zip(row, previous))
        elif filter_type == 3:  # Average
            for i in range(stride):
                left = row[i - channels] if i >= channels else 0
                row[i] = (row[i] + ((left + previous[i]) >> 1)) & 255
        elif filter_type == 4:  # Paeth
            for i in range(stride):
                a = row[i - channels] if i >= channels else 0
                b = previous[i]
                c = previous[i - channels] if i >= channels else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                row[i] = (row[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(row)
        previous = row
    return width, height, channels, rows


def xwd_to_png(xwd_path, png_path):
    """Xvfb's -fbdir screen file: an XWD header (big-endian CARD32 fields), the window name, the
    colour map, then the pixels, 32 bits each in TrueColor."""
    data = open(xwd_path, "rb").read()
    fields = struct.unpack_from(">25I", data, 0)
    if fields[1] != 7:
        raise ValueError(f"{xwd_path} is not an XWD (version 7) file")
    header_size, depth, width, height = fields[0], fields[3], fields[4], fields[5]
    byte_order, bits_per_pixel, bytes_per_line = fields[7], fields[11], fields[12]
    masks, ncolors = fields[14:17], fields[19]
    if bits_per_pixel != 32 or depth != 24:
        raise ValueError(f"{xwd_path}: {bits_per_pixel} bits per pixel, depth {depth}; 32/24 expected")
    # Which byte of a pixel holds each channel (byte_order 0: least significant byte first).
    offsets = []
    for mask in masks:
        shift = (mask & -mask).bit_length() - 1
        offsets.append(shift // 8 if byte_order == 0 else 3 - shift // 8)
    pixels = data[header_size + 12 * ncolors :]
    raw = bytearray()
    for y in range(height):
        row = pixels[y * bytes_per_line : y * bytes_per_line + 4 * width]
        rgb = bytearray(3 * width)
        for k in range(3):
            rgb[k::3] = row[offsets[k] :: 4]
        raw += b"\0" + rgb  # filter type 0
    write_png(png_path, width, height, bytes(raw))


def write_png(path, width, height, raw_rows):
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    with open(path, "xb") as f:  # never overwrites
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw_rows, 6)))
        f.write(chunk(b"IEND", b""))


def fluid_fraction(width, height, channels, rows, from_x=0.0):
    """Fractions of the frame that differ from the background, and that show fluid: a clear colour
    (the colour scale and the water are blue to red; the box's lines are grey) left of the colour
    bar (the right 5 % of the frame) and right of `from_x` (a fraction of the width)."""
    covered = fluid = 0
    left, right = int(width * from_x), int(width * 0.95)
    for row in rows:
        for x in range(width):
            i = x * channels
            r, g, b = row[i], row[i + 1], row[i + 2]
            if abs(r - BACKGROUND[0]) > 12 or abs(g - BACKGROUND[1]) > 12 or abs(b - BACKGROUND[2]) > 12:
                covered += 1
                if left <= x < right and max(r, g, b) - min(r, g, b) >= 40:
                    fluid += 1
    return covered / (width * height), fluid / (width * height)


def check(args):
    failures = []
    log = open(args.log, errors="replace").read() if os.path.exists(args.log) else ""
    if not log:
        failures.append(f"no viewer log at {args.log}")

    renderer = next((l.split("OpenGL: ", 1)[1] for l in log.splitlines() if l.startswith("OpenGL: ")), None)
    print(f"OpenGL renderer: {renderer or 'not reported'}")
    if renderer is None:
        failures.append("the viewer did not report its OpenGL renderer (it did not open a GL window)")
    elif not re.search(args.renderer, renderer):
        failures.append(f"the renderer `{renderer}` does not match `{args.renderer}`")

    path = re.search(r"particles by (.+?); the longest", log)
    transfer = path.group(1) if path else None
    refused = re.search(r"CUDA-OpenGL interop unavailable \((.*)\)", log)
    print(f"particles reached OpenGL by: {transfer or 'not reported'}"
          + (f" (interop refused: {refused.group(1)})" if refused else ""))
    print(f"interop: {'yes' if transfer == 'CUDA-GL interop' else 'no'}")
    if transfer is None:
        failures.append("the viewer did not say how the particles reached OpenGL (did it finish?)")
    elif args.transfer not in transfer:
        failures.append(f"particles went by `{transfer}`, expected `{args.transfer}`")

    stopped = re.search(r"viewer: the stepping stopped on an error at t = ([0-9.]+) s", log)
    if stopped:
        failures.append(f"the simulation stopped on an error at t = {stopped.group(1)} s (view.log says which)")

    if not os.path.exists(args.shot):
        failures.append(f"no screenshot at {args.shot}")
    else:
        width, height, channels, rows = read_png(args.shot)
        covered, fluid = fluid_fraction(width, height, channels, rows)
        print(f"screenshot: {width}x{height}, {100 * covered:.1f}% differs from the background, "
              f"fluid pixel fraction {100 * fluid:.1f}% (at least {100 * args.min_fluid:.1f}% wanted)")
        if fluid < args.min_fluid:
            failures.append(f"too little fluid in the frame: {100 * fluid:.2f}%")
        if covered > 0.9:
            failures.append(f"the frame is filled ({100 * covered:.0f}% not background), not drawn")
    if args.screen:
        if not os.path.exists(args.screen):
            failures.append(f"no dump of the X screen at {args.screen}")
        else:
            width, height, channels, rows = read_png(args.screen)
            # Only the right half counts: the panel on the left has coloured widgets (its legend).
            # The scene is the part of the window right of the panel: half the frame's share suffices.
            _, fluid = fluid_fraction(width, height, channels, rows, from_x=0.5)
            print(f"X screen: {width}x{height}, fluid pixel fraction {100 * fluid:.1f}% "
                  f"(at least {50 * args.min_fluid:.1f}% wanted)")
            if fluid < args.min_fluid / 2:
                failures.append(f"the X screen shows too little fluid ({100 * fluid:.2f}%): the frames "
                                "were drawn but not presented to the window")
    for f in failures:
        print(f"FAILED: {f}")
    print("window check: " + ("passed" if not failures else f"{len(failures)} failed"))
    return 1 if failures else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("unpack")
    p.add_argument("tarball")
    p.add_argument("dest")
    p = sub.add_parser("wait-x")
    p.add_argument("display_file")
    p.add_argument("pid", type=int)
    p.add_argument("timeout", type=float)
    p = sub.add_parser("xwd2png")
    p.add_argument("xwd")
    p.add_argument("png")
    p = sub.add_parser("check")
    p.add_argument("--shot", required=True)
    p.add_argument("--log", required=True)
    p.add_argument("--screen", help="a PNG of the X server's screen, taken while the viewer ran")
    p.add_argument("--renderer", default="NVIDIA", help="regular expression the GL renderer must match")
    p.add_argument("--transfer", default="CUDA-GL interop", help="the particle path the log must name")
    p.add_argument("--min-fluid", type=float, default=0.02, help="least fraction of fluid pixels")
    args = parser.parse_args()
    if args.command == "unpack":
        unpack(args.tarball, args.dest)
    elif args.command == "wait-x":
        wait_x(args.display_file, args.pid, args.timeout)
    elif args.command == "xwd2png":
        xwd_to_png(args.xwd, args.png)
    else:
        sys.exit(check(args))


if __name__ == "__main__":
    main()
