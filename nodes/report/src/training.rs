//! The training section: one curve per component model from its `training.json` — loss,
//! held-out PSNR and triangle count against iteration — with each component's best held-out
//! evaluation ringed and its early stop drawn as a dashed line, and a table of the runs.
//! Everything here is drawn against iterations: a Model holds no clock reading, so how long
//! training took is in the run record and drawn in the Run section ([`crate::run_summary`]).

use crate::data::ModelTraining;
use crate::plot::{PlotSpec, Series, line_plot_svg};
use objectsplat_core::TrainingLog;
use objectsplat_export::escape::escape;
use std::fmt::Write;

/// Keeps finite points; says how many were left out so nothing disappears silently.
pub(crate) fn finite_points(
    name: &str,
    what: &str,
    points: impl Iterator<Item = (f64, f64)>,
    notes: &mut Vec<String>,
) -> Vec<(f64, f64)> {
    let (kept, dropped): (Vec<_>, Vec<_>) =
        points.partition(|(x, y)| x.is_finite() && y.is_finite());
    if !dropped.is_empty() {
        notes.push(format!(
            "{name}: {} non-finite {what} point(s) not plotted",
            dropped.len()
        ));
    }
    kept
}

/// The best held-out evaluation, as (iteration, PSNR).
fn best_eval(log: &TrainingLog) -> Option<(f64, f64)> {
    log.evals
        .iter()
        .find(|e| e.iteration == log.best_iteration)
        .map(|e| (e.iteration as f64, e.psnr))
        .filter(|(_, p)| p.is_finite())
}

struct Plots {
    loss: Vec<Series>,
    psnr_by_iteration: Vec<Series>,
    faces: Vec<Series>,
    notes: Vec<String>,
}

fn build_series(logs: &[&TrainingLog]) -> Plots {
    let mut p = Plots {
        loss: Vec::new(),
        psnr_by_iteration: Vec::new(),
        faces: Vec::new(),
        notes: Vec::new(),
    };
    for log in logs {
        let name = log.component.as_str();
        let notes = &mut p.notes;
        // A finished model's run stopped the schedule where its finish began.
        let stop_iteration = log
            .stopped_early
            .then_some(log.finished_from.unwrap_or(log.iterations_run) as f64);
        let best = best_eval(log);
        if best.is_none() {
            notes.push(format!(
                "{name}: the best checkpoint (iteration {}) has no finite held-out evaluation to mark",
                log.best_iteration
            ));
        }

        let mut loss = Series::new(
            name,
            finite_points(
                name,
                "loss",
                log.steps.iter().map(|s| (s.iteration as f64, s.loss)),
                notes,
            ),
        );
        loss.stop = stop_iteration;
        p.loss.push(loss);

        let mut by_iteration = Series::new(
            name,
            finite_points(
                name,
                "PSNR",
                log.evals.iter().map(|e| (e.iteration as f64, e.psnr)),
                notes,
            ),
        );
        by_iteration.best = best;
        by_iteration.stop = stop_iteration;
        p.psnr_by_iteration.push(by_iteration);

        let mut faces = Series::new(
            name,
            log.steps
                .iter()
                .map(|s| (s.iteration as f64, s.faces as f64))
                .collect(),
        );
        faces.stop = stop_iteration;
        p.faces.push(faces);
    }
    p
}

fn table(training: &[ModelTraining], html: &mut String) {
    html.push_str("<table id=\"training-table\"><tr><th>component</th><th>budget</th><th>iterations run</th><th>best iteration</th><th>model returned</th><th>scored on</th><th>stopped early</th><th>final PSNR (dB)</th><th>faces</th></tr>");
    for entry in training {
        match &entry.log {
            Some(log) => {
                let _ = write!(
                    html,
                    r#"<tr data-component="{c}"><td>{c}</td><td class="num">{budget}</td><td class="num">{run}</td><td class="num">{best}</td><td>{returned}</td><td>{scored}</td><td>{early}</td><td class="num">{psnr:.2}</td><td class="num">{faces}</td></tr>"#,
                    c = escape(&log.component),
                    budget = log.iterations_budget,
                    run = log.iterations_run,
                    best = log.best_iteration,
                    returned = match (log.checkpoint.as_str(), log.finished_from) {
                        // Logs written before the `checkpoint` field always returned the best one.
                        ("", None) => "best".to_string(),
                        (c, Some(from)) => format!(
                            "{}, finished over {from}–{}",
                            if c.is_empty() { "best" } else { c },
                            log.iterations_run
                        ),
                        (c, None) => c.to_string(),
                    },
                    // Which views chose the checkpoint (or, with `last`, only reported).
                    scored = escape(log.scored_on.as_deref().unwrap_or("–")),
                    early = match (log.stopped_early, log.finished_from) {
                        (true, Some(at)) => format!("yes, at {at}"),
                        (true, None) => "yes".to_string(),
                        (false, _) => "no".to_string(),
                    },
                    psnr = log.final_psnr,
                    faces = log.final_faces,
                );
            }
            None => {
                let _ = write!(
                    html,
                    r#"<tr data-component="{m}"><td>{m}</td><td colspan="8">no training log</td></tr>"#,
                    m = escape(&entry.model)
                );
            }
        }
    }
    html.push_str("</table>");
}

/// The training section (curves and the table).
pub fn section_training(training: &[ModelTraining], html: &mut String) {
    html.push_str("<section id=\"training\"><h2>Training</h2>");
    if training.is_empty() {
        html.push_str("<p>No trained models were given to the report.</p></section>");
        return;
    }
    let logs: Vec<&TrainingLog> = training.iter().filter_map(|t| t.log.as_ref()).collect();
    if !logs.is_empty() {
        let plots = build_series(&logs);
        html.push_str("<p>Rings mark each component's best held-out evaluation (the model returned, unless the table says <em>last</em>); dashed lines mark where a component stopped early.</p><div class=\"plots\">");
        for spec in [
            PlotSpec {
                title: "Training loss".into(),
                x_label: "iteration".into(),
                y_label: "loss".into(),
                series: plots.loss,
                markers: false,
            },
            PlotSpec {
                title: "Held-out PSNR".into(),
                x_label: "iteration".into(),
                y_label: "PSNR (dB)".into(),
                series: plots.psnr_by_iteration,
                markers: true,
            },
            PlotSpec {
                title: "Triangles".into(),
                x_label: "iteration".into(),
                y_label: "faces".into(),
                series: plots.faces,
                markers: false,
            },
        ] {
            html.push_str(&line_plot_svg(&spec));
        }
        html.push_str("</div>");
        for note in plots.notes {
            let _ = write!(html, "<p class=\"note\">{}</p>", escape(&note));
        }
    }
    table(training, html);
    html.push_str("</section>");
}
