//! The model folder encoding: model.ply + model.json round-trip exactly, the
//! PLY has the documented layout, and broken folders give errors naming the file.

mod common;

use common::*;
use objectsplat_core::Ply;
use objectsplat_core::artifact::{MODEL_JSON, MODEL_PLY};
use objectsplat_raster::model_io::dc_to_u8;
use objectsplat_raster::{load_model, save_model};

fn sample_model() -> objectsplat_raster::Model<f32> {
    let (mut m, _) = gradient_scene(5);
    m.sh_degree = 2;
    m.opacity_floor = 0.35;
    m.sigma = 0.125;
    m.metadata
        .insert("component".into(), serde_json::json!("chair-3"));
    m.cast::<f32>()
}

#[test]
fn model_round_trips_through_its_folder() {
    let dir = tempfile::tempdir().unwrap();
    let model = sample_model();
    save_model(&model, dir.path()).unwrap();
    let back = load_model(dir.path()).unwrap();
    assert_eq!(back, model);
}

/// Flat colours (a trained model's bake) travel as `flat_dc_*` and are what the
/// 8-bit display colours show; a model without them writes no such property.
#[test]
fn flat_colours_round_trip_and_are_the_display_colours() {
    let dir = tempfile::tempdir().unwrap();
    let mut model = sample_model();
    assert!(
        !objectsplat_raster::model_io::model_to_ply(&model)
            .element("vertex")
            .unwrap()
            .has("flat_dc_0")
    );
    model.flat_dc = (0..model.vertex_count())
        .map(|v| [0.1 * v as f32 - 0.4, -0.2, 0.7])
        .collect();
    save_model(&model, dir.path()).unwrap();
    let back = load_model(dir.path()).unwrap();
    assert_eq!(back, model);
    let ply = Ply::read(&dir.path().join(MODEL_PLY)).unwrap();
    let vertex = ply.element("vertex").unwrap();
    let (red, blue) = (
        vertex.scalar_u8("red").unwrap(),
        vertex.scalar_u8("blue").unwrap(),
    );
    for v in 0..model.vertex_count() {
        assert_eq!(red[v], dc_to_u8(model.flat_dc[v][0]));
        assert_eq!(blue[v], dc_to_u8(0.7));
    }
    // A flat colour per vertex or none: a short list is refused.
    model.flat_dc.pop();
    assert!(save_model(&model, dir.path()).is_err());
}

#[test]
fn ply_has_the_documented_layout() {
    let dir = tempfile::tempdir().unwrap();
    let model = sample_model();
    save_model(&model, dir.path()).unwrap();
    let bytes = std::fs::read(dir.path().join(MODEL_PLY)).unwrap();
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap();
    let header = String::from_utf8_lossy(&bytes[..header_end]);
    let mut want = vec![
        "ply".to_string(),
        "format binary_little_endian 1.0".into(),
        format!("element vertex {}", model.vertex_count()),
    ];
    for p in ["x", "y", "z"] {
        want.push(format!("property float {p}"));
    }
    for p in ["red", "green", "blue"] {
        want.push(format!("property uchar {p}"));
    }
    for i in 0..3 {
        want.push(format!("property float f_dc_{i}"));
    }
    for i in 0..45 {
        want.push(format!("property float f_rest_{i}"));
    }
    want.push("property float opacity".into());
    want.push(format!("element face {}", model.face_count()));
    want.push("property list uchar int vertex_indices".into());
    let lines: Vec<&str> = header
        .lines()
        .filter(|l| !l.starts_with("comment"))
        .collect();
    assert_eq!(lines, want);

    let ply = Ply::read(&dir.path().join(MODEL_PLY)).unwrap();
    let v = ply.element("vertex").unwrap();
    let red = v.scalar_u8("red").unwrap();
    for (i, r) in red.iter().enumerate() {
        let want = ((0.5 + 0.28209479177387814 * model.sh[i][0][0] as f64).clamp(0.0, 1.0) * 255.0)
            .round() as u8;
        assert_eq!(*r, want);
    }
    // f_rest is channel-major: f_rest_{c·15 + k − 1} = sh[k][c].
    let rest_17 = v.scalar_f32("f_rest_17").unwrap();
    assert_eq!(rest_17[3], model.sh[3][3][1]);
    assert_eq!(dc_to_u8(100.0), 255);
    assert_eq!(dc_to_u8(-100.0), 0);
}

#[test]
fn broken_model_folders_are_rejected_with_the_file_named() {
    let dir = tempfile::tempdir().unwrap();
    let err = format!("{:#}", load_model(dir.path()).unwrap_err());
    assert!(err.contains(MODEL_JSON), "{err}");
    save_model(&sample_model(), dir.path()).unwrap();
    std::fs::write(
        dir.path().join(MODEL_JSON),
        "{\"sh_degree\": 7, \"opacity_floor\": 0, \"sigma\": 1}",
    )
    .unwrap();
    let err = format!("{:#}", load_model(dir.path()).unwrap_err());
    assert!(err.contains("sh_degree"), "{err}");
    save_model(&sample_model(), dir.path()).unwrap();
    let ply = dir.path().join(MODEL_PLY);
    let bytes = std::fs::read(&ply).unwrap();
    std::fs::write(&ply, &bytes[..bytes.len() - 10]).unwrap();
    let err = format!("{:#}", load_model(dir.path()).unwrap_err());
    assert!(err.contains(MODEL_PLY), "{err}");
}
