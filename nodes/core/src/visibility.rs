//! Which sparse points a camera sees: a point is hidden when another point
//! lies clearly in front of it on screen — and the Visibility artifact, every
//! frame's visible points computed once per scene for every stage that
//! assigns points to a surface (the trainer's point selection, surface
//! completion's plane fit).
//!
//! Sparse points have gaps between them, so each point is splatted into a
//! depth buffer with a radius of about the points' neighbour spacing on
//! screen; a point more than two spacings behind that buffer at its own pixel
//! is hidden. Without this test a floor point seen past a table from across
//! the room counted as the table's (the trainer's point selection), and a
//! table top's plane fit took in the floor it was seen over (surface completion).

use crate::artifact::VISIBILITY_BIN;
use crate::{Camera, Frame, Points};
use anyhow::{Context, Result, bail};
use glam::DVec3;
use std::collections::HashMap;
use std::path::Path;

/// Splat radii on screen are clamped to this many pixels.
const MAX_SPLAT_PX: f64 = 8.0;

/// The median distance from a point to its nearest neighbour (0 for fewer than two points).
pub fn neighbour_spacing(points: &[DVec3]) -> f64 {
    if points.len() < 2 {
        return 0.0;
    }
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    // Cells holding about two points each if the points covered the box's surface.
    let extent = (hi - lo).max_element().max(1e-12);
    let cell = (extent / (points.len() as f64 / 2.0).sqrt()).max(1e-12);
    let key = |p: DVec3| {
        let c = ((p - lo) / cell).floor();
        (c.x as i64, c.y as i64, c.z as i64)
    };
    let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    for (i, p) in points.iter().enumerate() {
        grid.entry(key(*p)).or_default().push(i);
    }
    let mut nearest: Vec<f64> = points
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let (cx, cy, cz) = key(*p);
            // The 3×3×3 block finds the nearest neighbour when it lies within one
            // cell; farther neighbours are rare and only overestimate the spacing.
            let mut best = f64::INFINITY;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        if let Some(cell) = grid.get(&(cx + dx, cy + dy, cz + dz)) {
                            for &j in cell.iter().filter(|&&j| j != i) {
                                best = best.min(p.distance(points[j]));
                            }
                        }
                    }
                }
            }
            best.is_finite().then_some(best)
        })
        .collect();
    if nearest.is_empty() {
        return cell;
    }
    let mid = nearest.len() / 2;
    *nearest.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Per point: its pixel (index in the full frame) and camera depth when
/// `camera` sees it (in front, inside the image, not hidden by the others).
pub fn visible_pixels(points: &[DVec3], spacing: f64, camera: &Camera) -> Vec<Option<(u32, f64)>> {
    let (w, h) = (camera.width as i64, camera.height as i64);
    let projected: Vec<Option<(f64, f64, f64)>> = points
        .iter()
        .map(|&p| {
            camera.project(p).filter(|&(x, y, z)| {
                z > 0.0 && x >= 0.0 && y >= 0.0 && x < w as f64 && y < h as f64
            })
        })
        .collect();
    let mut nearest = vec![f64::INFINITY; (w * h) as usize];
    for &(x, y, z) in projected.iter().flatten() {
        let r = (spacing * camera.fx / z).clamp(0.5, MAX_SPLAT_PX);
        let (x0, x1) = (
            ((x - r).floor() as i64).max(0),
            ((x + r).ceil() as i64).min(w - 1),
        );
        let (y0, y1) = (
            ((y - r).floor() as i64).max(0),
            ((y + r).ceil() as i64).min(h - 1),
        );
        for py in y0..=y1 {
            for px in x0..=x1 {
                let cell = &mut nearest[(py * w + px) as usize];
                *cell = cell.min(z);
            }
        }
    }
    projected
        .into_iter()
        .map(|p| {
            let (x, y, z) = p?;
            let pixel = (y as i64 * w + x as i64) as usize;
            (z <= nearest[pixel] + 2.0 * spacing).then_some((pixel as u32, z))
        })
        .collect()
}

/// One visible point of a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Seen {
    /// Index into the scene's points.
    pub point: u32,
    /// Pixel index in the frame.
    pub pixel: u32,
    /// Camera depth.
    pub depth: f32,
}

/// Per frame (by name), the scene points it sees: [`visible_pixels`] of every
/// frame against all the points, with one neighbour spacing for the scene.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Visibility {
    pub point_count: usize,
    pub spacing: f64,
    pub frames: Vec<(String, Vec<Seen>)>,
}

/// The file's first bytes (format version 1).
const MAGIC: &[u8; 8] = b"OSVIS01\0";

impl Visibility {
    /// Every frame's visible points, the frames spread over `threads` threads.
    pub fn compute(points: &Points, frames: &[Frame], threads: usize) -> Result<Visibility> {
        let world: Vec<DVec3> = points
            .positions
            .iter()
            .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .collect();
        if let Some(i) = world.iter().position(|p| !p.is_finite()) {
            bail!("point {i} {:?} is not finite", points.positions[i]);
        }
        let spacing = neighbour_spacing(&world);
        let threads = threads.clamp(1, frames.len().max(1));
        let per = frames.len().div_ceil(threads).max(1);
        let mut seen: Vec<Vec<Seen>> = vec![Vec::new(); frames.len()];
        std::thread::scope(|scope| {
            for (chunk, out) in frames.chunks(per).zip(seen.chunks_mut(per)) {
                let world = &world;
                scope.spawn(move || {
                    for (frame, slot) in chunk.iter().zip(out) {
                        *slot = visible_pixels(world, spacing, &frame.camera())
                            .into_iter()
                            .enumerate()
                            .filter_map(|(i, p)| {
                                p.map(|(pixel, depth)| Seen {
                                    point: i as u32,
                                    pixel,
                                    depth: depth as f32,
                                })
                            })
                            .collect();
                    }
                });
            }
        });
        Ok(Visibility {
            point_count: world.len(),
            spacing,
            frames: frames.iter().map(|f| f.name.clone()).zip(seen).collect(),
        })
    }

    /// The points frame `name` sees (None for a frame it does not know).
    pub fn of_frame(&self, name: &str) -> Option<&[Seen]> {
        self.frames
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, s)| s.as_slice())
    }

    /// Checks that this visibility was computed for `points` (by count).
    pub fn check_points(&self, points: &Points) -> Result<()> {
        if self.point_count != points.positions.len() {
            bail!(
                "the visibility was computed for {} points, but {} points are given (wire both \
                 from the same scene)",
                self.point_count,
                points.positions.len()
            );
        }
        Ok(())
    }

    /// Writes `visibility.bin` into `dir`: the magic, u64 point count, f64
    /// spacing, u32 frame count, then per frame a u32 name length, the name
    /// (UTF-8), a u32 count and that many (u32 point, u32 pixel, f32 depth),
    /// all little-endian.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let mut bytes = Vec::new();
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&(self.point_count as u64).to_le_bytes());
        bytes.extend_from_slice(&self.spacing.to_le_bytes());
        bytes.extend_from_slice(&(self.frames.len() as u32).to_le_bytes());
        for (name, seen) in &self.frames {
            bytes.extend_from_slice(&(name.len() as u32).to_le_bytes());
            bytes.extend_from_slice(name.as_bytes());
            bytes.extend_from_slice(&(seen.len() as u32).to_le_bytes());
            for s in seen {
                bytes.extend_from_slice(&s.point.to_le_bytes());
                bytes.extend_from_slice(&s.pixel.to_le_bytes());
                bytes.extend_from_slice(&s.depth.to_le_bytes());
            }
        }
        let path = dir.join(VISIBILITY_BIN);
        std::fs::write(&path, bytes).with_context(|| format!("{}: cannot write", path.display()))
    }

    /// Reads what [`Visibility::write`] wrote, with errors that name the file and the offset.
    pub fn read(dir: &Path) -> Result<Visibility> {
        let path = dir.join(VISIBILITY_BIN);
        let bytes =
            std::fs::read(&path).with_context(|| format!("{}: cannot read", path.display()))?;
        let mut r = Reader {
            bytes: &bytes,
            at: 0,
        };
        let parse = |r: &mut Reader| -> Result<Visibility> {
            if r.take(8)? != MAGIC {
                bail!("not a visibility file (version 1)");
            }
            let point_count = r.u64()? as usize;
            let spacing = f64::from_le_bytes(r.array()?);
            let frame_count = r.u32()? as usize;
            let mut frames = Vec::with_capacity(frame_count.min(1 << 16));
            for _ in 0..frame_count {
                let len = r.u32()? as usize;
                let name = String::from_utf8(r.take(len)?.to_vec()).context("a frame name")?;
                let count = r.u32()? as usize;
                let mut seen = Vec::with_capacity(count.min(r.remaining() / 12));
                for _ in 0..count {
                    let s = Seen {
                        point: r.u32()?,
                        pixel: r.u32()?,
                        depth: f32::from_le_bytes(r.array()?),
                    };
                    if s.point as usize >= point_count {
                        bail!("point {} of {point_count}", s.point);
                    }
                    seen.push(s);
                }
                frames.push((name, seen));
            }
            if r.remaining() != 0 {
                bail!("{} bytes after the last frame", r.remaining());
            }
            Ok(Visibility {
                point_count,
                spacing,
                frames,
            })
        };
        parse(&mut r).with_context(|| format!("{}: at byte {}", path.display(), r.at))
    }
}

/// A cursor over a byte slice that fails on truncation.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8]> {
        if self.remaining() < n {
            bail!("truncated: {n} bytes wanted, {} left", self.remaining());
        }
        self.at += n;
        Ok(&self.bytes[self.at - n..self.at])
    }
    fn array<const N: usize>(&mut self) -> Result<[u8; N]> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N)?);
        Ok(a)
    }
    fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.array()?))
    }
    fn remaining(&self) -> usize {
        self.bytes.len() - self.at
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Split;

    fn frames() -> Vec<Frame> {
        let camera = |x: f64| {
            Camera::look_at(
                32,
                24,
                30.0,
                30.0,
                DVec3::new(x, 0.0, -3.0),
                DVec3::ZERO,
                DVec3::Y,
            )
        };
        vec![
            Frame::new("a", "images/a.png", &camera(0.0), Split::Train),
            Frame::new("b", "images/b.png", &camera(0.7), Split::Test),
        ]
    }

    fn points() -> Points {
        let positions: Vec<[f32; 3]> = (0..60)
            .map(|i| {
                [
                    (i % 10) as f32 * 0.1 - 0.45,
                    (i / 10) as f32 * 0.1 - 0.25,
                    0.0,
                ]
            })
            .collect();
        Points {
            colors: vec![[0; 3]; positions.len()],
            positions,
        }
    }

    #[test]
    fn visibility_is_each_frames_visible_pixels_and_round_trips() {
        let (frames, points) = (frames(), points());
        let vis = Visibility::compute(&points, &frames, 2).unwrap();
        let world: Vec<DVec3> = points
            .positions
            .iter()
            .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .collect();
        for frame in &frames {
            let want: Vec<(u32, u32)> = visible_pixels(&world, vis.spacing, &frame.camera())
                .into_iter()
                .enumerate()
                .filter_map(|(i, p)| p.map(|(pixel, _)| (i as u32, pixel)))
                .collect();
            let got: Vec<(u32, u32)> = vis
                .of_frame(&frame.name)
                .unwrap()
                .iter()
                .map(|s| (s.point, s.pixel))
                .collect();
            assert!(!got.is_empty());
            assert_eq!(got, want);
        }
        let dir = tempfile::tempdir().unwrap();
        vis.write(dir.path()).unwrap();
        assert_eq!(Visibility::read(dir.path()).unwrap(), vis);
        // A truncated file is an error naming it and where it broke.
        let path = dir.path().join(VISIBILITY_BIN);
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 5]).unwrap();
        let err = format!("{:#}", Visibility::read(dir.path()).unwrap_err());
        assert!(
            err.contains(VISIBILITY_BIN) && err.contains("truncated"),
            "{err}"
        );
        assert!(vis.check_points(&Points::default()).is_err());
    }
}
