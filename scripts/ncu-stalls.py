#!/usr/bin/env python3
"""Where a kernel's warps wait, as text: sums Nsight Compute's warp-stall samples of one kernel by
stall reason and by SASS opcode. Standard library only.

    ncu --clock-control none --set full --import-source yes -k regex:one_pass \
        --launch-skip 30 --launch-count 1 -o one_pass mpm bench --scene dam-break --steps 40
    ncu -i one_pass.ncu-rep --page source --csv --print-source sass > one_pass-sass.csv
    python3 scripts/ncu-stalls.py one_pass-sass.csv

The CSV has one row per SASS instruction: its text, its samples ("Warp Stall Sampling (All
Samples)"), the warp instructions executed, and one `stall_<reason>` column per reason. The first
table is the share of all samples per reason (long_sb: waiting on global or local memory; short_sb:
on shared memory, shuffles and other variable-latency units; wait: a fixed latency; barrier: a
__syncthreads; selected / not_selected: issuing, or ready and not picked); the second, each opcode's
share with its top three reasons. BENCHMARKS.md 0m shows both for one_pass.
"""
import collections
import csv
import sys


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    path = sys.argv[1]
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except OSError as e:
        print(f"{path}: {e.strerror}", file=sys.stderr)
        return 2
    # ncu prints the kernel's name on a line of its own, then the header.
    header_at = next((i for i, r in enumerate(rows) if r and r[0] == "Address"), None)
    if header_at is None:
        print(f"{path}: no 'Address' header: not the output of ncu --page source --csv", file=sys.stderr)
        return 2
    header = rows[header_at]
    stalls = [i for i, h in enumerate(header) if h.startswith("stall_") and "(Not Issued)" not in h]
    if not stalls:
        print(f"{path}: no stall_* columns: profile with --set full (the source counters)", file=sys.stderr)
        return 2
    source = header.index("Source")
    executed = header.index("Instructions Executed")
    data = [r for r in rows[header_at + 1 :] if len(r) == len(header)]

    def number(text: str) -> float:
        return float(text) if text else 0.0

    by_reason = collections.Counter()
    by_opcode = collections.defaultdict(collections.Counter)
    executed_by_opcode = collections.Counter()
    for r in data:
        words = r[source].split()
        if not words:
            continue
        opcode = (words[1] if words[0].startswith("@") and len(words) > 1 else words[0]).split(".")[0]
        executed_by_opcode[opcode] += number(r[executed])
        for i in stalls:
            by_reason[header[i]] += number(r[i])
            by_opcode[opcode][header[i]] += number(r[i])
    total = sum(by_reason.values())
    if total == 0:
        print(f"{path}: no stall samples", file=sys.stderr)
        return 2
    print(f"samples: {total:.0f}; SASS instructions: {len(data)}")
    for reason, samples in by_reason.most_common():
        if samples / total >= 0.001:
            print(f"  {reason:25s} {samples / total * 100:5.1f} %")
    print("\nby opcode: share of samples, warp instructions executed, top stall reasons")
    ranked = sorted(by_opcode.items(), key=lambda item: -sum(item[1].values()))
    for opcode, reasons in ranked[:14]:
        samples = sum(reasons.values())
        top = ", ".join(
            f"{k.removeprefix('stall_')} {v / samples * 100:.0f} %" for k, v in reasons.most_common(3)
        )
        print(f"  {opcode:8s} {samples / total * 100:5.1f} %  {executed_by_opcode[opcode]:>10.0f}  {top}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
