#!/usr/bin/env python3
"""Weak and strong scaling on two H100s (BENCHMARKS.md 0x), from the bench JSON files beside this
script: python3 plot.py -> scaling.png."""
import json, os
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

here = os.path.dirname(os.path.abspath(__file__))

def phases(path):
    report = json.load(open(os.path.join(here, path)))["phases"][0]
    return report["total"]["median_ms"], report["wall_ms_per_substep"], report["particles"]

# One GPU: s97 (cd769e5); two GPUs: s101's final halo and bins kernels where measured, else s97.
one = {"16.8M": phases("s101-bench/c16-1-new.json"), "33.5M": phases("s97-bench/c33-1.json"),
       "269M": phases("s97-bench/c268-1.json"), "dam break\n451k": phases("s97-bench/dam1.json")}
two = {"16.8M": phases("s101-bench/c16-2-new.json"), "33.5M": phases("s101-bench/c33-2-new.json"),
       "269M": phases("s97-bench/c268-2.json"), "dam break\n451k": phases("s101-bench/dam2-new-1.json")}

fig, (weak, strong) = plt.subplots(1, 2, figsize=(11, 4.2))
w1, w2 = one["16.8M"], two["33.5M"]
labels = ["median substep\n(device events)", "host clock\nper substep"]
values = [100 * w1[0] / w2[0], 100 * w1[1] / w2[1]]
bars = weak.bar(labels, values, color=["#3b7dd8", "#9bbbe8"])
weak.axhline(100, color="grey", lw=1, ls="--")
weak.axhline(90, color="#d0453a", lw=1, ls=":", label="issue's target, 90 %")
for b, v in zip(bars, values):
    weak.text(b.get_x() + b.get_width() / 2, v + 1.5, f"{v:.0f} %", ha="center")
weak.set_ylim(0, 110)
weak.set_ylabel("efficiency, 1 GPU time / 2 GPU time")
weak.set_title("Weak scaling: 16.8M particles per GPU")
weak.legend(loc="lower right")

names = list(one)
x = range(len(names))
med = [one[n][0] / two[n][0] for n in names]
wall = [one[n][1] / two[n][1] for n in names]
strong.bar([i - 0.18 for i in x], med, 0.36, label="median substep (device events)", color="#3b7dd8")
strong.bar([i + 0.18 for i in x], wall, 0.36, label="host clock per substep", color="#9bbbe8")
strong.axhline(2, color="grey", lw=1, ls="--", label="ideal, 2x")
strong.axhline(1.8, color="#d0453a", lw=1, ls=":", label="issue's target, 1.8x")
strong.axhline(1, color="black", lw=0.6)
for i, (m, w) in enumerate(zip(med, wall)):
    strong.text(i - 0.18, m + 0.03, f"{m:.2f}", ha="center", fontsize=8)
    strong.text(i + 0.18, w + 0.03, f"{w:.2f}", ha="center", fontsize=8)
strong.set_xticks(list(x), names)
strong.set_ylim(0, 2.3)
strong.set_ylabel("speed-up, 2 GPUs over 1")
strong.set_title("Strong scaling: the same scene on 2 GPUs")
strong.legend(fontsize=8, loc="upper right")
fig.suptitle("mpm --gpus 2 on two H100 80GB (NV18, NCCL 2.28.3), 2026-11-27", fontsize=10)
fig.tight_layout()
fig.savefig(os.path.join(here, "scaling.png"), dpi=110)
for n in names:
    print(n.replace("\n", " "), one[n], two[n])
