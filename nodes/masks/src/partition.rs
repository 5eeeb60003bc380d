//! The image-space partition: every pixel of every frame goes to exactly one component.
//!
//! Components are the retained objects plus the background. An object is retained when
//! it owns at least `min_pixels` pixels over the whole capture; smaller objects are
//! dropped (with a reason) and their pixels go to the background, as do pixels of no
//! object (`0`) and pixels no surface owns ([`UNOWNED`]). Each component's per-frame
//! mask marks the pixels it owns [`OWN`] and every other pixel [`OTHER`], so over the
//! components present in a frame the OWN sets are disjoint and cover the frame.
//!
//! `holistic: true` is the baseline: one component named `scene` (kind background)
//! that owns every pixel of every frame, masks ignored.

use anyhow::{Context, Result, bail};
use objectsplat_core::artifact::FRAMES_JSON;
use objectsplat_core::component::{OTHER, OWN};
use objectsplat_core::frames::{check_relative, frame_stem};
use objectsplat_core::masks::{NO_OBJECT, UNOWNED};
use objectsplat_core::{ComponentInfo, ComponentKind, Frame, Frames, IdMap, ObjectLabels};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Written beside `component.json` in the background (or holistic) component: the
/// objects that did not become components, and why.
pub const DROPPED_JSON: &str = "dropped.json";

#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PartitionParams {
    /// Whole-capture pixel budget an object must reach to become a component. `None`
    /// uses 1% of the mean frame area.
    pub min_pixels: Option<u64>,
    /// One component (`scene`) owning everything: the holistic baseline.
    pub holistic: bool,
}

/// Which component owns a pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Owner {
    Object(u16),
    Background,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ComponentPlan {
    pub info: ComponentInfo,
    pub owner: Owner,
    /// Indices of the frames the component is trained/evaluated on.
    pub frames: Vec<usize>,
    /// Pixels it owns over the whole capture.
    pub pixels: u64,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DroppedObject {
    pub object_id: u16,
    pub label: String,
    pub pixels: u64,
    pub reason: String,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Partition {
    pub holistic: bool,
    /// Objects in id order, then the background.
    pub components: Vec<ComponentPlan>,
    pub dropped: Vec<DroppedObject>,
}

impl Partition {
    /// The owner of a pixel with mask value `value`.
    pub fn owner_of(&self, value: u16) -> Owner {
        if !self.holistic
            && value != NO_OBJECT
            && value != UNOWNED
            && self
                .components
                .iter()
                .any(|c| c.owner == Owner::Object(value))
        {
            Owner::Object(value)
        } else {
            Owner::Background
        }
    }

    /// The OWN/OTHER mask of one component in one frame.
    pub fn component_mask(&self, component: &ComponentPlan, ids: &IdMap) -> Vec<u8> {
        let retained: Vec<u16> = self
            .components
            .iter()
            .filter_map(|c| {
                if let Owner::Object(id) = c.owner {
                    Some(id)
                } else {
                    None
                }
            })
            .collect();
        // A lookup table over the u16 id space keeps the per-pixel work to one load.
        let mut owner_is_me = vec![component.owner == Owner::Background; UNOWNED as usize + 1];
        if !self.holistic {
            for id in retained {
                owner_is_me[id as usize] = component.owner == Owner::Object(id);
            }
        }
        ids.data
            .iter()
            .map(|&v| if owner_is_me[v as usize] { OWN } else { OTHER })
            .collect()
    }
}

/// Decides the components from the masks of every frame (same order as the frames).
pub fn plan_partition(
    masks: &[IdMap],
    labels: &ObjectLabels,
    params: &PartitionParams,
) -> Result<Partition> {
    let all_frames: Vec<usize> = (0..masks.len()).collect();
    let total_pixels: u64 = masks.iter().map(|m| m.data.len() as u64).sum();
    if params.holistic {
        let info = ComponentInfo {
            name: "scene".into(),
            ..ComponentInfo::background()
        };
        let plan = ComponentPlan {
            info,
            owner: Owner::Background,
            frames: all_frames,
            pixels: total_pixels,
        };
        return Ok(Partition {
            holistic: true,
            components: vec![plan],
            dropped: Vec::new(),
        });
    }
    // Pixel count and frames per object id.
    let mut per_object: BTreeMap<u16, (u64, Vec<usize>)> = BTreeMap::new();
    for (f, mask) in masks.iter().enumerate() {
        let mut counts = vec![0u64; UNOWNED as usize + 1];
        for &v in &mask.data {
            counts[v as usize] += 1;
        }
        for (id, &n) in counts.iter().enumerate() {
            let id = id as u16;
            if n == 0 || id == NO_OBJECT || id == UNOWNED {
                continue;
            }
            if !labels.contains_key(&id) {
                bail!("frame {f}: mask has object id {id}, which has no label in objects.json");
            }
            let entry = per_object.entry(id).or_default();
            entry.0 += n;
            entry.1.push(f);
        }
    }
    let budget = params.min_pixels.unwrap_or_else(|| {
        let mean_area = if masks.is_empty() {
            0.0
        } else {
            total_pixels as f64 / masks.len() as f64
        };
        (0.01 * mean_area).ceil() as u64
    });
    let mut components = Vec::new();
    let mut dropped = Vec::new();
    let mut object_pixels = 0;
    for (id, (pixels, frames)) in per_object {
        let label = labels[&id].clone();
        if pixels < budget {
            let reason =
                format!("owns {pixels} pixels over the capture, below the budget of {budget}");
            dropped.push(DroppedObject {
                object_id: id,
                label,
                pixels,
                reason,
            });
            continue;
        }
        object_pixels += pixels;
        components.push(ComponentPlan {
            info: ComponentInfo::object(id, &label),
            owner: Owner::Object(id),
            frames,
            pixels,
        });
    }
    for (id, label) in labels {
        if !components.iter().any(|c| c.owner == Owner::Object(*id))
            && !dropped.iter().any(|d| d.object_id == *id)
        {
            let reason = "owns no pixel in any frame".to_string();
            dropped.push(DroppedObject {
                object_id: *id,
                label: label.clone(),
                pixels: 0,
                reason,
            });
        }
    }
    components.push(ComponentPlan {
        info: ComponentInfo::background(),
        owner: Owner::Background,
        frames: all_frames,
        pixels: total_pixels - object_pixels,
    });
    Ok(Partition {
        holistic: false,
        components,
        dropped,
    })
}

/// Reads a Masks folder for the given frames: one id map per frame, checked against the frame size.
pub fn read_masks(masks_dir: &Path, frames: &[Frame]) -> Result<(Vec<IdMap>, ObjectLabels)> {
    let labels = objectsplat_core::masks::read_objects(masks_dir)?;
    let mut maps = Vec::with_capacity(frames.len());
    for frame in frames {
        let path = masks_dir.join(format!("{}.png", frame_stem(&frame.name)));
        if !path.exists() {
            bail!("{}: no mask for frame {:?}", path.display(), frame.name);
        }
        let map = IdMap::load(&path)?;
        if (map.width, map.height) != (frame.camera.width, frame.camera.height) {
            bail!(
                "{}: mask is {}×{} but frame {:?} is {}×{}",
                path.display(),
                map.width,
                map.height,
                frame.name,
                frame.camera.width,
                frame.camera.height
            );
        }
        maps.push(map);
    }
    Ok((maps, labels))
}

/// Partitions a Frames folder with its Masks folder into component folders under `out`.
/// Returns the plan (also useful for reporting dropped objects).
pub fn partition_folders(
    frames_dir: &Path,
    masks_dir: &Path,
    out: &Path,
    params: &PartitionParams,
    threads: usize,
) -> Result<Partition> {
    let frames = Frames::read(frames_dir)?;
    let (masks, labels) = if params.holistic {
        // The baseline ignores the masks, so it needs none.
        (
            frames
                .frames
                .iter()
                .map(|f| IdMap::new(f.camera.width, f.camera.height))
                .collect(),
            ObjectLabels::new(),
        )
    } else {
        read_masks(masks_dir, &frames.frames)?
    };
    let plan = plan_partition(&masks, &labels, params)
        .map_err(|e| anyhow::anyhow!("{}: {e}", masks_dir.display()))?;
    write_partition(&frames, &masks, &plan, out, threads)?;
    Ok(plan)
}

/// Writes one self-contained folder per component (see `objectsplat_core::component`),
/// each component's frames on up to `threads` threads.
pub fn write_partition(
    frames: &Frames,
    masks: &[IdMap],
    plan: &Partition,
    out: &Path,
    threads: usize,
) -> Result<()> {
    if masks.len() != frames.frames.len() {
        bail!("{} masks for {} frames", masks.len(), frames.frames.len());
    }
    let image_names = component_image_names(frames)?;
    for component in &plan.components {
        let dir = out.join(&component.info.name);
        let images_dir = dir.join("images");
        std::fs::create_dir_all(&images_dir)
            .with_context(|| format!("{}: cannot create folder", images_dir.display()))?;
        component.info.write(&dir)?;
        let write = |f: usize| -> Result<Frame> {
            let frame = &frames.frames[f];
            let src = frames.image_path(frame);
            let dst = dir.join(&image_names[f]);
            objectsplat_core::files::link_or_copy(&src, &dst)
                .context("sharing a frame image into its component")?;
            objectsplat_core::component::write_mask(
                &dir,
                frame,
                &plan.component_mask(component, &masks[f]),
            )?;
            Ok(Frame {
                image: image_names[f].clone(),
                ..frame.clone()
            })
        };
        let per = component.frames.len().div_ceil(threads.max(1)).max(1);
        let mut written: Vec<Option<Result<Frame>>> =
            (0..component.frames.len()).map(|_| None).collect();
        std::thread::scope(|scope| {
            for (chunk, slots) in component.frames.chunks(per).zip(written.chunks_mut(per)) {
                let write = &write;
                scope.spawn(move || {
                    for (&f, slot) in chunk.iter().zip(slots) {
                        *slot = Some(write(f));
                    }
                });
            }
        });
        let listed = written
            .into_iter()
            .map(|w| w.unwrap_or_else(|| bail!("a frame was not written")))
            .collect::<Result<Vec<Frame>>>()?;
        Frames::write_json(&dir, &listed)?;
        if component.info.kind == ComponentKind::Background {
            let path = dir.join(DROPPED_JSON);
            std::fs::write(&path, serde_json::to_string_pretty(&plan.dropped)?)
                .with_context(|| format!("{}: cannot write", path.display()))?;
        }
    }
    Ok(())
}

/// `images/<frame stem>.<ext>` for each frame, refusing two frames that would collide.
fn component_image_names(frames: &Frames) -> Result<Vec<String>> {
    let mut seen = BTreeMap::new();
    let mut names = Vec::with_capacity(frames.frames.len());
    for frame in &frames.frames {
        check_relative(&frame.image).with_context(|| {
            format!(
                "{}: frame {:?}",
                frames.root.join(FRAMES_JSON).display(),
                frame.name
            )
        })?;
        let ext = Path::new(&frame.image)
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("png");
        let name = format!("images/{}.{ext}", frame_stem(&frame.name));
        if let Some(other) = seen.insert(name.clone(), frame.name.clone()) {
            bail!(
                "{}: frames {other:?} and {:?} would both be stored as {name}",
                frames.root.join(FRAMES_JSON).display(),
                frame.name
            );
        }
        names.push(name);
    }
    Ok(names)
}
