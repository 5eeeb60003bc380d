//! Precision, recall, F-score, accuracy and completeness agree with scipy's cKDTree.
mod common;

use common::{fixture_json, points};
use objectsplat_metrics::fscore;

#[test]
fn fscore_matches_scipy_ckdtree() {
    let fx = fixture_json("fscore.json");
    let gt = points(fx["gt"].as_str().unwrap());
    let pred = points(fx["pred"].as_str().unwrap());
    assert_eq!(gt.len(), 1500);
    for s in fx["scores"].as_array().unwrap() {
        let tau = s["tau"].as_f64().unwrap();
        let ours = fscore(&pred, &gt, tau).unwrap();
        let close = |a: f64, k: &str| {
            let b = s[k].as_f64().unwrap();
            assert!((a - b).abs() < 1e-9, "tau {tau}: {k} ours {a} scipy {b}");
        };
        close(ours.precision, "precision");
        close(ours.recall, "recall");
        close(ours.fscore, "fscore");
        close(ours.accuracy.unwrap(), "accuracy");
        close(ours.completeness.unwrap(), "completeness");
    }
}

#[test]
fn empty_prediction_scores_zero_and_empty_ground_truth_is_an_error() {
    let gt = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
    let s = fscore(&[], &gt, 0.05).unwrap();
    assert_eq!(
        (s.precision, s.recall, s.fscore, s.accuracy),
        (0.0, 0.0, 0.0, None)
    );
    assert!(fscore(&gt, &[], 0.05).is_err());
    assert!(fscore(&gt, &gt, f64::NAN).is_err());
    assert!(fscore(&[[f64::NAN, 0.0, 0.0]], &gt, 0.05).is_err());
}
