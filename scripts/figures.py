#!/usr/bin/env python3
"""Reads what scripts/figures.sh ran (OUT/raw/) and writes OUT/figures.json (every raw number, with
its command, the device, the date and the commit) and OUT/figures.md (the table, one figure a cell).

    python3 scripts/figures.py OUT --commit HASH --backend B --quick 0|1

Exits 1 when a command failed or its output could not be read (the table then says which), 2 on bad
arguments. figures.sh calls it; run it by hand to rewrite the table from the same raw output.
"""
import argparse
import json
import os
import re
import sys

# The rows of the table, in order: (figure id, the run it is read from, label, unit, digits).
ROWS = [
    ("bench-655k", "bench-655k", "bench-655k (655,360 particles, 100^3 grid), ms a substep, median", "ms", 4),
    ("bench-65k", "bench-65k", "bench-65k (65,536 particles, 100^3 grid), ms a substep, median", "ms", 4),
    ("dam-break", "dam-break", "the dam break (451,200 particles), ms a substep, median", "ms", 4),
    ("16m", "16m", "16.8M particles, 256^3 grid, ms a substep, median", "ms", 3),
    ("16m-ns", "16m", "16.8M particles, 256^3 grid, ns a particle-step", "ns", 3),
    ("fixed-point", "fixed-point", "fixed-point substep / float substep, bench-655k (medians)", "x", 2),
    ("render-dam-break", "render-dam-break", "the dam break headless at 960x540, ms a 60 Hz frame (simulation + render)", "ms", 2),
    ("render-dam-break-sim", "render-dam-break", "the same, simulation, ms a frame", "ms", 2),
    ("render-dam-break-render", "render-dam-break", "the same, render (the water surface), ms a frame", "ms", 2),
    ("render-1m", "render-1m", "`dam-break-1m` (1,026,000 particles) headless at 960x540, ms a frame", "ms", 2),
    ("surface-1080", "surface-1080", "the dam break's water surface at 1920x1080, GPU ms a frame", "ms", 2),
    ("run", "run", "`mpm run --frames 300` (the dam break), wall time / summed GPU step time", "x", 2),
    ("viewer-fps", "viewer-fixed-1", "the dam break in the viewer's window (1280x720), FPS stepping one 60 Hz frame a draw", "FPS", 1),
    ("viewer-real-time", "viewer-fixed-1", "the same, times real time", "x", 2),
    ("viewer-own-pacing", "viewer-fixed-0", "the viewer's window with its own (real-time) pacing, FPS", "FPS", 1),
]

FRAME_LINE = re.compile(r"^frame\s+(\d+)\s.*?substeps=\s*(\d+)\s.*?step=([0-9.]+) ms")
VIEWER_LINE = re.compile(
    r"mean draw interval ([0-9.]+) ms \(([0-9.]+) FPS\); simulated ([0-9.]+) s in ([0-9.]+) s of wall time "
    r"\(([0-9.]+)x real time\)"
)
DEVICE_LINE = re.compile(r"^\s*device (\d+): (.+?), ([0-9.]+) GiB")
# Options whose value is a file or folder of this run: left out of the table's commands.
PATH_OPTIONS = {"--json", "--timings", "--out", "--mpm", "--x11"}


class Unreadable(Exception):
    """A run's output that does not hold what its figure needs."""


def read_runs(raw):
    runs = {}
    with open(os.path.join(raw, "commands.tsv")) as f:
        for line in f:
            fields = line.rstrip("\n").split("\t")
            if len(fields) != 5:
                continue
            run_id, rc, start, end, command = fields
            runs[run_id] = {
                "id": run_id,
                "command": command,
                "exit": int(rc),
                "wall_s": float(end) - float(start),
                "log": f"raw/{run_id}.log",
            }
    return runs


def shown(command):
    """The command as a reader would type it: no output paths, the scripts by their checkout path."""
    words = command.split(" ")
    kept = []
    skip = False
    for word in words:
        if skip:
            skip = False
            continue
        if word in PATH_OPTIONS:
            skip = True
            continue
        kept.append(word)
    if len(kept) >= 2 and kept[0] == "bash" and kept[1].endswith("/view-on-gpu.sh"):
        kept = ["scripts/view-on-gpu.sh"] + kept[2:]
    return " ".join(kept)


def load_json(raw, run_id):
    path = os.path.join(raw, f"{run_id}.json")
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as why:
        raise Unreadable(f"raw/{run_id}.json: {why}") from why


def bench_total(raw, run_id):
    """The one scene's phase table of an `mpm bench --json` run."""
    report = load_json(raw, run_id)
    phases = report.get("phases") or []
    if len(phases) != 1 or "total" not in phases[0]:
        raise Unreadable(f"raw/{run_id}.json: expected one scene's phase table, found {len(phases)}")
    return phases[0]


def render_timings(raw, run_id):
    report = load_json(raw, run_id)
    timings = report.get("timings") or {}
    if not timings.get("frames_measured"):
        raise Unreadable(f"raw/{run_id}.json: no frame was timed (too few --frames?)")
    return report


def run_ratio(raw, run):
    """Wall time of the whole process against the sum over its frame lines of substeps x step ms."""
    gpu_ms = 0.0
    frames = 0
    with open(os.path.join(raw, "run.log")) as f:
        for line in f:
            m = FRAME_LINE.match(line)
            if m:
                frames += 1
                gpu_ms += int(m.group(2)) * float(m.group(3))
    if frames == 0 or gpu_ms <= 0.0:
        raise Unreadable("raw/run.log: no frame line with a step time (`step=... ms`)")
    return {
        "frames": frames,
        "wall_s": run["wall_s"],
        "summed_step_s": gpu_ms / 1e3,
        "ratio": run["wall_s"] / (gpu_ms / 1e3),
    }


def viewer(raw, run_id):
    path = os.path.join(raw, run_id, "view.log")
    try:
        with open(path) as f:
            text = f.read()
    except OSError as why:
        raise Unreadable(f"raw/{run_id}/view.log: {why}") from why
    m = VIEWER_LINE.search(text)
    if not m:
        raise Unreadable(f"raw/{run_id}/view.log: no 'mean draw interval' line (did the viewer draw?)")
    interval, fps, simulated, wall, real_time = (float(g) for g in m.groups())
    return {"draw_interval_ms": interval, "fps": fps, "simulated_s": simulated, "wall_s": wall, "real_time": real_time}


def figure(row_id, run_id, raw, runs, cache):
    """(value, raw numbers) of one row; raises Unreadable."""
    run = runs[run_id]
    if run_id not in cache:
        if run_id in ("bench-655k", "bench-65k", "dam-break", "16m", "fixed-point"):
            cache[run_id] = bench_total(raw, run_id)
        elif run_id.startswith("render") or run_id == "surface-1080":
            cache[run_id] = render_timings(raw, run_id)
        elif run_id == "run":
            cache[run_id] = run_ratio(raw, run)
        else:
            cache[run_id] = viewer(raw, run_id)
    data = cache[run_id]
    if row_id in ("bench-655k", "bench-65k", "dam-break", "16m"):
        return data["total"]["median_ms"], {
            "median_ms": data["total"]["median_ms"],
            "mean_ms": data["total"]["mean_ms"],
            "particles": data["particles"],
            "steps": data["steps"],
            "device": data["device"],
        }
    if row_id == "16m-ns":
        ns = data["total"]["median_ms"] * 1e6 / data["particles"]
        return ns, {"median_ms": data["total"]["median_ms"], "particles": data["particles"]}
    if row_id == "fixed-point":
        if "bench-655k" not in runs or runs["bench-655k"]["exit"] != 0:
            raise Unreadable("the ratio needs the float run, bench-655k, which did not run or failed")
        if "bench-655k" not in cache:
            cache["bench-655k"] = bench_total(raw, "bench-655k")
        fixed, float_ = data["total"]["median_ms"], cache["bench-655k"]["total"]["median_ms"]
        return fixed / float_, {"fixed_point_median_ms": fixed, "float_median_ms": float_}
    if row_id.startswith("render") or row_id == "surface-1080":
        t = data["timings"]
        key = {"render-dam-break-sim": "sim_ms", "render-dam-break-render": "render_ms", "surface-1080": "gpu_render_ms"}
        return t[key.get(row_id, "frame_ms")], dict(t, transfer=data.get("transfer"), opengl=data.get("opengl"))
    if row_id == "run":
        return data["ratio"], data
    if row_id == "viewer-real-time":
        return data["real_time"], data
    return data["fps"], data


def device_of(raw):
    """The device's name: `mpm devices`' line for MPM_CUDA_DEVICE, else nvidia-smi's first line."""
    ordinal = os.environ.get("MPM_CUDA_DEVICE", "0")
    names = {}
    try:
        with open(os.path.join(raw, "devices.txt")) as f:
            for line in f:
                m = DEVICE_LINE.match(line)
                if m:
                    names[m.group(1)] = m.group(2)
    except OSError:
        pass
    smi = ""
    try:
        with open(os.path.join(raw, "nvidia-smi.txt")) as f:
            smi = f.readline().strip()
    except OSError:
        pass
    driver = smi.split(",")[1].strip() if smi.count(",") == 1 else None
    name = names.get(ordinal) or (smi.split(",")[0].strip() if driver else None)
    return name, driver


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--commit", required=True)
    parser.add_argument("--backend", required=True)
    parser.add_argument("--quick", type=int, choices=(0, 1), default=0)
    args = parser.parse_args()
    raw = os.path.join(args.out, "raw")
    try:
        runs = read_runs(raw)
        with open(os.path.join(raw, "date.txt")) as f:
            date = f.read().strip()
    except OSError as why:
        sys.exit(f"figures.py: {why}: give the folder scripts/figures.sh wrote into")

    gpu, driver = device_of(raw)
    skipped = []
    try:
        with open(os.path.join(raw, "viewer-skipped.txt")) as f:
            skipped.append(f.read().strip().removeprefix("figures: "))
    except OSError:
        pass
    rows, failed, cache, devices = [], [], {}, set()
    for row_id, run_id, label, unit, digits in ROWS:
        if run_id not in runs:
            continue  # not asked for (--only, --skip-viewer) or skipped (no X11 tree)
        run = runs[run_id]
        entry = {"id": row_id, "label": label, "unit": unit, "command": run["command"], "log": run["log"]}
        if run["exit"] != 0:
            entry["error"] = f"exit status {run['exit']} (see {run['log']})"
        else:
            try:
                value, numbers = figure(row_id, run_id, raw, runs, cache)
                entry.update(value=value, text=f"{value:.{digits}f}", raw=numbers)
                if "device" in numbers:
                    devices.add(numbers["device"])
            except (Unreadable, KeyError, ValueError, OSError) as why:
                entry["error"] = f"unreadable: {why}"
        if "error" in entry:
            failed.append(f"{row_id}: {entry['error']}")
        rows.append(entry)

    # The backend's own name for the device (bench's JSON) where every bench agrees, else the driver's.
    device = gpu or (devices.pop() if len(devices) == 1 else None) or "unknown device"
    if args.backend != "cuda" and len(devices) == 1:
        device = next(iter(devices))
    result = {
        "date": date,
        "commit": args.commit,
        "device": device,
        "driver": driver,
        "backend": args.backend,
        "quick": bool(args.quick),
        "made_by": "scripts/figures.sh",
        "figures": rows,
        "runs": list(runs.values()),
        "failed": failed,
        "skipped": skipped,
    }
    with open(os.path.join(args.out, "figures.json"), "w") as f:
        json.dump(result, f, indent=1)
        f.write("\n")

    lines = []
    if args.quick:
        lines.append("**A dry run (`--quick`): too few substeps and frames to be figures.**\n")
    lines.append(
        f"On {device}{f' (driver {driver})' if driver else ''}, {args.backend} backend, commit {args.commit}, "
        f"{date[:10]}; made by `scripts/figures.sh` in one call (raw numbers: figures.json).\n"
    )
    lines.append("| measure | figure | command |")
    lines.append("|---|---:|---|")
    for row in rows:
        cell = row.get("text") or "failed"
        lines.append(f"| {row['label']} | {cell} | `{shown(row['command'])}` |")
    if failed:
        lines.append("\nFailed: " + "; ".join(failed))
    for note in skipped:
        lines.append("\n" + note[0].upper() + note[1:])
    with open(os.path.join(args.out, "figures.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    if failed:
        sys.exit(1)


if __name__ == "__main__":
    main()
