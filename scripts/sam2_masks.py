#!/usr/bin/env python3
"""Object masks from SAM 2 (Meta's Segment Anything Model 2) with your own weights, as
the mask stage of graphs/photos.ron (a `command` node).

    python3 sam2_masks.py FRAMES_DIR OUT_DIR OPTIONS_JSON

FRAMES_DIR is a Frames artifact (frames.json and the images it names), OUT_DIR the
empty folder to fill, OPTIONS_JSON the node's `options` as JSON. Writes one mask per
frame, OUT_DIR/<frame stem>.png: an 8-bit grey PNG whose value is the object id (0 = no
object), which `import_masks` reads with `format: "davis"` exactly as it reads SAM 2's
own palette PNGs. The same object keeps its id in every frame: the frames are tracked in
name order as one video by SAM 2's video predictor, so photos taken while walking around
the room (or video frames) track best.

Setting up SAM 2 (once, outside ObjectSplat; a CUDA GPU makes it practical):
  1. a Python environment with PyTorch, e.g. `python3 -m venv ~/sam2-env` and
     `~/sam2-env/bin/pip install torch torchvision`;
  2. the `sam2` package from Meta's SAM 2 repository, installed into it as its README
     says (`pip install -e .` in a clone);
  3. a checkpoint from the same README, e.g. sam2.1_hiera_large.pt, and the name of its
     config, e.g. configs/sam2.1/sam2.1_hiera_l.yaml;
  4. in the graph, argv's first word becomes that environment's python
     ("/home/you/sam2-env/bin/python") and `options` name the checkpoint and config.

Options:
  checkpoint   the weights file (.pt), an absolute path (required)
  config       the model config matching the checkpoint (required)
  device       "cuda", "mps" or "cpu" (default: cuda when available, else cpu)
  prompts      the objects to track: a list of {"frame": <frame name>, "points":
               [[x, y], ...], "labels": [1, ...], "box": [x0, y0, x1, y1]} (points and/or
               box in that frame's pixels; labels 1 = on the object, 0 = not; default all
               1). Object ids follow the list order, from 1.
               Without prompts, SAM 2's automatic mask generator proposes the objects
               on the first frame:
  max_objects  the largest proposals kept (default 20, at most 254)
  min_area     the smallest proposal kept, as a fraction of the image (default 0.002)

The checkpoint's content is not part of the cache key (only this script's and the
options' are): after replacing the weights under the same name, edit an option (or
rerun with a fresh cache) to rerun the stage. Errors go to stderr with a non-zero exit;
the stage quotes them.
"""
import json
import os
import sys
import tempfile

MAX_IDS = 254  # 255 is DAVIS's "void"


def fail(message):
    print(f"sam2_masks: {message}", file=sys.stderr)
    sys.exit(1)


def read_inputs():
    if len(sys.argv) != 4:
        fail("usage: sam2_masks.py FRAMES_DIR OUT_DIR OPTIONS_JSON")
    frames_dir, out_dir, options_path = sys.argv[1:]
    with open(options_path) as f:
        options = json.load(f)
    with open(os.path.join(frames_dir, "frames.json")) as f:
        frames = sorted(json.load(f), key=lambda frame: frame["name"])
    if not frames:
        fail(f"{frames_dir}: frames.json lists no frames")
    for key in ("checkpoint", "config"):
        if not options.get(key):
            fail(f'options: "{key}" is required (see the top of {__file__})')
    if not os.path.isfile(options["checkpoint"]):
        fail(f'options: checkpoint {options["checkpoint"]!r} is not a file (give an absolute path)')
    return frames_dir, out_dir, options, frames


def import_sam2():
    try:
        import numpy
        import torch
        from PIL import Image
        from sam2.automatic_mask_generator import SAM2AutomaticMaskGenerator
        from sam2.build_sam import build_sam2, build_sam2_video_predictor
    except ImportError as e:
        fail(
            f"{e} ({sys.executable}): run this script with the Python environment SAM 2 is "
            f"installed in; setting it up is described at the top of {__file__}"
        )
    return numpy, torch, Image, SAM2AutomaticMaskGenerator, build_sam2, build_sam2_video_predictor


def main():
    frames_dir, out_dir, options, frames = read_inputs()
    np, torch, Image, AutomaticMaskGenerator, build_sam2, build_video_predictor = import_sam2()
    device = options.get("device") or ("cuda" if torch.cuda.is_available() else "cpu")
    index_of = {frame["name"]: i for i, frame in enumerate(frames)}

    with tempfile.TemporaryDirectory() as video_dir, torch.inference_mode():
        # The video predictor reads a folder of JPEGs named by their position.
        for i, frame in enumerate(frames):
            image = Image.open(os.path.join(frames_dir, frame["image"])).convert("RGB")
            image.save(os.path.join(video_dir, f"{i:05d}.jpg"), quality=95)
        predictor = build_video_predictor(options["config"], options["checkpoint"], device=device)
        state = predictor.init_state(video_path=video_dir)

        prompts = options.get("prompts")
        if prompts:
            if len(prompts) > MAX_IDS:
                fail(f"options: at most {MAX_IDS} prompts fit one mask")
            for obj_id, prompt in enumerate(prompts, start=1):
                if prompt.get("frame") not in index_of:
                    fail(f"options: prompt {obj_id} names frame {prompt.get('frame')!r}, not one of the frames")
                points = prompt.get("points")
                predictor.add_new_points_or_box(
                    state,
                    frame_idx=index_of[prompt["frame"]],
                    obj_id=obj_id,
                    points=np.array(points, dtype=np.float32) if points else None,
                    labels=np.array(prompt.get("labels", [1] * len(points)), dtype=np.int32) if points else None,
                    box=np.array(prompt["box"], dtype=np.float32) if prompt.get("box") else None,
                )
        else:
            generator = AutomaticMaskGenerator(build_sam2(options["config"], options["checkpoint"], device=device))
            first = np.array(Image.open(os.path.join(video_dir, "00000.jpg")))
            min_area = options.get("min_area", 0.002) * first.shape[0] * first.shape[1]
            proposals = [p for p in generator.generate(first) if p["area"] >= min_area]
            proposals.sort(key=lambda p: -p["area"])
            keep = min(int(options.get("max_objects", 20)), MAX_IDS)
            if not proposals:
                fail("SAM 2 proposed no object on the first frame; give `prompts`")
            for obj_id, proposal in enumerate(proposals[:keep], start=1):
                predictor.add_new_mask(state, frame_idx=0, obj_id=obj_id, mask=proposal["segmentation"])

        # Tracked forwards from the prompts, then backwards to the frames before them.
        logits_by_frame = {}
        for reverse in (False, True):
            for frame_idx, obj_ids, logits in predictor.propagate_in_video(state, reverse=reverse):
                logits_by_frame.setdefault(frame_idx, (obj_ids, logits[:, 0].float().cpu().numpy()))

    for i, frame in enumerate(frames):
        ids = np.zeros((frame["height"], frame["width"]), dtype=np.uint8)
        if i in logits_by_frame:
            obj_ids, logits = logits_by_frame[i]
            # Each pixel to the most confident object that claims it.
            best = logits.argmax(axis=0)
            claimed = logits.max(axis=0) > 0.0
            ids[claimed] = np.array(obj_ids, dtype=np.uint8)[best[claimed]]
        stem = os.path.splitext(os.path.basename(frame["name"]))[0]
        Image.fromarray(ids, mode="L").save(os.path.join(out_dir, stem + ".png"))
    print(f"sam2_masks: {len(frames)} frames on {device}", file=sys.stderr)


if __name__ == "__main__":
    main()
