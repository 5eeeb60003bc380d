//! Inline SVG line plots with labelled axes, "nice" ticks and a legend; a series may mark
//! one of its points (a ring, e.g. the best checkpoint) and an x position (a dashed vertical
//! line, e.g. where training stopped early).

use objectsplat_export::escape::escape;
use std::fmt::Write;

/// Categorical palette (colour-blind friendly, Okabe–Ito order), cycled per series.
pub const PALETTE: [&str; 8] = [
    "#0072B2", "#E69F00", "#009E73", "#D55E00", "#CC79A7", "#56B4E9", "#F0E442", "#000000",
];

#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    /// Drawn as a ring in the series colour (`class="best"`).
    pub best: Option<(f64, f64)>,
    /// Drawn as a dashed vertical line in the series colour (`class="stop"`).
    pub stop: Option<f64>,
}

impl Series {
    pub fn new(name: &str, points: Vec<(f64, f64)>) -> Series {
        Series {
            name: name.to_string(),
            points,
            best: None,
            stop: None,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct PlotSpec {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Draw a dot at each point (for sparse data such as held-out evaluations).
    pub markers: bool,
}

const WIDTH: f64 = 640.0;
const HEIGHT: f64 = 340.0;
const MARGIN_LEFT: f64 = 64.0;
const MARGIN_RIGHT: f64 = 160.0;
const MARGIN_TOP: f64 = 32.0;
const MARGIN_BOTTOM: f64 = 48.0;

/// Round tick positions covering [lo, hi]: steps of 1, 2 or 5 × 10^k, about `target` of them.
pub fn nice_ticks(lo: f64, hi: f64, target: usize) -> (Vec<f64>, f64) {
    debug_assert!(lo.is_finite() && hi.is_finite() && hi > lo && target >= 2);
    let raw_step = (hi - lo) / (target - 1) as f64;
    let magnitude = 10f64.powf(raw_step.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * magnitude)
        .find(|s| *s >= raw_step)
        .unwrap_or(10.0 * magnitude);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    ((first..=last).map(|k| k as f64 * step).collect(), step)
}

fn format_tick(value: f64, step: f64) -> String {
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let text = format!("{value:.decimals$}");
    // "-0" reads as a bug in an axis label.
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        text.trim_start_matches('-').to_string()
    } else {
        text
    }
}

/// Widens a degenerate or single-valued range so it can be mapped to pixels.
fn padded_range(lo: f64, hi: f64) -> (f64, f64) {
    if hi > lo {
        (lo, hi)
    } else {
        let pad = if lo == 0.0 { 1.0 } else { lo.abs() * 0.05 };
        (lo - pad, hi + pad)
    }
}

/// Renders the plot; non-finite points and marks must have been filtered out by the caller.
pub fn line_plot_svg(spec: &PlotSpec) -> String {
    let all: Vec<(f64, f64)> = spec
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied().chain(s.best))
        .collect();
    let stops = spec.series.iter().filter_map(|s| s.stop);
    let mut svg = String::new();
    // Writing to a String cannot fail, so the fmt::Results below are ignored.
    let _ = write!(
        svg,
        r#"<svg class="plot" viewBox="0 0 {WIDTH} {HEIGHT}" width="{WIDTH}" height="{HEIGHT}" role="img" aria-label="{t}"><title>{t}</title><rect x="0" y="0" width="{WIDTH}" height="{HEIGHT}" fill="white"/><text x="{cx}" y="20" text-anchor="middle" font-size="15" font-weight="bold">{t}</text>"#,
        t = escape(&spec.title),
        cx = WIDTH / 2.0,
    );
    let plot_w = WIDTH - MARGIN_LEFT - MARGIN_RIGHT;
    let plot_h = HEIGHT - MARGIN_TOP - MARGIN_BOTTOM;
    if all.is_empty() {
        let _ = write!(
            svg,
            r##"<text x="{x}" y="{y}" text-anchor="middle" font-size="14" fill="#666">no data</text></svg>"##,
            x = MARGIN_LEFT + plot_w / 2.0,
            y = MARGIN_TOP + plot_h / 2.0
        );
        return svg;
    }
    let (x_lo, x_hi) = padded_range(
        all.iter()
            .map(|p| p.0)
            .chain(stops.clone())
            .fold(f64::INFINITY, f64::min),
        all.iter()
            .map(|p| p.0)
            .chain(stops)
            .fold(f64::NEG_INFINITY, f64::max),
    );
    let (y_lo, y_hi) = padded_range(
        all.iter().map(|p| p.1).fold(f64::INFINITY, f64::min),
        all.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max),
    );
    let px = |x: f64| MARGIN_LEFT + (x - x_lo) / (x_hi - x_lo) * plot_w;
    let py = |y: f64| MARGIN_TOP + plot_h - (y - y_lo) / (y_hi - y_lo) * plot_h;

    let (x_ticks, x_step) = nice_ticks(x_lo, x_hi, 6);
    let (y_ticks, y_step) = nice_ticks(y_lo, y_hi, 6);
    for x in &x_ticks {
        let _ = write!(
            svg,
            r##"<line x1="{p:.2}" y1="{top}" x2="{p:.2}" y2="{bottom}" stroke="#e4e4e4"/><text x="{p:.2}" y="{ty}" text-anchor="middle" font-size="11">{label}</text>"##,
            p = px(*x),
            top = MARGIN_TOP,
            bottom = MARGIN_TOP + plot_h,
            ty = MARGIN_TOP + plot_h + 15.0,
            label = format_tick(*x, x_step)
        );
    }
    for y in &y_ticks {
        let _ = write!(
            svg,
            r##"<line x1="{left}" y1="{p:.2}" x2="{right}" y2="{p:.2}" stroke="#e4e4e4"/><text x="{tx}" y="{ty:.2}" text-anchor="end" font-size="11">{label}</text>"##,
            p = py(*y),
            left = MARGIN_LEFT,
            right = MARGIN_LEFT + plot_w,
            tx = MARGIN_LEFT - 5.0,
            ty = py(*y) + 4.0,
            label = format_tick(*y, y_step)
        );
    }
    let _ = write!(
        svg,
        r##"<rect x="{MARGIN_LEFT}" y="{MARGIN_TOP}" width="{plot_w}" height="{plot_h}" fill="none" stroke="#333"/><text x="{xl}" y="{xly}" text-anchor="middle" font-size="12">{xlabel}</text><text transform="translate(16 {yly}) rotate(-90)" text-anchor="middle" font-size="12">{ylabel}</text>"##,
        xl = MARGIN_LEFT + plot_w / 2.0,
        xly = HEIGHT - 8.0,
        yly = MARGIN_TOP + plot_h / 2.0,
        xlabel = escape(&spec.x_label),
        ylabel = escape(&spec.y_label)
    );
    for (i, series) in spec.series.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let name = escape(&series.name);
        let mut points = series.points.clone();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let coords: Vec<String> = points
            .iter()
            .map(|&(x, y)| format!("{:.2},{:.2}", px(x), py(y)))
            .collect();
        let _ = write!(
            svg,
            r#"<g class="series" data-series="{name}"><polyline fill="none" stroke="{colour}" stroke-width="2" points="{pts}"/>"#,
            pts = coords.join(" ")
        );
        if spec.markers || points.len() == 1 {
            for &(x, y) in &points {
                let _ = write!(
                    svg,
                    r#"<circle cx="{:.2}" cy="{:.2}" r="3.5" fill="{colour}"/>"#,
                    px(x),
                    py(y)
                );
            }
        }
        if let Some((x, y)) = series.best {
            let _ = write!(
                svg,
                r#"<circle class="best" cx="{:.2}" cy="{:.2}" r="7" fill="none" stroke="{colour}" stroke-width="2"/>"#,
                px(x),
                py(y)
            );
        }
        if let Some(x) = series.stop {
            let _ = write!(
                svg,
                r#"<line class="stop" x1="{p:.2}" y1="{top}" x2="{p:.2}" y2="{bottom}" stroke="{colour}" stroke-width="1.5" stroke-dasharray="5 4"/>"#,
                p = px(x),
                top = MARGIN_TOP,
                bottom = MARGIN_TOP + plot_h,
            );
        }
        let ly = MARGIN_TOP + 14.0 + 18.0 * i as f64;
        let lx = MARGIN_LEFT + plot_w + 12.0;
        let _ = write!(
            svg,
            r#"<line x1="{lx}" y1="{l1}" x2="{lx2}" y2="{l1}" stroke="{colour}" stroke-width="3"/><text x="{tx}" y="{ty}" font-size="11">{name}</text></g>"#,
            l1 = ly - 4.0,
            lx2 = lx + 18.0,
            tx = lx + 24.0,
            ty = ly
        );
    }
    svg.push_str("</svg>");
    svg
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        let (ticks, step) = nice_ticks(0.0, 30_000.0, 6);
        // Raw step 6000 rounds up to the next 1-2-5 step, 10000.
        assert_eq!(step, 10000.0);
        assert_eq!(ticks, vec![0.0, 10000.0, 20000.0, 30000.0]);
        let (ticks, step) = nice_ticks(21.3, 27.9, 6);
        assert_eq!(step, 2.0);
        assert_eq!(ticks, vec![22.0, 24.0, 26.0]);
        assert_eq!(format_tick(0.30000000000000004, 0.1), "0.3");
        assert_eq!(format_tick(-0.0, 0.5), "0.0");
    }
}
