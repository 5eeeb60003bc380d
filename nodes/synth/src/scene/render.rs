//! Renders the room: z-buffer visibility from our rasterizer, exact surface points by
//! intersecting each sample's ray with its face, textures and lighting at those points,
//! box-filtered down from `supersample²` samples per pixel.

use super::SyntheticParams;
use super::layout::Room;
use anyhow::{Result, anyhow};
use glam::DVec3;
use objectsplat_core::{Camera, Image};
use objectsplat_masks::raster::{RasterOptions, pixel_ray, rasterize, ray_triangle_plane};

pub struct Views {
    pub images: Vec<Render8>,
    /// The supersampled camera and depth of every view (for visibility tests).
    pub depth: Vec<(Camera, Depth)>,
}

/// A rendered view as its 8-bit PNG holds it (3 bytes a pixel: hundreds of
/// 1752×1168 views fit in memory).
#[derive(Debug, Clone, PartialEq)]
pub struct Render8 {
    pub width: u32,
    pub height: u32,
    /// RGB, row-major.
    pub rgb: Vec<u8>,
}

impl Render8 {
    /// The image quantized as its 8-bit PNG would be.
    fn of(image: &Image) -> Self {
        Render8 {
            width: image.width,
            height: image.height,
            rgb: image.to_rgb8(),
        }
    }
}

/// The inverse depth of a view's nearest surface per (supersampled) pixel:
/// a raster without its face ids, which only the render itself needs.
#[derive(Debug, Clone, PartialEq)]
pub struct Depth {
    pub width: u32,
    pub height: u32,
    inv_depth: Vec<f32>,
}

impl Depth {
    /// Camera depth of the visible surface at a pixel, if any.
    #[inline]
    pub fn depth_at(&self, x: u32, y: u32) -> Option<f32> {
        let iz = self.inv_depth[(y * self.width + x) as usize];
        (iz > 0.0).then(|| 1.0 / iz)
    }
}

pub fn render_views(
    room: &Room,
    cameras: &[Camera],
    params: &SyntheticParams,
    texture_seed: u64,
) -> Result<Views> {
    let threads = params.threads.max(1);
    let chunk = cameras.len().div_ceil(threads).max(1);
    let results: Vec<Result<Vec<(Render8, Camera, Depth)>>> = crossbeam::scope(|s| {
        let handles: Vec<_> = cameras
            .chunks(chunk)
            .map(|part| {
                s.spawn(move |_| {
                    part.iter()
                        .map(|camera| render_view(room, camera, params.supersample, texture_seed))
                        .collect()
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err(anyhow!("a render thread panicked")))
            })
            .collect()
    })
    .map_err(|_| anyhow!("a render thread panicked"))?;
    let mut views = Views {
        images: Vec::new(),
        depth: Vec::new(),
    };
    for part in results {
        for (image, camera, raster) in part? {
            views.images.push(image);
            views.depth.push((camera, raster));
        }
    }
    Ok(views)
}

fn render_view(
    room: &Room,
    camera: &Camera,
    supersample: u32,
    texture_seed: u64,
) -> Result<(Render8, Camera, Depth)> {
    let fine = camera.scaled(camera.width * supersample, camera.height * supersample);
    let b = &room.builder;
    let options = RasterOptions {
        near: 0.01,
        threads: 1,
    };
    let raster = rasterize(&b.positions, &b.faces, &fine, &options)
        .map_err(|e| anyhow!("rendering a view: {e}"))?;
    let vertex = |i: u32| {
        let p = b.positions[i as usize];
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    };
    let mut image = Image::new(fine.width, fine.height, 3);
    for y in 0..fine.height {
        for x in 0..fine.width {
            let Some(face) = raster.face_at(x, y) else {
                continue;
            };
            let [a, bb, c] = b.faces[face as usize].map(vertex);
            let (origin, dir) = pixel_ray(&fine, x as f64 + 0.5, y as f64 + 0.5);
            // The ray hit this face's interior in screen space, so it is not parallel to
            // its plane; if rounding says otherwise, fall back to the centroid.
            let p = ray_triangle_plane(origin, dir, a, bb, c)
                .map(|(p, _)| p)
                .unwrap_or((a + bb + c) / 3.0);
            let color = room.surface_color(face as usize, p, texture_seed);
            for (ch, v) in color.iter().enumerate() {
                image.set(x, y, ch as u32, *v as f32);
            }
        }
    }
    let image = if supersample > 1 {
        image.resize_area(camera.width, camera.height)
    } else {
        image
    };
    let depth = Depth {
        width: raster.width,
        height: raster.height,
        inv_depth: raster.inv_depth,
    };
    Ok((Render8::of(&image), fine, depth))
}
