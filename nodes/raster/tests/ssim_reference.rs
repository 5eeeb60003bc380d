//! SSIM (plain and weighted mean of the map) matches an independent scipy
//! computation (fixture made by tests/fixtures/make_fixtures.py).

use objectsplat_raster::loss::{Dims, ssim};

#[derive(serde::Deserialize)]
struct Fixture {
    width: usize,
    height: usize,
    x: Vec<f64>,
    y: Vec<f64>,
    weights: Vec<f64>,
    ssim_mean: f64,
    ssim_weighted: f64,
}

impl Fixture {
    fn dims(&self) -> Dims {
        Dims {
            width: self.width,
            height: self.height,
            channels: 3,
        }
    }
}

fn fixture() -> Fixture {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/ssim_reference.json"
    );
    serde_json::from_str(&std::fs::read_to_string(path).expect("fixture present"))
        .expect("fixture parses")
}

#[test]
fn ssim_matches_scipy_reference() {
    let f = fixture();
    let dims = f.dims();
    let plain = ssim(dims, &f.x, &f.y, None).unwrap().value;
    assert!(
        (plain - f.ssim_mean).abs() < 1e-12,
        "{plain} vs {}",
        f.ssim_mean
    );
    let weighted = ssim(dims, &f.x, &f.y, Some(&f.weights)).unwrap().value;
    assert!(
        (weighted - f.ssim_weighted).abs() < 1e-12,
        "{weighted} vs {}",
        f.ssim_weighted
    );
    // f32 path agrees to single precision.
    let x32: Vec<f32> = f.x.iter().map(|&v| v as f32).collect();
    let y32: Vec<f32> = f.y.iter().map(|&v| v as f32).collect();
    let v32 = ssim(dims, &x32, &y32, None).unwrap().value;
    assert!((v32 as f64 - f.ssim_mean).abs() < 1e-5);
}

#[test]
fn ssim_of_an_image_with_itself_is_one() {
    let f = fixture();
    let dims = f.dims();
    let s = ssim(dims, &f.x, &f.x, None).unwrap();
    assert!((s.value - 1.0).abs() < 1e-12);
    assert!(
        s.grad.iter().all(|g| g.abs() < 1e-9),
        "SSIM is maximal, so its gradient vanishes"
    );
}
