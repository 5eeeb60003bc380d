//! Depth supervision at measured points: which points a view keeps (own pixels,
//! or the other components' for the free-space rule; nearest surface), and that the loss's gradient, carried through the renderer,
//! matches finite differences and pulls a surface onto the points.

use glam::DVec3;
use objectsplat_core::component::{OTHER, OWN};
use objectsplat_core::{Camera, ComponentKind, Split};
use objectsplat_raster::{CpuBackend, Model, OutputGrads, RenderBackend, RenderSettings};
use objectsplat_train::point_depth::PointDepth;
use objectsplat_train::trainer::{ComponentData, View};

const W: u32 = 32;
const H: u32 = 24;

/// A camera at the origin looking down +z (world = camera coordinates).
fn camera() -> Camera {
    Camera::look_at(
        W,
        H,
        30.0,
        30.0,
        DVec3::ZERO,
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(0.0, -1.0, 0.0),
    )
}

/// One view whose pixels are all the component's own, except column `other_column`.
fn data(points: Vec<[f32; 3]>, other_column: Option<u32>) -> ComponentData {
    let labels = (0..W * H)
        .map(|p| match other_column {
            Some(c) if p % W == c => OTHER,
            _ => OWN,
        })
        .collect::<Vec<u8>>();
    let target = vec![0.5; (W * H * 3) as usize];
    ComponentData {
        name: "background".into(),
        kind: ComponentKind::Background,
        views: vec![View::from_planes("v", camera(), &target, &labels, Split::Train).unwrap()],
        occluders: None,
        depth_points: points,
        other_points: Vec::new(),
    }
}

/// The pixel column a world point projects to.
fn column(p: [f32; 3]) -> u32 {
    let (x, _, _) = camera()
        .project(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .unwrap();
    x as u32
}

#[test]
fn a_view_keeps_the_nearest_points_on_its_own_pixels() {
    // A grid of points on the plane z = 2 (spacing 0.1), one point hidden behind
    // it at z = 4, and the grid's column through x = 0.3 belongs to another component.
    let mut points: Vec<[f32; 3]> = Vec::new();
    for i in -5..=5 {
        for j in -3..=3 {
            points.push([0.1 * i as f32, 0.1 * j as f32, 2.0]);
        }
    }
    let plane = points.len();
    points.push([0.05, 0.05, 4.0]);
    let other = column([0.3, 0.0, 2.0]);
    let on_other = points[..plane]
        .iter()
        .filter(|p| column(**p) == other)
        .count();
    assert!(on_other > 0);
    let depth = PointDepth::new(&points, &data(points.clone(), Some(other)));
    // Every plane point lands on its own pixel (they are 1.5 px apart), the one
    // behind the plane is hidden, the other component's column is dropped.
    assert_eq!(depth.count(0), plane - on_other);
    let all_own = PointDepth::new(&points, &data(points.clone(), None));
    assert_eq!(all_own.count(0), plane);
    // The free-space rule's other side: only the other component's column, the
    // point hidden behind the plane still dropped.
    let others = PointDepth::on_other_components(&points, &data(points.clone(), Some(other)));
    assert_eq!(others.count(0), on_other);
    assert!(
        others
            .of_view(0)
            .iter()
            .all(|&(pixel, d)| pixel % W == other && d == 2.0)
    );
}

/// One opaque triangle in the plane z = `z`, filling the view, its edges far
/// from the points (its window is near 1 there).
fn plane(z: f32) -> Model<f32> {
    let mut model = Model::empty();
    model.vertices = vec![[-8.0, -6.0, z], [8.0, -6.0, z], [0.0, 10.0, z]];
    model.faces = vec![[0, 1, 2]];
    model.sh = vec![[[0.0; 3]; objectsplat_raster::SH_COEFFS]; 3];
    model.opacity_logits = vec![8.0; 3];
    model.sigma = 0.05;
    model
}

/// The depth loss of `model` and its gradient with respect to every vertex's z.
fn loss_and_z_gradient(model: &Model<f32>, depth: &PointDepth) -> (f64, Vec<f64>) {
    let backend = CpuBackend::new(1);
    let settings = RenderSettings::for_model(model);
    let background = vec![0.0; (W * H * 3) as usize];
    let (out, saved) = backend
        .forward(model, &camera(), &settings, &background)
        .unwrap();
    let pixels = out.region.pixels();
    let (mut d_depth, mut d_alpha) = (vec![0.0; pixels], vec![0.0; pixels]);
    let loss = depth.add_gradient(0, &out, 1.0, &mut d_depth, &mut d_alpha);
    let color = vec![0.0; pixels * 3];
    let grads = backend
        .backward(
            model,
            &saved,
            &OutputGrads {
                color: &color,
                alpha: Some(&d_alpha),
                depth: Some(&d_depth),
                median_depth: None,
            },
        )
        .unwrap();
    (loss, grads.vertices.iter().map(|g| g[2] as f64).collect())
}

#[test]
fn the_gradient_matches_finite_differences_and_pulls_the_surface_onto_the_points() {
    // Points measured on z = 2.5; the surface stands at z = 3.
    let points: Vec<[f32; 3]> = (-3..=3)
        .flat_map(|i| (-2..=2).map(move |j| [0.1 * i as f32, 0.1 * j as f32, 2.5]))
        .collect();
    let depth = PointDepth::new(&points, &data(points.clone(), None));
    assert_eq!(depth.count(0), points.len());
    let model = plane(3.0);
    let (loss, grad) = loss_and_z_gradient(&model, &depth);
    // Every point sees the surface 0.5 behind it: |D/α − d| / d = 0.5 / 2.5.
    assert!((loss - 0.2).abs() < 1e-4, "loss {loss}");
    // Moving the whole plane by h changes the loss by h · Σ dL/dz.
    let h = 1e-2;
    let moved = |dz: f32| {
        let mut m = model.clone();
        m.vertices.iter_mut().for_each(|v| v[2] += dz);
        loss_and_z_gradient(&m, &depth).0
    };
    let numeric = (moved(h) - moved(-h)) / (2.0 * h as f64);
    let analytic: f64 = grad.iter().sum();
    assert!(
        (numeric - analytic).abs() < 0.02 * numeric.abs(),
        "finite differences {numeric} vs gradient {analytic}"
    );
    // The surface is too far: every vertex is pulled toward the camera.
    assert!(grad.iter().all(|&g| g > 0.0), "{grad:?}");
    // Transparency does not pay: the loss does not depend on the coverage.
    let mut faded = model.clone();
    faded.opacity_logits.iter_mut().for_each(|o| *o = 0.5);
    let (faded_loss, _) = loss_and_z_gradient(&faded, &depth);
    assert!((faded_loss - loss).abs() < 1e-4, "{faded_loss} vs {loss}");
    // Descending the loss brings it onto the points.
    let mut m = model.clone();
    for _ in 0..200 {
        let (_, g) = loss_and_z_gradient(&m, &depth);
        for (v, g) in m.vertices.iter_mut().zip(&g) {
            v[2] -= 0.05 * g.signum() as f32 * 0.1;
        }
    }
    let (after, _) = loss_and_z_gradient(&m, &depth);
    assert!(after < 0.01, "loss after descent {after}");
}
