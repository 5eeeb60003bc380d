//! The Component artifact: what one component (an object or the background) is trained on.
//!
//! Encoding (a folder, one item of a `[Component]` collection, named `obj_<id>_<label>`
//! or `background`):
//! - `component.json`: `{"name", "kind": "object" | "background", "object_id", "label"}`
//!   (`object_id`/`label` are null for the background);
//! - `frames.json` + `images/`: the frames it appears in (the Frames encoding);
//! - `masks/<frame stem>.png`: 8-bit grey per frame: [`OWN`] = a pixel this component
//!   owns; [`OTHER`] = owned by another component (an object supervises it toward the
//!   random background colour, the background gives it zero weight); [`IGNORE`] =
//!   never supervised (invalid pixels);
//! - `targets/<frame stem>.png` (optional): replacement target colours, used for owned
//!   pixels instead of the frame image (set by surface completion for filled pixels).

use serde::{Deserialize, Serialize};

pub const COMPONENT_JSON: &str = "component.json";
pub const OWN: u8 = 255;
pub const OTHER: u8 = 0;
pub const IGNORE: u8 = 128;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ComponentKind {
    Object,
    Background,
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ComponentInfo {
    pub name: String,
    pub kind: ComponentKind,
    pub object_id: Option<u16>,
    pub label: Option<String>,
}

impl ComponentInfo {
    pub fn object(id: u16, label: &str) -> ComponentInfo {
        ComponentInfo {
            name: object_item_name(id, label),
            kind: ComponentKind::Object,
            object_id: Some(id),
            label: Some(label.to_string()),
        }
    }

    pub fn background() -> ComponentInfo {
        ComponentInfo {
            name: "background".into(),
            kind: ComponentKind::Background,
            object_id: None,
            label: None,
        }
    }
}

/// `obj_<id>_<label>` with the label reduced to `[a-z0-9_]` so it is a valid item/folder name.
pub fn object_item_name(id: u16, label: &str) -> String {
    let clean: String = label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    format!("obj_{id}_{clean}")
}
