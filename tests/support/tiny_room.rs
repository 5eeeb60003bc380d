//! A tiny synthetic room (8 views of 32×24, two objects kept: box and ball) trained for
//! 40 iterations per component on the CPU: a couple of seconds of real training, for the
//! tests of what consumes trained models. Its vertex learning rates are given in world
//! units: the trainer's default is a step in pixels, and at 32×24 a pixel spans 5–7 cm,
//! so the default's steps are three times these; 40 iterations leave a handful of faces
//! either way, and these tests need them where the viewer looks, not a judged training.
//! Its frames take one sample per pixel (`supersample: 1`), and so does its training.

/// The trained room's graph (`scene`, `masks`, `parts`, `train`) with `nodes` added (RON
/// map entries reading `scene.*` and `train.model`), building `targets` (a RON list).
pub fn graph(nodes: &str, targets: &str) -> String {
    format!(
        r#"(
  nodes: {{
    "scene":    (kind: "synthetic_scene", params: (views: 8, width: 32, height: 24, points: 3000, supersample: 1)),
    "masks":    (kind: "gt_masks", inputs: (frames: "scene.frames", mesh: "scene.mesh"), params: (keep_labels: ["box", "ball"])),
    "parts":    (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks")),
    "train":    (kind: "train", inputs: (component: each("parts.components"), points: "scene.points"),
                 params: (iterations: 40, backend: "cpu",
                          schedule: {{"lr_vertices_start": 4e-3, "lr_vertices_end": 4e-4,
                                     "supersample": 1, "object_supersample": 1}})),
{nodes}
  }},
  targets: {targets},
)"#
    )
}
