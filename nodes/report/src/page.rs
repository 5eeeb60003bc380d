//! Assembles `index.html`: one self-contained page (inline CSS, inline SVG, PNG data URIs,
//! no external fetches) so it can be mailed or archived as a single file. The only script
//! is the embedded 3D viewer's, when the report has one.

use crate::data::ReportData;
use crate::images::render_triplet;
use crate::plot::{PlotSpec, Series, line_plot_svg};
use crate::run_summary::{run_loader, run_section};
use crate::training::{finite_points, section_training};
use anyhow::{Context, Result, ensure};
use objectsplat_core::artifact::PAGE_HTML;
use objectsplat_core::component::object_item_name;
use objectsplat_export::escape::escape;
use objectsplat_export::viewer::{read_viewer, viewer_fragment, viewer_style};
use objectsplat_metrics::report::ScopeMetrics;
use std::fmt::Write;
use std::path::{Path, PathBuf};

pub const REPORT_FILE: &str = PAGE_HTML;

/// Default error drawn with the hottest heatmap colour (mean absolute RGB error).
pub const DEFAULT_ERROR_SCALE: f64 = 0.25;

const STYLE: &str = "body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:24px;color:#222;background:#fafafa}\
h1{margin-top:0}h2{border-bottom:2px solid #ddd;padding-bottom:4px;margin-top:32px}\
table{border-collapse:collapse;margin:8px 0;background:white}th,td{border:1px solid #ccc;padding:4px 10px;text-align:left}\
td.num{text-align:right;font-variant-numeric:tabular-nums}th{background:#eee}\
.status{display:inline-block;padding:1px 8px;border-radius:8px}\
.triplet{display:flex;gap:8px;flex-wrap:wrap;margin-bottom:16px}.triplet figure{margin:0}\
.triplet img{display:block;width:min(384px,30vw);height:auto;border:1px solid #bbb}\
figcaption{font-size:12px;color:#555}.plots{display:flex;flex-wrap:wrap;gap:16px}\
.note{color:#a33}svg{background:white;max-width:100%;height:auto}";

fn metric_cell(value: Option<f64>) -> String {
    match value {
        Some(v) if v.is_finite() => format!(r#"<td class="num">{v:.4}</td>"#),
        Some(v) => format!(r#"<td class="num">{v}</td>"#),
        None => r#"<td class="num">–</td>"#.to_string(),
    }
}

/// Column headers and values of a metrics row, in display order; null = not computed.
/// The scores as exported show beside the trained ones when the run scored them.
fn columns(m: &ScopeMetrics, exported: bool) -> Vec<(&'static str, Option<f64>)> {
    let mut columns = vec![("PSNR", m.psnr)];
    if exported {
        columns.push(("PSNR as exported", m.exported_psnr));
    }
    columns.push(("SSIM", m.ssim));
    if exported {
        columns.push(("SSIM as exported", m.exported_ssim));
    }
    columns.extend([
        ("LPIPS", m.lpips),
        ("F-score", m.fscore),
        ("precision", m.precision),
        ("recall", m.recall),
        ("τ (m)", m.tau),
        ("normals |cos|", m.normal_consistency),
        ("background in front", m.background_in_front),
    ]);
    columns
}

fn metrics_row(name: &str, values: &ScopeMetrics, exported: bool) -> String {
    let cells: String = columns(values, exported)
        .iter()
        .map(|(_, v)| metric_cell(*v))
        .collect();
    format!("<tr><th>{}</th>{cells}</tr>", escape(name))
}

fn section_metrics(data: &ReportData, html: &mut String) {
    html.push_str("<section id=\"metrics\"><h2>Metrics</h2>");
    let Some(metrics) = &data.metrics else {
        html.push_str("<p>This run did not evaluate.</p></section>");
        return;
    };
    let exported = metrics.scene.exported_psnr.is_some();
    html.push_str("<table id=\"metrics-table\"><tr><th></th>");
    for (header, _) in columns(&metrics.scene, exported) {
        let _ = write!(html, "<th>{}</th>", escape(header));
    }
    html.push_str("</tr>");
    html.push_str(&metrics_row("scene", &metrics.scene, exported));
    for object in &metrics.objects {
        html.push_str(&metrics_row(
            &object_item_name(object.id, &object.label),
            &object.metrics,
            exported,
        ));
    }
    html.push_str("</table>");
    if exported {
        html.push_str("<p>As exported: the test views rendered as the <code>.glb</code> holds the scene (visible faces only, opaque, hard-edged, one colour per vertex, fitted to the training views as the export draws them) — what a user who opens the export sees.</p>");
    }
    if metrics.scene.background_in_front.is_some() {
        html.push_str("<p>Background in front: the share of an object's true pixels in the test views where the background renders a surface nearer than the object (floaters, sheets).</p>");
    }
    html.push_str("</section>");
}

fn section_views(data: &ReportData, html: &mut String) -> Result<()> {
    let scale = if data.error_scale == 0.0 {
        DEFAULT_ERROR_SCALE
    } else {
        data.error_scale
    };
    ensure!(
        scale.is_finite() && scale > 0.0,
        "report error_scale must be a positive number, got {scale}"
    );
    let _ = write!(
        html,
        "<section id=\"views\"><h2>Test views</h2><p>Ground truth, render, and mean absolute RGB error (black = 0, pale yellow ≥ {scale}).</p>"
    );
    if data.views.is_empty() {
        html.push_str("<p>No test views.</p>");
    }
    for view in &data.views {
        let t = render_triplet(&view.ground_truth, &view.render, scale as f32)
            .with_context(|| format!("test view {}", view.name))?;
        let name = escape(&view.name);
        let _ = write!(
            html,
            r#"<h3>{name} <small>PSNR {psnr:.2} dB</small></h3><div class="triplet" data-view="{name}"><figure><img alt="{name} ground truth" src="{gt}"><figcaption>ground truth</figcaption></figure><figure><img alt="{name} render" src="{r}"><figcaption>render</figcaption></figure><figure><img alt="{name} error" src="{e}"><figcaption>error</figcaption></figure></div>"#,
            psnr = t.psnr,
            gt = t.ground_truth,
            r = t.render,
            e = t.error
        );
    }
    html.push_str("</section>");
    Ok(())
}

/// Measured configurations (e.g. from a benchmark), when the report was given any.
fn section_runtime(data: &ReportData, html: &mut String) {
    if data.runtime_vs_error.is_empty() {
        return;
    }
    let mut notes = Vec::new();
    let mut series_names: Vec<&str> = Vec::new();
    for p in &data.runtime_vs_error {
        if !series_names.contains(&p.series.as_str()) {
            series_names.push(&p.series);
        }
    }
    let series: Vec<Series> = series_names
        .iter()
        .map(|s| {
            let points = data
                .runtime_vs_error
                .iter()
                .filter(|p| p.series == *s)
                .map(|p| (p.seconds, p.psnr));
            Series::new(s, finite_points(s, "run-time", points, &mut notes))
        })
        .collect();
    html.push_str("<section id=\"runtime\"><h2>Run time against error</h2>");
    html.push_str(&line_plot_svg(&PlotSpec {
        title: "PSNR against wall time".into(),
        x_label: "wall time (s)".into(),
        y_label: "PSNR (dB)".into(),
        series,
        markers: true,
    }));
    html.push_str("<table id=\"runtime-table\"><tr><th>series</th><th>configuration</th><th>seconds</th><th>PSNR (dB)</th></tr>");
    for p in &data.runtime_vs_error {
        let _ = write!(
            html,
            r#"<tr><td>{}</td><td>{}</td><td class="num">{:.2}</td><td class="num">{:.2}</td></tr>"#,
            escape(&p.series),
            escape(&p.label),
            p.seconds,
            p.psnr
        );
    }
    html.push_str("</table>");
    for note in notes {
        let _ = write!(html, "<p class=\"note\">{}</p>", escape(&note));
    }
    html.push_str("</section>");
}

/// The interactive 3D view of the scene, when the report was given a viewer folder.
fn section_scene(data: &ReportData, html: &mut String) -> Result<()> {
    let Some(dir) = &data.viewer else {
        return Ok(());
    };
    let (glb, scene) = read_viewer(dir)?;
    html.push_str("<section id=\"scene\"><h2>Scene</h2><p>Click an object to select it; drag it to move it; the panel lists the controls. <em>Export edits</em> gives the list for <code>edit_scene</code>.</p><div class=\"scene-view\">");
    html.push_str(&viewer_fragment(&glb, &scene)?);
    html.push_str("</div></section>");
    Ok(())
}

/// Builds the page's HTML.
pub fn report_html(data: &ReportData) -> Result<String> {
    let title = escape(&data.title);
    let viewer_style = if data.viewer.is_some() {
        format!(".scene-view{{height:560px}}{}", viewer_style())
    } else {
        String::new()
    };
    let mut html = format!(
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width\"><title>{title}</title><style>{STYLE}{viewer_style}</style></head><body><h1>{title}</h1>"
    );
    html.push_str(&run_section(&data.run)?);
    html.push_str(&run_loader());
    section_scene(data, &mut html)?;
    section_metrics(data, &mut html);
    section_views(data, &mut html)?;
    section_training(&data.training, &mut html);
    section_runtime(data, &mut html);
    html.push_str("</body></html>\n");
    Ok(html)
}

/// Writes `<out_dir>/index.html` and returns its path.
pub fn render_report(out_dir: &Path, data: &ReportData) -> Result<PathBuf> {
    let html = report_html(data).context("cannot build the HTML report")?;
    std::fs::create_dir_all(out_dir)
        .with_context(|| format!("{}: cannot create folder", out_dir.display()))?;
    let path = out_dir.join(REPORT_FILE);
    std::fs::write(&path, html)
        .with_context(|| format!("{}: cannot write report", path.display()))?;
    Ok(path)
}
