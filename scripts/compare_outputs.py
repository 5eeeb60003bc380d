#!/usr/bin/env python3
"""Compares two OUT folders of the same graph file by file, for changes that must not change
what a run produces (a refactoring, a crate move).

Usage: scripts/compare_outputs.py OUT_BEFORE OUT_AFTER

Every file must be byte-identical except the run's own summary beside the outputs (run.json,
run.js: times, hosts and executors differ by design; no output of a node holds any). Exits 1
when anything else differs.
"""
import os
import sys

RUN_FILES = {"run.json", "run.js"}


def files(root):
    out = {}
    for folder, _, names in os.walk(root):
        for name in names:
            path = os.path.join(folder, name)
            out[os.path.relpath(path, root)] = path
    return out


def main(before, after):
    a, b = files(before), files(after)
    if a.keys() != b.keys():
        print("different file sets:", sorted(set(a) ^ set(b)))
        return 1
    differing = 0
    for rel in sorted(a):
        if rel in RUN_FILES:
            continue
        x, y = open(a[rel], "rb").read(), open(b[rel], "rb").read()
        if x == y:
            continue
        print(f"DIFFERS: {rel}")
        differing += 1
    compared = sum(1 for rel in a if rel not in RUN_FILES)
    print(f"{compared - differing} of {compared} files the same")
    return 1 if differing else 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1], sys.argv[2]))
