//! Reading the report's inline SVG back: the `<svg>` blocks of a page and the polylines of
//! a plot's series.

/// Every `<svg>…</svg>` block of the page, in page order.
pub fn svg_blocks(html: &str) -> Vec<&str> {
    let mut blocks = Vec::new();
    let mut rest = html;
    while let Some(start) = rest.find("<svg") {
        let end =
            rest[start..].find("</svg>").expect("every <svg> is closed") + start + "</svg>".len();
        blocks.push(&rest[start..end]);
        rest = &rest[end..];
    }
    blocks
}

/// The part of the page inside `<section id="ID">…</section>` (sections do not nest).
pub fn section<'a>(html: &'a str, id: &str) -> &'a str {
    let open = format!("<section id=\"{id}\">");
    let start = html
        .find(&open)
        .unwrap_or_else(|| panic!("no section {id}"));
    let end = start + html[start..].find("</section>").expect("section closed");
    &html[start..end]
}

fn number(node: roxmltree::Node, attribute: &str) -> f64 {
    node.attribute(attribute)
        .unwrap_or_else(|| panic!("missing {attribute}"))
        .parse()
        .unwrap()
}

/// Each series of a plot: its name and polyline points (pixels).
pub fn polylines(doc: &roxmltree::Document) -> Vec<(String, Vec<(f64, f64)>)> {
    series_groups(doc)
        .map(|g| {
            let line = g.children().find(|c| c.has_tag_name("polyline")).unwrap();
            let points = line
                .attribute("points")
                .unwrap()
                .split_whitespace()
                .map(|p| {
                    let (x, y) = p.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect();
            (g.attribute("data-series").unwrap().to_string(), points)
        })
        .collect()
}

fn series_groups<'a>(
    doc: &'a roxmltree::Document<'a>,
) -> impl Iterator<Item = roxmltree::Node<'a, 'a>> {
    doc.descendants()
        .filter(|n| n.attribute("class") == Some("series"))
}

/// The best-checkpoint ring of the named series (pixel centre), if drawn.
pub fn best_ring(doc: &roxmltree::Document, series: &str) -> Option<(f64, f64)> {
    let g = series_groups(doc).find(|g| g.attribute("data-series") == Some(series))?;
    g.children()
        .find(|c| c.attribute("class") == Some("best"))
        .map(|c| (number(c, "cx"), number(c, "cy")))
}

/// The early-stop line of the named series (pixel x), if drawn.
pub fn stop_line(doc: &roxmltree::Document, series: &str) -> Option<f64> {
    let g = series_groups(doc).find(|g| g.attribute("data-series") == Some(series))?;
    g.children()
        .find(|c| c.attribute("class") == Some("stop"))
        .map(|c| {
            assert_eq!(
                number(c, "x1"),
                number(c, "x2"),
                "the stop line is vertical"
            );
            number(c, "x1")
        })
}
