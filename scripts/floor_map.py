#!/usr/bin/env python3
"""Draws where a trained background's floor is, seen from above (the picture in
docs/benchmarks.md, "a planar prior for the background").

Samples points uniformly by area on the model's faces and plots those with
-0.5 m < z < 0.3 m: green within 5 cm of the synthetic room's floor (z = 0),
red below it (darker = deeper), blue above it (the feet of the walls, or
shards floating over the floor). Needs numpy, plyfile and Pillow.

    python3 scripts/floor_map.py floor.png BEFORE/model.ply:"without" AFTER/model.ply:"with"

Each MODEL.ply:LABEL becomes one panel, side by side, its label above it.
"""
import sys

import numpy as np
from PIL import Image, ImageDraw
from plyfile import PlyData

ROOM_HALF_WIDTH = 2.2  # metres: the synthetic room spans about ±2 m
PIXELS_PER_METRE = 80


def sample_surface(path, count, rng):
    ply = PlyData.read(path)
    v = ply["vertex"]
    vertices = np.stack([v["x"], v["y"], v["z"]], 1).astype(np.float64)
    faces = ply["face"].data
    faces = np.stack(faces[faces.dtype.names[0]]).astype(np.int64)
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    pick = rng.choice(len(faces), count, p=area / area.sum())
    u, w = rng.random(count), rng.random(count)
    su = np.sqrt(u)
    return (
        (1 - su)[:, None] * a[pick]
        + (su * (1 - w))[:, None] * b[pick]
        + (su * w)[:, None] * c[pick]
    )


def floor_panel(model_path):
    points = sample_surface(model_path, 600_000, np.random.default_rng(0))
    points = points[(points[:, 2] < 0.3) & (points[:, 2] > -0.5)]
    size = int(2 * ROOM_HALF_WIDTH * PIXELS_PER_METRE)
    image = np.full((size, size, 3), 255, np.uint8)
    # Highest last, so a correct floor piece covers a sunken one under it.
    for x, y, z in points[np.argsort(points[:, 2])]:
        col = int((x + ROOM_HALF_WIDTH) * PIXELS_PER_METRE)
        row = size - 1 - int((y + ROOM_HALF_WIDTH) * PIXELS_PER_METRE)
        if 0 <= col < size and 0 <= row < size:
            if abs(z) < 0.05:
                image[row, col] = (0, 170, 0)
            elif z < 0:
                image[row, col] = (min(255, int(-z * 1500)), 0, 0)
            else:
                image[row, col] = (0, 0, min(255, int(z * 800)))
    return Image.fromarray(image).resize((int(1.2 * size), int(1.2 * size)), Image.NEAREST)


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    panels = [(floor_panel(arg.rsplit(":", 1)[0]), arg.rsplit(":", 1)[-1]) for arg in sys.argv[2:]]
    width = panels[0][0].width
    out = Image.new("RGB", (len(panels) * (width + 10) - 10, width + 24), "white")
    draw = ImageDraw.Draw(out)
    for k, (panel, label) in enumerate(panels):
        out.paste(panel, (k * (width + 10), 24))
        draw.text((k * (width + 10) + 4, 4), label, fill="black")
    out.convert("RGB").quantize(16).save(sys.argv[1], optimize=True)


if __name__ == "__main__":
    main()
