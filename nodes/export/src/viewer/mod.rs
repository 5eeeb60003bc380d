//! The interactive scene viewer: a page that shows a scene's `.glb` in WebGL2, picks,
//! moves, turns, scales, duplicates, removes and recolors objects, undoes, and exports
//! the edits as the RON list `edit_scene` takes.
//!
//! The page is self-contained (works from `file://` with no network): the `.glb` travels
//! base64-encoded and the scene description as JSON inside the HTML, next to the viewer's
//! own script (`viewer.js`, plain WebGL2, no dependencies) and style (`viewer.css`), both
//! compiled into this crate. A viewer folder ([`write_viewer`]) holds:
//!
//! - `index.html`: the page;
//! - `scene.glb`: the same `.glb` (for other tools);
//! - `viewer.json`: the [`ViewerScene`] (so the report can embed the same view, [`read_viewer`]).
//!
//! The page's scripting surface, `window.objectsplat`: `ready` (a promise), `objects()`
//! → `[{name, label}]`, `pick(x, y)` → member name or null (CSS pixels of the canvas),
//! `apply(edit)` (plain objects: `{op: "move", target: NAME, by: [dx, dy, dz]}`, `rotate`
//! `{axis, degrees}`, `scale` `{factor}`, `duplicate` `{offset}`, `remove`, `recolor`
//! `{rgb}`), `edits()` → the RON text; also `transform(name)` → the member's node
//! transform and `undo()`.

use anyhow::{Context, Result, ensure};
use base64::Engine as _;
use objectsplat_core::ComponentKind;
use objectsplat_core::artifact::PAGE_HTML;
use objectsplat_core::artifact::SCENE_GLB;
use objectsplat_scene::Placement;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

pub const VIEWER_PAGE: &str = PAGE_HTML;
pub const VIEWER_JSON: &str = "viewer.json";

const SCRIPT: &str = include_str!("viewer.js");
const STYLE: &str = include_str!("viewer.css");

/// What the page shows besides the `.glb`'s meshes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewerScene {
    pub title: String,
    /// One per `.glb` child node, by the same name.
    pub members: Vec<ViewerMember>,
    /// The edits (RON text) that made this scene from the composed one; the page's
    /// exported list starts with them.
    #[serde(default)]
    pub edits: Vec<String>,
    /// Where the view starts; `None`: framing the objects.
    #[serde(default)]
    pub camera: Option<ViewerCamera>,
}

/// A scene member: its identity and its placement in full precision (the `.glb` node
/// holds the same transform in f32; edits done in the page start from these doubles).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewerMember {
    pub name: String,
    pub kind: ComponentKind,
    pub id: Option<u16>,
    pub label: Option<String>,
    pub placement: Placement,
}

/// A starting view: the eye looks at `target` (Z up), vertical field of view in degrees.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ViewerCamera {
    pub eye: [f64; 3],
    pub target: [f64; 3],
    pub fov_y_degrees: f64,
}

impl ViewerScene {
    fn check(&self) -> Result<()> {
        if let Some(c) = &self.camera {
            ensure!(
                c.eye.iter().chain(&c.target).all(|v| v.is_finite())
                    && c.fov_y_degrees.is_finite()
                    && c.fov_y_degrees > 0.0
                    && c.fov_y_degrees < 180.0,
                "viewer camera {c:?} needs finite points and a field of view in (0, 180) degrees"
            );
            ensure!(
                c.eye != c.target,
                "viewer camera: eye and target are the same point"
            );
        }
        Ok(())
    }
}

/// JSON safe inside a `<script>` element: `<` never appears literally, so neither
/// `</script>` nor `<!--` can end or change the block.
fn script_json(value: &impl Serialize) -> Result<String> {
    let text = serde_json::to_string(value).context("cannot encode the viewer's scene as JSON")?;
    Ok(text.replace('<', "\\u003c"))
}

/// The viewer as an HTML fragment (one `<div class="osv">` with its data and script) to
/// place in a page that includes [`viewer_style`]; it fills its container's height.
pub fn viewer_fragment(glb: &[u8], scene: &ViewerScene) -> Result<String> {
    scene.check()?;
    let json = script_json(scene)?;
    let glb64 = base64::engine::general_purpose::STANDARD.encode(glb);
    Ok(format!(
        "<div class=\"osv\"><script type=\"application/json\" class=\"osv-data\">{json}</script><script type=\"application/octet-stream\" class=\"osv-glb\">{glb64}</script><script>{SCRIPT}</script></div>"
    ))
}

/// The viewer's style sheet (for pages embedding [`viewer_fragment`]).
pub fn viewer_style() -> &'static str {
    STYLE
}

/// A whole page with the viewer filling the window.
pub fn viewer_page(glb: &[u8], scene: &ViewerScene) -> Result<String> {
    let title = crate::escape::escape(&scene.title);
    let fragment = viewer_fragment(glb, scene)?;
    Ok(format!(
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width\"><title>{title}</title><link rel=\"icon\" href=\"data:,\"><style>html,body{{margin:0;height:100%;overflow:hidden}}body>.osv{{height:100vh;border:0}}{STYLE}</style></head><body>{fragment}</body></html>\n"
    ))
}

/// Writes `index.html`, `scene.glb` and `viewer.json` into `dir`; returns the page's path.
pub fn write_viewer(dir: &Path, glb: &[u8], scene: &ViewerScene) -> Result<PathBuf> {
    let page = viewer_page(glb, scene)?;
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create folder", dir.display()))?;
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        std::fs::write(&path, bytes).with_context(|| format!("{}: cannot write", path.display()))
    };
    write(SCENE_GLB, glb)?;
    write(
        VIEWER_JSON,
        (serde_json::to_string_pretty(scene)? + "\n").as_bytes(),
    )?;
    write(VIEWER_PAGE, page.as_bytes())?;
    Ok(dir.join(VIEWER_PAGE))
}

/// Reads the `.glb` and the scene description of a folder written by [`write_viewer`].
pub fn read_viewer(dir: &Path) -> Result<(Vec<u8>, ViewerScene)> {
    let glb_path = dir.join(SCENE_GLB);
    let glb = std::fs::read(&glb_path).with_context(|| {
        format!(
            "{}: cannot read (is this a `viewer` node's folder?)",
            glb_path.display()
        )
    })?;
    let json_path = dir.join(VIEWER_JSON);
    let text = std::fs::read_to_string(&json_path)
        .with_context(|| format!("{}: cannot read", json_path.display()))?;
    let scene: ViewerScene = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a viewer scene description", json_path.display()))?;
    scene
        .check()
        .with_context(|| format!("{}", json_path.display()))?;
    Ok((glb, scene))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_code_cannot_end_its_element_early() {
        for text in [SCRIPT, STYLE] {
            assert!(!text.to_ascii_lowercase().contains("</script"));
            assert!(!text.to_ascii_lowercase().contains("</style"));
        }
    }

    #[test]
    fn scene_json_in_the_page_has_no_markup() {
        let scene = ViewerScene {
            title: "</script><script>alert(1)</script>".into(),
            members: Vec::new(),
            edits: vec!["Remove(target: Label(\"<!--\"))".into()],
            camera: None,
        };
        let page = viewer_page(b"glTF", &scene).unwrap();
        assert_eq!(page.matches("</script>").count(), 3, "{page}");
        assert!(!page.contains("<!--"));
        assert!(page.contains("<title>&lt;/script&gt;"));
    }
}
