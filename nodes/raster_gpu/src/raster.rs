//! [`WgpuBackend`]: the rasterizer of objectsplat-raster as wgpu compute
//! kernels, matching the CPU backend's culling, ordering, compositing and
//! analytic gradients.
//!
//! Forward: `vertex_pre` → `face_pre` (culling) → radix sort of the faces by
//! the tile of their top-left pixel (the CPU's slot order) → per-slot tile
//! counts → prefix sum → one entry per (face, tile) in slot order → stable
//! radix sort by depth bits, then by tile (so ties break by slot, as the CPU's
//! (depth, slot) key does) → tile ranges → per-tile compositing. Backward:
//! per-tile back-to-front walk with workgroup-reduced per-face partials →
//! per-face geometry backward → per-vertex projection/SH/opacity backward.
//!
//! Regions ([`RenderSettings::region`]): `face_pre` reduces the drawn faces'
//! pixel boxes with atomics, and `frame_region` turns them (with `include`
//! and the margin) into the rendered rectangle, rounded out to whole tiles, in
//! the frame record that comes back with the tile-entry count (one readback).
//! Binning stays in the whole image's tile grid, so every tile's entry list
//! and every pixel's fragment order is the full render's: pixels inside the
//! region are bit-identical to a full render. Compositing, the backward pass
//! and the outputs cover the region's tiles and pixels only.
//!
//! Buffers live in pools (`RasterPool`, `GradPool`) that grow to the
//! largest model and image seen; the training loop keeps its own across steps.

use crate::atomics::{FloatAtomics, accumulator_wgsl};
use crate::kernels::{
    Kernel, Pooled, Recorder, UniformArena, groups_for, shader, storage, storage_from,
};
use crate::scan::{GpuScan, ScanScratch};
use crate::sort::{GpuSort, SortBuffers, SortScratch, key_bits};
use anyhow::{Context, Result, bail};
use objectsplat_core::Camera;
use objectsplat_gpu::{GpuContext, map_and_copy, read_buffers};
use objectsplat_raster::backend::{PixelRect, Region, check_buffer};
use objectsplat_raster::cpu::preprocess::CameraParams;
use objectsplat_raster::{
    Model, ModelGrads, OutputGrads, RenderBackend, RenderOutput, RenderSettings, SH_COEFFS,
    SavedForward,
};
use std::sync::Arc;

pub const RASTER_COMMON_WGSL: &str = concat!(
    include_str!("frame_record.wgsl"),
    include_str!("thread_index.wgsl"),
    include_str!("raster_common.wgsl")
);
pub const RASTER_PRE_WGSL: &str = include_str!("raster_pre.wgsl");
const RASTER_TILES_WGSL: &str = include_str!("raster_tiles.wgsl");
pub const RASTER_FORWARD_WGSL: &str = include_str!("raster_forward.wgsl");
pub const RASTER_BACKWARD_WGSL: &str = include_str!("raster_backward.wgsl");
pub const RASTER_GRADS_WGSL: &str = include_str!("raster_grads.wgsl");

const BACKEND_NAME: &str = "wgpu";
const TILE: u32 = 16;
const FACE_BYTES: u64 = 192;
const VERTEX_BYTES: u64 = 64;
const IMAGE_STRIDE: usize = 6;
const STATE_STRIDE: usize = 3;
const PARTIAL: usize = 23;
const VERTEX_ACCUMULATORS: usize = 7;
const THREADS_1D: usize = 256;

/// Kernel variants: float accumulation mode and threads per tile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KernelConfig {
    pub atomics: FloatAtomics,
    /// Threads per 16×16 tile in the forward kernel: 32, 64, 128 or 256.
    pub forward_threads: u32,
    /// Threads per 16×16 tile in the backward kernel: 32, 64, 128 or 256.
    pub backward_threads: u32,
}

impl KernelConfig {
    /// Native float atomics where available. One thread per pixel forward and
    /// two pixels per thread backward on GPUs; on CPU adapters (lavapipe),
    /// where every workgroup barrier costs a coroutine switch per SIMD group
    /// and per-SIMD-group overheads dominate, 64 and 32 threads per tile.
    pub fn for_context(ctx: &GpuContext) -> Self {
        let atomics = if ctx.float_atomics {
            FloatAtomics::Native
        } else {
            FloatAtomics::CompareExchange
        };
        let cpu = ctx.adapter_info.device_type == wgpu::DeviceType::Cpu;
        KernelConfig {
            atomics,
            forward_threads: if cpu { 64 } else { 256 },
            backward_threads: if cpu { 32 } else { 128 },
        }
    }

    fn validate(&self, ctx: &GpuContext) -> Result<()> {
        if self.atomics == FloatAtomics::Native && !ctx.float_atomics {
            bail!(
                "native float atomics requested but {} lacks SHADER_FLOAT32_ATOMIC",
                ctx.adapter_info.name
            );
        }
        for (name, n) in [
            ("forward", self.forward_threads),
            ("backward", self.backward_threads),
        ] {
            if ![32, 64, 128, 256].contains(&n) {
                bail!("{name} threads per tile {n} must be 32, 64, 128 or 256");
            }
        }
        Ok(())
    }
}

/// The WGSL programs as compiled, for a given accumulation mode and backward
/// workgroup size (32, 64, 128 or 256), for validation and for the pipelines.
pub fn raster_sources(
    mode: FloatAtomics,
    backward_threads: u32,
    forward_threads: u32,
) -> [(&'static str, String); 4] {
    let forward_constants = format!(
        "const FWD_THREADS: u32 = {forward_threads}u;\nconst FWD_PIXELS: u32 = {}u;\n",
        256 / forward_threads
    );
    let backward_constants = format!(
        "const THREADS: u32 = {backward_threads}u;\nconst PIXELS_PER_THREAD: u32 = {}u;\n",
        256 / backward_threads
    );
    let with_common = |body: &str, extra: String| format!("{RASTER_COMMON_WGSL}\n{extra}\n{body}");
    [
        (
            "raster_pre.wgsl",
            with_common(RASTER_PRE_WGSL, String::new()),
        ),
        (
            "raster_forward.wgsl",
            with_common(RASTER_FORWARD_WGSL, forward_constants + RASTER_TILES_WGSL),
        ),
        (
            "raster_backward.wgsl",
            with_common(
                RASTER_BACKWARD_WGSL,
                backward_constants
                    + RASTER_TILES_WGSL
                    + &accumulator_wgsl(mode, "face_grad", "face_grads", 8),
            ),
        ),
        (
            "raster_grads.wgsl",
            with_common(
                RASTER_GRADS_WGSL,
                accumulator_wgsl(mode, "face_grad", "face_grads", 9)
                    + &accumulator_wgsl(mode, "vertex_grad", "vertex_grads", 10),
            ),
        ),
    ]
}

/// The uniform block every raster kernel reads (`RasterParams` in raster_common.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct RasterParams {
    rot: [[f32; 4]; 3],
    center: [f32; 4],
    fx: f32,
    fy: f32,
    cx: f32,
    cy: f32,
    width: u32,
    height: u32,
    tiles_x: u32,
    tiles_y: u32,
    vertex_count: u32,
    face_count: u32,
    sh_degree: u32,
    entry_count: u32,
    sigma: f32,
    z_near: f32,
    min_centroid_depth: f32,
    min_abs_cos: f32,
    min_opacity: f32,
    max_screen_extent: f32,
    min_screen_extent: f32,
    min_inradius: f32,
    alpha_max: f32,
    alpha_min: f32,
    transmittance_min: f32,
    opacity_floor: f32,
    include_x0: u32,
    include_y0: u32,
    include_x1: u32,
    include_y1: u32,
    margin: u32,
    region_mode: u32,
    uniform_background: u32,
    sigma_from: u32,
    background_color: [f32; 4],
}

struct RasterKernels {
    scan: GpuScan,
    sort: GpuSort,
    vertex_pre: Kernel,
    face_pre: Kernel,
    tile_counts: Kernel,
    frame_region: Kernel,
    emit_entries: Kernel,
    pad_entries: Kernel,
    gather_tiles: Kernel,
    tile_ranges: Kernel,
    forward: Kernel,
    backward: Kernel,
    face_backward: Kernel,
    vertex_backward: Kernel,
}

/// The wgpu rasterizer (f32). Cheap to clone; kernels are compiled once in [`WgpuBackend::new`].
#[derive(Clone)]
pub struct WgpuBackend {
    ctx: Arc<GpuContext>,
    kernels: Arc<RasterKernels>,
    config: KernelConfig,
}

impl std::fmt::Debug for WgpuBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WgpuBackend")
            .field("ctx", &self.ctx)
            .field("config", &self.config)
            .finish()
    }
}

/// A model's parameters on the device, in the kernels' layout: positions
/// (3 per vertex), SH (16×3 per vertex), opacity logits, face indices, and the
/// window sharpness σ of the faces from `sigma_from` on (the others take the
/// render's σ). The buffers may be larger than the model (pooled); the counts
/// say how much is used.
#[derive(Clone)]
pub(crate) struct ModelBuffers {
    pub positions: wgpu::Buffer,
    pub sh: wgpu::Buffer,
    pub opacity_logits: wgpu::Buffer,
    pub face_indices: wgpu::Buffer,
    pub face_sigma: wgpu::Buffer,
    pub vertex_count: usize,
    pub face_count: usize,
    pub sigma_from: usize,
    pub opacity_floor: f32,
}

impl ModelBuffers {
    /// The same buffers drawing only the first `faces` faces (a trained
    /// model without the frozen occluders appended to it).
    pub fn first_faces(&self, faces: usize) -> ModelBuffers {
        ModelBuffers {
            face_count: faces.min(self.face_count),
            ..self.clone()
        }
    }
}

/// A model's per-face σ for the device: `(σ of every face from `sigma_from`
/// on (indexed by face, the earlier entries unused), sigma_from)`. Faces
/// before `first_own` take the render's σ; a model without per-face σ has
/// none of its own.
fn face_sigma_of(model: &Model<f32>, first_own: usize) -> (Vec<f32>, usize) {
    if model.face_sigma.is_empty() {
        // A storage binding may not be empty.
        return (vec![0.0], model.face_count());
    }
    let from = first_own.min(model.face_count());
    let sigma = model
        .face_sigma
        .iter()
        .enumerate()
        .map(|(f, &s)| if f < from { 0.0 } else { s as f32 })
        .collect();
    (sigma, from)
}

/// Words of the frame record that come back to the host (frame_record.wgsl's
/// FRAME_*: entry count, region), and the record's size on the device.
const FRAME_READ_WORDS: usize = 5;
const FRAME_BYTES: u64 = 64;

/// The background the faces are composited over.
#[derive(Debug, Clone, Copy)]
pub(crate) enum BackgroundSource<'a> {
    /// One colour for every pixel (no per-pixel buffer).
    Uniform([f32; 3]),
    /// Per pixel of the whole image (H×W×3) on the host; the region's part is uploaded.
    Image(&'a [f32]),
}

/// What a render read back and left on the device for its backward pass.
#[derive(Clone)]
pub(crate) struct Rendered {
    params: RasterParams,
    model: ModelBuffers,
    /// The pixels rendered; images and per-pixel state cover them, row-major.
    pub region: PixelRect,
}

/// Every device buffer of a render, kept from render to render and grown
/// (never shrunk) to the largest model, entry count and region seen, so a
/// training loop renders without creating buffers once they have grown.
pub(crate) struct RasterPool {
    vertices: Pooled,
    faces: Pooled,
    order_keys: Pooled,
    order_faces: Pooled,
    order_scratch_keys: Pooled,
    order_scratch_faces: Pooled,
    entry_offsets: Pooled,
    /// Per face: max blending weight (f32 bits), pixel count.
    face_stats: Pooled,
    depth_keys: Pooled,
    entry_ids: Pooled,
    entry_tiles: Pooled,
    entry_faces: Pooled,
    tile_keys: Pooled,
    entries: Pooled,
    scratch_a: Pooled,
    scratch_b: Pooled,
    tile_ranges: Pooled,
    /// Per pixel of the region: colour, alpha, depth, median depth (stride 6).
    image: Pooled,
    pixel_state: Pooled,
    /// The region's background when it is given per pixel.
    background: Pooled,
    frame: wgpu::Buffer,
    staging: wgpu::Buffer,
    sort: SortScratch,
    scan: ScanScratch,
    last: Option<Rendered>,
    created: u64,
    /// Host waits for the device so far (one per render that reads its frame record back).
    pub syncs: u64,
}

impl RasterPool {
    pub fn new(ctx: &GpuContext) -> Self {
        let mut created = 0;
        let mut pooled = |label| Pooled::new(ctx, label, &mut created);
        let mut pool = RasterPool {
            vertices: pooled("vertices"),
            faces: pooled("faces"),
            order_keys: pooled("order keys"),
            order_faces: pooled("order faces"),
            order_scratch_keys: pooled("order scratch keys"),
            order_scratch_faces: pooled("order scratch faces"),
            entry_offsets: pooled("entry offsets"),
            face_stats: pooled("face stats"),
            depth_keys: pooled("entry depth keys"),
            entry_ids: pooled("entry ids"),
            entry_tiles: pooled("entry tiles"),
            entry_faces: pooled("entry faces"),
            tile_keys: pooled("sorted tile keys"),
            entries: pooled("sorted entries"),
            scratch_a: pooled("sort scratch a"),
            scratch_b: pooled("sort scratch b"),
            tile_ranges: pooled("tile ranges"),
            image: pooled("image"),
            pixel_state: pooled("pixel state"),
            background: pooled("background"),
            frame: storage(ctx, "frame record", FRAME_BYTES),
            staging: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("frame record readback"),
                size: FRAME_BYTES,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            sort: SortScratch::new(ctx),
            scan: ScanScratch::new(ctx),
            last: None,
            created,
            syncs: 0,
        };
        pool.created += 2;
        pool
    }

    /// Buffers this pool has created (the pooling checks).
    pub fn created(&self) -> u64 {
        self.created + self.sort.created() + self.scan.created
    }

    /// The last render that read its frame record back (None after one that did not).
    pub fn last(&self) -> Option<&Rendered> {
        self.last.as_ref()
    }

    pub fn image(&self) -> &wgpu::Buffer {
        self.image.buffer()
    }

    pub fn face_stats(&self) -> &wgpu::Buffer {
        self.face_stats.buffer()
    }

    /// The frame record (entry count at word 0, region at words 1–4).
    pub fn frame(&self) -> &wgpu::Buffer {
        &self.frame
    }

    /// Tile entries a render may have without reading its count back.
    pub fn entry_capacity(&self) -> usize {
        [
            &self.depth_keys,
            &self.entry_ids,
            &self.entry_tiles,
            &self.entry_faces,
            &self.tile_keys,
            &self.entries,
            &self.scratch_a,
            &self.scratch_b,
        ]
        .iter()
        .map(|b| b.buffer().size() as usize / 4)
        .min()
        .unwrap_or(0) // the array is not empty
    }

    fn ensure_model(&mut self, ctx: &GpuContext, nv: usize, nf: usize) {
        let c = &mut self.created;
        self.vertices.ensure(ctx, nv as u64 * VERTEX_BYTES, c);
        self.faces.ensure(ctx, nf as u64 * FACE_BYTES, c);
        for b in [
            &mut self.order_keys,
            &mut self.order_faces,
            &mut self.order_scratch_keys,
            &mut self.order_scratch_faces,
        ] {
            b.ensure(ctx, nf as u64 * 4, c);
        }
        self.entry_offsets.ensure(ctx, (nf as u64 + 1) * 4, c);
        self.face_stats.ensure(ctx, nf as u64 * 8, c);
    }

    /// Makes the entry buffers hold at least `n` entries.
    pub fn ensure_entries(&mut self, ctx: &GpuContext, n: usize) {
        let c = &mut self.created;
        for b in [
            &mut self.depth_keys,
            &mut self.entry_ids,
            &mut self.entry_tiles,
            &mut self.entry_faces,
            &mut self.tile_keys,
            &mut self.entries,
            &mut self.scratch_a,
            &mut self.scratch_b,
        ] {
            b.ensure(ctx, n as u64 * 4, c);
        }
    }

    fn ensure_pixels(&mut self, ctx: &GpuContext, pixels: usize, tiles: usize) {
        let c = &mut self.created;
        self.image
            .ensure(ctx, (pixels * IMAGE_STRIDE * 4) as u64, c);
        self.pixel_state
            .ensure(ctx, (pixels * STATE_STRIDE * 4) as u64, c);
        self.tile_ranges.ensure(ctx, tiles as u64 * 8, c);
    }
}

/// The backward pass's buffers, pooled like [`RasterPool`]'s. The gradients
/// are in [`ModelBuffers`]' layout; the background's covers the region.
pub(crate) struct GradPool {
    background: Pooled,
    face_grads: Pooled,
    vertex_grads: Pooled,
    positions: Pooled,
    sh: Pooled,
    opacity_logits: Pooled,
    created: u64,
}

impl GradPool {
    pub fn new(ctx: &GpuContext) -> Self {
        let mut created = 0;
        let mut pooled = |label| Pooled::new(ctx, label, &mut created);
        GradPool {
            background: pooled("background gradient"),
            face_grads: pooled("face partials"),
            vertex_grads: pooled("vertex accumulators"),
            positions: pooled("position gradient"),
            sh: pooled("sh gradient"),
            opacity_logits: pooled("logit gradient"),
            created,
        }
    }

    pub fn created(&self) -> u64 {
        self.created
    }

    pub fn positions(&self) -> &wgpu::Buffer {
        self.positions.buffer()
    }

    pub fn sh(&self) -> &wgpu::Buffer {
        self.sh.buffer()
    }

    pub fn opacity_logits(&self) -> &wgpu::Buffer {
        self.opacity_logits.buffer()
    }
}

/// Pooled device buffers of a model's parameters ([`ModelBuffers`]' layout).
pub(crate) struct ModelPool {
    positions: Pooled,
    sh: Pooled,
    opacity_logits: Pooled,
    face_indices: Pooled,
    face_sigma: Pooled,
}

impl ModelPool {
    /// Minimal buffers; `created` counts them.
    pub fn new(ctx: &GpuContext, created: &mut u64) -> Self {
        let mut pooled = |label| Pooled::new(ctx, label, created);
        ModelPool {
            positions: pooled("positions"),
            sh: pooled("sh"),
            opacity_logits: pooled("opacity logits"),
            face_indices: pooled("face indices"),
            face_sigma: pooled("face sigma"),
        }
    }
}

impl WgpuBackend {
    /// Compiles the kernels on `ctx` with [`KernelConfig::for_context`].
    pub fn new(ctx: Arc<GpuContext>) -> Result<Self> {
        let config = KernelConfig::for_context(&ctx);
        Self::with_config(ctx, config)
    }

    /// As [`WgpuBackend::new`] with an explicit accumulation mode (tests force
    /// the compare-exchange path); `Native` needs `ctx.float_atomics`.
    pub fn with_atomics(ctx: Arc<GpuContext>, atomics: FloatAtomics) -> Result<Self> {
        let config = KernelConfig {
            atomics,
            ..KernelConfig::for_context(&ctx)
        };
        Self::with_config(ctx, config)
    }

    /// Compiles the kernels in the given variant (tests run the GPU layout on lavapipe too).
    pub fn with_config(ctx: Arc<GpuContext>, config: KernelConfig) -> Result<Self> {
        config.validate(&ctx)?;
        ctx.check_errors("setup before compiling the raster kernels")?;
        let [pre, fwd, bwd, grads] = raster_sources(
            config.atomics,
            config.backward_threads,
            config.forward_threads,
        );
        let pre = shader(&ctx, pre.0, &pre.1);
        let fwd = shader(&ctx, fwd.0, &fwd.1);
        let bwd = shader(&ctx, bwd.0, &bwd.1);
        let grads = shader(&ctx, grads.0, &grads.1);
        let kernels = RasterKernels {
            scan: GpuScan::new(&ctx),
            sort: GpuSort::new(&ctx),
            vertex_pre: Kernel::new(&ctx, &pre, "vertex_pre"),
            face_pre: Kernel::new(&ctx, &pre, "face_pre"),
            tile_counts: Kernel::new(&ctx, &pre, "tile_counts"),
            frame_region: Kernel::new(&ctx, &pre, "frame_region"),
            emit_entries: Kernel::new(&ctx, &pre, "emit_entries"),
            pad_entries: Kernel::new(&ctx, &pre, "pad_entries"),
            gather_tiles: Kernel::new(&ctx, &pre, "gather_tiles"),
            tile_ranges: Kernel::new(&ctx, &pre, "tile_ranges"),
            forward: Kernel::new(&ctx, &fwd, "forward"),
            backward: Kernel::new(&ctx, &bwd, "backward"),
            face_backward: Kernel::new(&ctx, &grads, "face_backward"),
            vertex_backward: Kernel::new(&ctx, &grads, "vertex_backward"),
        };
        ctx.check_errors("compiling the raster kernels")?;
        Ok(WgpuBackend {
            ctx,
            kernels: Arc::new(kernels),
            config,
        })
    }

    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    pub fn float_atomics(&self) -> FloatAtomics {
        self.config.atomics
    }

    pub fn config(&self) -> KernelConfig {
        self.config
    }

    /// An error naming the buffer when it exceeds the device's storage binding limit.
    pub(crate) fn check_binding_size(&self, what: &str, bytes: u64) -> Result<()> {
        let limit = self.ctx.device.limits().max_storage_buffer_binding_size;
        if bytes > limit {
            bail!(
                "the {what} need {bytes} bytes, more than {} allows in one storage binding ({limit} bytes); use the cpu backend or a larger device",
                self.ctx.adapter_info.name
            );
        }
        Ok(())
    }

    fn check_model(&self, model: &Model<f32>) -> Result<()> {
        model.validate().context("invalid model")?;
        let (nv, nf) = (model.vertex_count(), model.face_count());
        if nf >= u32::MAX as usize / 2 {
            bail!("model has {nf} faces, too many for the wgpu backend");
        }
        self.check_binding_size("face records", nf as u64 * FACE_BYTES)?;
        self.check_binding_size("SH coefficients", (nv * SH_COEFFS * 3 * 4) as u64)
    }

    /// Uploads a validated model's parameters into new buffers (its per-face
    /// σ for every face when it has one).
    pub(crate) fn upload_model(&self, model: &Model<f32>) -> Result<ModelBuffers> {
        let mut created = 0;
        let mut pool = ModelPool::new(&self.ctx, &mut created);
        self.upload_model_into(model, 0, &mut pool, &mut created)
    }

    /// Writes a validated model's parameters into pooled buffers (grown when
    /// too small) and describes them; `created` counts new buffers. Per-face σ
    /// applies from face `first_own_sigma` on (the faces before it are trained
    /// and take each render's σ).
    pub(crate) fn upload_model_into(
        &self,
        model: &Model<f32>,
        first_own_sigma: usize,
        pool: &mut ModelPool,
        created: &mut u64,
    ) -> Result<ModelBuffers> {
        self.check_model(model)?;
        let ctx = &self.ctx;
        let positions: Vec<f32> = model.vertices.iter().flatten().copied().collect();
        let face_idx: Vec<u32> = model.faces.iter().flatten().copied().collect();
        let sh: Vec<f32> = model.sh.iter().flatten().flatten().copied().collect();
        let (face_sigma, sigma_from) = face_sigma_of(model, first_own_sigma);
        let ModelPool {
            positions: p,
            sh: s,
            opacity_logits: o,
            face_indices: f,
            face_sigma: fs,
        } = pool;
        p.write(ctx, &positions, created);
        s.write(ctx, &sh, created);
        o.write(ctx, &model.opacity_logits, created);
        f.write(ctx, &face_idx, created);
        fs.write(ctx, &face_sigma, created);
        Ok(ModelBuffers {
            positions: p.buffer().clone(),
            sh: s.buffer().clone(),
            opacity_logits: o.buffer().clone(),
            face_indices: f.buffer().clone(),
            face_sigma: fs.buffer().clone(),
            vertex_count: model.vertex_count(),
            face_count: model.face_count(),
            sigma_from,
            opacity_floor: model.opacity_floor as f32,
        })
    }

    /// The uniform block of a render (entry count 0: preprocessing).
    fn raster_params(
        &self,
        model: &ModelBuffers,
        camera: &Camera,
        settings: &RenderSettings,
        background: BackgroundSource<'_>,
    ) -> Result<RasterParams> {
        camera
            .validate()
            .map_err(anyhow::Error::msg)
            .context("invalid camera")?;
        settings.validate()?;
        let pixels = camera.width as usize * camera.height as usize;
        self.check_binding_size("image", (pixels * IMAGE_STRIDE * 4) as u64)?;
        let (uniform_background, background_color) = match background {
            BackgroundSource::Uniform(c) => {
                if c.iter().any(|v| !v.is_finite()) {
                    bail!("background colour {c:?} is not finite");
                }
                (1, [c[0], c[1], c[2], 0.0])
            }
            BackgroundSource::Image(b) => {
                check_buffer("background", b, pixels * 3)?;
                (0, [0.0; 4])
            }
        };
        let (region_mode, include, margin) = match settings.region {
            Region::Full => (0, PixelRect::default(), 0),
            Region::Footprint { include, margin } => (1, include, margin),
        };
        let cam = CameraParams::<f32>::new(camera);
        Ok(RasterParams {
            rot: [0, 1, 2].map(|i| {
                [
                    cam.rotation[i][0],
                    cam.rotation[i][1],
                    cam.rotation[i][2],
                    cam.translation[i],
                ]
            }),
            center: [cam.center[0], cam.center[1], cam.center[2], 0.0],
            fx: cam.fx,
            fy: cam.fy,
            cx: cam.cx,
            cy: cam.cy,
            width: camera.width,
            height: camera.height,
            tiles_x: camera.width.div_ceil(TILE),
            tiles_y: camera.height.div_ceil(TILE),
            vertex_count: model.vertex_count as u32,
            face_count: model.face_count as u32,
            sh_degree: settings.sh_degree,
            entry_count: 0,
            sigma: settings.sigma as f32,
            z_near: settings.z_near as f32,
            min_centroid_depth: settings.min_centroid_depth as f32,
            min_abs_cos: settings.min_abs_cos as f32,
            min_opacity: settings.min_opacity as f32,
            max_screen_extent: settings.max_screen_extent as f32,
            min_screen_extent: settings.min_screen_extent as f32,
            min_inradius: settings.min_inradius as f32,
            alpha_max: settings.alpha_max as f32,
            alpha_min: settings.alpha_min as f32,
            transmittance_min: settings.transmittance_min as f32,
            opacity_floor: model.opacity_floor,
            include_x0: include.x0,
            include_y0: include.y0,
            include_x1: include.x1,
            include_y1: include.y1,
            margin,
            region_mode,
            uniform_background,
            sigma_from: model.sigma_from.min(u32::MAX as usize) as u32,
            background_color,
        })
    }

    /// Records projection, culling, the faces' slot order, the entry offsets
    /// and the frame record (entry count, region).
    fn encode_preprocess(
        &self,
        rec: &mut Recorder<'_>,
        pool: &mut RasterPool,
        model: &ModelBuffers,
        params: &RasterParams,
    ) {
        let k = &self.kernels;
        let (nv, nf) = (model.vertex_count, model.face_count);
        let tiles = params.tiles_x * params.tiles_y;
        rec.enc.clear_buffer(&pool.frame, 0, None);
        rec.dispatch(
            &k.vertex_pre,
            params,
            &[
                (1, &model.positions),
                (3, &model.sh),
                (4, &model.opacity_logits),
                (5, pool.vertices.buffer()),
            ],
            groups_for(nv, THREADS_1D),
        );
        rec.dispatch(
            &k.face_pre,
            params,
            &[
                (2, &model.face_indices),
                (5, pool.vertices.buffer()),
                (6, pool.faces.buffer()),
                (7, pool.order_keys.buffer()),
                (8, pool.order_faces.buffer()),
                (17, &pool.frame),
                (18, &model.face_sigma),
            ],
            groups_for(nf, THREADS_1D),
        );
        k.sort.encode(
            rec,
            &k.scan,
            &SortBuffers {
                keys: pool.order_keys.buffer(),
                values: pool.order_faces.buffer(),
                scratch_keys: pool.order_scratch_keys.buffer(),
                scratch_values: pool.order_scratch_faces.buffer(),
            },
            nf,
            key_bits(tiles),
            &mut pool.sort,
        );
        rec.dispatch(
            &k.tile_counts,
            params,
            &[
                (6, pool.faces.buffer()),
                (8, pool.order_faces.buffer()),
                (9, pool.entry_offsets.buffer()),
            ],
            groups_for(nf + 1, THREADS_1D),
        );
        k.scan
            .encode(rec, pool.entry_offsets.buffer(), nf + 1, &mut pool.scan);
        rec.dispatch(
            &k.frame_region,
            params,
            &[(9, pool.entry_offsets.buffer()), (17, &pool.frame)],
            1,
        );
    }

    /// Records the tile entries (`params.entry_count` of them sorted: the real
    /// count, or the buffers' capacity with `pad`), their two sorts, the tile
    /// ranges and the compositing over `tile_groups` workgroups.
    fn encode_composite(
        &self,
        rec: &mut Recorder<'_>,
        pool: &mut RasterPool,
        params: &RasterParams,
        pad: bool,
        tile_groups: u32,
    ) {
        let k = &self.kernels;
        let nf = params.face_count as usize;
        let n = params.entry_count as usize;
        let tiles = params.tiles_x * params.tiles_y;
        rec.enc.clear_buffer(pool.tile_ranges.buffer(), 0, None);
        rec.enc.clear_buffer(pool.face_stats.buffer(), 0, None);
        rec.dispatch(
            &k.emit_entries,
            params,
            &[
                (6, pool.faces.buffer()),
                (8, pool.order_faces.buffer()),
                (9, pool.entry_offsets.buffer()),
                (10, pool.depth_keys.buffer()),
                (11, pool.entry_ids.buffer()),
                (12, pool.entry_tiles.buffer()),
                (13, pool.entry_faces.buffer()),
            ],
            groups_for(nf, THREADS_1D),
        );
        if pad {
            rec.dispatch(
                &k.pad_entries,
                params,
                &[
                    (10, pool.depth_keys.buffer()),
                    (11, pool.entry_ids.buffer()),
                    (12, pool.entry_tiles.buffer()),
                    (13, pool.entry_faces.buffer()),
                    (17, &pool.frame),
                ],
                groups_for(n, THREADS_1D),
            );
        }
        k.sort.encode(
            rec,
            &k.scan,
            &SortBuffers {
                keys: pool.depth_keys.buffer(),
                values: pool.entry_ids.buffer(),
                scratch_keys: pool.scratch_a.buffer(),
                scratch_values: pool.scratch_b.buffer(),
            },
            n,
            32,
            &mut pool.sort,
        );
        rec.dispatch(
            &k.gather_tiles,
            params,
            &[
                (11, pool.entry_ids.buffer()),
                (12, pool.entry_tiles.buffer()),
                (13, pool.entry_faces.buffer()),
                (14, pool.tile_keys.buffer()),
                (15, pool.entries.buffer()),
            ],
            groups_for(n, THREADS_1D),
        );
        // Keys up to `tiles` inclusive: padding sorts after the last tile.
        k.sort.encode(
            rec,
            &k.scan,
            &SortBuffers {
                keys: pool.tile_keys.buffer(),
                values: pool.entries.buffer(),
                scratch_keys: pool.scratch_a.buffer(),
                scratch_values: pool.scratch_b.buffer(),
            },
            n,
            key_bits(tiles),
            &mut pool.sort,
        );
        rec.dispatch(
            &k.tile_ranges,
            params,
            &[
                (14, pool.tile_keys.buffer()),
                (16, pool.tile_ranges.buffer()),
            ],
            groups_for(n, THREADS_1D),
        );
        rec.dispatch(
            &k.forward,
            params,
            &[
                (1, pool.tile_ranges.buffer()),
                (2, pool.entries.buffer()),
                (3, pool.faces.buffer()),
                (4, pool.background.buffer()),
                (5, pool.image.buffer()),
                (6, pool.pixel_state.buffer()),
                (7, pool.face_stats.buffer()),
                (8, &pool.frame),
            ],
            tile_groups,
        );
    }

    /// Renders resident parameters into `pool`'s buffers, over the region
    /// `settings.region` asks for. The one host round trip reads the frame
    /// record back (tile-entry count and region), which sizes the entry
    /// buffers and the dispatches.
    pub(crate) fn render_on<'p>(
        &self,
        pool: &'p mut RasterPool,
        uniforms: &mut UniformArena,
        model: &ModelBuffers,
        camera: &Camera,
        settings: &RenderSettings,
        background: BackgroundSource<'_>,
    ) -> Result<&'p Rendered> {
        let ctx = &*self.ctx;
        let mut params = self.raster_params(model, camera, settings, background)?;
        let frame =
            self.preprocess_and_read_frame(pool, uniforms, model, &params, FRAME_READ_WORDS)?;
        let entry_count = frame[0] as usize;
        let region = PixelRect {
            x0: frame[1],
            y0: frame[2],
            x1: frame[3],
            y1: frame[4],
        };
        self.check_binding_size("tile entries", entry_count as u64 * 4)?;
        pool.ensure_entries(ctx, entry_count);
        pool.ensure_pixels(
            ctx,
            region.pixels(),
            (params.tiles_x * params.tiles_y) as usize,
        );
        if let BackgroundSource::Image(full) = background {
            let w = camera.width as usize;
            let mut part = Vec::with_capacity(region.pixels() * 3);
            for y in region.y0 as usize..region.y1 as usize {
                part.extend_from_slice(
                    &full[3 * (y * w + region.x0 as usize)..3 * (y * w + region.x1 as usize)],
                );
            }
            pool.background.write(ctx, &part, &mut pool.created);
        }
        params.entry_count = entry_count as u32;
        let mut rec = Recorder::new(ctx, uniforms);
        self.encode_composite(&mut rec, pool, &params, false, region_tiles(region));
        rec.submit();
        ctx.check_errors("the wgpu forward pass")?;
        Ok(pool.last.insert(Rendered {
            params,
            model: model.clone(),
            region,
        }))
    }

    /// Records a render of resident parameters over a uniform `background`
    /// without reading anything back: the entry buffers are sorted at their
    /// capacity (`pool.entry_capacity()`, at least 1), padded past the real
    /// count, and every tile of the image gets a workgroup (those outside the
    /// region return at once). The frame record's entry count tells the caller
    /// afterwards whether the capacity sufficed; if not, the render is wrong
    /// and must be redone with larger buffers. Pixels of a render that fits are
    /// bit-identical to [`WgpuBackend::render_on`]'s.
    pub(crate) fn encode_render(
        &self,
        rec: &mut Recorder<'_>,
        pool: &mut RasterPool,
        model: &ModelBuffers,
        camera: &Camera,
        settings: &RenderSettings,
        background: [f32; 3],
    ) -> Result<RasterParams> {
        let ctx = rec.ctx();
        let mut params = self.raster_params(
            model,
            camera,
            settings,
            BackgroundSource::Uniform(background),
        )?;
        pool.last = None;
        pool.ensure_model(ctx, model.vertex_count, model.face_count);
        let tiles = params.tiles_x * params.tiles_y;
        let pixels = camera.width as usize * camera.height as usize;
        pool.ensure_pixels(ctx, pixels, tiles as usize);
        pool.ensure_entries(ctx, 1);
        self.encode_preprocess(rec, pool, model, &params);
        params.entry_count = pool.entry_capacity() as u32;
        self.encode_composite(rec, pool, &params, true, tiles);
        Ok(params)
    }

    /// The tile entries a render of `model` from `camera` needs (one
    /// preprocessing pass and a readback of its count), to size the entry
    /// buffers of renders recorded without a readback ([`WgpuBackend::encode_render`]).
    pub(crate) fn measure_entries(
        &self,
        pool: &mut RasterPool,
        uniforms: &mut UniformArena,
        model: &ModelBuffers,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<usize> {
        let ctx = &*self.ctx;
        let params =
            self.raster_params(model, camera, settings, BackgroundSource::Uniform([0.0; 3]))?;
        let frame = self.preprocess_and_read_frame(pool, uniforms, model, &params, 1)?;
        ctx.check_errors("measuring a render's tile entries")?;
        Ok(frame[0] as usize)
    }

    /// Runs the preprocessing pass (a fresh frame: no render is current) and reads the
    /// first `words` words of the frame record back: the one host round trip of a render.
    fn preprocess_and_read_frame(
        &self,
        pool: &mut RasterPool,
        uniforms: &mut UniformArena,
        model: &ModelBuffers,
        params: &RasterParams,
        words: usize,
    ) -> Result<Vec<u32>> {
        let ctx = &*self.ctx;
        pool.last = None;
        pool.ensure_model(ctx, model.vertex_count, model.face_count);
        let mut rec = Recorder::new(ctx, uniforms);
        self.encode_preprocess(&mut rec, pool, model, params);
        rec.enc
            .copy_buffer_to_buffer(&pool.frame, 0, &pool.staging, 0, FRAME_BYTES);
        rec.submit();
        let frame =
            bytemuck::pod_collect_to_vec(&map_and_copy(ctx, &pool.staging, (words * 4) as u64)?);
        pool.syncs += 1;
        Ok(frame)
    }

    /// Reads a forward pass's image and face statistics back to the host.
    fn read_output(&self, pool: &RasterPool) -> Result<RenderOutput<f32>> {
        let Some(r) = pool.last() else {
            bail!("no render to read back");
        };
        let p = &r.params;
        let pixels = r.region.pixels();
        let nf = r.model.face_count;
        let [image, stats]: [Vec<u8>; 2] = read_buffers(
            &self.ctx,
            &[
                (pool.image(), (pixels * IMAGE_STRIDE * 4) as u64),
                (pool.face_stats(), (nf * 2 * 4) as u64),
            ],
        )?
        .try_into()
        .map_err(|_| anyhow::anyhow!("two readbacks were asked for"))?;
        let image: Vec<f32> = bytemuck::pod_collect_to_vec(&image);
        let stats: Vec<u32> = bytemuck::pod_collect_to_vec(&stats);
        let mut out = RenderOutput {
            width: p.width,
            height: p.height,
            region: r.region,
            color: vec![0.0; pixels * 3],
            alpha: vec![0.0; pixels],
            depth: vec![0.0; pixels],
            median_depth: vec![0.0; pixels],
            face_max_weight: vec![0.0; nf],
            face_pixel_count: vec![0; nf],
        };
        for (i, px) in image.chunks_exact(IMAGE_STRIDE).enumerate() {
            out.color[i * 3..i * 3 + 3].copy_from_slice(&px[..3]);
            out.alpha[i] = px[3];
            out.depth[i] = px[4];
            out.median_depth[i] = px[5];
        }
        for (f, s) in stats.chunks_exact(2).enumerate() {
            out.face_max_weight[f] = f32::from_bits(s[0]);
            out.face_pixel_count[f] = s[1];
        }
        Ok(out)
    }

    fn forward_impl(
        &self,
        model: &Model<f32>,
        camera: &Camera,
        settings: &RenderSettings,
        background: &[f32],
    ) -> Result<(RenderOutput<f32>, WgpuSaved)> {
        let pixels = camera.width as usize * camera.height as usize;
        check_buffer("background", background, pixels * 3)?;
        let buffers = self.upload_model(model)?;
        let mut pool = RasterPool::new(&self.ctx);
        let mut uniforms = UniformArena::default();
        self.render_on(
            &mut pool,
            &mut uniforms,
            &buffers,
            camera,
            settings,
            BackgroundSource::Image(background),
        )?;
        let out = self.read_output(&pool)?;
        if !out.all_finite() {
            bail!("the wgpu forward pass produced non-finite values");
        }
        Ok((out, WgpuSaved { pool }))
    }

    fn backward_impl(
        &self,
        model: &Model<f32>,
        saved: &WgpuSaved,
        grads: &OutputGrads<'_, f32>,
    ) -> Result<ModelGrads<f32>> {
        let Some(rendered) = saved.pool.last() else {
            bail!("backward pass before a forward pass");
        };
        let (nv, nf) = (rendered.model.vertex_count, rendered.model.face_count);
        if model.vertex_count() != nv || model.face_count() != nf {
            bail!(
                "backward got a model with {} vertices / {} faces, but the forward pass rendered {nv} / {nf}",
                model.vertex_count(),
                model.face_count(),
            );
        }
        let pixels = rendered.region.pixels();
        grads.validate(pixels)?;
        let mut upstream = vec![0f32; pixels * IMAGE_STRIDE];
        for i in 0..pixels {
            let u = &mut upstream[i * IMAGE_STRIDE..(i + 1) * IMAGE_STRIDE];
            u[..3].copy_from_slice(&grads.color[i * 3..i * 3 + 3]);
            u[3] = grads.alpha.map_or(0.0, |a| a[i]);
            u[4] = grads.depth.map_or(0.0, |d| d[i]);
            u[5] = grads.median_depth.map_or(0.0, |m| m[i]);
        }
        let ctx = &self.ctx;
        let upstream = storage_from(ctx, "upstream gradients", &upstream);
        let mut pool = GradPool::new(ctx);
        let mut uniforms = UniformArena::default();
        self.backward_on(&saved.pool, &mut pool, &mut uniforms, &upstream)?;
        let [positions, sh, logits, background]: [Vec<u8>; 4] = read_buffers(
            ctx,
            &[
                (pool.positions(), (nv * 3 * 4) as u64),
                (pool.sh(), (nv * SH_COEFFS * 3 * 4) as u64),
                (pool.opacity_logits(), (nv * 4) as u64),
                (pool.background.buffer(), (pixels * 3 * 4) as u64),
            ],
        )?
        .try_into()
        .map_err(|_| anyhow::anyhow!("four readbacks were asked for"))?;
        let positions: Vec<f32> = bytemuck::pod_collect_to_vec(&positions);
        let sh: Vec<f32> = bytemuck::pod_collect_to_vec(&sh);
        let logits: Vec<f32> = bytemuck::pod_collect_to_vec(&logits);
        let background: Vec<f32> = bytemuck::pod_collect_to_vec(&background);
        let mut result = ModelGrads::<f32>::zeros(nv, pixels);
        for v in 0..nv {
            result.vertices[v].copy_from_slice(&positions[v * 3..v * 3 + 3]);
            for c in 0..SH_COEFFS {
                let at = (v * SH_COEFFS + c) * 3;
                result.sh[v][c].copy_from_slice(&sh[at..at + 3]);
            }
        }
        result.opacity_logits = logits;
        result.background = background;
        if !result.all_finite() {
            bail!("the wgpu backward pass produced non-finite gradients");
        }
        Ok(result)
    }

    /// The backward pass on the device of `pool`'s last render from
    /// `upstream`: per pixel of its region, the loss's gradient with respect
    /// to colour, alpha, depth and median depth (stride 6). The gradients land
    /// in `grads`.
    pub(crate) fn backward_on(
        &self,
        pool: &RasterPool,
        grads: &mut GradPool,
        uniforms: &mut UniformArena,
        upstream: &wgpu::Buffer,
    ) -> Result<()> {
        let Some(rendered) = pool.last() else {
            bail!("backward pass before a forward pass that read its region back");
        };
        let ctx = &*self.ctx;
        let mut rec = Recorder::new(ctx, uniforms);
        self.encode_backward(
            &mut rec,
            pool,
            grads,
            &rendered.params,
            &rendered.model,
            BackwardCover {
                pixels: rendered.region.pixels(),
                tile_groups: region_tiles(rendered.region),
            },
            upstream,
        );
        rec.submit();
        ctx.check_errors("the wgpu backward pass")
    }

    /// Records the backward pass of the render in `pool` (of `model` with
    /// `p`) from `upstream`, over `cover`'s tiles: the region's, or every
    /// tile of the image for a render recorded without a readback.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn encode_backward(
        &self,
        rec: &mut Recorder<'_>,
        pool: &RasterPool,
        grads: &mut GradPool,
        p: &RasterParams,
        model: &ModelBuffers,
        cover: BackwardCover,
        upstream: &wgpu::Buffer,
    ) {
        let pixels = cover.pixels;
        let (nv, nf) = (model.vertex_count, model.face_count);
        let ctx = rec.ctx();
        let k = &self.kernels;
        let c = &mut grads.created;
        grads.background.ensure(ctx, (pixels * 3 * 4) as u64, c);
        let face_bytes = (nf * PARTIAL * 4) as u64;
        let vertex_bytes = (nv * VERTEX_ACCUMULATORS * 4) as u64;
        grads.face_grads.ensure(ctx, face_bytes, c);
        grads.vertex_grads.ensure(ctx, vertex_bytes, c);
        grads.positions.ensure(ctx, (nv * 3 * 4) as u64, c);
        grads.sh.ensure(ctx, (nv * SH_COEFFS * 3 * 4) as u64, c);
        grads.opacity_logits.ensure(ctx, (nv * 4) as u64, c);
        if face_bytes > 0 {
            rec.enc
                .clear_buffer(grads.face_grads.buffer(), 0, Some(face_bytes));
        }
        if vertex_bytes > 0 {
            rec.enc
                .clear_buffer(grads.vertex_grads.buffer(), 0, Some(vertex_bytes));
        }
        rec.dispatch(
            &k.backward,
            p,
            &[
                (1, pool.tile_ranges.buffer()),
                (2, pool.entries.buffer()),
                (3, pool.faces.buffer()),
                (4, pool.pixel_state.buffer()),
                (5, upstream),
                (6, pool.background.buffer()),
                (7, grads.background.buffer()),
                (8, grads.face_grads.buffer()),
                (9, &pool.frame),
            ],
            cover.tile_groups,
        );
        rec.dispatch(
            &k.face_backward,
            p,
            &[
                (1, pool.faces.buffer()),
                (2, &model.face_indices),
                (9, grads.face_grads.buffer()),
                (10, grads.vertex_grads.buffer()),
            ],
            groups_for(nf, THREADS_1D),
        );
        rec.dispatch(
            &k.vertex_backward,
            p,
            &[
                (3, pool.vertices.buffer()),
                (4, &model.sh),
                (5, &model.opacity_logits),
                (6, grads.positions.buffer()),
                (7, grads.sh.buffer()),
                (8, grads.opacity_logits.buffer()),
                (10, grads.vertex_grads.buffer()),
            ],
            groups_for(nv, THREADS_1D),
        );
    }
}

/// What a backward pass covers: pixels of its buffers and tiles dispatched.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BackwardCover {
    pub pixels: usize,
    pub tile_groups: u32,
}

impl BackwardCover {
    /// Every tile of a `width`×`height` image (tiles outside the rendered region return at once).
    pub fn whole_image(width: u32, height: u32) -> Self {
        BackwardCover {
            pixels: width as usize * height as usize,
            tile_groups: width.div_ceil(TILE) * height.div_ceil(TILE),
        }
    }
}

/// Tiles of a tile-aligned region (the forward and backward workgroups).
fn region_tiles(region: PixelRect) -> u32 {
    region.width().div_ceil(TILE) * region.height().div_ceil(TILE)
}

/// What the trait's forward pass saves: its pool, holding the render.
struct WgpuSaved {
    pool: RasterPool,
}

impl RenderBackend<f32> for WgpuBackend {
    fn name(&self) -> &'static str {
        BACKEND_NAME
    }

    fn forward(
        &self,
        model: &Model<f32>,
        camera: &Camera,
        settings: &RenderSettings,
        background: &[f32],
    ) -> Result<(RenderOutput<f32>, SavedForward)> {
        let (out, saved) = self.forward_impl(model, camera, settings, background)?;
        Ok((out, SavedForward::new(BACKEND_NAME, saved)))
    }

    fn backward(
        &self,
        model: &Model<f32>,
        saved: &SavedForward,
        grads: &OutputGrads<'_, f32>,
    ) -> Result<ModelGrads<f32>> {
        self.backward_impl(model, saved.state_of::<WgpuSaved>(BACKEND_NAME)?, grads)
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use objectsplat_gpu::{check_mirrors_wgsl, wgsl_struct_layout};
    use std::mem::{offset_of, size_of};

    /// The common declarations as compiled (raster_common.wgsl alone refers to
    /// bindings each program declares).
    fn compiled_source() -> String {
        let [pre, ..] = raster_sources(FloatAtomics::CompareExchange, 128, 256);
        pre.1
    }

    #[test]
    fn raster_params_mirror_the_wgsl_struct() {
        let rot = offset_of!(RasterParams, rot);
        macro_rules! same_names {
            ($($f:ident),*) => { [$((stringify!($f), offset_of!(RasterParams, $f))),*] };
        }
        let mut rust = vec![("rot0", rot), ("rot1", rot + 16), ("rot2", rot + 32)];
        rust.extend(same_names!(
            center,
            fx,
            fy,
            cx,
            cy,
            width,
            height,
            tiles_x,
            tiles_y,
            vertex_count,
            face_count,
            sh_degree,
            entry_count,
            sigma,
            z_near,
            min_centroid_depth,
            min_abs_cos,
            min_opacity,
            max_screen_extent,
            min_screen_extent,
            min_inradius,
            alpha_max,
            alpha_min,
            transmittance_min,
            opacity_floor,
            include_x0,
            include_y0,
            include_x1,
            include_y1,
            margin,
            region_mode,
            uniform_background,
            sigma_from,
            background_color
        ));
        check_mirrors_wgsl(
            &compiled_source(),
            "RasterParams",
            size_of::<RasterParams>(),
            &rust,
        )
        .unwrap();
    }

    #[test]
    fn face_and_vertex_record_sizes_match_the_wgsl_structs() {
        let source = compiled_source();
        let size = |name| wgsl_struct_layout(&source, name).unwrap().0 as u64;
        assert_eq!(size("Face"), FACE_BYTES);
        assert_eq!(size("Vertex"), VERTEX_BYTES);
    }
}
