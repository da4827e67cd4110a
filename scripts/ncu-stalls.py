#!/usr/bin/env python3
"""Where a kernel's warps wait, as text: sums Nsight Compute's warp-stall samples of each profiled
kernel by stall reason and by SASS opcode. Standard library only.

    ncu --clock-control none --set full --import-source yes -k regex:one_pass \
        --launch-skip 30 --launch-count 1 -o one_pass mpm bench --scene dam-break --steps 40
    ncu -i one_pass.ncu-rep --page source --csv --print-source sass > one_pass-sass.csv
    python3 scripts/ncu-stalls.py one_pass-sass.csv

The CSV has, per profiled kernel launch, a "Kernel Name" line, a header and one row per SASS
instruction: its text, its samples ("Warp Stall Sampling (All Samples)"), the warp instructions
executed, and one `stall_<reason>` column per reason. Each launch gets two tables: the first is the
share of all samples per reason (long_sb: waiting on global or local memory; short_sb: on shared
memory, shuffles and other variable-latency units; wait: a fixed latency; barrier: a __syncthreads;
selected / not_selected: issuing, or ready and not picked); the second, each opcode's share with its
top three reasons. BENCHMARKS.md 0m shows both for one_pass.
"""
import collections
import csv
import sys


def sections(rows):
    """(kernel name, header, instruction rows) for each kernel in the page: ncu prints a
    "Kernel Name" line, then the header, then a row per instruction."""
    name, header, data = None, None, []
    for r in rows:
        if r and r[0] == "Kernel Name":
            if header is not None:
                yield name, header, data
            name, header, data = (r[1] if len(r) > 1 else "?"), None, []
        elif r and r[0] == "Address":
            header = r
        elif header is not None and len(r) == len(header):
            data.append(r)
    if header is not None:
        yield name, header, data


def number(text: str) -> float:
    return float(text) if text else 0.0


def summarize(name: str, header: list, data: list) -> bool:
    stalls = [i for i, h in enumerate(header) if h.startswith("stall_") and "(Not Issued)" not in h]
    if not stalls:
        print(f"{name}: no stall_* columns: profile with --set full (the source counters)", file=sys.stderr)
        return False
    source = header.index("Source")
    executed = header.index("Instructions Executed")
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
        print(f"{name}: no stall samples", file=sys.stderr)
        return False
    print(f"{name}: samples: {total:.0f}; SASS instructions: {len(data)}")
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
    return True


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
    found = list(sections(rows))
    if not found:
        print(f"{path}: no 'Address' header: not the output of ncu --page source --csv", file=sys.stderr)
        return 2
    ok = True
    for k, (name, header, data) in enumerate(found):
        if k:
            print()
        ok &= summarize(name or path, header, data)
    return 0 if ok else 2


if __name__ == "__main__":
    sys.exit(main())
