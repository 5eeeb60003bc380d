#!/usr/bin/env python3
"""Compares two OUT folders of the same graph file by file, for changes that must not change
what a run produces (a refactoring, a crate move).

Usage: scripts/compare_outputs.py OUT_BEFORE OUT_AFTER

Every file must be byte-identical except the run's own summary (run.json, run.js: times and
executors differ by design) and the report pages' wall-clock figures (the "against run time"
plot and the "wall s" column), which differ between two runs of the same binary; a page is
compared again with those masked. Exits 1 when anything else differs.
"""
import os
import re
import sys

RUN_FILES = {"run.json", "run.js"}


def files(root):
    out = {}
    for folder, _, names in os.walk(root):
        for name in names:
            path = os.path.join(folder, name)
            out[os.path.relpath(path, root)] = path
    return out


def without_wall_times(page):
    page = re.sub(r"<svg[^>]*>(?:(?!</svg>).)*run time(?:(?!</svg>).)*</svg>", "<svg-time/>", page, flags=re.S)
    return re.sub(
        r"(<th>wall s</th>.*?</table>)",
        lambda m: re.sub(r'<td class="num">[0-9.]+</td>(<td class="num">[0-9.]+</td><td class="num">\d+</td></tr>)', r"<td>T</td>\1", m.group(1)),
        page,
        flags=re.S,
    )


def main(before, after):
    a, b = files(before), files(after)
    if a.keys() != b.keys():
        print("different file sets:", sorted(set(a) ^ set(b)))
        return 1
    differing = 0
    for rel in sorted(a):
        if os.path.basename(rel) in RUN_FILES:
            continue
        x, y = open(a[rel], "rb").read(), open(b[rel], "rb").read()
        if x == y:
            continue
        if rel.endswith(".html") and without_wall_times(x.decode()) == without_wall_times(y.decode()):
            print(f"differs only in wall times: {rel}")
            continue
        print(f"DIFFERS: {rel}")
        differing += 1
    compared = sum(1 for rel in a if os.path.basename(rel) not in RUN_FILES)
    print(f"{compared - differing} of {compared} files the same")
    return 1 if differing else 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1], sys.argv[2]))
