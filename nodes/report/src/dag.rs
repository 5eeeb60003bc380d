//! A layered drawing of the run's graph: each node sits one column right of its deepest
//! input (longest-path layering), nodes within a column are ordered by the mean row of
//! their inputs (one barycentre pass, which removes most crossings in pipeline-shaped
//! graphs), and boxes are coloured by run status.

use crate::data::{GraphEdge, NodeRun, NodeStatus};
use anyhow::{Result, bail};
use objectsplat_export::escape::escape;
use std::collections::HashMap;
use std::fmt::Write;

/// Column and row of every node, indexed like the input `nodes`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    pub layer: Vec<usize>,
    pub row: Vec<usize>,
}

/// Lays out the DAG; fails on an edge naming an unknown node, a self-loop or a cycle.
pub fn layered_layout(nodes: &[NodeRun], edges: &[GraphEdge]) -> Result<Layout> {
    let mut index = HashMap::new();
    for (i, n) in nodes.iter().enumerate() {
        if index.insert(n.id.as_str(), i).is_some() {
            bail!("run report: node id {:?} appears twice", n.id);
        }
    }
    let mut preds: Vec<Vec<usize>> = vec![Vec::new(); nodes.len()];
    let mut succs: Vec<Vec<usize>> = vec![Vec::new(); nodes.len()];
    for e in edges {
        let (Some(&a), Some(&b)) = (index.get(e.from.as_str()), index.get(e.to.as_str())) else {
            bail!(
                "graph edge {} → {} names a node that is not in the run report",
                e.from,
                e.to
            );
        };
        if a == b {
            bail!("graph edge {} → {} is a self-loop", e.from, e.to);
        }
        preds[b].push(a);
        succs[a].push(b);
    }

    // Kahn's algorithm gives a topological order (and detects cycles).
    let mut indegree: Vec<usize> = preds.iter().map(Vec::len).collect();
    let mut ready: Vec<usize> = (0..nodes.len()).filter(|&i| indegree[i] == 0).collect();
    ready.reverse();
    let mut order = Vec::with_capacity(nodes.len());
    while let Some(n) = ready.pop() {
        order.push(n);
        for &s in &succs[n] {
            indegree[s] -= 1;
            if indegree[s] == 0 {
                ready.push(s);
            }
        }
    }
    if order.len() != nodes.len() {
        let stuck: Vec<&str> = (0..nodes.len())
            .filter(|&i| indegree[i] > 0)
            .map(|i| nodes[i].id.as_str())
            .collect();
        bail!("graph has a cycle through {}", stuck.join(", "));
    }

    let mut layer = vec![0usize; nodes.len()];
    for &n in &order {
        layer[n] = preds[n].iter().map(|&p| layer[p] + 1).max().unwrap_or(0);
    }
    let depth = layer.iter().copied().max().map_or(0, |m| m + 1);
    let mut row = vec![0usize; nodes.len()];
    for l in 0..depth {
        let mut members: Vec<usize> = (0..nodes.len()).filter(|&i| layer[i] == l).collect();
        // Earlier layers are final, so their rows are the barycentre keys; ties keep input order.
        let key = |i: usize| -> f64 {
            if preds[i].is_empty() {
                i as f64 * 1e-6
            } else {
                preds[i].iter().map(|&p| row[p] as f64).sum::<f64>() / preds[i].len() as f64
            }
        };
        members.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
        for (r, &m) in members.iter().enumerate() {
            row[m] = r;
        }
    }
    Ok(Layout { layer, row })
}

pub fn status_colour(status: NodeStatus) -> &'static str {
    match status {
        NodeStatus::Ran => "#7bc96f",
        NodeStatus::Cached => "#8ab6e8",
        NodeStatus::Skipped => "#d0d0d0",
        NodeStatus::Failed => "#e8756f",
    }
}

const BOX_W: f64 = 150.0;
const BOX_H: f64 = 50.0;
const COL_GAP: f64 = 60.0;
const ROW_GAP: f64 = 18.0;
const PAD: f64 = 12.0;

/// The graph as an SVG: boxes (id, kind, status, seconds) joined by arrows.
pub fn dag_svg(nodes: &[NodeRun], edges: &[GraphEdge]) -> Result<String> {
    let layout = layered_layout(nodes, edges)?;
    let columns = layout.layer.iter().copied().max().map_or(0, |m| m + 1);
    let rows = layout.row.iter().copied().max().map_or(0, |m| m + 1);
    let width = PAD * 2.0 + columns as f64 * BOX_W + columns.saturating_sub(1) as f64 * COL_GAP;
    let height = PAD * 2.0 + rows as f64 * BOX_H + rows.saturating_sub(1) as f64 * ROW_GAP;
    let x_of = |i: usize| PAD + layout.layer[i] as f64 * (BOX_W + COL_GAP);
    let y_of = |i: usize| PAD + layout.row[i] as f64 * (BOX_H + ROW_GAP);
    let index: HashMap<&str, usize> = nodes
        .iter()
        .enumerate()
        .map(|(i, n)| (n.id.as_str(), i))
        .collect();

    let mut svg = String::new();
    // Writing to a String cannot fail, so the fmt::Results below are ignored.
    let _ = write!(
        svg,
        r##"<svg class="dag" viewBox="0 0 {width} {height}" width="{width}" height="{height}" role="img" aria-label="run graph"><defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="7" markerHeight="7" orient="auto"><path d="M0,0 L10,5 L0,10 z" fill="#555"/></marker></defs>"##
    );
    for e in edges {
        // layered_layout has checked every edge endpoint exists.
        let (a, b) = (index[e.from.as_str()], index[e.to.as_str()]);
        let (x1, y1) = (x_of(a) + BOX_W, y_of(a) + BOX_H / 2.0);
        let (x2, y2) = (x_of(b), y_of(b) + BOX_H / 2.0);
        let mid = (x1 + x2) / 2.0;
        let _ = write!(
            svg,
            r##"<path class="edge" data-from="{f}" data-to="{t}" d="M{x1},{y1} C{mid},{y1} {mid},{y2} {x2},{y2}" fill="none" stroke="#555" stroke-width="1.5" marker-end="url(#arrow)"/>"##,
            f = escape(&e.from),
            t = escape(&e.to)
        );
    }
    for (i, n) in nodes.iter().enumerate() {
        let (x, y) = (x_of(i), y_of(i));
        let tooltip = match &n.reason {
            Some(r) => format!("{} ({}) {}: {r}", n.id, n.kind, n.status.as_str()),
            None => format!("{} ({}) {}", n.id, n.kind, n.status.as_str()),
        };
        let _ = write!(
            svg,
            r##"<g class="node" data-id="{id}" data-status="{status}" data-layer="{layer}"><title>{tip}</title><rect x="{x}" y="{y}" width="{BOX_W}" height="{BOX_H}" rx="6" fill="{fill}" stroke="#333"/><text x="{tx}" y="{ty1}" text-anchor="middle" font-size="12" font-weight="bold">{id}</text><text x="{tx}" y="{ty2}" text-anchor="middle" font-size="10">{kind} · {status} · {secs:.2} s</text></g>"##,
            id = escape(&n.id),
            status = n.status.as_str(),
            layer = layout.layer[i],
            tip = escape(&tooltip),
            fill = status_colour(n.status),
            tx = x + BOX_W / 2.0,
            ty1 = y + 21.0,
            ty2 = y + 38.0,
            kind = escape(&n.kind),
            secs = n.seconds
        );
    }
    svg.push_str("</svg>");
    Ok(svg)
}
