#!/usr/bin/env python3
"""PSNR between two sets of frames on each object's pixels.

usage: frames_per_object.py IMAGES_A IMAGES_B MASKS
  IMAGES_A, IMAGES_B  folders of PNGs with the same names (e.g. two `synthetic_scene`
                      runs' scene/frames/images, or a `render` node's images and the frames)
  MASKS               a gt_masks output folder (label PNGs and objects.json)

Pools squared errors over every frame both folders hold; prints one line per object:
label, PSNR on its pixels, mean pixels per frame. Used for docs/benchmarks.md
("Samples per pixel").
"""
import json
import os
import sys

import numpy as np
from PIL import Image


def main(a, b, masks):
    # objects.json maps each label value (as a string) to the object's name.
    labels = {int(k): v for k, v in json.load(open(os.path.join(masks, "objects.json"))).items()}
    sums = {k: [0.0, 0] for k in labels}
    frames = sorted(f for f in os.listdir(a) if f.endswith(".png") and os.path.exists(os.path.join(b, f)))
    if not frames:
        sys.exit(f"no PNG is in both {a} and {b}")
    for name in frames:
        x = np.asarray(Image.open(os.path.join(a, name)).convert("RGB"), dtype=np.float64) / 255
        y = np.asarray(Image.open(os.path.join(b, name)).convert("RGB"), dtype=np.float64) / 255
        m = np.asarray(Image.open(os.path.join(masks, name)))
        for k in labels:
            on = m == k
            sums[k][0] += ((x[on] - y[on]) ** 2).sum()
            sums[k][1] += int(on.sum())
    for k, (sq, n) in sorted(sums.items()):
        if n == 0:
            continue
        psnr = 10 * np.log10(3 * n / sq) if sq > 0 else float("inf")
        print(f"{labels[k]}\t{psnr:.1f} dB\t{n // len(frames)} px per frame")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
