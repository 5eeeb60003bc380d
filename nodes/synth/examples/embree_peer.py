"""Peer for the gt_masks benchmark: Intel Embree (embreex, through trimesh) casts one
ray per pixel centre of the same cameras into the same meshes exported by
`bench_gt_masks -- THREADS FRAMES EXPORT_DIR`. Reports rays/s and frames/s, and how
many pixels of the first frame differ from our mask (face -> value via the exported
per-face values; no hit = 65535).

Usage: python embree_peer.py EXPORT_DIR [FRAMES]
Needs numpy, trimesh, embreex, pillow (e.g. a venv: pip install numpy trimesh embreex pillow).
"""
import json
import sys
import time

import numpy as np
import trimesh
from PIL import Image
from trimesh.ray.ray_pyembree import RayMeshIntersector


def rays(frame):
    w, h = frame["width"], frame["height"]
    m = np.array(frame["world_to_camera"], float)
    r, t = m[:3, :3], m[:3, 3]
    i, j = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    d = np.stack([(i - frame["cx"]) / frame["fx"], (j - frame["cy"]) / frame["fy"], np.ones_like(i)], -1).reshape(-1, 3)
    d = d @ r  # camera -> world: R^T d, row-vector form
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    origin = -r.T @ t
    return np.repeat(origin[None], len(d), 0), d


def main():
    folder = sys.argv[1]
    nframes = int(sys.argv[2]) if len(sys.argv) > 2 else 6
    frames = json.load(open(f"{folder}/frames.json"))[:nframes]
    print(f"{'faces':>9} {'build s':>8} {'ms/frame':>10} {'cpu ms/fr':>10} {'frames/s':>9} {'differ':>7} {'of pixels':>10}")
    for k in [1, 2, 4, 13]:
        mesh = trimesh.load(f"{folder}/mesh_k{k}.ply", process=False)
        values = np.fromfile(f"{folder}/face_values_k{k}.bin", "<u2")
        t0 = time.perf_counter()
        caster = RayMeshIntersector(mesh)
        caster.intersects_first(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))  # builds the BVH
        build = time.perf_counter() - t0
        t0, c0 = time.perf_counter(), time.process_time()
        first = None
        for frame in frames:
            o, d = rays(frame)
            hit = caster.intersects_first(o, d)
            if first is None:
                first = (frame, hit)
        per = (time.perf_counter() - t0) / len(frames)
        cpu = (time.process_time() - c0) / len(frames)
        frame, hit = first
        peer = np.where(hit >= 0, values[np.maximum(hit, 0)], 65535).reshape(frame["height"], frame["width"])
        ours = np.array(Image.open(f"{folder}/mask_k{k}.png")).astype(np.uint16)
        differ = int(np.count_nonzero(peer != ours))
        print(f"{len(mesh.faces):>9} {build:>8.2f} {per * 1e3:>10.1f} {cpu * 1e3:>10.1f} {1 / per:>9.2f} {differ:>7} {peer.size:>10}")


if __name__ == "__main__":
    main()
