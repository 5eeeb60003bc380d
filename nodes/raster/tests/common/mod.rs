//! Scenes and helpers shared by the integration tests.
#![allow(dead_code)]

use objectsplat_core::Camera;
use objectsplat_core::glam::{DMat4, DVec3};
use objectsplat_raster::{Model, RenderSettings, SH_COEFFS};

/// SplitMix64: a tiny deterministic generator for test data.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A 64-bit linear congruential generator (Knuth's MMIX constants), the loss
/// tests' source of images.
pub struct Lcg(pub u64);

impl Lcg {
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A camera at the world origin looking down +z (world = camera frame), with
/// a principal point off the pixel grid so no symmetry lines up with pixel centres.
pub fn identity_camera(width: u32, height: u32, focal: f64) -> Camera {
    Camera::from_view(
        width,
        height,
        focal,
        focal,
        width as f64 / 2.0 + 0.31,
        height as f64 / 2.0 - 0.27,
        DMat4::IDENTITY,
    )
}

/// A general camera: looking at the origin from `eye`.
pub fn orbit_camera(width: u32, height: u32, focal: f64, eye: DVec3) -> Camera {
    Camera::look_at(
        width,
        height,
        focal,
        focal,
        eye,
        DVec3::new(0.05, -0.02, 0.03),
        DVec3::new(0.1, 1.0, 0.2).normalize(),
    )
}

/// Appends a triangle with its own three vertices, random SH and the given opacity logits.
pub fn push_triangle(
    model: &mut Model<f64>,
    rng: &mut Rng,
    corners: [[f64; 3]; 3],
    logits: [f64; 3],
) -> [u32; 3] {
    let base = model.vertices.len() as u32;
    for (k, c) in corners.iter().enumerate() {
        model.vertices.push(*c);
        model.sh.push(random_sh(rng));
        model.opacity_logits.push(logits[k]);
    }
    let face = [base, base + 1, base + 2];
    model.faces.push(face);
    face
}

/// SH rows with a DC giving a mid-grey-ish colour and small higher bands, so
/// colours stay away from the clamp at 0.
pub fn random_sh(rng: &mut Rng) -> [[f64; 3]; SH_COEFFS] {
    let mut rows = [[0.0; 3]; SH_COEFFS];
    for ch in 0..3 {
        rows[0][ch] = rng.uniform(-0.8, 0.8);
        for row in rows.iter_mut().skip(1) {
            row[ch] = rng.uniform(-0.12, 0.12);
        }
    }
    rows
}

/// Background image with random colours in [0, 1].
pub fn random_background(rng: &mut Rng, camera: &Camera) -> Vec<f64> {
    (0..camera.width as usize * camera.height as usize * 3)
        .map(|_| rng.uniform(0.0, 1.0))
        .collect()
}

/// The gradient-check scene: 40×36 px (3×3 tiles) seen by [`identity_camera`] with focal 36.
/// Faces: 0 large (crosses tile borders), 1 overlapping 0 at a close depth,
/// 2 sharing an edge with 1, 3 tiny (inradius ≈ 1.5 px), 4 nearly edge-on,
/// 5 saturated opacity (α clamp active near its incenter), 6 overlapping 5
/// and 0 with shared vertices.
pub fn gradient_scene(seed: u64) -> (Model<f64>, Camera) {
    let mut rng = Rng(seed);
    let mut m = Model::<f64>::empty();
    m.sh_degree = 3;
    push_triangle(
        &mut m,
        &mut rng,
        [[-0.9, -0.8, 2.6], [0.8, -0.5, 2.4], [-0.2, 0.9, 2.5]],
        [0.3, -0.2, 0.6],
    );
    let f1 = push_triangle(
        &mut m,
        &mut rng,
        [[-0.6, -0.3, 2.52], [0.7, 0.25, 2.49], [0.1, -0.95, 2.55]],
        [1.1, 0.7, 0.2],
    );
    // Face 2 shares the edge (f1[1], f1[2]).
    m.vertices.push([1.15, -0.7, 2.62]);
    m.sh.push(random_sh(&mut rng));
    m.opacity_logits.push(-0.4);
    m.faces.push([f1[2], f1[1], m.vertices.len() as u32 - 1]);
    // Face 3: tiny, side ≈ 5.2 px at z = 2.
    push_triangle(
        &mut m,
        &mut rng,
        [[-1.0, 0.55, 2.0], [-0.71, 0.56, 2.0], [-0.86, 0.80, 2.01]],
        [0.9, 1.3, 0.5],
    );
    // Face 4: its plane almost contains the view ray through its centroid.
    let c = DVec3::new(0.75, 0.62, 2.2);
    let d = c.normalize();
    let w = d.cross(DVec3::Z).normalize();
    let n = d.cross(w);
    let tilt = 0.2;
    let a = c - 0.9 * d + 0.25 * w;
    let b = c + 0.9 * d + 0.35 * w + tilt * n;
    let e = c - 0.3 * w - tilt * n;
    push_triangle(
        &mut m,
        &mut rng,
        [a.to_array(), b.to_array(), e.to_array()],
        [0.8, 1.5, 1.2],
    );
    // Face 5: saturated opacity (sigmoid(9.3) > 0.999).
    push_triangle(
        &mut m,
        &mut rng,
        [[0.2, 0.35, 1.9], [0.9, 0.5, 1.95], [0.45, 1.0, 1.92]],
        [9.5, 9.3, 9.8],
    );
    // Face 6: overlaps 5 and 0, shares vertex 0 of face 5 and vertex 2 of face 0.
    m.vertices.push([-0.3, 0.2, 2.05]);
    m.sh.push(random_sh(&mut rng));
    m.opacity_logits.push(0.05);
    m.faces.push([13, 2, m.vertices.len() as u32 - 1]);
    (m, identity_camera(40, 36, 36.0))
}

/// |cos| between the face normal and the view ray to its centroid, and its
/// projected inradius in px: computed here from the definitions, to check the
/// scene really contains the intended cases.
pub fn face_diagnostics(model: &Model<f64>, camera: &Camera, f: usize) -> (f64, f64) {
    let p = model.faces[f].map(|i| DVec3::from_array(model.vertices[i as usize]));
    let cam = p.map(|x| camera.to_camera(x));
    let centroid = (cam[0] + cam[1] + cam[2]) / 3.0;
    let n = (cam[1] - cam[0]).cross(cam[2] - cam[0]);
    let cos = n.dot(centroid).abs() / (n.length() * centroid.length());
    let s = p.map(|x| {
        let (u, v, _) = camera.project(x).expect("in front");
        DVec3::new(u, v, 0.0)
    });
    let area = (s[1] - s[0]).cross(s[2] - s[0]).length() / 2.0;
    let perimeter = (s[1] - s[0]).length() + (s[2] - s[1]).length() + (s[0] - s[2]).length();
    (cos, 2.0 * area / perimeter)
}

/// Settings for the gradient checks.
pub fn settings(sigma: f64, sh_degree: u32) -> RenderSettings {
    RenderSettings {
        sigma,
        sh_degree,
        ..Default::default()
    }
}

/// A triangle's corners: a centre uniform in the box ±`extent`, then each corner
/// uniform in the cube of half-side r around it, r uniform in `radius`.
pub fn random_corners(rng: &mut Rng, extent: [f64; 3], radius: (f64, f64)) -> [[f64; 3]; 3] {
    let centre = extent.map(|e| rng.uniform(-e, e));
    let r = rng.uniform(radius.0, radius.1);
    [0, 1, 2].map(|_| centre.map(|x| x + rng.uniform(-r, r)))
}

/// A random soup of `count` triangles around the origin in f32, seen by an orbit camera.
pub fn random_soup_f32(
    seed: u64,
    count: usize,
    width: u32,
    height: u32,
) -> (Model<f32>, Camera, Vec<f32>) {
    let mut rng = Rng(seed);
    let camera = orbit_camera(
        width,
        height,
        width as f64 * 0.9,
        DVec3::new(0.3, 0.2, -3.0),
    );
    let mut model = Model::<f64>::empty();
    model.sh_degree = 3;
    for _ in 0..count {
        let corners = random_corners(&mut rng, [1.2, 1.0, 1.0], (0.08, 0.3));
        let logits = [0, 1, 2].map(|_| rng.uniform(-2.0, 4.0));
        push_triangle(&mut model, &mut rng, corners, logits);
    }
    let bg: Vec<f32> = random_background(&mut rng, &camera)
        .into_iter()
        .map(|v| v as f32)
        .collect();
    (model.cast::<f32>(), camera, bg)
}
