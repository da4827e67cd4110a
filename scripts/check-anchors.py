#!/usr/bin/env python3
"""Checks that every link to a heading in the given markdown files resolves: `[x](#anchor)` to a
heading of the same file, `[x](other.md#anchor)` to one of that file, with GitHub's slugs (lower
case, punctuation dropped but for - and _, spaces as -, a repeated heading suffixed -1, -2, ...).
Links to files alone are checked to exist. Code blocks and inline code are skipped.

    python3 scripts/check-anchors.py README.md BENCHMARKS.md docs/*.md

Prints each broken link with its file and line, and exits 1 if there is one, 0 otherwise.
"""
import os
import re
import sys

LINK = re.compile(r"\]\(([^()\s]*)\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")


def lines_outside_code(path):
    """(line number, text) of the lines outside fenced code blocks, inline code removed."""
    fenced = False
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if line.lstrip().startswith("```"):
                fenced = not fenced
                continue
            if not fenced:
                yield number, line.rstrip("\n")


def slug(text):
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link in a heading keeps its text
    text = text.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path, cache={}):
    if path not in cache:
        seen = {}
        found = set()
        for _, line in lines_outside_code(path):
            m = HEADING.match(line)
            if not m:
                continue
            base = slug(m.group(2))
            n = seen.get(base, 0)
            seen[base] = n + 1
            found.add(base if n == 0 else f"{base}-{n}")
        cache[path] = found
    return cache[path]


def check(path):
    broken = []
    for number, line in lines_outside_code(path):
        line = re.sub(r"`[^`]*`", "", line)
        for target in LINK.findall(line):
            if re.match(r"^[a-z]+:", target):
                continue  # http:, https:, mailto:
            file_part, _, anchor = target.partition("#")
            linked = os.path.normpath(os.path.join(os.path.dirname(path), file_part)) if file_part else path
            if not os.path.exists(linked):
                broken.append(f"{path}:{number}: {target}: {linked} does not exist")
            elif anchor and linked.endswith(".md") and anchor not in anchors(linked):
                broken.append(f"{path}:{number}: {target}: no heading of {linked} has the anchor #{anchor}")
    return broken


def main():
    if len(sys.argv) < 2:
        sys.exit("usage: python3 scripts/check-anchors.py FILE.md ...")
    broken = [problem for path in sys.argv[1:] for problem in check(path)]
    for problem in broken:
        print(problem)
    print(f"{len(broken)} broken link{'s' if len(broken) != 1 else ''} in {len(sys.argv) - 1} files")
    sys.exit(1 if broken else 0)


if __name__ == "__main__":
    main()
