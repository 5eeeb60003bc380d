//! Generic image nodes: `load_image`, `load_mask`, `resize_image`, `save_image`.

use anyhow::{Result, bail};
use objectsplat_core::Image;
use objectsplat_core::artifact::{IMAGE_PNG, MASK_PNG};
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry, node_ports};
use std::sync::Arc;

objectsplat_runtime::node_params! {
    /// The parameters of `load_image`.
    pub struct LoadImageParams {
        /// image file, relative to the graph file
        path: String = required as ParamType::Path,
    }
}

/// Reads an image file (PNG or JPEG) into an Image artifact.
pub struct LoadImage;

node_ports! {
    struct LoadImagePorts {
        /// the image
        image: output "Image",
    }
}

impl Node for LoadImage {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("load_image", "1")
            .doc("Reads a PNG or JPEG file into an Image artifact (8-bit images stay 8-bit, 16-bit stay 16-bit).")
            .ports::<LoadImagePorts>()
            .params::<LoadImageParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: LoadImagePorts = ctx.ports_as()?;
        let p: LoadImageParams = ctx.params_as()?;
        let path: String = p.path;
        let img = Image::load(std::path::Path::new(&path))?;
        img.check_finite(&path)?;
        let out = ports.image.join(IMAGE_PNG);
        if is_16_bit(std::path::Path::new(&path)) {
            img.save_png16(&out)?
        } else {
            img.save_png8(&out)?
        }
        ctx.note(
            "size",
            format!("{}×{}×{}", img.width, img.height, img.channels),
        );
        Ok(Outcome::Done)
    }
}

fn is_16_bit(path: &std::path::Path) -> bool {
    image::ImageReader::open(path)
        .ok()
        .and_then(|r| r.with_guessed_format().ok())
        .and_then(|r| r.into_decoder().ok())
        .map(|d| {
            use image::ImageDecoder;
            d.color_type().bytes_per_pixel() as u32 / d.color_type().channel_count() as u32 > 1
        })
        .unwrap_or(false)
}

objectsplat_runtime::node_params! {
    /// The parameters of `load_mask`.
    pub struct LoadMaskParams {
        /// mask image file, relative to the graph file
        path: String = required as ParamType::Path,
    }
}

/// Reads a mask image; any non-zero value (in any channel) counts as set.
pub struct LoadMask;

node_ports! {
    struct LoadMaskPorts {
        /// 8-bit mask, 255 = set
        mask: output "Mask",
    }
}

impl Node for LoadMask {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("load_mask", "1")
            .doc("Reads a mask image; a pixel is set where any channel is non-zero.")
            .ports::<LoadMaskPorts>()
            .params::<LoadMaskParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: LoadMaskPorts = ctx.ports_as()?;
        let p: LoadMaskParams = ctx.params_as()?;
        let path: String = p.path;
        let img = Image::load(std::path::Path::new(&path))?;
        let c = img.channels as usize;
        let mask = Image {
            width: img.width,
            height: img.height,
            channels: 1,
            data: img
                .data
                .chunks(c)
                .map(|p| if p.iter().any(|&v| v > 0.0) { 1.0 } else { 0.0 })
                .collect(),
        };
        let set = mask.data.iter().filter(|&&v| v > 0.0).count();
        mask.save_png8(&ports.mask.join(MASK_PNG))?;
        ctx.note("set_pixels", set);
        Ok(Outcome::Done)
    }
}

objectsplat_runtime::node_params! {
    /// The parameters of `resize_image`.
    pub struct ResizeImageParams {
        /// integer downscale factor
        factor: u32 = "1" as ParamType::Int { min: Some(1), max: Some(64) },
        /// cap on the width, applied after `factor`
        max_width: Option<u32> = "None" as ParamType::optional(ParamType::Int { min: Some(1), max: None }),
    }
}

/// Area-downscales an image by an integer factor or to a maximum width.
pub struct ResizeImage;

node_ports! {
    struct ResizeImagePorts {
        /// the image
        image: input "Image",
        /// the resized image
        image_out: output "Image" as "image",
    }
}

impl Node for ResizeImage {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("resize_image", "1")
            .doc("Box-filter downscale by an integer `factor`, or to at most `max_width` pixels wide.")
            .ports::<ResizeImagePorts>()
            .params::<ResizeImageParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: ResizeImagePorts = ctx.ports_as()?;
        let p: ResizeImageParams = ctx.params_as()?;
        let img = Image::load(&ports.image.join(IMAGE_PNG))?;
        let factor: u32 = p.factor;
        let max_width: Option<u32> = p.max_width;
        let mut w = (img.width / factor).max(1);
        let mut h = (img.height / factor).max(1);
        if let Some(mw) = max_width
            && w > mw
        {
            h = ((h as u64 * mw as u64) / w as u64).max(1) as u32;
            w = mw;
        }
        let out = if (w, h) == (img.width, img.height) {
            img
        } else {
            img.resize_area(w, h)
        };
        out.save_png8(&ports.image_out.join(IMAGE_PNG))?;
        ctx.note("size", format!("{w}×{h}"));
        Ok(Outcome::Done)
    }
}

objectsplat_runtime::node_params! {
    /// The parameters of `save_image`.
    pub struct SaveImageParams {
        /// file name relative to the node's output folder
        path: String = "\"image.png\"" as ParamType::RelPath,
        /// bit depth
        bits: String = "\"8\"" as ParamType::Enum(vec!["8".into(), "16".into()]),
    }
}

/// Writes an image to a path inside the node's output folder.
pub struct SaveImage;

node_ports! {
    struct SaveImagePorts {
        /// the image
        image: input "Image",
        /// the written file
        file: output "File",
    }
}

impl Node for SaveImage {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("save_image", "1")
            .doc("Writes an image as PNG at `path` inside OUT/<node>/file/ (paths may not leave that folder).")
            .ports::<SaveImagePorts>()
            .params::<SaveImageParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: SaveImagePorts = ctx.ports_as()?;
        let p: SaveImageParams = ctx.params_as()?;
        let img = Image::load(&ports.image.join(IMAGE_PNG))?;
        let rel: String = p.path;
        if !rel.to_ascii_lowercase().ends_with(".png") {
            bail!("path {rel:?} must end in .png");
        }
        let dest = ports.file.join(&rel);
        if let Some(parent) = dest.parent() {
            std::fs::create_dir_all(parent)?;
        }
        match p.bits.as_str() {
            "16" => img.save_png16(&dest)?,
            _ => img.save_png8(&dest)?,
        }
        Ok(Outcome::Done)
    }
}

pub fn register(reg: &mut Registry) {
    for node in [
        Arc::new(LoadImage) as Arc<dyn Node>,
        Arc::new(LoadMask),
        Arc::new(ResizeImage),
        Arc::new(SaveImage),
    ] {
        // Kinds here are unique by construction; a collision is a programming error the
        // catalogue test catches.
        reg.add_node(node).expect("built-in node kinds are unique");
    }
}
