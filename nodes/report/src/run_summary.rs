//! The report's "Run" section: the graph with each node's status and time, a node table, and
//! how long each trained item took (the times its run measured; they are no part of the Model).
//!
//! A `report` node runs inside the run it reports on, so it cannot know how the run ends;
//! it writes a placeholder between [`RUN_SUMMARY_BEGIN`] and [`RUN_SUMMARY_END`]. After the
//! run the CLI writes the run summary beside the outputs as data ([`write_run_files`]:
//! `OUT/run.json`, and `OUT/run.js` for pages opened from disk, which may load a script but
//! not read a JSON file), and the page's loader puts it in place when the page is opened.
//! Nothing rewrites the page: the materialized copy is the cached artifact, byte for byte.
//! `objectsplat report --run RUN.json --html PAGE` fills a page in place instead
//! ([`write_with_run_summary`]), for pages moved away from their run.

use crate::dag::{dag_svg, status_colour};
use crate::data::{NodeStatus, RunSummary};
use crate::plot::{PlotSpec, Series, line_plot_svg};
use anyhow::{Context, Result, bail};
use objectsplat_core::{TRAINING_TIMES, TrainingTimes};
use objectsplat_export::escape::escape;
use std::fmt::Write;
use std::io::Write as _;
use std::path::Path;

/// Opens the run section (an HTML comment, invisible in the page).
pub const RUN_SUMMARY_BEGIN: &str = "<!-- objectsplat:run-summary -->";
/// Closes the run section.
pub const RUN_SUMMARY_END: &str = "<!-- /objectsplat:run-summary -->";

/// The run report as data, written beside a run's outputs.
pub const RUN_DATA_FILE: &str = "run.json";
/// The same run as a script that sets `window.objectsplatRun`, for pages opened from disk.
pub const RUN_SCRIPT_FILE: &str = "run.js";

fn placeholder() -> String {
    format!(
        "{RUN_SUMMARY_BEGIN}<section id=\"run\"><h2>Run</h2><p class=\"placeholder\">The run summary (each node's status and time) comes from <code>{RUN_SCRIPT_FILE}</code> beside the outputs of <code>objectsplat run</code>, or is filled in by <code>objectsplat report --run RUN.json --html index.html</code>.</p></section>{RUN_SUMMARY_END}"
    )
}

/// The page's loader: a materialized page lies at `OUT/<node>/<port>/index.html`, so the
/// run's script is two folders up. The placeholder is replaced only while it is one (a page
/// filled in by `objectsplat report` keeps its run).
pub fn run_loader() -> String {
    format!(
        "<script src=\"../../{RUN_SCRIPT_FILE}\"></script><script>(function(){{var r=window.objectsplatRun,s=document.getElementById(\"run\");if(r&&s&&s.querySelector(\".placeholder\")){{s.outerHTML=r.section;}}}})();</script>"
    )
}

/// Writes `OUT/run.json` (`report`, the JSON `objectsplat run --json` writes) and
/// `OUT/run.js` (`run`'s rendered section, for the page's loader).
pub fn write_run_files(out: &Path, report: &serde_json::Value, run: &RunSummary) -> Result<()> {
    let section = run_section(run)?;
    let data = serde_json::to_string_pretty(report).context("serialising the run report")?;
    let script = format!(
        "window.objectsplatRun = {{\"section\": {}}};\n",
        serde_json::to_string(&section).context("serialising the run section")?
    );
    for (name, text) in [(RUN_DATA_FILE, data), (RUN_SCRIPT_FILE, script)] {
        let path = out.join(name);
        std::fs::write(&path, text).with_context(|| format!("{}: cannot write", path.display()))?;
    }
    Ok(())
}

/// The run section between its markers; the placeholder when `run` has no nodes.
pub fn run_section(run: &RunSummary) -> Result<String> {
    let nodes = &run.nodes;
    if nodes.is_empty() {
        return Ok(placeholder());
    }
    for n in nodes {
        if !(n.seconds.is_finite() && n.seconds >= 0.0) {
            bail!(
                "run report: node {} has invalid seconds {}",
                n.id,
                n.seconds
            );
        }
    }
    // Cached nodes carry the time of the run that produced their outputs: reused work,
    // not this run's.
    // Folded from +0.0: an empty f64 `sum()` is −0.0, which prints as "-0.00 s".
    let seconds = |cached: bool| {
        nodes
            .iter()
            .filter(|n| (n.status == NodeStatus::Cached) == cached)
            .fold(0.0, |sum, n| sum + n.seconds)
    };
    let (total, reused) = (seconds(false), seconds(true));
    let count = |s: NodeStatus| nodes.iter().filter(|n| n.status == s).count();
    let mut html = String::new();
    // Writing to a String cannot fail, so the fmt::Results below are ignored.
    let _ = write!(
        html,
        "{RUN_SUMMARY_BEGIN}<section id=\"run\"><h2>Run</h2><p>{} nodes: {} ran, {} cached, {} skipped, {} failed; {total:.2} s of node time",
        nodes.len(),
        count(NodeStatus::Ran),
        count(NodeStatus::Cached),
        count(NodeStatus::Skipped),
        count(NodeStatus::Failed)
    );
    if reused > 0.0 {
        let _ = write!(
            html,
            ", {reused:.2} s of cached work reused (as timed when it ran)"
        );
    }
    if let Some(wall) = run.seconds.filter(|s| s.is_finite() && *s >= 0.0) {
        let _ = write!(html, ", {wall:.2} s wall time");
    }
    if let Some(graph) = &run.graph {
        let _ = write!(html, " (graph {})", escape(graph));
    }
    html.push_str(".</p>");
    html.push_str(&dag_svg(nodes, &run.edges)?);
    html.push_str("<table id=\"nodes\"><tr><th>id</th><th>kind</th><th>status</th><th>seconds (own run)</th><th>queued</th><th>reason</th><th>items</th></tr>");
    for n in nodes {
        let items: Vec<String> = n
            .items
            .iter()
            .map(|i| format!("{} ({}, {:.2} s)", i.name, i.status.as_str(), i.seconds))
            .collect();
        let _ = write!(
            html,
            r#"<tr data-node="{id}" data-status="{st}"><td>{id}</td><td>{kind}</td><td><span class="status" style="background:{bg}">{st}</span></td><td class="num">{secs:.2}{cached}</td><td class="num">{queued:.2}</td><td>{reason}</td><td>{items}</td></tr>"#,
            id = escape(&n.id),
            kind = escape(&n.kind),
            bg = status_colour(n.status),
            st = n.status.as_str(),
            secs = n.seconds,
            cached = if n.status == NodeStatus::Cached {
                " (cached; when produced)"
            } else {
                ""
            },
            queued = n.queued_seconds,
            reason = escape(n.reason.as_deref().unwrap_or("")),
            items = escape(&items.join(", "))
        );
    }
    html.push_str("</table>");
    html.push_str(&training_times(run)?);
    html.push_str("</section>");
    html.push_str(RUN_SUMMARY_END);
    Ok(html)
}

/// How long each trained item took, from the [`TrainingTimes`] it measured (a Model holds no
/// clock reading): iterations against seconds, one line per item, and a table; nothing when no
/// item of the run measured any.
fn training_times(run: &RunSummary) -> Result<String> {
    let mut timed = Vec::new();
    for n in &run.nodes {
        for item in &n.items {
            if let Some(value) = item.measurements.get(TRAINING_TIMES) {
                let times = TrainingTimes::from_json(value)
                    .with_context(|| format!("run report: node {} item {}", n.id, item.name))?;
                timed.push((format!("{}[{}]", n.id, item.name), item.status, times));
            }
        }
    }
    if timed.is_empty() {
        return Ok(String::new());
    }
    let series = timed
        .iter()
        .map(|(label, _, t)| {
            // Seconds count from the start of training, at iteration 0.
            let points = [(0.0, 0.0)]
                .into_iter()
                .chain(t.steps.iter().map(|&(i, s)| (s, i as f64)))
                .chain([(t.seconds, t.iterations as f64)])
                .collect();
            Series::new(label, points)
        })
        .collect();
    let mut html = String::from("<h3>Training time</h3>");
    html.push_str(&line_plot_svg(&PlotSpec {
        title: "Training iterations against wall time".into(),
        x_label: "wall time (s)".into(),
        y_label: "iterations".into(),
        series,
        markers: false,
    }));
    html.push_str("<table id=\"training-times\"><tr><th>item</th><th>status</th><th>iterations</th><th>training s</th><th>it/s</th></tr>");
    for (label, status, t) in &timed {
        let rate = t
            .iterations_per_second()
            .map_or("–".to_string(), |r| format!("{r:.2}"));
        let _ = write!(
            html,
            r#"<tr data-item="{l}"><td>{l}</td><td>{st}{cached}</td><td class="num">{it}</td><td class="num">{secs:.2}</td><td class="num">{rate}</td></tr>"#,
            l = escape(label),
            st = status.as_str(),
            cached = if *status == NodeStatus::Cached {
                " (when produced)"
            } else {
                ""
            },
            it = t.iterations,
            secs = t.seconds,
        );
    }
    html.push_str("</table>");
    Ok(html)
}

/// Replaces the page's run section (placeholder or an earlier summary) with `run`'s.
pub fn inject_run_summary(html: &str, run: &RunSummary) -> Result<String> {
    let Some(begin) = html.find(RUN_SUMMARY_BEGIN) else {
        bail!(
            "the page has no run-summary marker {RUN_SUMMARY_BEGIN} (not written by the `report` node?)"
        );
    };
    let Some(end) = html[begin..].find(RUN_SUMMARY_END) else {
        bail!("the page's run-summary section is not closed by {RUN_SUMMARY_END}");
    };
    let end = begin + end + RUN_SUMMARY_END.len();
    let section = run_section(run)?;
    let mut out = String::with_capacity(html.len() + section.len());
    out.push_str(&html[..begin]);
    out.push_str(&section);
    out.push_str(&html[end..]);
    Ok(out)
}

/// Reads a run report written by `objectsplat run --json` (its nodes and, when recorded, the
/// graph's edges).
pub fn read_run_summary(path: &Path) -> Result<RunSummary> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the run report", path.display()))?;
    serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: not a run report written by `objectsplat run --json`",
            path.display()
        )
    })
}

/// Writes `report` with `run`'s summary filled in to `out` (which may be `report` itself).
///
/// `out` is replaced by renaming a new file over it, never written through: a materialized
/// page may be a hard link to the cache's blob, which must keep the placeholder.
pub fn write_with_run_summary(report: &Path, run: &RunSummary, out: &Path) -> Result<()> {
    let html = std::fs::read_to_string(report)
        .with_context(|| format!("{}: cannot read the report", report.display()))?;
    let filled = inject_run_summary(&html, run).with_context(|| format!("{}", report.display()))?;
    let folder = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut temp = tempfile::NamedTempFile::new_in(folder)
        .with_context(|| format!("{}: cannot create a temporary file", folder.display()))?;
    // A temporary file is private (0600); the page is an ordinary output everyone may read.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        temp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))
            .with_context(|| format!("{}: cannot set permissions", temp.path().display()))?;
    }
    temp.write_all(filled.as_bytes())
        .and_then(|()| temp.as_file().sync_all())
        .with_context(|| format!("{}: cannot write", temp.path().display()))?;
    temp.persist(out)
        .map_err(|e| e.error)
        .with_context(|| format!("{}: cannot replace", out.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::run_section;
    use crate::data::{NodeRun, NodeStatus, RunSummary};

    #[test]
    fn a_fully_cached_run_has_zero_seconds_of_node_time_not_minus_zero() {
        let run = RunSummary {
            nodes: vec![NodeRun {
                id: "scene".into(),
                kind: "synthetic_scene".into(),
                status: NodeStatus::Cached,
                seconds: 1.5,
                queued_seconds: 0.0,
                reason: None,
                items: vec![],
            }],
            edges: vec![],
            graph: None,
            seconds: Some(0.02),
        };
        let html = run_section(&run).unwrap();
        assert!(
            html.contains("1 nodes: 0 ran, 1 cached, 0 skipped, 0 failed; 0.00 s of node time")
        );
        assert!(!html.contains("-0.00"));
    }
}
