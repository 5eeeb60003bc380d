"""Writes mask-import benchmark data and times the Python peers decoding it.

    python make_bench_data.py OUT_DIR [FRAMES] [OBJECTS]

Writes OUT_DIR/{frames,davis,sav,coco_rle,gsam} (640x480 frames, OBJECTS moving
ellipses per frame) and prints, per format, the peer's decode rate in masks/s:
  davis          PIL.Image.open + np.array (palette indices)
  per_object_png PIL.Image.open + np.array for each object's PNG
  coco_rle       json.load + pycocotools.mask.decode for each RLE
  grounded_sam2  np.load + json.load per frame
The Rust side (examples/bench_import.rs) imports the same folders end to end.
"""
import json
import pathlib
import sys
import time

import numpy as np
from PIL import Image
from pycocotools import mask as mask_api

out = pathlib.Path(sys.argv[1])
n_frames = int(sys.argv[2]) if len(sys.argv) > 2 else 20
n_obj = int(sys.argv[3]) if len(sys.argv) > 3 else 20
W, H = 640, 480
yy, xx = np.mgrid[0:H, 0:W]
rng = np.random.default_rng(5)
centres = rng.uniform([60, 60], [W - 60, H - 60], size=(n_obj, 2))
radii = rng.uniform(20, 90, size=(n_obj, 2))
stems = [f"frame{i:04d}" for i in range(n_frames)]
for d in ["frames", "davis", "sav", "coco_rle", "gsam/mask_data", "gsam/json_data"]:
    (out / d).mkdir(parents=True, exist_ok=True)
ident = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
(out / "frames" / "frames.json").write_text(json.dumps([
    {"name": f"{s}.jpg", "image": f"images/{s}.png", "width": W, "height": H, "fx": 500.0, "fy": 500.0,
     "cx": 320.0, "cy": 240.0, "world_to_camera": ident, "split": "train"} for s in stems]))
for f, s in enumerate(stems):
    masks = []
    for k in range(n_obj):
        cx, cy = centres[k] + f * 2.0
        masks.append(((xx - cx) / radii[k, 0]) ** 2 + ((yy - cy) / radii[k, 1]) ** 2 <= 1)
    lab = np.zeros((H, W), np.uint8)
    for k in reversed(range(n_obj)):
        lab[masks[k]] = k + 1
    img = Image.fromarray(lab, mode="P")
    img.putpalette([v for i in range(256) for v in (i, 255 - i, (i * 7) % 256)])
    img.save(out / "davis" / f"{s}.png")
    np.save(out / "gsam" / "mask_data" / f"mask_{s}.npy", lab.astype(np.uint16))
    (out / "gsam" / "json_data" / f"mask_{s}.json").write_text(json.dumps(
        {"labels": {str(k + 1): {"instance_id": k + 1, "class_name": "thing"} for k in range(n_obj)}}))
    anns = []
    for k, m in enumerate(masks):
        d = out / "sav" / f"{k + 1:03d}"
        d.mkdir(exist_ok=True)
        Image.fromarray(m.astype(np.uint8), mode="L").save(d / f"{s}.png")
        r = mask_api.encode(np.asfortranarray(m.astype(np.uint8)))
        anns.append({"segmentation": {"size": [H, W], "counts": r["counts"].decode()}, "area": int(m.sum()),
                     "predicted_iou": float(rng.uniform(0.5, 1.0))})
    (out / "coco_rle" / f"{s}.json").write_text(json.dumps(anns))


def rate(label, masks, fn):
    t = time.perf_counter()
    fn()
    dt = time.perf_counter() - t
    print(f"peer {label}: {masks} masks in {dt:.3f} s = {masks / dt:.1f} masks/s")


rate("davis (PIL)", n_frames, lambda: [np.array(Image.open(out / "davis" / f"{s}.png")) for s in stems])
rate("per_object_png (PIL)", n_frames * n_obj,
     lambda: [np.array(Image.open(out / "sav" / f"{k + 1:03d}" / f"{s}.png")) for s in stems for k in range(n_obj)])
rate("coco_rle (pycocotools)", n_frames * n_obj,
     lambda: [mask_api.decode(a["segmentation"] | {"counts": a["segmentation"]["counts"].encode()})
              for s in stems for a in json.loads((out / "coco_rle" / f"{s}.json").read_text())])
rate("grounded_sam2 (numpy)", n_frames,
     lambda: [(np.load(out / "gsam" / "mask_data" / f"mask_{s}.npy"),
               json.loads((out / "gsam" / "json_data" / f"mask_{s}.json").read_text())) for s in stems])
