//! The CPU reference backend: multi-threaded over rows of tiles (the
//! [`crate::parallel`] workers), deterministic for any thread count, generic
//! over f32/f64.
//!
//! Each tile is composited by one of two kernels: the scalar one (one pixel
//! at a time, any scalar type: the reference) or, for f32 on x86-64 CPUs with
//! AVX2 and FMA, the eight-lane one in [`simd`] (see [`Kernel`]). The rest
//! of both passes is shared.
//!
//! [`CpuBackend::forward_into`] and [`CpuBackend::backward_into`] work in a
//! caller-held [`CpuWorkspace`] whose buffers are reused from pass to pass, so
//! a training loop allocates nothing once they have grown to the model and the
//! image; the [`RenderBackend`] methods wrap them with a fresh workspace.

pub mod backward;
pub mod binning;
pub mod forward;
pub mod preprocess;
#[cfg(target_arch = "x86_64")]
pub mod simd;

use crate::backend::{
    OutputGrads, PixelRect, Region, RenderBackend, RenderOutput, RenderSettings, SavedForward,
    check_buffer,
};
use crate::model::{Model, ModelGrads, sigmoid};
use crate::parallel::{chunk_size, for_chunks_mut, run_iter};
use crate::real::Real;
use crate::sh;
use anyhow::{Context, Result, bail};
use backward::{CornerGrads, FacePartial, GradBand, PixelGrads, backward_tile, face_backward};
use binning::{SplitBy, TILE, TileGrid, TileLists};
pub use forward::Background;
use forward::{Band, EntryStats, PixelRules, TileFragments, render_tile};
use objectsplat_core::Camera;
use preprocess::{
    CameraParams, ScreenFace, VertexData, footprint, order_by_tile, preprocess_faces,
    preprocess_vertices, shade_vertices,
};
use std::ops::Range;

const BACKEND_NAME: &str = "cpu";

/// Which tile kernels the CPU backend runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Kernel {
    /// Eight f32 lanes per instruction where they exist (x86-64 with AVX2 and
    /// FMA, f32 models); the scalar kernels elsewhere.
    #[default]
    Simd,
    /// One pixel at a time on every CPU and scalar type: the reference.
    Scalar,
}

impl Kernel {
    /// [`Kernel::Scalar`] when the environment variable `OBJECTSPLAT_CPU_KERNEL`
    /// is `scalar` (to compare the paths on a whole run), else [`Kernel::Simd`].
    pub fn from_env() -> Self {
        match std::env::var("OBJECTSPLAT_CPU_KERNEL") {
            Ok(v) if v.eq_ignore_ascii_case("scalar") => Kernel::Scalar,
            _ => Kernel::Simd,
        }
    }
}

/// The CPU backend; `threads` worker threads (≥ 1) for every pass.
#[derive(Debug, Clone, Copy)]
pub struct CpuBackend {
    pub threads: usize,
    pub kernel: Kernel,
}

impl CpuBackend {
    /// `threads` workers and the kernels [`Kernel::from_env`] picks.
    pub fn new(threads: usize) -> Self {
        CpuBackend {
            threads: threads.max(1),
            kernel: Kernel::from_env(),
        }
    }

    /// The same backend with the given kernels.
    pub fn with_kernel(self, kernel: Kernel) -> Self {
        CpuBackend { kernel, ..self }
    }

    /// The eight-lane kernels for scalar type `R`, when asked for and available.
    fn lanes<R: Real>(&self) -> TileKernel {
        #[cfg(target_arch = "x86_64")]
        if self.kernel == Kernel::Simd
            && std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>()
            && let Some(t) = simd::Avx2::detect()
        {
            return TileKernel::Avx2(t);
        }
        TileKernel::Scalar
    }
}

/// The tile kernels a forward pass ran; its backward pass runs the same.
#[derive(Debug, Clone, Copy, Default)]
enum TileKernel {
    #[default]
    Scalar,
    #[cfg(target_arch = "x86_64")]
    Avx2(simd::Avx2),
}

/// What a forward pass leaves for its backward pass.
#[derive(Default)]
struct ForwardState<R: Real> {
    settings: RenderSettings,
    camera: Option<CameraParams<R>>,
    vertex_count: usize,
    face_count: usize,
    verts: VertexData<R>,
    faces: Vec<ScreenFace<R>>,
    /// Per slot of `faces`: its model face, packed for the passes that need
    /// only that (a `ScreenFace` is ~200 bytes; these passes are memory-bound).
    face_ids: Vec<u32>,
    grid: TileGrid,
    tiles: TileLists,
    /// Where each row of tiles' entries start in `tiles` (and one past the last).
    row_offsets: Vec<usize>,
    /// The background of the rendered region (its pixels, row-major).
    background: Vec<R>,
    /// Per entry of `tiles`: its largest blending weight and pixel count.
    stats: Vec<EntryStats<R>>,
    /// The kernels that composited the tiles.
    kernel: TileKernel,
    /// Per tile, the fragments it blended (scalar kernel); never shrunk, so a
    /// smaller region keeps the larger one's allocations for the next pass.
    fragments: Vec<TileFragments<R>>,
    /// Per tile, the lane groups it blended (eight-lane kernel); never shrunk.
    #[cfg(target_arch = "x86_64")]
    chunks: Vec<simd::forward::TileChunks>,
}

/// Scratch of the forward pass.
#[derive(Default)]
struct ForwardScratch<R: Real> {
    /// The faces that survive culling, in runs (see [`preprocess_faces`]).
    visible: Vec<Vec<ScreenFace<R>>>,
    /// Per vertex, where it lies against the view (see [`preprocess_vertices`]).
    sides: Vec<u8>,
    counts: Vec<usize>,
    used: Vec<bool>,
}

/// Scratch of the backward pass.
#[derive(Default)]
struct BackwardScratch<R: Real> {
    partials: Vec<FacePartial<R>>,
    face_entry_offsets: Vec<usize>,
    cursor: Vec<usize>,
    face_entries: Vec<usize>,
    corner_grads: Vec<CornerGrads<R>>,
    vertex_offsets: Vec<usize>,
    vertex_corners: Vec<(u32, u8)>,
}

/// Everything one forward + backward pass needs, kept between passes.
/// [`CpuWorkspace::output`] holds the last forward's outputs and
/// [`CpuWorkspace::grads`] the last backward's gradients.
pub struct CpuWorkspace<R: Real> {
    state: ForwardState<R>,
    forward: ForwardScratch<R>,
    backward: BackwardScratch<R>,
    pub output: RenderOutput<R>,
    pub grads: ModelGrads<R>,
}

impl<R: Real> Default for CpuWorkspace<R> {
    fn default() -> Self {
        CpuWorkspace {
            state: ForwardState::default(),
            forward: ForwardScratch::default(),
            backward: BackwardScratch::default(),
            output: RenderOutput::default(),
            grads: ModelGrads::zeros(0, 0),
        }
    }
}

fn check_inputs<R: Real>(
    threads: usize,
    model: &Model<R>,
    camera: &Camera,
    settings: &RenderSettings,
    background: &Background<'_, R>,
) -> Result<()> {
    model.validate_on(threads).context("invalid model")?;
    camera
        .validate()
        .map_err(anyhow::Error::msg)
        .context("invalid camera")?;
    settings.validate()?;
    let pixels = camera.width as usize * camera.height as usize;
    match background {
        Background::Image(b) => check_buffer("background", b, pixels * 3),
        Background::Uniform(c) => check_buffer("background colour", c, 3),
    }
}

/// Resizes `v` to `n` copies of `value` without shrinking its allocation.
fn refill<T: Clone>(v: &mut Vec<T>, n: usize, value: T) {
    v.clear();
    v.resize(n, value);
}

/// The output planes of `out` and the kept background, split into rows of tiles.
fn bands<'a, R: Real>(
    grid: &TileGrid,
    out: &'a mut RenderOutput<R>,
    background: &'a mut [R],
) -> impl Iterator<Item = Band<'a, R>> + Send {
    let region = grid.rect;
    let width = region.width() as usize;
    // At least 1: an empty region has no rows to split.
    let band = (TILE as usize * width).max(1);
    out.color
        .chunks_mut(3 * band)
        .zip(out.alpha.chunks_mut(band))
        .zip(out.depth.chunks_mut(band))
        .zip(out.median_depth.chunks_mut(band))
        .zip(background.chunks_mut(3 * band))
        .enumerate()
        .map(
            move |(row, ((((color, alpha), depth), median_depth), background))| Band {
                x0: region.x0,
                y0: region.y0 + row as u32 * TILE,
                width,
                color,
                alpha,
                depth,
                median_depth,
                background,
            },
        )
}

/// Runs `work(tile, entries, band, per_entry, record)` for every tile of the
/// grid, a row of tiles per job: `band` is the row's output, `per_entry` the
/// tile's part of `per_entry` (one element per entry of the tile lists, reset
/// to its default first) and `record` the tile's element of `records`.
#[allow(clippy::too_many_arguments)]
fn for_each_tile_row<B: Send, S: Send + Default, K: Send>(
    threads: usize,
    grid: &TileGrid,
    tiles: &TileLists,
    row_offsets: &[usize],
    bands: impl Iterator<Item = B> + Send,
    per_entry: &mut [S],
    records: &mut [K],
    work: impl Fn(usize, Range<usize>, &mut B, &mut [S], &mut K) + Sync,
) {
    let tiles_x = (grid.tiles_x as usize).max(1);
    let jobs = bands
        .zip(SplitBy::new(per_entry, row_offsets))
        .zip(records[..grid.tile_count()].chunks_mut(tiles_x))
        .enumerate();
    run_iter(
        threads,
        jobs,
        || (),
        |_, (row, ((mut band, mut per_entry), records))| {
            for (tile, record) in (row * tiles_x..).zip(records) {
                let entries = tiles.offsets[tile]..tiles.offsets[tile + 1];
                let (these, rest) = per_entry.split_at_mut(entries.len());
                per_entry = rest;
                // The kernels write only the entries they reach (a tile stops
                // at saturation): the others must read as nothing. Reset here,
                // in parallel, rather than the whole array on one core.
                these.fill_with(S::default);
                work(tile, entries, &mut band, these, record);
            }
        },
    );
}

/// Composites every tile of `st`'s grid with the kernels `st.kernel` names
/// into `out`'s planes, `st.stats` and the per-tile records the backward
/// pass reads.
fn composite_tiles<R: Real>(
    threads: usize,
    st: &mut ForwardState<R>,
    out: &mut RenderOutput<R>,
    background: &Background<'_, R>,
    rules: &PixelRules<R>,
) {
    let tile_count = st.grid.tile_count();
    #[cfg(target_arch = "x86_64")]
    if let TileKernel::Avx2(t) = st.kernel
        && let Some(st) = (st as &mut dyn std::any::Any).downcast_mut::<ForwardState<f32>>()
        && let Some(out) = (out as &mut dyn std::any::Any).downcast_mut::<RenderOutput<f32>>()
        && let Some(background) = background.as_f32()
        && let Some(rules) = (rules as &dyn std::any::Any).downcast_ref::<PixelRules<f32>>()
    {
        if st.chunks.len() < tile_count {
            st.chunks.resize_with(tile_count, Default::default);
        }
        let (grid, tiles, faces) = (&st.grid, &st.tiles, &st.faces);
        for_each_tile_row(
            threads,
            grid,
            tiles,
            &st.row_offsets,
            bands(grid, out, &mut st.background),
            &mut st.stats,
            &mut st.chunks,
            |tile, entries, band, stats, kept| {
                let entries = &tiles.entries[entries];
                simd::forward::render_tile(
                    t,
                    grid,
                    tile,
                    faces,
                    entries,
                    &background,
                    rules,
                    band,
                    stats,
                    kept,
                );
            },
        );
        return;
    }
    st.kernel = TileKernel::Scalar;
    if st.fragments.len() < tile_count {
        st.fragments.resize_with(tile_count, TileFragments::default);
    }
    let (grid, tiles, faces) = (&st.grid, &st.tiles, &st.faces);
    for_each_tile_row(
        threads,
        grid,
        tiles,
        &st.row_offsets,
        bands(grid, out, &mut st.background),
        &mut st.stats,
        &mut st.fragments,
        |tile, entries, band, stats, kept| {
            let entries = &tiles.entries[entries];
            render_tile(
                grid, tile, faces, entries, background, rules, band, stats, kept,
            );
        },
    );
}

/// dL/d(background) of `result` split into rows of tiles.
fn grad_bands<'a, R: Real>(
    grid: &TileGrid,
    background: &'a mut [R],
) -> impl Iterator<Item = GradBand<'a, R>> + Send {
    let region = grid.rect;
    let width = region.width() as usize;
    // At least 1: an empty region has no rows to split.
    let band = (TILE as usize * width).max(1);
    background
        .chunks_mut(3 * band)
        .enumerate()
        .map(move |(row, background)| GradBand {
            x0: region.x0,
            y0: region.y0 + row as u32 * TILE,
            width,
            background,
        })
}

/// The per-(tile, face) partials and the background gradient, a row of
/// tiles per job, with the kernels the forward pass ran.
fn backward_tiles<R: Real>(
    threads: usize,
    st: &ForwardState<R>,
    bw: &mut BackwardScratch<R>,
    result: &mut ModelGrads<R>,
    pixel_grads: &PixelGrads<'_, R>,
) {
    let (grid, tiles, faces) = (&st.grid, &st.tiles, &st.faces);
    let rules = PixelRules::<R>::new(&st.settings);
    // The backward writes no per-tile record: a zero-sized one per tile (no allocation).
    let mut no_records = vec![(); grid.tile_count()];
    #[cfg(target_arch = "x86_64")]
    if let TileKernel::Avx2(t) = st.kernel
        && let Some(st) = (st as &dyn std::any::Any).downcast_ref::<ForwardState<f32>>()
        && let Some(bw) = (bw as &mut dyn std::any::Any).downcast_mut::<BackwardScratch<f32>>()
        && let Some(result) = (result as &mut dyn std::any::Any).downcast_mut::<ModelGrads<f32>>()
        && let Some(grads) = pixel_grads.as_f32()
        && let Some(rules) = (&rules as &dyn std::any::Any).downcast_ref::<PixelRules<f32>>()
    {
        for_each_tile_row(
            threads,
            grid,
            tiles,
            &st.row_offsets,
            grad_bands(grid, &mut result.background),
            &mut bw.partials,
            &mut no_records,
            |tile, entries, band, partials, _| {
                simd::backward::backward_tile(
                    t,
                    &st.grid,
                    tile,
                    &st.faces,
                    &st.tiles.entries[entries],
                    &st.background,
                    rules,
                    &st.chunks[tile],
                    &grads,
                    partials,
                    band,
                );
            },
        );
        return;
    }
    for_each_tile_row(
        threads,
        grid,
        tiles,
        &st.row_offsets,
        grad_bands(grid, &mut result.background),
        &mut bw.partials,
        &mut no_records,
        |tile, entries, band, partials, _| {
            backward_tile(
                grid,
                tile,
                faces,
                &tiles.entries[entries.clone()],
                &st.background,
                &rules,
                &st.fragments[tile],
                &st.stats[entries],
                pixel_grads,
                partials,
                band,
            );
        },
    );
}

/// Projects, culls, orders and bins `model`'s faces for a render from
/// `camera` into `ws.state` (shading their corners when `shade`), and returns
/// the region of pixels the render covers.
fn bin_faces<R: Real>(
    threads: usize,
    ws: &mut CpuWorkspace<R>,
    model: &Model<R>,
    camera: &Camera,
    settings: &RenderSettings,
    shade: bool,
) -> PixelRect {
    let cam = CameraParams::<R>::new(camera);
    let (st, fw) = (&mut ws.state, &mut ws.forward);
    preprocess_vertices(model, &cam, settings, threads, &mut st.verts, &mut fw.sides);
    preprocess_faces(
        model,
        &st.verts,
        &fw.sides,
        &cam,
        settings,
        threads,
        &mut fw.visible,
    );
    let (w, h) = (camera.width, camera.height);
    let region = match settings.region {
        Region::Full => PixelRect::full(w, h),
        Region::Footprint { include, margin } => {
            // One rectangle per run of faces, in parallel; their union is the footprint.
            let mut rects = vec![PixelRect::default(); fw.visible.len()];
            let visible = &fw.visible;
            for_chunks_mut(threads, &mut rects, 1, |run, rect| {
                rect[0] = footprint(visible[run].iter());
            });
            rects
                .into_iter()
                .fold(PixelRect::default(), PixelRect::union)
                .union(include)
                .grown_to_tiles(margin, TILE, w, h)
        }
    };
    st.grid = TileGrid::new(w, h, region);
    order_by_tile(
        &fw.visible,
        &st.grid,
        &mut st.faces,
        &mut st.face_ids,
        &mut fw.counts,
    );
    if shade {
        shade_vertices(
            model,
            &mut st.verts,
            &mut st.faces,
            &st.face_ids,
            settings.sh_degree,
            threads,
            &mut fw.used,
        );
    }
    st.tiles.bin(&st.faces, &st.grid, threads);
    // Sized only: `for_each_tile_row` resets each tile's statistics.
    st.stats
        .resize(st.tiles.entries.len(), EntryStats::default());
    st.tiles.row_offsets(&st.grid, &mut st.row_offsets);
    region
}

/// Per face of the model, the largest blending weight and the pixel count
/// over the entries of `st`'s last composite.
fn face_maxima<R: Real>(st: &ForwardState<R>, faces: usize, out: &mut RenderOutput<R>) {
    let (tiles, face_ids) = (&st.tiles, &st.face_ids);
    refill(&mut out.face_max_weight, faces, R::zero());
    refill(&mut out.face_pixel_count, faces, 0);
    for (e, s) in st.stats.iter().enumerate() {
        let f = face_ids[tiles.entries[e] as usize] as usize;
        out.face_max_weight[f] = out.face_max_weight[f].max(s.max_weight);
        out.face_pixel_count[f] += s.pixels;
    }
}

impl CpuBackend {
    /// Renders into `ws.output` and keeps in `ws` what the backward pass needs.
    pub fn forward_into<R: Real>(
        &self,
        ws: &mut CpuWorkspace<R>,
        model: &Model<R>,
        camera: &Camera,
        settings: &RenderSettings,
        background: Background<'_, R>,
    ) -> Result<()> {
        check_inputs(self.threads, model, camera, settings, &background)?;
        let threads = self.threads;
        let region = bin_faces(threads, ws, model, camera, settings, true);
        let st = &mut ws.state;
        let out = &mut ws.output;
        let n = region.pixels();
        out.width = camera.width;
        out.height = camera.height;
        out.region = region;
        // The kernels write every pixel of the region: no need to clear.
        for plane in [&mut out.color, &mut st.background] {
            plane.resize(n * 3, R::zero());
        }
        for plane in [&mut out.alpha, &mut out.depth, &mut out.median_depth] {
            plane.resize(n, R::zero());
        }
        st.kernel = self.lanes::<R>();
        let rules = PixelRules::<R>::new(settings);
        composite_tiles(threads, st, out, &background, &rules);
        face_maxima(st, model.face_count(), out);
        st.settings = settings.clone();
        st.camera = Some(CameraParams::<R>::new(camera));
        st.vertex_count = model.vertex_count();
        st.face_count = model.face_count();
        Ok(())
    }

    /// Per face, the largest blending weight of a render of `model` from
    /// `camera` (as [`Self::forward_into`]'s `face_max_weight`, bit for bit),
    /// without shading or storing colour, depth or what a backward pass needs
    /// when the eight-lane kernels run (the scalar ones render in full).
    /// `ws.output`'s pixel planes are left as they were, and a backward pass
    /// refuses the workspace until the next [`Self::forward_into`].
    pub fn face_max_weight_into<'w, R: Real>(
        &self,
        ws: &'w mut CpuWorkspace<R>,
        model: &Model<R>,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<&'w [R]> {
        let kernel = self.lanes::<R>();
        let mut weights_only = false;
        #[cfg(target_arch = "x86_64")]
        if let TileKernel::Avx2(t) = kernel
            && let Some(ws) = (ws as &mut dyn std::any::Any).downcast_mut::<CpuWorkspace<f32>>()
            && let Some(model) = (model as &dyn std::any::Any).downcast_ref::<Model<f32>>()
        {
            let background = Background::Uniform([0.0; 3]);
            check_inputs(self.threads, model, camera, settings, &background)?;
            bin_faces(self.threads, ws, model, camera, settings, false);
            let st = &mut ws.state;
            // What the workspace holds is no longer a forward pass a backward could use.
            st.camera = None;
            st.kernel = kernel;
            let rules = PixelRules::<f32>::new(settings);
            let (grid, tiles, faces) = (&st.grid, &st.tiles, &st.faces);
            // The weights-only kernel writes no pixel and keeps no per-tile record.
            let mut no_records = vec![(); grid.tile_count()];
            for_each_tile_row(
                self.threads,
                grid,
                tiles,
                &st.row_offsets,
                std::iter::repeat_n((), grid.tiles_y as usize),
                &mut st.stats,
                &mut no_records,
                |tile, entries, _, stats, _| {
                    let entries = &tiles.entries[entries];
                    simd::forward::tile_weights(t, grid, tile, faces, entries, &rules, stats);
                },
            );
            face_maxima(st, model.face_count(), &mut ws.output);
            weights_only = true;
        }
        if !weights_only {
            let background = Background::Uniform([R::zero(); 3]);
            self.forward_into(ws, model, camera, settings, background)?;
        }
        Ok(&ws.output.face_max_weight)
    }

    /// Back-propagates `grads` (covering the last forward's region) to the
    /// model's parameters and the region's background, into `ws.grads`.
    /// `model` must be the one the forward pass rendered.
    pub fn backward_into<R: Real>(
        &self,
        ws: &mut CpuWorkspace<R>,
        model: &Model<R>,
        grads: &OutputGrads<'_, R>,
    ) -> Result<()> {
        backward_impl(
            self.threads,
            &ws.state,
            &mut ws.backward,
            &mut ws.grads,
            model,
            grads,
        )
    }
}

fn backward_impl<R: Real>(
    threads: usize,
    st: &ForwardState<R>,
    bw: &mut BackwardScratch<R>,
    result: &mut ModelGrads<R>,
    model: &Model<R>,
    grads: &OutputGrads<'_, R>,
) -> Result<()> {
    let Some(cam) = &st.camera else {
        bail!("backward pass before any forward pass");
    };
    if model.vertex_count() != st.vertex_count || model.face_count() != st.face_count {
        bail!(
            "backward got a model with {} vertices / {} faces, but the forward pass rendered {} / {}",
            model.vertex_count(),
            model.face_count(),
            st.vertex_count,
            st.face_count
        );
    }
    let (grid, tiles, faces) = (&st.grid, &st.tiles, &st.faces);
    let pixels = grid.rect.pixels();
    grads.validate(pixels)?;
    let pixel_grads = PixelGrads {
        color: grads.color,
        alpha: grads.alpha,
        depth: grads.depth,
        median_depth: grads.median_depth,
    };

    // 1. Per (tile, face) partials and the background gradient, tile by tile.
    // Sized only: `for_each_tile_row` resets each tile's partials.
    bw.partials
        .resize(tiles.entries.len(), FacePartial::default());
    // The kernels write every pixel of the region: no need to clear.
    result.background.resize(pixels * 3, R::zero());
    backward_tiles(threads, st, bw, result, &pixel_grads);

    // 2. Per visible face: sum its partials in tile order, then back through the 2D geometry.
    refill(&mut bw.face_entry_offsets, faces.len() + 1, 0);
    for &fi in &tiles.entries {
        bw.face_entry_offsets[fi as usize + 1] += 1;
    }
    for i in 0..faces.len() {
        bw.face_entry_offsets[i + 1] += bw.face_entry_offsets[i];
    }
    bw.cursor.clear();
    bw.cursor.extend_from_slice(&bw.face_entry_offsets);
    // Sized only, here and below: every element is written before it is read.
    bw.face_entries.resize(tiles.entries.len(), 0);
    for (e, &fi) in tiles.entries.iter().enumerate() {
        bw.face_entries[bw.cursor[fi as usize]] = e;
        bw.cursor[fi as usize] += 1;
    }
    bw.corner_grads.resize(faces.len(), CornerGrads::default());
    {
        let (offsets, entries, partials) = (&bw.face_entry_offsets, &bw.face_entries, &bw.partials);
        let n = faces.len();
        for_chunks_mut(
            threads,
            &mut bw.corner_grads,
            chunk_size(n, threads, 1024),
            |start, chunk| {
                for (i, out) in chunk.iter_mut().enumerate() {
                    let fi = start + i;
                    let mut sum = FacePartial::<R>::default();
                    for &e in &entries[offsets[fi]..offsets[fi + 1]] {
                        sum.add(&partials[e]);
                    }
                    *out = face_backward(&faces[fi], &sum);
                }
            },
        );
    }

    // 3. Per vertex: gather its corners in face order, then projection, SH and opacity backward.
    let nv = model.vertex_count();
    refill(&mut bw.vertex_offsets, nv + 1, 0);
    for &f in &st.face_ids {
        for &v in &model.faces[f as usize] {
            bw.vertex_offsets[v as usize + 1] += 1;
        }
    }
    for i in 0..nv {
        bw.vertex_offsets[i + 1] += bw.vertex_offsets[i];
    }
    bw.cursor.clear();
    bw.cursor.extend_from_slice(&bw.vertex_offsets);
    bw.vertex_corners.resize(bw.vertex_offsets[nv], (0, 0));
    for (fi, &f) in st.face_ids.iter().enumerate() {
        for (k, &v) in model.faces[f as usize].iter().enumerate() {
            bw.vertex_corners[bw.cursor[v as usize]] = (fi as u32, k as u8);
            bw.cursor[v as usize] += 1;
        }
    }

    // Sized only: each job zeroes its own vertices (in parallel; the SH
    // gradients alone are 192 bytes a vertex).
    result.vertices.resize(nv, [R::zero(); 3]);
    result.sh.resize(nv, [[R::zero(); 3]; crate::SH_COEFFS]);
    result.opacity_logits.resize(nv, R::zero());
    let verts = &st.verts;
    let floor = R::of(model.opacity_floor);
    let degree = st.settings.sh_degree;
    let (vertex_offsets, vertex_corners, corner_grads) =
        (&bw.vertex_offsets, &bw.vertex_corners, &bw.corner_grads);
    // Each job owns the same vertex range of the three gradient arrays.
    let chunk = chunk_size(nv, threads, 1024);
    let jobs = result
        .vertices
        .chunks_mut(chunk)
        .zip(result.sh.chunks_mut(chunk))
        .zip(result.opacity_logits.chunks_mut(chunk))
        .enumerate()
        .map(|(j, ((pos, sh), logit))| (j * chunk, pos, sh, logit));
    run_iter(
        threads,
        jobs,
        || (),
        |_, (start, pos_out, sh_out, logit_out)| {
            for i in 0..pos_out.len() {
                let v = start + i;
                pos_out[i] = [R::zero(); 3];
                sh_out[i] = [[R::zero(); 3]; crate::SH_COEFFS];
                logit_out[i] = R::zero();
                let corners = &vertex_corners[vertex_offsets[v]..vertex_offsets[v + 1]];
                if corners.is_empty() {
                    continue;
                }
                let mut d_screen = [R::zero(); 2];
                let mut d_zcam = R::zero();
                let mut d_color = [R::zero(); 3];
                let mut d_opacity = R::zero();
                for &(fi, k) in corners {
                    let g = &corner_grads[fi as usize];
                    let k = k as usize;
                    d_screen[0] += g.d_screen[k][0];
                    d_screen[1] += g.d_screen[k][1];
                    d_zcam += g.d_z[k];
                    for ch in 0..3 {
                        d_color[ch] += g.d_color[k][ch];
                    }
                    d_opacity += g.d_opacity[k];
                }
                // u = fx·x/z + cx, v = fy·y/z + cy.
                let [x, y, z] = verts[v].cam;
                let gu = d_screen[0] * cam.fx / z;
                let gv = d_screen[1] * cam.fy / z;
                let d_cam = [gu, gv, d_zcam - (gu * x + gv * y) / z];
                let mut position = cam.to_world_vector(d_cam);
                let via_dir = sh::vertex_color_backward(
                    &model.sh[v],
                    verts[v].dir,
                    verts[v].distance,
                    degree,
                    verts[v].clamped,
                    d_color,
                    &mut sh_out[i],
                );
                for a in 0..3 {
                    position[a] += via_dir[a];
                }
                pos_out[i] = position;
                let s = sigmoid(model.opacity_logits[v]);
                logit_out[i] = d_opacity * (R::one() - floor) * s * (R::one() - s);
            }
        },
    );
    Ok(())
}

impl<R: Real> RenderBackend<R> for CpuBackend {
    fn name(&self) -> &'static str {
        BACKEND_NAME
    }

    fn forward(
        &self,
        model: &Model<R>,
        camera: &Camera,
        settings: &RenderSettings,
        background: &[R],
    ) -> Result<(RenderOutput<R>, SavedForward)> {
        let mut ws = CpuWorkspace::<R>::default();
        self.forward_into(
            &mut ws,
            model,
            camera,
            settings,
            Background::Image(background),
        )?;
        let out = std::mem::take(&mut ws.output);
        Ok((out, SavedForward::new(BACKEND_NAME, ws.state)))
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }

    fn backward(
        &self,
        model: &Model<R>,
        saved: &SavedForward,
        grads: &OutputGrads<'_, R>,
    ) -> Result<ModelGrads<R>> {
        let state = saved.state_of::<ForwardState<R>>(BACKEND_NAME)?;
        let mut result = ModelGrads::zeros(0, 0);
        backward_impl(
            self.threads,
            state,
            &mut BackwardScratch::default(),
            &mut result,
            model,
            grads,
        )?;
        Ok(result)
    }
}

/// Renders the model's colour over a uniform background with its own σ and SH degree.
pub fn render_model<R: Real>(
    model: &Model<R>,
    camera: &Camera,
    background: [f64; 3],
    threads: usize,
) -> Result<objectsplat_core::Image> {
    let settings = RenderSettings::for_model(model);
    let mut ws = CpuWorkspace::<R>::default();
    let bg = Background::Uniform(background.map(R::of));
    CpuBackend::new(threads).forward_into(&mut ws, model, camera, &settings, bg)?;
    Ok(ws.output.color_image())
}
