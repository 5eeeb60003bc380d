//! A tiny synthetic room (8 views of 32×24, two objects kept: box and ball) trained for
//! 40 iterations per component on the CPU: a couple of seconds of real training, for the
//! tests of what consumes trained models.

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
                 params: (iterations: 40, backend: "cpu")),
{nodes}
  }},
  targets: {targets},
)"#
    )
}
