//! A reused `CpuWorkspace` gives the same bits as a fresh one. The forward pass
//! leaves per-tile fragment records for the backward pass and keeps them
//! allocated between passes, so a pass over a smaller region, a different model
//! or a second backward over one forward must not see a previous pass's records.

mod common;

use common::*;
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::cpu::{Background, CpuWorkspace};
use objectsplat_raster::{CpuBackend, ModelGrads, OutputGrads, RenderSettings};

fn bits(g: &ModelGrads<f32>) -> Vec<u32> {
    let mut v: Vec<u32> = g.vertices.iter().flatten().map(|x| x.to_bits()).collect();
    v.extend(g.sh.iter().flatten().flatten().map(|x| x.to_bits()));
    v.extend(g.opacity_logits.iter().map(|x| x.to_bits()));
    v.extend(g.background.iter().map(|x| x.to_bits()));
    v
}

/// Forward + backward with fixed upstream gradients on every output: the image's and the gradients' bits.
fn pass(
    ws: &mut CpuWorkspace<f32>,
    model: &objectsplat_raster::Model<f32>,
    camera: &objectsplat_core::Camera,
    settings: &RenderSettings,
) -> (Vec<u32>, Vec<u32>) {
    let backend = CpuBackend::new(2);
    backend
        .forward_into(
            ws,
            model,
            camera,
            settings,
            Background::Uniform([0.2, 0.5, 0.7]),
        )
        .unwrap();
    let image: Vec<u32> = ws.output.color.iter().map(|x| x.to_bits()).collect();
    let color: Vec<f32> = (0..ws.output.color.len())
        .map(|i| ((i * 7919) % 13) as f32 / 13.0 - 0.5)
        .collect();
    let alpha: Vec<f32> = (0..ws.output.alpha.len())
        .map(|i| ((i * 31) % 5) as f32 / 5.0 - 0.4)
        .collect();
    let depth: Vec<f32> = (0..ws.output.depth.len())
        .map(|i| ((i * 17) % 7) as f32 / 7.0 - 0.5)
        .collect();
    let median: Vec<f32> = (0..ws.output.median_depth.len())
        .map(|i| ((i * 13) % 3) as f32 - 1.0)
        .collect();
    let grads = OutputGrads {
        color: &color,
        alpha: Some(&alpha),
        depth: Some(&depth),
        median_depth: Some(&median),
    };
    backend.backward_into(ws, model, &grads).unwrap();
    let first = bits(&ws.grads);
    // A second backward over the same forward sees the same records.
    backend.backward_into(ws, model, &grads).unwrap();
    assert_eq!(first, bits(&ws.grads), "a second backward pass differed");
    (image, first)
}

#[test]
fn a_reused_workspace_matches_a_fresh_one() {
    let (big, camera, _) = random_soup_f32(11, 300, 96, 80);
    let (small, _, _) = random_soup_f32(12, 40, 96, 80);
    let full = settings(0.5, 3);
    let crop = RenderSettings {
        region: Region::Footprint {
            include: PixelRect {
                x0: 40,
                y0: 30,
                x1: 48,
                y1: 38,
            },
            margin: 4,
        },
        ..full.clone()
    };
    let mut reused = CpuWorkspace::<f32>::default();
    // Big model over the whole frame first, so every tile record is full of fragments.
    pass(&mut reused, &big, &camera, &full);
    for (model, settings) in [(&small, &crop), (&big, &crop), (&small, &full)] {
        let again = pass(&mut reused, model, &camera, settings);
        let fresh = pass(&mut CpuWorkspace::default(), model, &camera, settings);
        assert!(
            again == fresh,
            "a reused workspace differed from a fresh one"
        );
    }
}
