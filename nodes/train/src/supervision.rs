//! What a component is trained on: its views, and what every pixel is
//! supervised toward.
//!
//! Objects keep their OWN pixels and pull every other pixel toward the
//! background colour `b` (weight 1 for OTHER pixels, 0 for IGNORE and unowned
//! ones, whose target is `b` too, so an object's targets differ from `b` only on
//! its own pixels); the background component keeps its OWN pixels and gives
//! every other pixel zero weight — unless it is trained behind the frozen,
//! already trained objects (`occluders`): then every valid pixel is
//! supervised by the composite, so nothing of the background may hang in
//! front of an object.

use crate::neighbours::NeighbourLayer;
use anyhow::{Context, Result, bail};
use objectsplat_core::component::{IGNORE, OTHER, OWN};
use objectsplat_core::visibility::{Visibility, neighbour_spacing, visible_pixels};
use objectsplat_core::{
    Camera, ComponentFolder, ComponentKind, LabelRuns, Points, RgbWindow, Split,
};
use objectsplat_raster::backend::PixelRect;
use std::path::Path;

/// One supervised view of a component, held compactly: the mask as runs per
/// row, the target colours (8-bit when the frame is) only over the window
/// where they can matter — an object's own pixels (elsewhere its target is
/// the background colour), a background's whole frame.
pub struct View {
    pub name: String,
    pub camera: Camera,
    /// Target colours (the frame image, or the component's replacement
    /// targets on its own pixels) over their window.
    pub target: RgbWindow,
    /// Per-pixel ownership label (OWN / OTHER / IGNORE).
    pub labels: LabelRuns,
    /// Own pixels whose targets surface completion inpainted (1; others 0):
    /// pixels of the objects resting on a completed surface, adopted by it.
    pub completed: Option<LabelRuns>,
    pub split: Split,
}

impl View {
    /// A view from whole-frame planes (RGB targets, labels): tests and tools.
    pub fn from_planes(
        name: &str,
        camera: Camera,
        target: &[f32],
        labels: &[u8],
        split: Split,
    ) -> Result<View> {
        let (w, h) = (camera.width, camera.height);
        if target.len() != 3 * labels.len() {
            bail!(
                "view {name:?}: {} target values for {} labels",
                target.len(),
                labels.len()
            );
        }
        Ok(View {
            name: name.to_string(),
            camera,
            target: RgbWindow::from_rgb_f32(w, target, [0, 0, w, h]),
            labels: LabelRuns::from_plane(w, h, labels)?,
            completed: None,
            split,
        })
    }

    /// The label of pixel `p` (row-major index in the frame).
    pub fn label(&self, p: usize) -> u8 {
        self.labels.at(p)
    }

    /// The target colour of pixel `(x, y)`; the window holds every pixel
    /// whose target is not the background colour.
    pub fn target_at(&self, x: u32, y: u32) -> [f32; 3] {
        if self.target.contains(x, y) {
            self.target.get(x, y)
        } else {
            [0.0; 3]
        }
    }

    /// Bytes this view holds (for memory reports).
    pub fn bytes(&self) -> usize {
        self.target.bytes()
            + self.labels.bytes()
            + self.completed.as_ref().map_or(0, LabelRuns::bytes)
    }
}

/// What a component is trained on.
pub struct ComponentData {
    pub name: String,
    pub kind: ComponentKind,
    pub views: Vec<View>,
    /// Trained components rendered, frozen, with this one (their union, see
    /// `Model::union`): the objects in front of the background, or an
    /// object's neighbours around it.
    pub occluders: Option<objectsplat_raster::Model<f32>>,
    /// Measured points on this component's surfaces (its SfM or scanner points,
    /// not seeds), which supervise depth (see `crate::point_depth`).
    pub depth_points: Vec<[f32; 3]>,
    /// Measured points of the other components' surfaces (the scene's points
    /// this component does not own): on the pixels those components own, the
    /// ray to such a point is empty of this component (see `crate::free_space`).
    pub other_points: Vec<[f32; 3]>,
}

impl ComponentData {
    /// Reads a Component folder once — its description, frames, masks, images
    /// and replacement targets — decoding the frames on up to `threads` threads.
    pub fn read(dir: &Path, threads: usize) -> Result<ComponentData> {
        Self::from_folder(ComponentFolder::read(dir)?, threads)
    }

    /// [`ComponentData::read`] of a folder whose description and frames were read.
    pub fn from_folder(folder: ComponentFolder, threads: usize) -> Result<ComponentData> {
        let frames = &folder.frames.frames;
        let threads = threads.clamp(1, frames.len().max(1));
        let mut views: Vec<Option<Result<View>>> = (0..frames.len()).map(|_| None).collect();
        std::thread::scope(|scope| {
            let per = frames.len().div_ceil(threads).max(1);
            for (chunk, out) in frames.chunks(per).zip(views.chunks_mut(per)) {
                let folder = &folder;
                scope.spawn(move || {
                    for (frame, slot) in chunk.iter().zip(out) {
                        *slot = Some(read_view(folder, frame));
                    }
                });
            }
        });
        Ok(ComponentData {
            name: folder.info.name.clone(),
            kind: folder.info.kind,
            views: views
                .into_iter()
                .map(|v| v.unwrap_or_else(|| bail!("a frame was not read")))
                .collect::<Result<Vec<_>>>()?,
            occluders: None,
            depth_points: Vec::new(),
            other_points: Vec::new(),
        })
    }

    /// How this component's pixels are supervised.
    pub fn rule(&self) -> PixelRule {
        PixelRule {
            kind: self.kind,
            behind_occluders: self.occluders.is_some(),
        }
    }

    /// Bytes the views hold (for memory reports).
    pub fn bytes(&self) -> usize {
        self.views.iter().map(View::bytes).sum()
    }

    /// Pixels this component owns across its training views.
    pub fn owned_training_pixels(&self) -> usize {
        self.views
            .iter()
            .filter(|v| v.split == Split::Train)
            .map(|v| v.labels.count(OWN))
            .sum()
    }

    /// Indices of the points that project inside this component's OWN pixels in
    /// a strict majority of the training views that see them (in front of the
    /// camera, inside the image, not hidden behind other points — see
    /// `objectsplat_core::visibility`, computed here unless the scene's
    /// `visibility` is given — and not on an IGNORE pixel).
    pub fn select_points(
        &self,
        points: &Points,
        visibility: Option<&Visibility>,
    ) -> Result<Vec<usize>> {
        let (mut visible, mut own) = (
            vec![0usize; points.positions.len()],
            vec![0usize; points.positions.len()],
        );
        let mut count = |view: &View, point: usize, pixel: u32| {
            let label = view.label(pixel as usize);
            if label != IGNORE {
                visible[point] += 1;
                own[point] += usize::from(label == OWN);
            }
        };
        let training = self.views.iter().filter(|v| v.split == Split::Train);
        match visibility {
            Some(vis) => {
                vis.check_points(points)?;
                for view in training {
                    let Some(seen) = vis.of_frame(&view.name) else {
                        bail!(
                            "the visibility has no frame {:?}: it was computed for another capture",
                            view.name
                        );
                    };
                    for s in seen {
                        count(view, s.point as usize, s.pixel);
                    }
                }
            }
            None => {
                let world: Vec<glam::DVec3> = points
                    .positions
                    .iter()
                    .map(|p| glam::DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
                    .collect();
                let spacing = neighbour_spacing(&world);
                for view in training {
                    for (i, seen) in visible_pixels(&world, spacing, &view.camera)
                        .into_iter()
                        .enumerate()
                    {
                        if let Some((pixel, _)) = seen {
                            count(view, i, pixel);
                        }
                    }
                }
            }
        }
        Ok((0..points.positions.len())
            .filter(|&i| visible[i] > 0 && 2 * own[i] > visible[i])
            .collect())
    }

    /// The scene's points split by [`Self::select_points`]: the ones it picks,
    /// with their colours, and the positions of the rest — the other
    /// components' points, which the free-space rule uses.
    pub fn partition_points(
        &self,
        points: &Points,
        visibility: Option<&Visibility>,
    ) -> Result<(Points, Vec<[f32; 3]>)> {
        let chosen = self.select_points(points, visibility)?;
        let mut mine = vec![false; points.positions.len()];
        for &i in &chosen {
            mine[i] = true;
        }
        let own = Points {
            positions: chosen.iter().map(|&i| points.positions[i]).collect(),
            colors: chosen.iter().map(|&i| points.colors[i]).collect(),
        };
        let others = points
            .positions
            .iter()
            .zip(mine)
            .filter(|(_, mine)| !mine)
            .map(|(p, _)| *p)
            .collect();
        Ok((own, others))
    }

    /// The points [`Self::select_points`] picks, possibly none.
    pub fn owned_points(&self, points: &Points, visibility: Option<&Visibility>) -> Result<Points> {
        Ok(self.partition_points(points, visibility)?.0)
    }

    /// This component's points, or an error naming the component when none qualifies.
    pub fn component_points(
        &self,
        points: &Points,
        visibility: Option<&Visibility>,
    ) -> Result<Points> {
        let chosen = self.owned_points(points, visibility)?;
        if chosen.positions.is_empty() {
            return Err(self.nothing_to_initialize(points.positions.len()));
        }
        Ok(chosen)
    }

    /// The error for a component none of the scene's `scene_points` belongs to.
    pub(crate) fn nothing_to_initialize(&self, scene_points: usize) -> anyhow::Error {
        anyhow::anyhow!(
            "component {:?}: none of the {scene_points} sparse points projects inside its own mask \
             in most training views where it is visible, so there is nothing to initialize from",
            self.name
        )
    }
}

/// One frame of a Component folder as a compact [`View`].
fn read_view(folder: &ComponentFolder, frame: &objectsplat_core::Frame) -> Result<View> {
    let labels = folder.load_labels(frame)?;
    let (w, h) = (frame.camera.width, frame.camera.height);
    // An object's target differs from the background colour only on its own pixels.
    let window = match folder.info.kind {
        ComponentKind::Object => labels.bounds(|l| l == OWN).unwrap_or([0; 4]),
        ComponentKind::Background => [0, 0, w, h],
    };
    let image = folder.frames.image_path(frame);
    let mut target =
        RgbWindow::load(&image, w, h, window).with_context(|| format!("frame {:?}", frame.name))?;
    let mut completed = None;
    if let Some(replacement) = folder.load_replacement_target(frame)? {
        // Completion wrote the whole frame, the image itself where it adopted nothing.
        let mut adopted = vec![0u8; (w * h) as usize];
        for y in window[1]..window[3] {
            for (start, end, label) in labels.row(y) {
                if label != OWN {
                    continue;
                }
                for x in start.max(window[0])..end.min(window[2]) {
                    let p = (y * w + x) as usize;
                    let rgb = [
                        replacement[3 * p],
                        replacement[3 * p + 1],
                        replacement[3 * p + 2],
                    ];
                    let image = target.get(x, y);
                    if (0..3).any(|k| (rgb[k] as f32 - 255.0 * image[k]).abs() > 0.5) {
                        adopted[p] = 1;
                    }
                    target.set_rgb8(x, y, rgb);
                }
            }
        }
        completed = Some(LabelRuns::from_plane(w, h, &adopted)?);
    }
    if let Some(i) = target.first_non_finite() {
        bail!("frame {:?}: target value {i} is not finite", frame.name);
    }
    Ok(View {
        name: frame.name.clone(),
        camera: frame.camera(),
        target,
        labels,
        completed,
        split: frame.split,
    })
}

/// How a component's pixels are supervised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelRule {
    pub kind: ComponentKind,
    /// The background trained behind frozen objects: the composite is supervised everywhere.
    pub behind_occluders: bool,
}

impl PixelRule {
    pub fn new(kind: ComponentKind) -> Self {
        PixelRule {
            kind,
            behind_occluders: false,
        }
    }

    /// A pixel's loss weight and whether its target is the background colour
    /// (instead of the image), from its label.
    #[inline]
    pub fn apply(&self, label: u8) -> (f32, bool) {
        match (label, self.kind) {
            (OWN, _) => (1.0, false),
            (OTHER, ComponentKind::Object) => (1.0, true),
            // IGNORE and unowned grey values: not supervised; for an object the
            // target is the background colour, what renders where it draws nothing.
            (_, ComponentKind::Object) => (0.0, true),
            (OTHER, ComponentKind::Background) if self.behind_occluders => (1.0, false),
            (_, ComponentKind::Background) => (0.0, false),
        }
    }
}

/// Pixel weights and targets of one view under background colour `b`.
pub fn supervision(view: &View, kind: ComponentKind, b: [f32; 3]) -> (Vec<f32>, Vec<f32>) {
    let TargetPlanes {
        mut target,
        weights,
        from_background,
        ..
    } = supervision_parts(view, PixelRule::new(kind), None);
    for p in (0..weights.len()).filter(|&p| from_background[p]) {
        target[3 * p..3 * p + 3].copy_from_slice(&b);
    }
    (target, weights)
}

/// The parts of [`supervision`] that do not depend on the background colour,
/// over the whole frame.
pub(crate) struct TargetPlanes {
    /// RGB per pixel: the target, or where it takes the background colour
    /// what lies over it (0 without neighbours).
    pub target: Vec<f32>,
    pub weights: Vec<f32>,
    /// Which pixels' targets take the background colour.
    pub from_background: Vec<bool>,
    /// Per pixel, the share of the background colour in such a target: what
    /// the neighbours leave uncovered (1 without them).
    pub background_share: Vec<f32>,
}

/// [`TargetPlanes`] of a view, with the frozen neighbours' `layer` over the
/// targets of the pixels it does not own and of its completed ones.
pub(crate) fn supervision_parts(
    view: &View,
    rule: PixelRule,
    layer: Option<&NeighbourLayer>,
) -> TargetPlanes {
    let labels = view.labels.to_plane();
    let w = view.camera.width as usize;
    let (weights, from_background): (Vec<f32>, Vec<bool>) =
        labels.iter().map(|&l| rule.apply(l)).unzip();
    let mut target = vec![0.0f32; 3 * labels.len()];
    let mut background_share = vec![1.0f32; labels.len()];
    for (p, &from_b) in from_background.iter().enumerate() {
        let (x, y) = ((p % w) as u32, (p / w) as u32);
        let over = layer.and_then(|l| l.premultiplied(x, y));
        // Only where a layer covers the pixel: the lookup is a search per pixel.
        let completed = || view.completed.as_ref().is_some_and(|c| c.get(x, y) != 0);
        let rgb = match (from_b, over) {
            (false, Some(_)) if completed() => layer.map(|l| l.over(x, y, view.target_at(x, y))),
            (false, _) => Some(view.target_at(x, y)),
            (true, Some((colour, alpha))) => {
                background_share[p] = 1.0 - alpha;
                Some(colour)
            }
            (true, None) => None,
        };
        if let Some(rgb) = rgb {
            target[3 * p..3 * p + 3].copy_from_slice(&rgb);
        }
    }
    TargetPlanes {
        target,
        weights,
        from_background,
        background_share,
    }
}

/// What stays fixed about a view's supervision whatever the background colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewSummary {
    /// Bounding box of the pixels whose target is not the background colour.
    pub include: PixelRect,
    /// `Σ` of the pixel weights over the whole image.
    pub total_weight: f64,
}

impl ViewSummary {
    pub fn of(view: &View, rule: PixelRule) -> ViewSummary {
        let (mut include, mut total_weight) = (PixelRect::default(), 0.0);
        for y in 0..view.labels.height() {
            for (start, end, label) in view.labels.row(y) {
                let (weight, from_background) = rule.apply(label);
                // Weights are 0 or 1: a run's sum is exact, as the per-pixel sum was.
                total_weight += weight as f64 * (end - start) as f64;
                if !from_background {
                    include = include.union(PixelRect {
                        x0: start,
                        y0: y,
                        x1: end,
                        y1: y + 1,
                    });
                }
            }
        }
        ViewSummary {
            include,
            total_weight,
        }
    }
}

/// Fills `target` (RGB) and `weights` for the pixels of `region` under
/// background colour `b`, reusing the buffers (and `labels`, a row's scratch);
/// returns the region's weight sum. With `layer`, the targets of the pixels
/// the component does not own and of its completed ones are the layer over them.
#[allow(clippy::too_many_arguments)]
pub fn fill_region(
    view: &View,
    rule: PixelRule,
    b: [f32; 3],
    layer: Option<&NeighbourLayer>,
    region: PixelRect,
    target: &mut Vec<f32>,
    weights: &mut Vec<f32>,
    labels: &mut Vec<u8>,
) -> f64 {
    target.clear();
    weights.clear();
    let mut sum = 0.0;
    let mut completed = Vec::new();
    for y in region.y0..region.y1 {
        labels.clear();
        view.labels.extend_row(y, region.x0, region.x1, labels);
        completed.clear();
        if let (Some(_), Some(c)) = (layer, &view.completed) {
            c.extend_row(y, region.x0, region.x1, &mut completed);
        }
        for (i, (x, &label)) in (region.x0..region.x1).zip(labels.iter()).enumerate() {
            let (weight, from_background) = rule.apply(label);
            weights.push(weight);
            sum += weight as f64;
            let under = if from_background {
                b
            } else {
                view.target_at(x, y)
            };
            let covered = from_background || completed.get(i).is_some_and(|&c| c != 0);
            match layer {
                Some(l) if covered => target.extend_from_slice(&l.over(x, y, under)),
                _ => target.extend_from_slice(&under),
            }
        }
    }
    sum
}
