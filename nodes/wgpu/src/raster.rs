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

use crate::atomics::{FloatAtomics, accumulator_wgsl};
use crate::device::{GpuContext, map_and_copy, read_buffers};
use crate::kernels::{Kernel, groups_for, shader, storage, storage_from, uniform};
use crate::scan::GpuScan;
use crate::sort::{GpuSort, SortBuffers, key_bits};
use anyhow::{Context, Result, bail};
use objectsplat_core::Camera;
use objectsplat_raster::backend::check_buffer;
use objectsplat_raster::cpu::preprocess::CameraParams;
use objectsplat_raster::{
    Model, ModelGrads, OutputGrads, RenderBackend, RenderOutput, RenderSettings, SH_COEFFS,
    SavedForward,
};
use std::sync::Arc;

pub const RASTER_COMMON_WGSL: &str = include_str!("raster_common.wgsl");
pub const RASTER_PRE_WGSL: &str = include_str!("raster_pre.wgsl");
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
            with_common(RASTER_FORWARD_WGSL, forward_constants),
        ),
        (
            "raster_backward.wgsl",
            with_common(
                RASTER_BACKWARD_WGSL,
                backward_constants + &accumulator_wgsl(mode, "face_grad", "face_grads", 8),
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
struct RasterParams {
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
}

struct RasterKernels {
    scan: GpuScan,
    sort: GpuSort,
    vertex_pre: Kernel,
    face_pre: Kernel,
    tile_counts: Kernel,
    emit_entries: Kernel,
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
/// (3 per vertex), SH (16×3 per vertex), opacity logits, face indices.
#[derive(Clone)]
pub(crate) struct ModelBuffers {
    pub positions: wgpu::Buffer,
    pub sh: wgpu::Buffer,
    pub opacity_logits: wgpu::Buffer,
    pub face_indices: wgpu::Buffer,
    pub vertex_count: usize,
    pub face_count: usize,
    pub opacity_floor: f32,
}

/// What the forward pass leaves on the device: its image and face statistics,
/// and everything the backward pass reads.
pub(crate) struct WgpuSaved {
    params: RasterParams,
    model: ModelBuffers,
    background: wgpu::Buffer,
    vertices: wgpu::Buffer,
    faces: wgpu::Buffer,
    entries: wgpu::Buffer,
    tile_ranges: wgpu::Buffer,
    pixel_state: wgpu::Buffer,
    /// Per pixel: colour, alpha, depth, median depth (stride 6).
    pub image: wgpu::Buffer,
    /// Per face: max blending weight (f32 bits), pixel count.
    face_stats: wgpu::Buffer,
}

/// The backward pass's gradients on the device, in [`ModelBuffers`]' layout.
pub(crate) struct GradBuffers {
    pub positions: wgpu::Buffer,
    pub sh: wgpu::Buffer,
    pub opacity_logits: wgpu::Buffer,
    background: wgpu::Buffer,
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
            emit_entries: Kernel::new(&ctx, &pre, "emit_entries"),
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

    fn encoder(&self) -> wgpu::CommandEncoder {
        self.ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default())
    }

    /// An error naming the buffer when it exceeds the device's storage binding limit.
    fn check_binding_size(&self, what: &str, bytes: u64) -> Result<()> {
        let limit = self.ctx.device.limits().max_storage_buffer_binding_size;
        if bytes > limit {
            bail!(
                "the {what} need {bytes} bytes, more than {} allows in one storage binding ({limit} bytes); use the cpu backend or a larger device",
                self.ctx.adapter_info.name
            );
        }
        Ok(())
    }

    fn staging(&self, bytes: u64) -> wgpu::Buffer {
        self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("staging"),
            size: bytes.max(4).div_ceil(4) * 4,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Uploads a validated model's parameters.
    pub(crate) fn upload_model(&self, model: &Model<f32>) -> Result<ModelBuffers> {
        model.validate().context("invalid model")?;
        let (nv, nf) = (model.vertex_count(), model.face_count());
        if nf >= u32::MAX as usize / 2 {
            bail!("model has {nf} faces, too many for the wgpu backend");
        }
        self.check_binding_size("face records", nf as u64 * FACE_BYTES)?;
        self.check_binding_size("SH coefficients", (nv * SH_COEFFS * 3 * 4) as u64)?;
        let ctx = &self.ctx;
        let positions: Vec<f32> = model.vertices.iter().flatten().copied().collect();
        let face_idx: Vec<u32> = model.faces.iter().flatten().copied().collect();
        let sh: Vec<f32> = model.sh.iter().flatten().flatten().copied().collect();
        Ok(ModelBuffers {
            positions: storage_from(ctx, "positions", &positions),
            sh: storage_from(ctx, "sh", &sh),
            opacity_logits: storage_from(ctx, "opacity logits", &model.opacity_logits),
            face_indices: storage_from(ctx, "face indices", &face_idx),
            vertex_count: nv,
            face_count: nf,
            opacity_floor: model.opacity_floor as f32,
        })
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
        let background = storage_from(&self.ctx, "background", background);
        let saved = self.render_on(&buffers, camera, settings, &background)?;
        let out = self.read_output(&saved)?;
        if !out.all_finite() {
            bail!("the wgpu forward pass produced non-finite values");
        }
        Ok((out, saved))
    }

    /// The forward pass of resident parameters into device buffers. The one
    /// host round trip is the tile-entry count, which sizes the entry buffers.
    pub(crate) fn render_on(
        &self,
        model: &ModelBuffers,
        camera: &Camera,
        settings: &RenderSettings,
        background: &wgpu::Buffer,
    ) -> Result<WgpuSaved> {
        camera
            .validate()
            .map_err(anyhow::Error::msg)
            .context("invalid camera")?;
        settings.validate()?;
        let (w, h) = (camera.width as usize, camera.height as usize);
        let pixels = w * h;
        let (nv, nf) = (model.vertex_count, model.face_count);
        let ctx = &self.ctx;
        let k = &self.kernels;
        self.check_binding_size("image", (pixels * IMAGE_STRIDE * 4) as u64)?;
        let cam = CameraParams::<f32>::new(camera);
        let (tiles_x, tiles_y) = (camera.width.div_ceil(TILE), camera.height.div_ceil(TILE));
        let tiles = (tiles_x * tiles_y) as usize;
        let mut params = RasterParams {
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
            tiles_x,
            tiles_y,
            vertex_count: nv as u32,
            face_count: nf as u32,
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
        };
        let vertices = storage(ctx, "vertices", nv as u64 * VERTEX_BYTES);
        let faces = storage(ctx, "faces", nf as u64 * FACE_BYTES);
        let order_keys = storage(ctx, "order keys", nf as u64 * 4);
        let order_faces = storage(ctx, "order faces", nf as u64 * 4);
        let order_scratch_keys = storage(ctx, "order scratch keys", nf as u64 * 4);
        let order_scratch_faces = storage(ctx, "order scratch faces", nf as u64 * 4);
        let entry_offsets = storage(ctx, "entry offsets", (nf as u64 + 1) * 4);

        // Stage 1: preprocessing, slot order, entry offsets; the entry total comes back.
        let uniform_params = uniform(ctx, "raster params", &params);
        let mut enc = self.encoder();
        k.vertex_pre.dispatch(
            ctx,
            &mut enc,
            &[
                (0, &uniform_params),
                (1, &model.positions),
                (3, &model.sh),
                (4, &model.opacity_logits),
                (5, &vertices),
            ],
            groups_for(nv, THREADS_1D),
        );
        k.face_pre.dispatch(
            ctx,
            &mut enc,
            &[
                (0, &uniform_params),
                (2, &model.face_indices),
                (5, &vertices),
                (6, &faces),
                (7, &order_keys),
                (8, &order_faces),
            ],
            groups_for(nf, THREADS_1D),
        );
        k.sort.encode(
            ctx,
            &k.scan,
            &mut enc,
            &SortBuffers {
                keys: &order_keys,
                values: &order_faces,
                scratch_keys: &order_scratch_keys,
                scratch_values: &order_scratch_faces,
            },
            nf,
            key_bits(tiles as u32),
        );
        k.tile_counts.dispatch(
            ctx,
            &mut enc,
            &[
                (0, &uniform_params),
                (6, &faces),
                (8, &order_faces),
                (9, &entry_offsets),
            ],
            groups_for(nf + 1, THREADS_1D),
        );
        k.scan.encode(ctx, &mut enc, &entry_offsets, nf + 1);
        let total_staging = self.staging(4);
        enc.copy_buffer_to_buffer(&entry_offsets, nf as u64 * 4, &total_staging, 0, 4);
        ctx.queue.submit([enc.finish()]);
        let total: Vec<u32> = bytemuck::pod_collect_to_vec(&map_and_copy(ctx, &total_staging, 4)?);
        let entry_count = total[0] as usize;
        self.check_binding_size("tile entries", entry_count as u64 * 4)?;

        // Stage 2: entries, the two sorts, tile ranges, compositing.
        params.entry_count = entry_count as u32;
        let uniform_params = uniform(ctx, "raster params", &params);
        let e_bytes = entry_count as u64 * 4;
        let depth_keys = storage(ctx, "entry depth keys", e_bytes);
        let entry_ids = storage(ctx, "entry ids", e_bytes);
        let entry_tiles = storage(ctx, "entry tiles", e_bytes);
        let entry_faces = storage(ctx, "entry faces", e_bytes);
        let tile_keys = storage(ctx, "sorted tile keys", e_bytes);
        let entries = storage(ctx, "sorted entries", e_bytes);
        let scratch_a = storage(ctx, "sort scratch a", e_bytes);
        let scratch_b = storage(ctx, "sort scratch b", e_bytes);
        let tile_ranges = storage(ctx, "tile ranges", tiles as u64 * 8);
        let image = storage(ctx, "image", (pixels * IMAGE_STRIDE * 4) as u64);
        let pixel_state = storage(ctx, "pixel state", (pixels * STATE_STRIDE * 4) as u64);
        let face_stats = storage(ctx, "face stats", nf as u64 * 8);
        let mut enc = self.encoder();
        enc.clear_buffer(&tile_ranges, 0, None);
        enc.clear_buffer(&face_stats, 0, None);
        k.emit_entries.dispatch(
            ctx,
            &mut enc,
            &[
                (0, &uniform_params),
                (6, &faces),
                (8, &order_faces),
                (9, &entry_offsets),
                (10, &depth_keys),
                (11, &entry_ids),
                (12, &entry_tiles),
                (13, &entry_faces),
            ],
            groups_for(nf, THREADS_1D),
        );
        k.sort.encode(
            ctx,
            &k.scan,
            &mut enc,
            &SortBuffers {
                keys: &depth_keys,
                values: &entry_ids,
                scratch_keys: &scratch_a,
                scratch_values: &scratch_b,
            },
            entry_count,
            32,
        );
        k.gather_tiles.dispatch(
            ctx,
            &mut enc,
            &[
                (0, &uniform_params),
                (11, &entry_ids),
                (12, &entry_tiles),
                (13, &entry_faces),
                (14, &tile_keys),
                (15, &entries),
            ],
            groups_for(entry_count, THREADS_1D),
        );
        k.sort.encode(
            ctx,
            &k.scan,
            &mut enc,
            &SortBuffers {
                keys: &tile_keys,
                values: &entries,
                scratch_keys: &scratch_a,
                scratch_values: &scratch_b,
            },
            entry_count,
            key_bits(tiles.saturating_sub(1) as u32),
        );
        k.tile_ranges.dispatch(
            ctx,
            &mut enc,
            &[(0, &uniform_params), (14, &tile_keys), (16, &tile_ranges)],
            groups_for(entry_count, THREADS_1D),
        );
        k.forward.dispatch(
            ctx,
            &mut enc,
            &[
                (0, &uniform_params),
                (1, &tile_ranges),
                (2, &entries),
                (3, &faces),
                (4, background),
                (5, &image),
                (6, &pixel_state),
                (7, &face_stats),
            ],
            tiles as u32,
        );
        ctx.queue.submit([enc.finish()]);
        ctx.check_errors("the wgpu forward pass")?;
        Ok(WgpuSaved {
            params,
            model: model.clone(),
            background: background.clone(),
            vertices,
            faces,
            entries,
            tile_ranges,
            pixel_state,
            image,
            face_stats,
        })
    }

    /// Reads a forward pass's image and face statistics back to the host.
    fn read_output(&self, saved: &WgpuSaved) -> Result<RenderOutput<f32>> {
        let p = &saved.params;
        let pixels = p.width as usize * p.height as usize;
        let nf = saved.model.face_count;
        let [image, stats]: [Vec<u8>; 2] = read_buffers(
            &self.ctx,
            &[
                (&saved.image, (pixels * IMAGE_STRIDE * 4) as u64),
                (&saved.face_stats, (nf * 2 * 4) as u64),
            ],
        )?
        .try_into()
        .map_err(|_| anyhow::anyhow!("two readbacks were asked for"))?;
        let image: Vec<f32> = bytemuck::pod_collect_to_vec(&image);
        let stats: Vec<u32> = bytemuck::pod_collect_to_vec(&stats);
        // Regions are not cropped on this backend yet: every pass covers the whole image.
        let mut out = RenderOutput {
            width: p.width,
            height: p.height,
            region: objectsplat_raster::backend::PixelRect::full(p.width, p.height),
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

    fn backward_impl(
        &self,
        model: &Model<f32>,
        saved: &WgpuSaved,
        grads: &OutputGrads<'_, f32>,
    ) -> Result<ModelGrads<f32>> {
        let (nv, nf) = (saved.model.vertex_count, saved.model.face_count);
        if model.vertex_count() != nv || model.face_count() != nf {
            bail!(
                "backward got a model with {} vertices / {} faces, but the forward pass rendered {nv} / {nf}",
                model.vertex_count(),
                model.face_count(),
            );
        }
        let p = &saved.params;
        let pixels = p.width as usize * p.height as usize;
        grads.validate(pixels)?;
        let mut upstream = vec![0f32; pixels * IMAGE_STRIDE];
        for i in 0..pixels {
            let u = &mut upstream[i * IMAGE_STRIDE..(i + 1) * IMAGE_STRIDE];
            u[..3].copy_from_slice(&grads.color[i * 3..i * 3 + 3]);
            u[3] = grads.alpha.map_or(0.0, |a| a[i]);
            u[4] = grads.depth.map_or(0.0, |d| d[i]);
            u[5] = grads.median_depth.map_or(0.0, |m| m[i]);
        }
        let upstream = storage_from(&self.ctx, "upstream gradients", &upstream);
        let on_device = self.backward_on(saved, &upstream)?;
        let ctx = &self.ctx;
        let [positions, sh, logits, background]: [Vec<u8>; 4] = read_buffers(
            ctx,
            &[
                (&on_device.positions, (nv * 3 * 4) as u64),
                (&on_device.sh, (nv * SH_COEFFS * 3 * 4) as u64),
                (&on_device.opacity_logits, (nv * 4) as u64),
                (&on_device.background, (pixels * 3 * 4) as u64),
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

    /// The backward pass on the device from `upstream`: per pixel the loss's
    /// gradient with respect to colour, alpha, depth and median depth (stride 6).
    pub(crate) fn backward_on(
        &self,
        saved: &WgpuSaved,
        upstream: &wgpu::Buffer,
    ) -> Result<GradBuffers> {
        let p = &saved.params;
        let pixels = p.width as usize * p.height as usize;
        let (nv, nf) = (saved.model.vertex_count, saved.model.face_count);
        let tiles = (p.tiles_x * p.tiles_y) as usize;
        let ctx = &self.ctx;
        let k = &self.kernels;
        let uniform_params = uniform(ctx, "raster params", p);
        let background_grad = storage(ctx, "background gradient", (pixels * 3 * 4) as u64);
        let face_grads = storage(ctx, "face partials", (nf * PARTIAL * 4) as u64);
        let vertex_grads = storage(
            ctx,
            "vertex accumulators",
            (nv * VERTEX_ACCUMULATORS * 4) as u64,
        );
        let position_grad = storage(ctx, "position gradient", (nv * 3 * 4) as u64);
        let sh_grad = storage(ctx, "sh gradient", (nv * SH_COEFFS * 3 * 4) as u64);
        let logit_grad = storage(ctx, "logit gradient", (nv * 4) as u64);
        let mut enc = self.encoder();
        enc.clear_buffer(&face_grads, 0, None);
        enc.clear_buffer(&vertex_grads, 0, None);
        k.backward.dispatch(
            ctx,
            &mut enc,
            &[
                (0, &uniform_params),
                (1, &saved.tile_ranges),
                (2, &saved.entries),
                (3, &saved.faces),
                (4, &saved.pixel_state),
                (5, upstream),
                (6, &saved.background),
                (7, &background_grad),
                (8, &face_grads),
            ],
            tiles as u32,
        );
        k.face_backward.dispatch(
            ctx,
            &mut enc,
            &[
                (0, &uniform_params),
                (1, &saved.faces),
                (2, &saved.model.face_indices),
                (9, &face_grads),
                (10, &vertex_grads),
            ],
            groups_for(nf, THREADS_1D),
        );
        k.vertex_backward.dispatch(
            ctx,
            &mut enc,
            &[
                (0, &uniform_params),
                (3, &saved.vertices),
                (4, &saved.model.sh),
                (5, &saved.model.opacity_logits),
                (6, &position_grad),
                (7, &sh_grad),
                (8, &logit_grad),
                (10, &vertex_grads),
            ],
            groups_for(nv, THREADS_1D),
        );
        ctx.queue.submit([enc.finish()]);
        ctx.check_errors("the wgpu backward pass")?;
        Ok(GradBuffers {
            positions: position_grad,
            sh: sh_grad,
            opacity_logits: logit_grad,
            background: background_grad,
        })
    }
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
    use crate::device::{check_mirrors_wgsl, wgsl_struct_layout};
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
            opacity_floor
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
