//! The HTML report's content, checked by parsing what was written: self-contained, every SVG
//! well-formed XML (roxmltree), the graph layered along its edges and coloured by status,
//! pictures decodable and faithful, plots carrying the finite data, tables the numbers.

mod common;

use base64::Engine;
use common::svg::{polylines, svg_blocks};
use common::synthetic_report::{VIEW_H, VIEW_W, ground_truth_image, report_data};
use objectsplat_report::images::heat_colour;
use objectsplat_report::*;
use std::collections::HashMap;

fn written_report() -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    let data = report_data(dir.path());
    let path = render_report(&dir.path().join("out"), &data).unwrap();
    assert_eq!(path, dir.path().join("out").join(REPORT_FILE));
    let html = std::fs::read_to_string(path).unwrap();
    (dir, html)
}

fn data_uri_images(html: &str) -> Vec<image::RgbImage> {
    let prefix = "src=\"data:image/png;base64,";
    html.match_indices(prefix)
        .map(|(i, _)| {
            let start = i + prefix.len();
            let end = start + html[start..].find('"').unwrap();
            let png = base64::engine::general_purpose::STANDARD
                .decode(&html[start..end])
                .expect("valid base64");
            image::load_from_memory(&png).expect("valid PNG").to_rgb8()
        })
        .collect()
}

#[test]
fn page_is_self_contained() {
    let (_dir, html) = written_report();
    assert!(html.starts_with("<!DOCTYPE html>"));
    // The one script is the loader of the run summary written beside the outputs.
    let loader = objectsplat_report::run_loader();
    assert_eq!(html.matches(&loader).count(), 1);
    let html = html.replace(&loader, "");
    for forbidden in ["http:", "https:", "<script", "<link", "@import", "<iframe"] {
        assert!(!html.contains(forbidden), "report contains {forbidden}");
    }
    // Every src is an inline PNG.
    assert_eq!(
        html.matches(" src=\"").count(),
        html.matches(" src=\"data:image/png;base64,").count()
    );
    // The only url() is the in-document arrow marker.
    assert_eq!(
        html.matches("url(").count(),
        html.matches("url(#arrow)").count()
    );
    assert!(html.contains("<title>Synthetic run &lt;0a5c013435&gt;</title>"));
}

#[test]
fn every_svg_is_well_formed_xml() {
    let (_dir, html) = written_report();
    let blocks = svg_blocks(&html);
    assert_eq!(
        blocks.len(),
        6,
        "graph + loss, PSNR by iteration, PSNR by time, triangles + configurations"
    );
    for block in blocks {
        roxmltree::Document::parse(block).unwrap_or_else(|e| panic!("bad SVG ({e}): {block}"));
    }
}

#[test]
fn graph_is_layered_along_edges_and_coloured_by_status() {
    let (dir, html) = written_report();
    let data = report_data(dir.path());
    let dag = svg_blocks(&html)[0];
    let doc = roxmltree::Document::parse(dag).unwrap();
    let mut layer = HashMap::new();
    let mut left = HashMap::new();
    for g in doc
        .descendants()
        .filter(|n| n.attribute("class") == Some("node"))
    {
        let id = g.attribute("data-id").unwrap().to_string();
        let rect = g.children().find(|c| c.has_tag_name("rect")).unwrap();
        let node = data.run.nodes.iter().find(|n| n.id == id).unwrap();
        assert_eq!(g.attribute("data-status"), Some(node.status.as_str()));
        assert_eq!(
            rect.attribute("fill"),
            Some(dag::status_colour(node.status))
        );
        layer.insert(
            id.clone(),
            g.attribute("data-layer").unwrap().parse::<usize>().unwrap(),
        );
        left.insert(id, rect.attribute("x").unwrap().parse::<f64>().unwrap());
    }
    assert_eq!(layer.len(), data.run.nodes.len());
    for e in &data.run.edges {
        assert!(layer[&e.from] < layer[&e.to], "{} → {}", e.from, e.to);
        assert!(
            left[&e.from] < left[&e.to],
            "{} is drawn left of {}",
            e.from,
            e.to
        );
    }
    // Longest-path layering: decompose waits for masks, so it is two columns after scene.
    assert_eq!(
        (
            layer["scene"],
            layer["masks"],
            layer["decompose"],
            layer["report"]
        ),
        (0, 1, 2, 7)
    );
    let edges = doc
        .descendants()
        .filter(|n| n.attribute("class") == Some("edge"))
        .count();
    assert_eq!(edges, data.run.edges.len());
}

#[test]
fn view_pictures_are_faithful_and_the_heatmap_marks_the_error() {
    let (_dir, html) = written_report();
    let images = data_uri_images(&html);
    assert_eq!(images.len(), 6, "two views × (ground truth, render, error)");
    let gt = ground_truth_image(0);
    let gt_back = &images[0];
    assert_eq!(gt_back.dimensions(), (VIEW_W, VIEW_H));
    for (x, y, p) in gt_back.enumerate_pixels() {
        for c in 0..3 {
            assert_eq!(
                p[c] as f32,
                (gt.get(x, y, c as u32) * 255.0).round(),
                "pixel ({x},{y})"
            );
        }
    }
    // Error: 51/255 = 0.2 inside the block, 0 elsewhere; scale 0.25 → heat(0.8) and heat(0).
    let error = &images[2];
    let quantise = |c: [f32; 3]| c.map(|v| (v * 255.0).round() as u8);
    assert_eq!(error.get_pixel(12, 12).0, quantise(heat_colour(0.8)));
    assert_eq!(error.get_pixel(40, 30).0, quantise(heat_colour(0.0)));
    // The page states the view's PSNR: 256 of 3072 pixels off by 0.2 → MSE 0.04/12.
    let expected_psnr = 10.0 * (12.0f64 / 0.04).log10();
    assert!(
        html.contains(&format!("PSNR {expected_psnr:.2} dB")),
        "expected PSNR {expected_psnr:.2}"
    );
}

#[test]
fn runtime_configurations_are_plotted_per_series() {
    let (_dir, html) = written_report();
    let blocks = svg_blocks(common::svg::section(&html, "runtime"));
    assert_eq!(blocks.len(), 1);
    let runtime = roxmltree::Document::parse(blocks[0]).unwrap();
    let series = polylines(&runtime);
    assert_eq!(
        series
            .iter()
            .map(|s| (s.0.as_str(), s.1.len()))
            .collect::<Vec<_>>(),
        [("cpu", 2), ("wgpu", 1)]
    );
    // Sorted by run time: the 30 s point is left of the 180 s point.
    assert!(series[0].1[0].0 < series[0].1[1].0);
    assert!(html.contains(
        "<td>cpu</td><td>30k it</td><td class=\"num\">180.00</td><td class=\"num\">24.30</td>"
    ));
}

#[test]
fn tables_show_nodes_and_metrics() {
    let (_dir, html) = written_report();
    assert!(html.contains("9 nodes: 5 ran, 2 cached, 1 skipped, 1 failed; 126.56 s of node time, 100.25 s wall time (graph graphs/synthetic.ron)."));
    assert!(html.contains("no planar support surface"));
    assert!(html.contains("obj_3_chair (ran, 60.00 s), background (cached, 0.00 s)"));
    assert!(html.contains("<tr><th>scene</th><td class=\"num\">24.3125</td><td class=\"num\">0.8123</td><td class=\"num\">–</td>"));
    assert!(html.contains("<tr><th>obj_3_chair</th><td class=\"num\">27.5000</td>"));
}
