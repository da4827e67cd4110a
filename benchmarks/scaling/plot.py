"""Weak and strong scaling of `mpm bench` on several GPUs.

Left: weak-scaling efficiency t1 / tN (16.8M particles a GPU). Right: strong-scaling speedup
t1 / tN (a 67.1M-particle column). Both on a 320^3 grid, by the host clock per substep.

The numbers are `wall_ms_per_substep` from `mpm bench`, copied from BENCHMARKS.md (sections M28
and M29, and issue 43's table of targets, whose start was measured at a11a4d2 on 4 x H200).

Redraw (writes scaling.png beside this script; needs only matplotlib):

    python3 benchmarks/scaling/plot.py
"""
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

# ms per substep, {gpus: ms}. Each series: (legend label, weak, strong, colour, marker).
SERIES = [
    # 2026-11-27, main a11a4d2, 4 x H200 (every GPU held the whole run); issue 43's start
    ("a11a4d2, 4 x H200, every GPU holds the whole run",
     {1: 2.332, 2: 3.293, 4: 4.865}, {1: 8.961, 2: 5.984, 4: 4.865}, "tab:gray", "s"),
    # 2026-11-30, efce0f5, 2 x H200 (ranks own their particles), one process; BENCHMARKS.md M28/M29
    ("efce0f5, 2 x H200, ranks own their particles, one process",
     {1: 1.949, 2: 2.388}, {1: 7.621, 2: 4.392}, "tab:blue", "o"),
    # 2026-11-30, efce0f5, 2 x H200, a process per GPU (--processes); BENCHMARKS.md M29
    ("efce0f5, 2 x H200, a process per GPU (--processes)",
     {1: 1.949, 2: 2.419}, {1: 7.621, 2: 4.437}, "tab:orange", "D"),
]
GPUS = [1, 2, 4]
WEAK_TARGET = 90.0  # % at 2 GPUs, issue 43
STRONG_TARGET = 1.8  # x at 2 GPUs, issue 43
FOOTNOTE = ("mpm bench, host clock per substep; "
            "--particles 16777216 x N (weak) / 67108864 (strong), "
            "--grid 320; NCCL_NVLS_ENABLE=0")
# label offsets (points) by series at N > 1, per panel, so near-equal values do not overlap;
# last entry: the shared 1-GPU label
WEAK_DY = [10, 10, -18, 10]
STRONG_DY = [-20, 10, -18, -20]


def ratios(times):
    return {n: times[1] / t for n, t in times.items()}


def main():
    plt.rcParams.update({"font.size": 12})
    fig, (weak, strong) = plt.subplots(1, 2, figsize=(14, 6), dpi=100)

    for i, (label, w, s, colour, marker) in enumerate(SERIES):
        for ax, times, scale, fmt, dys in ((weak, w, 100.0, "{:.1f} %", WEAK_DY),
                                           (strong, s, 1.0, "{:.2f}x", STRONG_DY)):
            r = ratios(times)
            xs = sorted(r)
            ys = [r[n] * scale for n in xs]
            ax.plot(xs, ys, marker=marker, color=colour, lw=2, ms=8, label=label, zorder=3)
            for x, y in zip(xs, ys):
                if x == 1 and i > 0:
                    continue  # every series is 100 % / 1.00x at one GPU: label it once
                dy = dys[-1] if x == 1 else dys[i]
                ax.annotate(fmt.format(y), (x, y), textcoords="offset points", xytext=(8, dy),
                            color="black" if x == 1 else colour, fontsize=11, fontweight="bold")

    weak.axhline(100, color="black", ls="--", lw=1.2, zorder=1)
    weak.axhline(WEAK_TARGET, color="tab:red", ls=":", lw=1.8, zorder=1)
    weak.text(3.95, WEAK_TARGET - 1.5, "issue 43 target", color="tab:red", ha="right", va="top")
    weak.text(3.95, 101.5, "ideal", ha="right", va="bottom")
    weak.set_ylim(30, 110)
    weak.set_ylabel("weak-scaling efficiency t$_1$ / t$_N$ (%)")
    weak.set_title("weak scaling: 16.8M particles per GPU", fontsize=13)

    ideal, = strong.plot(GPUS, GPUS, color="black", ls="--", lw=1.2, label="ideal (speedup = N)",
                         zorder=1)
    strong.plot([2], [STRONG_TARGET], marker="*", color="tab:red", ms=18, ls="none", zorder=4)
    strong.annotate(f"issue 43 target {STRONG_TARGET:.1f}x", (2, STRONG_TARGET),
                    textcoords="offset points", xytext=(-12, 10), ha="right", color="tab:red")
    strong.set_ylim(0.7, 4.2)
    strong.set_ylabel("strong-scaling speedup t$_1$ / t$_N$ (x)")
    strong.set_title("strong scaling: 67.1M-particle column", fontsize=13)

    for ax in (weak, strong):
        ax.set_xlabel("GPUs")
        ax.set_xticks(GPUS)
        ax.set_xlim(0.8, 4.4)
        ax.grid(alpha=0.3)
    weak.legend(handles=weak.get_lines()[:len(SERIES)], loc="lower left", fontsize=10.5,
                framealpha=0.95)
    strong.legend(handles=[ideal], loc="upper left", fontsize=10.5, framealpha=0.95)

    fig.text(0.5, 0.015, FOOTNOTE, ha="center", fontsize=10, color="dimgray")
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    out = Path(__file__).resolve().parent / "scaling.png"
    fig.savefig(out)
    print(out)


if __name__ == "__main__":
    main()
