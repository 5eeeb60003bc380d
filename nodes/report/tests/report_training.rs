//! Training curves from the models' `training.json` (hand-written fixtures in
//! tests/fixtures/models): every plotted vertex, best-checkpoint ring and early-stop line sits
//! where the logged numbers put it on the plot's axes, and the table lists every model. How
//! long training took is no part of a model: the Run section draws it from the times each
//! item's run measured.

mod common;

use common::svg::{best_ring, polylines, section, stop_line, svg_blocks};
use common::synthetic_report::{fixture_models, fixture_training};
use objectsplat_core::artifact::{MODEL_JSON, TRAINING_JSON};
use objectsplat_report::*;

// Pixel coordinates are written with 2 decimals (±0.005 each); the maps are fitted on the
// extreme points, so an interpolated position is off by at most about three roundings.
const EPS: f64 = 0.016;

/// An axis's data → pixel map, fitted on two points: p = a·v + b.
#[derive(Clone, Copy, Debug)]
struct Axis {
    a: f64,
    b: f64,
}

impl Axis {
    fn through(v0: f64, p0: f64, v1: f64, p1: f64) -> Axis {
        let a = (p1 - p0) / (v1 - v0);
        Axis { a, b: p0 - a * v0 }
    }
    fn at(self, v: f64) -> f64 {
        self.a * v + self.b
    }
}

/// A logged (value x, value y) and where it was drawn (pixel x, pixel y).
type Placed = ((f64, f64), (f64, f64));

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= EPS
}

/// Checks that every series' pixels are one affine image of its data (one map per axis,
/// shared by all series) and returns the two maps.
fn check_affine(
    plotted: &[(String, Vec<(f64, f64)>)],
    data: &[(&str, Vec<(f64, f64)>)],
) -> (Axis, Axis) {
    assert_eq!(plotted.len(), data.len());
    let pairs: Vec<Placed> = plotted
        .iter()
        .zip(data)
        .flat_map(|((name, pixels), (want_name, values))| {
            assert_eq!(name, want_name);
            assert_eq!(
                pixels.len(),
                values.len(),
                "{name}: one vertex per logged value"
            );
            values.iter().copied().zip(pixels.iter().copied())
        })
        .collect();
    let extreme = |key: fn(&Placed) -> f64| {
        let lo = pairs
            .iter()
            .min_by(|a, b| key(a).total_cmp(&key(b)))
            .unwrap();
        let hi = pairs
            .iter()
            .max_by(|a, b| key(a).total_cmp(&key(b)))
            .unwrap();
        (*lo, *hi)
    };
    let (lo, hi) = extreme(|p| p.0.0);
    let x = Axis::through(lo.0.0, lo.1.0, hi.0.0, hi.1.0);
    let (lo, hi) = extreme(|p| p.0.1);
    let y = Axis::through(lo.0.1, lo.1.1, hi.0.1, hi.1.1);
    assert!(x.a > 0.0, "x grows to the right");
    assert!(y.a < 0.0, "y grows up the page");
    for ((vx, vy), (px, py)) in &pairs {
        assert!(
            close(x.at(*vx), *px),
            "x {vx} drawn at {px}, map gives {}",
            x.at(*vx)
        );
        assert!(
            close(y.at(*vy), *py),
            "y {vy} drawn at {py}, map gives {}",
            y.at(*vy)
        );
    }
    (x, y)
}

/// Parses `plot` and checks its chair and background series against the logged values
/// (see [`check_affine`]); returns the document and the two maps.
fn parse_and_check_affine(
    plot: &str,
    chair: Vec<(f64, f64)>,
    background: Vec<(f64, f64)>,
) -> (roxmltree::Document<'_>, Axis, Axis) {
    parse_and_check_series(plot, [("obj_3_chair", chair), ("background", background)])
}

/// [`parse_and_check_affine`] for two series of any names.
fn parse_and_check_series<'a>(
    plot: &'a str,
    series: [(&str, Vec<(f64, f64)>); 2],
) -> (roxmltree::Document<'a>, Axis, Axis) {
    let doc = roxmltree::Document::parse(plot).unwrap();
    let (x, y) = check_affine(&polylines(&doc), &series);
    (doc, x, y)
}

/// Asserts `name`'s best-checkpoint ring is drawn where the maps put the logged `(x, y)`.
fn assert_best_ring_at(
    doc: &roxmltree::Document,
    name: &str,
    (x, y): (Axis, Axis),
    at: (f64, f64),
) {
    let (cx, cy) = best_ring(doc, name).unwrap();
    assert!(close(cx, x.at(at.0)) && close(cy, y.at(at.1)), "{cx},{cy}");
}

fn training_plots() -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    let data = ReportData {
        title: "training".into(),
        training: fixture_training(),
        ..Default::default()
    };
    let html = std::fs::read_to_string(render_report(dir.path(), &data).unwrap()).unwrap();
    svg_blocks(section(&html, "training"))
        .into_iter()
        .map(str::to_string)
        .collect()
}

#[test]
fn loss_and_triangle_curves_follow_the_steps() {
    let plots = training_plots();
    assert_eq!(
        plots.len(),
        3,
        "loss, held-out PSNR and triangles, against iterations"
    );
    let (loss, x, _) = parse_and_check_affine(
        &plots[0],
        vec![(100.0, 0.5), (200.0, 0.25), (300.0, 0.125), (400.0, 0.1)],
        vec![(200.0, 0.4), (400.0, 0.3), (600.0, 0.2)],
    );
    // The chair stopped early after 400 iterations; the background ran its budget.
    assert!(close(stop_line(&loss, "obj_3_chair").unwrap(), x.at(400.0)));
    assert_eq!(stop_line(&loss, "background"), None);

    let (faces, _, _) = parse_and_check_affine(
        &plots[2],
        vec![
            (100.0, 1000.0),
            (200.0, 1200.0),
            (300.0, 1100.0),
            (400.0, 900.0),
        ],
        vec![(200.0, 5000.0), (400.0, 6000.0), (600.0, 6500.0)],
    );
    assert!(stop_line(&faces, "obj_3_chair").is_some());
}

#[test]
fn held_out_psnr_marks_the_best_checkpoint_and_the_early_stop() {
    let plots = training_plots();
    let (by_iteration, x, y) = parse_and_check_affine(
        &plots[1],
        vec![(100.0, 18.0), (200.0, 21.0), (300.0, 24.0), (400.0, 23.5)],
        vec![(300.0, 15.0), (600.0, 17.0)],
    );
    // Best checkpoints: the chair's at 300 (24 dB, not the last eval), the background's at 600.
    assert_best_ring_at(&by_iteration, "obj_3_chair", (x, y), (300.0, 24.0));
    assert_best_ring_at(&by_iteration, "background", (x, y), (600.0, 17.0));
    assert!(close(
        stop_line(&by_iteration, "obj_3_chair").unwrap(),
        x.at(400.0)
    ));
    assert_eq!(stop_line(&by_iteration, "background"), None);
}

#[test]
fn the_run_section_draws_iterations_against_the_measured_training_times() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::synthetic_report::report_data(dir.path()).run;
    let html = run_section(&run).unwrap();
    let plots = svg_blocks(&html);
    assert_eq!(plots.len(), 2, "the graph, then the training times");
    // From iteration 0 at 0 s through each logged step to the end of the run
    // (common::synthetic_report::CHAIR_TIMES and BACKGROUND_TIMES).
    parse_and_check_series(
        plots[1],
        [
            (
                "train[obj_3_chair]",
                vec![
                    (0.0, 0.0),
                    (1.0, 100.0),
                    (2.0, 200.0),
                    (3.0, 300.0),
                    (4.0, 400.0),
                    (4.75, 400.0),
                ],
            ),
            (
                "train[background]",
                vec![
                    (0.0, 0.0),
                    (2.0, 200.0),
                    (4.0, 400.0),
                    (6.0, 600.0),
                    (7.0, 600.0),
                ],
            ),
        ],
    );
    // 400 / 4.75 and 600 / 7 iterations per second; the cached item's from the run that
    // trained it.
    assert!(html.contains(
        r#"<tr data-item="train[obj_3_chair]"><td>train[obj_3_chair]</td><td>ran</td><td class="num">400</td><td class="num">4.75</td><td class="num">84.21</td></tr>"#
    ));
    assert!(html.contains(
        r#"<tr data-item="train[background]"><td>train[background]</td><td>cached (when produced)</td><td class="num">600</td><td class="num">7.00</td><td class="num">85.71</td></tr>"#
    ));
    // The node's page holds no time of its own.
    let page = std::fs::read_to_string(
        render_report(
            &dir.path().join("page"),
            &ReportData {
                title: "training".into(),
                training: common::synthetic_report::fixture_training(),
                ..Default::default()
            },
        )
        .unwrap(),
    )
    .unwrap();
    assert!(!page.contains("wall time") && !page.contains("training-times"));
}

#[test]
fn a_broken_training_time_names_the_item() {
    let dir = tempfile::tempdir().unwrap();
    let mut run = common::synthetic_report::report_data(dir.path()).run;
    let train = run.nodes.iter_mut().find(|n| n.id == "train").unwrap();
    train.items[1].measurements.insert(
        "training_times".into(),
        serde_json::json!({"seconds": "soon"}),
    );
    let msg = format!("{:#}", run_section(&run).unwrap_err());
    common::assert_mentions(&msg, &["node train item background", "training_times"]);
}

#[test]
fn non_finite_psnr_is_left_out_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let mut training = fixture_training();
    // A perfect held-out render has infinite PSNR; it cannot be placed on an axis.
    training[1].log.as_mut().unwrap().evals[0].psnr = f64::INFINITY;
    let data = ReportData {
        title: "training".into(),
        training,
        ..Default::default()
    };
    let html = std::fs::read_to_string(render_report(dir.path(), &data).unwrap()).unwrap();
    assert!(html.contains("background: 1 non-finite PSNR point(s) not plotted"));
    let plots = svg_blocks(section(&html, "training"));
    for plot in &plots[1..2] {
        let doc = roxmltree::Document::parse(plot).unwrap();
        let background = polylines(&doc).into_iter().find(|s| s.0 == "background");
        assert_eq!(background.unwrap().1.len(), 1);
    }
}

/// The fixture models plus `obj_5_lamp`, a model folder without a training log.
fn models_collection(root: &std::path::Path) -> std::path::PathBuf {
    let models = root.join("models");
    for name in ["obj_3_chair", "background"] {
        std::fs::create_dir_all(models.join(name)).unwrap();
        std::fs::copy(
            fixture_models().join(name).join(TRAINING_JSON),
            models.join(name).join(TRAINING_JSON),
        )
        .unwrap();
    }
    std::fs::create_dir_all(models.join("obj_5_lamp")).unwrap();
    std::fs::write(models.join("obj_5_lamp").join(MODEL_JSON), "{}").unwrap();
    models
}

#[test]
fn report_node_tabulates_every_model_and_says_which_have_no_log() {
    let dir = tempfile::tempdir().unwrap();
    let models = models_collection(dir.path());
    let (run, html) = common::run_report(&[("models", &models)], "()", &dir.path().join("out"));
    let table = section(&html, "training");
    assert!(table.contains(
        r#"<tr data-component="obj_3_chair"><td>obj_3_chair</td><td class="num">600</td><td class="num">400</td><td class="num">300</td><td>best</td><td>–</td><td>yes</td><td class="num">23.75</td><td class="num">850</td></tr>"#
    ));
    assert!(table.contains(
        r#"<tr data-component="background"><td>background</td><td class="num">600</td><td class="num">600</td><td class="num">600</td><td>last</td><td>–</td><td>no</td><td class="num">17.00</td><td class="num">6400</td></tr>"#
    ));
    assert!(table.contains(
        r#"<tr data-component="obj_5_lamp"><td>obj_5_lamp</td><td colspan="8">no training log</td></tr>"#
    ));
    assert_eq!(svg_blocks(table).len(), 3);
    assert!(
        run.notes
            .contains(&("training logs".to_string(), "2 of 3".to_string()))
    );
    assert!(
        html.contains("This run did not evaluate"),
        "metrics are optional"
    );
}

#[test]
fn a_broken_training_log_names_the_model_and_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let models = models_collection(dir.path());
    std::fs::write(
        models.join("background").join(TRAINING_JSON),
        "{\"component\": 3}",
    )
    .unwrap();
    let msg = common::report_error(
        &[("models", &models)],
        &dir.path().join("out"),
        "a broken log is an error, not a silently missing curve",
    );
    common::assert_mentions(&msg, &["models item \"background\"", TRAINING_JSON]);
}
