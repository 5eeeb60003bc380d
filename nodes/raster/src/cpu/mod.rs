//! The CPU reference backend: multi-threaded over tiles (crossbeam scoped
//! threads), deterministic for any thread count, generic over f32/f64.

pub mod backward;
pub mod binning;
pub mod forward;
pub mod preprocess;

use crate::backend::{
    OutputGrads, RenderBackend, RenderOutput, RenderSettings, SavedForward, check_buffer,
};
use crate::model::{Model, ModelGrads, sigmoid};
use crate::parallel::{chunk_size, for_chunks_mut, run_jobs};
use crate::real::Real;
use crate::sh;
use anyhow::{Context, Result, bail};
use backward::{CornerGrads, FacePartial, PixelGrads, backward_tile, face_backward};
use binning::{TILE, TILE_PIXELS, TileGrid, TileLists, bin_faces};
use forward::{EntryStats, PixelOut, PixelRules, render_tile};
use objectsplat_core::Camera;
use preprocess::{
    CameraParams, ScreenFace, VertexData, preprocess_faces, preprocess_vertices, shade_vertices,
};

const BACKEND_NAME: &str = "cpu";

/// The CPU backend; `threads` worker threads (≥ 1) for every pass.
#[derive(Debug, Clone, Copy)]
pub struct CpuBackend {
    pub threads: usize,
}

impl CpuBackend {
    pub fn new(threads: usize) -> Self {
        CpuBackend {
            threads: threads.max(1),
        }
    }
}

/// What the forward pass leaves for the backward pass.
struct CpuSaved<R: Real> {
    settings: RenderSettings,
    camera: CameraParams<R>,
    vertex_count: usize,
    face_count: usize,
    verts: VertexData<R>,
    faces: Vec<ScreenFace<R>>,
    grid: TileGrid,
    tiles: TileLists,
    background: Vec<R>,
}

fn check_inputs<R: Real>(
    model: &Model<R>,
    camera: &Camera,
    settings: &RenderSettings,
    background: &[R],
) -> Result<()> {
    model.validate().context("invalid model")?;
    camera
        .validate()
        .map_err(anyhow::Error::msg)
        .context("invalid camera")?;
    settings.validate()?;
    let pixels = camera.width as usize * camera.height as usize;
    check_buffer("background", background, pixels * 3)
}

impl CpuBackend {
    /// Renders and keeps the state the backward pass needs.
    fn forward_impl<R: Real>(
        &self,
        model: &Model<R>,
        camera: &Camera,
        settings: &RenderSettings,
        background: &[R],
    ) -> Result<(RenderOutput<R>, CpuSaved<R>)> {
        check_inputs(model, camera, settings, background)?;
        let threads = self.threads;
        let cam = CameraParams::<R>::new(camera);
        let mut verts = preprocess_vertices(model, &cam, threads);
        let mut faces = preprocess_faces(model, &verts, &cam, settings, threads);
        shade_vertices(model, &mut verts, &mut faces, settings.sh_degree, threads);
        let grid = TileGrid::new(camera.width, camera.height);
        let tiles = bin_faces(&faces, &grid, threads);
        let rules = PixelRules::<R>::new(settings);

        let tile_count = grid.tile_count();
        let mut pixel_buf = vec![PixelOut::<R>::default(); tile_count * TILE_PIXELS];
        let mut stats = vec![EntryStats::<R>::default(); tiles.entries.len()];
        {
            let mut jobs = Vec::with_capacity(tile_count);
            let mut pix_rest: &mut [PixelOut<R>] = &mut pixel_buf;
            let mut stat_rest: &mut [EntryStats<R>] = &mut stats;
            for t in 0..tile_count {
                let (p, pr) = pix_rest.split_at_mut(TILE_PIXELS);
                let (s, sr) = stat_rest.split_at_mut(tiles.offsets[t + 1] - tiles.offsets[t]);
                pix_rest = pr;
                stat_rest = sr;
                jobs.push((t, p, s));
            }
            run_jobs(
                threads,
                jobs,
                || (),
                |_, (t, p, s)| {
                    let entries = &tiles.entries[tiles.offsets[t]..tiles.offsets[t + 1]];
                    render_tile(&grid, t, &faces, entries, background, &rules, p, s);
                },
            );
        }

        let (w, h) = (camera.width as usize, camera.height as usize);
        let mut out = RenderOutput {
            width: camera.width,
            height: camera.height,
            color: vec![R::zero(); w * h * 3],
            alpha: vec![R::zero(); w * h],
            depth: vec![R::zero(); w * h],
            median_depth: vec![R::zero(); w * h],
            face_max_weight: vec![R::zero(); model.face_count()],
            face_pixel_count: vec![0; model.face_count()],
        };
        for t in 0..tile_count {
            let [x0, y0, x1, y1] = grid.tile_rect(t);
            for y in y0..y1 {
                for x in x0..x1 {
                    let src = &pixel_buf[t * TILE_PIXELS + ((y - y0) * TILE + (x - x0)) as usize];
                    let i = y as usize * w + x as usize;
                    out.color[i * 3..i * 3 + 3].copy_from_slice(&src.color);
                    out.alpha[i] = R::one() - src.transmittance;
                    out.depth[i] = src.depth;
                    out.median_depth[i] = src.median_depth;
                }
            }
        }
        for (e, st) in stats.iter().enumerate() {
            let f = faces[tiles.entries[e] as usize].face as usize;
            out.face_max_weight[f] = out.face_max_weight[f].max(st.max_weight);
            out.face_pixel_count[f] += st.pixels;
        }
        let saved = CpuSaved {
            settings: settings.clone(),
            camera: cam,
            vertex_count: model.vertex_count(),
            face_count: model.face_count(),
            verts,
            faces,
            grid,
            tiles,
            background: background.to_vec(),
        };
        Ok((out, saved))
    }

    fn backward_impl<R: Real>(
        &self,
        model: &Model<R>,
        saved: &CpuSaved<R>,
        grads: &OutputGrads<'_, R>,
    ) -> Result<ModelGrads<R>> {
        if model.vertex_count() != saved.vertex_count || model.face_count() != saved.face_count {
            bail!(
                "backward got a model with {} vertices / {} faces, but the forward pass rendered {} / {}",
                model.vertex_count(),
                model.face_count(),
                saved.vertex_count,
                saved.face_count
            );
        }
        let (grid, tiles, faces) = (&saved.grid, &saved.tiles, &saved.faces);
        let pixels = grid.width as usize * grid.height as usize;
        grads.validate(pixels)?;
        let threads = self.threads;
        let rules = PixelRules::<R>::new(&saved.settings);
        let pixel_grads = PixelGrads {
            color: grads.color,
            alpha: grads.alpha,
            depth: grads.depth,
            median_depth: grads.median_depth,
        };

        // 1. Per (tile, face) partials and the background gradient, tile by tile.
        let tile_count = grid.tile_count();
        let mut partials = vec![FacePartial::<R>::default(); tiles.entries.len()];
        let mut d_bg_tiles = vec![[R::zero(); 3]; tile_count * TILE_PIXELS];
        {
            let mut jobs = Vec::with_capacity(tile_count);
            let mut part_rest: &mut [FacePartial<R>] = &mut partials;
            let mut bg_rest: &mut [[R; 3]] = &mut d_bg_tiles;
            for t in 0..tile_count {
                let (p, pr) = part_rest.split_at_mut(tiles.offsets[t + 1] - tiles.offsets[t]);
                let (b, br) = bg_rest.split_at_mut(TILE_PIXELS);
                part_rest = pr;
                bg_rest = br;
                jobs.push((t, p, b));
            }
            run_jobs(
                threads,
                jobs,
                backward::TileScratch::default,
                |scratch, (t, p, b)| {
                    let entries = &tiles.entries[tiles.offsets[t]..tiles.offsets[t + 1]];
                    backward_tile(
                        grid,
                        t,
                        faces,
                        entries,
                        &saved.background,
                        &rules,
                        &pixel_grads,
                        scratch,
                        p,
                        b,
                    );
                },
            );
        }

        // 2. Per visible face: sum its partials in tile order, then back through the 2D geometry.
        let mut face_entry_offsets = vec![0usize; faces.len() + 1];
        for &fi in &tiles.entries {
            face_entry_offsets[fi as usize + 1] += 1;
        }
        for i in 0..faces.len() {
            face_entry_offsets[i + 1] += face_entry_offsets[i];
        }
        let mut cursor = face_entry_offsets.clone();
        let mut face_entries = vec![0usize; tiles.entries.len()];
        for (e, &fi) in tiles.entries.iter().enumerate() {
            face_entries[cursor[fi as usize]] = e;
            cursor[fi as usize] += 1;
        }
        let mut corner_grads = vec![CornerGrads::<R>::default(); faces.len()];
        for_chunks_mut(
            threads,
            &mut corner_grads,
            chunk_size(faces.len(), threads, 1024),
            |start, chunk| {
                for (i, out) in chunk.iter_mut().enumerate() {
                    let fi = start + i;
                    let mut sum = FacePartial::<R>::default();
                    for &e in &face_entries[face_entry_offsets[fi]..face_entry_offsets[fi + 1]] {
                        sum.add(&partials[e]);
                    }
                    *out = face_backward(&faces[fi], &sum);
                }
            },
        );

        // 3. Per vertex: gather its corners in face order, then projection, SH and opacity backward.
        let nv = model.vertex_count();
        let mut vertex_offsets = vec![0usize; nv + 1];
        for f in faces {
            for &v in &model.faces[f.face as usize] {
                vertex_offsets[v as usize + 1] += 1;
            }
        }
        for i in 0..nv {
            vertex_offsets[i + 1] += vertex_offsets[i];
        }
        let mut cursor = vertex_offsets.clone();
        let mut vertex_corners = vec![(0u32, 0u8); vertex_offsets[nv]];
        for (fi, f) in faces.iter().enumerate() {
            for (k, &v) in model.faces[f.face as usize].iter().enumerate() {
                vertex_corners[cursor[v as usize]] = (fi as u32, k as u8);
                cursor[v as usize] += 1;
            }
        }

        let mut result = ModelGrads::<R>::zeros(nv, pixels);
        let cam = &saved.camera;
        let verts = &saved.verts;
        let floor = R::of(model.opacity_floor);
        let degree = saved.settings.sh_degree;
        // Each job owns the same vertex range of the three gradient arrays.
        let chunk = chunk_size(nv, threads, 1024);
        let jobs: Vec<_> = result
            .vertices
            .chunks_mut(chunk)
            .zip(result.sh.chunks_mut(chunk))
            .zip(result.opacity_logits.chunks_mut(chunk))
            .enumerate()
            .map(|(j, ((pos, sh), logit))| (j * chunk, pos, sh, logit))
            .collect();
        run_jobs(
            threads,
            jobs,
            || (),
            |_, (start, pos_out, sh_out, logit_out)| {
                for i in 0..pos_out.len() {
                    let v = start + i;
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
        for t in 0..tile_count {
            let [x0, y0, x1, y1] = grid.tile_rect(t);
            for y in y0..y1 {
                for x in x0..x1 {
                    let i = (y * grid.width + x) as usize;
                    let src = d_bg_tiles[t * TILE_PIXELS + ((y - y0) * TILE + (x - x0)) as usize];
                    result.background[i * 3..i * 3 + 3].copy_from_slice(&src);
                }
            }
        }
        Ok(result)
    }
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
        let (out, saved) = self.forward_impl(model, camera, settings, background)?;
        Ok((out, SavedForward::new(BACKEND_NAME, saved)))
    }

    fn backward(
        &self,
        model: &Model<R>,
        saved: &SavedForward,
        grads: &OutputGrads<'_, R>,
    ) -> Result<ModelGrads<R>> {
        self.backward_impl(model, saved.state_of::<CpuSaved<R>>(BACKEND_NAME)?, grads)
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
    let pixels = camera.width as usize * camera.height as usize;
    let bg: Vec<R> = (0..pixels * 3).map(|i| R::of(background[i % 3])).collect();
    let (out, _) = CpuBackend::new(threads).forward_impl(model, camera, &settings, &bg)?;
    Ok(out.color_image())
}
