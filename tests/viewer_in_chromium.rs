//! The `viewer` page in headless Chromium (WebGL on SwiftShader), opened from `file://`:
//! it lists the scene's members, picking the centre pixel of a member's rendered mask
//! returns that member, a move changes the picture where that object was or is and
//! nowhere else, the mouse and keys select and edit, it draws what the project's own
//! renderer draws from the same camera (turned and scaled objects included), and the
//! page logs no error and requests nothing but its own file.
//!
//! The masks come from the screenshot, not from the page's picking: every member is
//! recolored to its own flat colour first (the page draws unlit), so a pixel's colour
//! says which member covers it.

mod support;

use objectsplat_core::artifact::PAGE_HTML;
use objectsplat_runtime::testing::run_node;
use serde_json::{Value, json};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use support::chromium::{Browser, Page, numbers, strings};

const WIDTH: u32 = 900;
const HEIGHT: u32 = 600;

/// The hand-made scene as a viewer folder in a new scratch folder; returns that folder
/// (the page lives as long as it) and the page's index.html.
fn viewer_page() -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("scene");
    support::small_scene::write(&scene);
    let run = run_node(
        &objectsplat_export::nodes::Viewer,
        &[("scene", &scene)],
        "(title: \"small scene\")",
        &tmp.path().join("viewer"),
        None,
    )
    .unwrap();
    let page = run.outputs["file"].join(PAGE_HTML);
    (tmp, page)
}

fn canvas_rect(page: &mut Page) -> [f64; 4] {
    numbers(&page.eval(
        "(() => { const r = document.querySelector('.osv-canvas').getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; })()",
    ))
}

/// Pixels of `shot` with exactly `rgb`.
fn mask(shot: &image::RgbaImage, rgb: [u8; 3]) -> Vec<(u32, u32)> {
    shot.enumerate_pixels()
        .filter(|(_, _, p)| p.0[..3] == rgb)
        .map(|(x, y, _)| (x, y))
        .collect()
}

/// The mask pixel nearest the mask's centroid.
fn centre_pixel(mask: &[(u32, u32)]) -> (u32, u32) {
    let n = mask.len() as f64;
    let cx = mask.iter().map(|p| p.0 as f64).sum::<f64>() / n;
    let cy = mask.iter().map(|p| p.1 as f64).sum::<f64>() / n;
    *mask
        .iter()
        .min_by(|a, b| {
            let da = (a.0 as f64 - cx).powi(2) + (a.1 as f64 - cy).powi(2);
            let db = (b.0 as f64 - cx).powi(2) + (b.1 as f64 - cy).powi(2);
            da.total_cmp(&db)
        })
        .unwrap()
}

/// Flat colours, one per member, none of them the page's backdrop.
const FLAT: [(&str, [u8; 3]); 4] = [
    ("background", [0, 0, 255]),
    ("obj_3_chair", [255, 0, 0]),
    ("obj_5_cup", [0, 255, 0]),
    ("obj_7_desk_lamp", [255, 0, 255]),
];

fn recolor_all(page: &mut Page) {
    for (name, rgb) in FLAT {
        let rgb: Vec<f64> = rgb.iter().map(|&c| c as f64 / 255.0).collect();
        page.eval(&format!(
            "window.objectsplat.apply({})",
            json!({"op": "recolor", "target": name, "rgb": rgb})
        ));
    }
}

fn assert_clean(page: &mut Page, page_path: &Path) {
    // A round trip drains events the page sent before it.
    page.eval("1");
    let errors = page.errors();
    assert!(errors.is_empty(), "console errors: {errors:#?}");
    let own = format!("file://{}", page_path.display());
    for url in page.requests() {
        assert!(
            url == own || url.starts_with("data:"),
            "the page requested {url}"
        );
    }
}

#[test]
fn viewer_lists_picks_and_moves_exactly_the_object() {
    let Some(mut browser) = Browser::launch("viewer_lists_picks_and_moves_exactly_the_object")
    else {
        return;
    };
    let (_tmp, page_path) = viewer_page();
    let mut page = browser.open(&page_path, WIDTH, HEIGHT);
    assert_eq!(page.eval("window.objectsplat.ready"), json!(true));
    assert_eq!(
        page.eval("window.objectsplat.objects()"),
        json!([
            {"name": "background", "label": null},
            {"name": "obj_3_chair", "label": "chair"},
            {"name": "obj_5_cup", "label": "cup"},
            {"name": "obj_7_desk_lamp", "label": "desk lamp"},
        ])
    );
    let rect = canvas_rect(&mut page);
    assert!(rect[2] > 400.0 && rect[3] > 400.0, "canvas {rect:?}");

    recolor_all(&mut page);
    let before = page.screenshot(rect);
    if let Some(keep) = std::env::var_os("OBJECTSPLAT_KEEP_SCREENSHOT") {
        before
            .save(Path::new(&keep).join("viewer_flat.png"))
            .unwrap();
    }
    let masks: HashMap<&str, Vec<(u32, u32)>> =
        FLAT.iter().map(|(n, c)| (*n, mask(&before, *c))).collect();
    for (name, _) in FLAT {
        let m = &masks[name];
        assert!(m.len() > 200, "{name} covers only {} px", m.len());
        let (x, y) = centre_pixel(m);
        let picked = page.eval(&format!(
            "window.objectsplat.pick({}, {})",
            x as f64 + 0.5,
            y as f64 + 0.5
        ));
        assert_eq!(picked, json!(name), "centre pixel ({x}, {y}) of {name}");
    }
    // Nothing is drawn in a corner above the horizon: the backdrop picks nothing.
    let backdrop = before.get_pixel(2, 2).0;
    assert!(
        FLAT.iter().all(|(_, c)| c[..] != backdrop[..3]),
        "corner {backdrop:?} is covered"
    );
    assert_eq!(page.eval("window.objectsplat.pick(2.5, 2.5)"), Value::Null);

    // Move the chair sideways: only pixels the chair covered or covers change.
    page.eval("window.objectsplat.apply({op: 'move', target: 'obj_3_chair', by: [0.35, 0, 0]})");
    let after = page.screenshot(rect);
    let chair_after = mask(&after, [255, 0, 0]);
    let chair: std::collections::HashSet<(u32, u32)> = masks["obj_3_chair"]
        .iter()
        .chain(&chair_after)
        .copied()
        .collect();
    let mut changed = 0;
    for (x, y, p) in before.enumerate_pixels() {
        if p != after.get_pixel(x, y) {
            changed += 1;
            assert!(
                chair.contains(&(x, y)),
                "pixel ({x}, {y}) changed ({:?} → {:?}) outside the chair",
                p.0,
                after.get_pixel(x, y).0
            );
        }
    }
    assert!(changed > 200, "the move changed only {changed} px");
    assert_ne!(masks["obj_3_chair"], chair_after);

    let edits = page.eval("window.objectsplat.edits()");
    let edits = edits.as_str().unwrap();
    assert!(
        edits.starts_with("[\n    Recolor(target: Name(\"background\"), rgb: (0, 0, 1)),\n"),
        "{edits}"
    );
    assert!(
        edits.ends_with("    Move(target: Name(\"obj_3_chair\"), by: (0.35, 0, 0)),\n]"),
        "{edits}"
    );
    // A bad edit is an exception naming the problem, and changes nothing.
    let err = page
        .try_eval("window.objectsplat.apply({op: 'move', target: 'sofa', by: [1, 0, 0]})")
        .unwrap_err();
    assert!(err.contains("no scene member is named \"sofa\""), "{err}");
    assert_eq!(
        page.eval("window.objectsplat.edits()").as_str(),
        Some(edits)
    );
    // The thrown error is the caller's; it is not a console error of the page.
    page.browser
        .events
        .retain(|e| e["method"] != json!("Runtime.exceptionThrown"));
    assert_clean(&mut page, &page_path);
}

/// The CSS pixel (relative to the canvas) nearest the centre of where `name` is drawn,
/// found with the page's own picking on a grid.
fn centre_of(page: &mut Page, name: &str) -> (f64, f64) {
    let hits = page.eval(&format!(
        "(() => {{ const c = document.querySelector('.osv-canvas'); const out = []; for (let y = 2; y < c.clientHeight; y += 4) for (let x = 2; x < c.clientWidth; x += 4) if (window.objectsplat.pick(x + 0.5, y + 0.5) === {name:?}) out.push([x + 0.5, y + 0.5]); return out; }})()"
    ));
    let hits: Vec<(f64, f64)> = hits
        .as_array()
        .unwrap()
        .iter()
        .map(|p| (p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
        .collect();
    assert!(
        hits.len() > 10,
        "{name} is hardly visible ({} hits)",
        hits.len()
    );
    let n = hits.len() as f64;
    let (cx, cy) = (
        hits.iter().map(|p| p.0).sum::<f64>() / n,
        hits.iter().map(|p| p.1).sum::<f64>() / n,
    );
    *hits
        .iter()
        .min_by(|a, b| {
            ((a.0 - cx).powi(2) + (a.1 - cy).powi(2))
                .total_cmp(&((b.0 - cx).powi(2) + (b.1 - cy).powi(2)))
        })
        .unwrap()
}

fn translation(page: &mut Page, name: &str) -> [f64; 3] {
    numbers(&page.eval(&format!(
        "window.objectsplat.transform({name:?}).translation"
    )))
}

#[test]
fn mouse_and_keys_select_edit_undo_and_export() {
    let Some(mut browser) = Browser::launch("mouse_and_keys_select_edit_undo_and_export") else {
        return;
    };
    let (_tmp, page_path) = viewer_page();
    let mut page = browser.open(&page_path, WIDTH, HEIGHT);
    page.eval("window.objectsplat.ready");
    let rect = canvas_rect(&mut page);
    let edits = |page: &mut Page| {
        page.eval("window.objectsplat.edits()")
            .as_str()
            .unwrap()
            .to_string()
    };

    // A click on the lamp selects it: panel and on-canvas tag name it.
    let (x, y) = centre_of(&mut page, "obj_7_desk_lamp");
    let (px, py) = (rect[0] + x, rect[1] + y);
    page.mouse("mousePressed", px, py, 0);
    page.mouse("mouseReleased", px, py, 0);
    let selected = page.eval("document.querySelector('.osv-selected').textContent");
    assert!(
        selected
            .as_str()
            .unwrap()
            .contains("desk lamp (id 7) — obj_7_desk_lamp"),
        "{selected}"
    );
    assert_eq!(
        page.eval("(() => { const t = document.querySelector('.osv-tag'); return t.hidden ? null : t.textContent; })()"),
        json!("desk lamp · obj_7_desk_lamp")
    );
    assert_eq!(edits(&mut page), "[]", "a click is not an edit");

    // Keys: a step sideways, a turn, a scale, then duplicate and remove the copy, undo.
    let t0 = translation(&mut page, "obj_7_desk_lamp");
    page.key("ArrowRight", "ArrowRight", 39);
    let t1 = translation(&mut page, "obj_7_desk_lamp");
    let step: Vec<f64> = (0..3).map(|k| t1[k] - t0[k]).collect();
    assert!(
        step[2] == 0.0 && (step[0].abs() > 0.0) != (step[1].abs() > 0.0),
        "an arrow key moves along one ground axis: {step:?}"
    );
    page.key("q", "KeyQ", 81);
    page.key("+", "Equal", 187);
    page.key("d", "KeyD", 68);
    let names = strings(&page.eval("window.objectsplat.objects().map(o => o.name)"));
    assert_eq!(names.last().map(String::as_str), Some("obj_8_desk_lamp"));
    page.key("Delete", "Delete", 46);
    assert_eq!(page.eval("window.objectsplat.objects().length"), json!(4));
    let text = edits(&mut page);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 7, "{text}");
    assert!(
        lines[1].starts_with("    Move(target: Name(\"obj_7_desk_lamp\"), by: ("),
        "{text}"
    );
    assert_eq!(
        lines[2],
        "    Rotate(target: Name(\"obj_7_desk_lamp\"), axis: (0, 0, 1), degrees: 15),"
    );
    assert_eq!(
        lines[3],
        "    Scale(target: Name(\"obj_7_desk_lamp\"), factor: 1.25),"
    );
    assert!(
        lines[4].starts_with("    Duplicate(target: Name(\"obj_7_desk_lamp\"), offset: ("),
        "{text}"
    );
    assert_eq!(lines[5], "    Remove(target: Name(\"obj_8_desk_lamp\")),");
    page.key("z", "KeyZ", 90); // without Ctrl: nothing
    assert_eq!(edits(&mut page), text);
    page.key_with("z", "KeyZ", 90, 2); // Ctrl+Z
    assert_eq!(page.eval("window.objectsplat.objects().length"), json!(5));

    // A mouse drag on the selected copy moves it on the ground plane.
    let (x, y) = centre_of(&mut page, "obj_8_desk_lamp");
    let (px, py) = (rect[0] + x, rect[1] + y);
    page.mouse("mousePressed", px, py, 0);
    page.mouse("mouseReleased", px, py, 0);
    let before = translation(&mut page, "obj_8_desk_lamp");
    page.mouse("mousePressed", px, py, 0);
    for k in 1..=5 {
        page.mouse("mouseMoved", px + 8.0 * k as f64, py + 3.0 * k as f64, 0);
    }
    page.mouse("mouseReleased", px + 40.0, py + 15.0, 0);
    let after = translation(&mut page, "obj_8_desk_lamp");
    assert_eq!(after[2], before[2], "a plain drag keeps the height");
    assert!(
        (after[0] - before[0]).hypot(after[1] - before[1]) > 0.05,
        "{before:?} → {after:?}"
    );
    let text = edits(&mut page);
    let last = text.lines().rev().nth(1).unwrap();
    assert!(
        last.starts_with("    Move(target: Name(\"obj_8_desk_lamp\"), by: (")
            && last.ends_with(", 0)),"),
        "{text}"
    );

    // The Export edits button shows the same list.
    page.eval("[...document.querySelectorAll('.osv-button')].find(b => b.textContent === 'Export edits').click()");
    assert_eq!(
        page.eval("(() => { const d = document.querySelector('.osv-dialog'); return d.hidden ? null : document.querySelector('.osv-edits').value; })()"),
        json!(text)
    );
    if let Some(keep) = std::env::var_os("OBJECTSPLAT_KEEP_SCREENSHOT") {
        page.eval("document.querySelector('.osv-dialog').hidden = true");
        page.screenshot([0.0, 0.0, WIDTH as f64, HEIGHT as f64])
            .save(Path::new(&keep).join("viewer_selected.png"))
            .unwrap();
    }
    assert_clean(&mut page, &page_path);
}

/// The scene's palette: backdrop, floor and the three boxes (sRGB).
fn palette() -> Vec<[f64; 3]> {
    let mut colours = vec![[0.16, 0.17, 0.19], [0.55, 0.55, 0.5]];
    colours.extend(
        support::small_scene::BOXES
            .iter()
            .map(|b| b.4.map(f64::from)),
    );
    colours
}

/// The palette entry nearest each pixel.
fn labels(pixels: impl Iterator<Item = [f64; 3]>) -> Vec<usize> {
    let palette = palette();
    pixels
        .map(|p| {
            (0..palette.len())
                .min_by(|&a, &b| {
                    let d = |c: &[f64; 3]| (0..3).map(|k| (p[k] - c[k]).powi(2)).sum::<f64>();
                    d(&palette[a]).total_cmp(&d(&palette[b]))
                })
                .unwrap()
        })
        .collect()
}

#[test]
fn viewer_draws_what_render_draws() {
    use objectsplat_scene::render::{Backdrop, render_view};
    let Some(mut browser) = Browser::launch("viewer_draws_what_render_draws") else {
        return;
    };
    // Turned, scaled and moved objects, seen from a frame's camera.
    let tmp = tempfile::tempdir().unwrap();
    let scene = support::viewer_page::edited(
        support::small_scene::scene(),
        &[
            "Rotate(target: Id(7), axis: (1, 0.5, 0), degrees: 70)",
            "Scale(target: Id(7), factor: 0.8)",
            "Move(target: Id(7), by: (0.1, -0.2, 0.3))",
            "Rotate(target: Label(\"chair\"), axis: (0, 0, 1), degrees: 30)",
        ],
    );
    let (dir, start) = support::viewer_page::viewer_of(&scene, tmp.path());

    let page_path = dir.join(PAGE_HTML);
    let mut page = browser.open(&page_path, WIDTH, HEIGHT);
    page.eval("window.objectsplat.ready");
    let rect = canvas_rect(&mut page);
    let shot = page.screenshot(rect);
    let (w, h) = shot.dimensions();
    // The same pinhole camera: the viewer's eye, target and vertical field of view.
    let camera = support::viewer_page::page_camera(&start, w, h);
    let merged = scene.merged_model().unwrap().model;
    let rendered = render_view(
        &merged,
        &camera,
        &Backdrop::Uniform([0.16, 0.17, 0.19]),
        &objectsplat_raster::CpuBackend::new(1),
        1,
    )
    .unwrap();
    if let Some(keep) = std::env::var_os("OBJECTSPLAT_KEEP_SCREENSHOT") {
        shot.save(Path::new(&keep).join("viewer_vs_render_page.png"))
            .unwrap();
        rendered
            .save_png8(&Path::new(&keep).join("viewer_vs_render_render.png"))
            .unwrap();
    }
    let page_labels = labels(
        shot.pixels()
            .map(|p| [0, 1, 2].map(|k| p.0[k] as f64 / 255.0)),
    );
    let rgb = rendered.to_rgb();
    let render_labels = labels(
        rgb.data
            .chunks(3)
            .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64]),
    );
    assert_eq!(page_labels.len(), render_labels.len());
    let agree = page_labels
        .iter()
        .zip(&render_labels)
        .filter(|(a, b)| a == b)
        .count() as f64
        / page_labels.len() as f64;
    eprintln!("page and renderer agree on {:.3}% of pixels", agree * 100.0);
    assert!(
        agree > 0.995,
        "the page and the renderer agree on {:.2}% of pixels",
        agree * 100.0
    );
    // Each box: the same pixels (intersection over union).
    for label in 2..5 {
        let a: Vec<bool> = page_labels.iter().map(|&l| l == label).collect();
        let b: Vec<bool> = render_labels.iter().map(|&l| l == label).collect();
        let inter = a.iter().zip(&b).filter(|(x, y)| **x && **y).count() as f64;
        let union = a.iter().zip(&b).filter(|(x, y)| **x || **y).count() as f64;
        assert!(union > 500.0, "box {label} hardly visible");
        eprintln!("box {label}: IoU {:.4}", inter / union);
        assert!(
            inter / union > 0.98,
            "box {label}: IoU {:.3}",
            inter / union
        );
    }
    assert_clean(&mut page, &page_path);
}
