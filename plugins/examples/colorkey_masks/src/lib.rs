//! Example plugin: object masks from colour keys. Each key gives an object id to
//! every pixel whose colour is within `tolerance` (per channel, 8-bit units) of the
//! key colour; the first matching key wins. It produces a Masks artifact, so it can
//! replace `gt_masks` for captures where objects were painted or lit in known colours.

use objectsplat_plugin_sdk::core::masks::{NO_OBJECT, UNOWNED};
use objectsplat_plugin_sdk::prelude::*;
use serde::Deserialize;

/// One colour key, written in a graph as `(id: 1, label: "chair", rgb: (200, 30, 30), tolerance: 12)`.
#[derive(Debug, Clone, Deserialize)]
struct Key {
    id: u16,
    label: String,
    rgb: (u8, u8, u8),
    tolerance: u8,
}

fn check_keys(keys: &[Key]) -> Result<()> {
    if keys.is_empty() {
        bail!("`keys` is empty: give at least one (id, label, rgb, tolerance)");
    }
    let mut seen = std::collections::BTreeSet::new();
    for k in keys {
        if k.id == NO_OBJECT || k.id == UNOWNED {
            bail!("key {:?}: id {} is reserved; use 1..=65534", k.label, k.id);
        }
        if !seen.insert(k.id) {
            bail!("id {} appears in two keys", k.id);
        }
        if k.label.trim().is_empty() {
            bail!("key with id {} has an empty label", k.id);
        }
    }
    Ok(())
}

/// The id of the first key within tolerance of `rgb`, or 0.
fn key_of(keys: &[Key], rgb: [u8; 3]) -> u16 {
    keys.iter()
        .find(|k| {
            let target = [k.rgb.0, k.rgb.1, k.rgb.2];
            rgb.iter()
                .zip(target)
                .all(|(&a, b)| a.abs_diff(b) <= k.tolerance)
        })
        .map_or(NO_OBJECT, |k| k.id)
}

fn colorkey_masks(req: &mut Request) -> Result<Outcome> {
    let keys: Vec<Key> = req.param("keys")?;
    check_keys(&keys)?;
    let frames = read_frames(req.input("frames")?)?;
    let out = req.output("masks")?;
    let mut counts = vec![0u64; keys.len()];
    for (i, frame) in frames.frames.iter().enumerate() {
        if req.cancelled() {
            bail!("cancelled");
        }
        req.progress(i as u64, frames.frames.len() as u64, "keying frames");
        let image = frames.load_rgb(frame)?;
        let mut map = IdMap::new(image.width, image.height);
        for (px, id) in image.data.chunks_exact(3).zip(map.data.iter_mut()) {
            // Frames hold 8-bit images; rounding recovers the stored byte exactly.
            let rgb = [0, 1, 2].map(|c| (px[c].clamp(0.0, 1.0) * 255.0).round() as u8);
            *id = key_of(&keys, rgb);
            if let Some(k) = keys.iter().position(|k| k.id == *id) {
                counts[k] += 1;
            }
        }
        write_id_map(&out, &frame.name, &map)?;
    }
    let labels: ObjectLabels = keys.iter().map(|k| (k.id, k.label.clone())).collect();
    write_labels(&out, &labels)?;
    for (k, n) in keys.iter().zip(&counts) {
        req.note(&format!("pixels_{}", k.label), n);
    }
    Ok(Outcome::Done)
}

/// The code version: bump when the output for the same inputs changes. The
/// environment override exists for the host's cache tests (tests/plugins.rs).
const VERSION: &str = match option_env!("OBJECTSPLAT_EXAMPLE_CODE_VERSION") {
    Some(v) => v,
    None => "1",
};

export_plugin!(
    Plugin::new("colorkey_masks", VERSION).node(
        NodeDecl::new("colorkey_masks", colorkey_masks)
            .doc("Object masks from colour keys: pixels within a key's tolerance get its object id (first match wins).")
            .input("frames", "Frames", "the posed images to key")
            .output("masks", "Masks", "16-bit id map per frame + objects.json")
            .param(
                "keys",
                "list(ron)",
                None,
                "keys as (id: 1, label: \"chair\", rgb: (200, 30, 30), tolerance: 12); tolerance per channel in 8-bit units",
            ),
    )
);
