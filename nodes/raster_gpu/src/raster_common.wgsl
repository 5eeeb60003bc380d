// Shared by every rasterizer kernel (prepended to each): the parameters, the
// per-vertex and per-face records and the fragment evaluation, all mirroring
// the CPU backend of objectsplat-raster (cpu/preprocess.rs, cpu/forward.rs).

struct RasterParams {
    // World→camera rotation rows, translation in w.
    rot0: vec4<f32>,
    rot1: vec4<f32>,
    rot2: vec4<f32>,
    // Camera centre in xyz.
    center: vec4<f32>,
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
    // Region::Footprint's `include` rectangle [x0, x1) × [y0, y1) and margin.
    include_x0: u32,
    include_y0: u32,
    include_x1: u32,
    include_y1: u32,
    margin: u32,
    // 0: the whole image; 1: the footprint of the drawn faces ∪ include.
    region_mode: u32,
    // 1: every pixel's background is `background_color` (no per-pixel buffer).
    uniform_background: u32,
    // Faces from this index on take their window sharpness from `face_sigma`
    // (a model with per-face σ, or frozen occluders after the trained faces);
    // the faces before it take `sigma`.
    sigma_from: u32,
    background_color: vec4<f32>,
}

// Per vertex: camera position, projection, colour, view direction, opacity.
struct Vertex {
    cam: array<f32, 3>,
    screen: array<f32, 2>,
    color: array<f32, 3>,
    // Bit ch set: channel ch was clamped at 0.
    clamped: u32,
    dir: array<f32, 3>,
    distance: f32,
    opacity: f32,
    _pad: array<f32, 2>,
}

// Per face (indexed by model face): `ScreenFace` of the CPU backend.
struct Face {
    // λ_k(q) = lam[3k]·qx + lam[3k+1]·qy + lam[3k+2].
    lam: array<f32, 9>,
    scale: array<f32, 3>,
    q: array<f32, 6>,
    origin_x: f32,
    origin_y: f32,
    area2: f32,
    inv_area2: f32,
    len: array<f32, 3>,
    perimeter: f32,
    opacity: f32,
    depth: f32,
    // Corner k channel ch at 3k + ch.
    color: array<f32, 9>,
    z: array<f32, 3>,
    // Inclusive pixel box x0, y0, x1, y1.
    pixels: array<u32, 4>,
    argmin_corner: u32,
    visible: u32,
    // Tile of the pixel box's top-left corner.
    tile_key: u32,
    // The window sharpness σ of `α = o·G^σ`.
    sigma: f32,
}

const TILE: u32 = 16u;
const NONE: u32 = 0xffffffffu;
// Values per pixel of the packed forward image: r, g, b, alpha, depth, median depth.
const IMAGE_STRIDE: u32 = 6u;
// Values per pixel of the saved state: final T (bits), entries processed, median entry.
const STATE_STRIDE: u32 = 3u;
// Per-face gradient partial: d_q (6), area term, d_scale (3), d_color (9), d_z (3), d_opacity.
const PARTIAL: u32 = 23u;
const P_AREA: u32 = 6u;
const P_SCALE: u32 = 7u;
const P_COLOR: u32 = 10u;
const P_Z: u32 = 19u;
const P_OPACITY: u32 = 22u;
// Per-vertex gradient accumulator: d_screen (2), d_z, d_color (3), d_opacity.
const VACC: u32 = 7u;

struct Fragment {
    q: vec2<f32>,
    lambda: vec3<f32>,
    g: f32,
    kstar: u32,
    intensity: f32,
    alpha: f32,
    clamped: bool,
    hit: bool,
}

// The face fields the pixel test needs, packed so a workgroup can stage a
// batch of them in shared memory (per-lane storage loads are slow on lavapipe).
struct HotFace {
    // λ_k coefficients in xyz, scale_k in w.
    l0: vec4<f32>,
    l1: vec4<f32>,
    l2: vec4<f32>,
    // origin x, origin y, opacity, σ.
    o: vec4<f32>,
    // Inclusive pixel box x0, y0, x1, y1.
    pixels: vec4<u32>,
}

fn hot_face(fi: u32) -> HotFace {
    var h: HotFace;
    h.l0 = vec4<f32>(faces[fi].lam[0], faces[fi].lam[1], faces[fi].lam[2], faces[fi].scale[0]);
    h.l1 = vec4<f32>(faces[fi].lam[3], faces[fi].lam[4], faces[fi].lam[5], faces[fi].scale[1]);
    h.l2 = vec4<f32>(faces[fi].lam[6], faces[fi].lam[7], faces[fi].lam[8], faces[fi].scale[2]);
    h.o = vec4<f32>(faces[fi].origin_x, faces[fi].origin_y, faces[fi].opacity, faces[fi].sigma);
    h.pixels = vec4<u32>(faces[fi].pixels[0], faces[fi].pixels[1], faces[fi].pixels[2], faces[fi].pixels[3]);
    return h;
}

fn pixel_in_box(h: HotFace, x: u32, y: u32) -> bool {
    return x >= h.pixels.x && x <= h.pixels.z && y >= h.pixels.y && y <= h.pixels.w;
}

// `evaluate` of the CPU backend: `hit` false outside the window or below alpha_min.
fn evaluate(h: HotFace, px: f32, py: f32) -> Fragment {
    var out: Fragment;
    out.hit = false;
    let q = vec2<f32>(px - h.o.x, py - h.o.y);
    let lambda = vec3<f32>(
        h.l0.x * q.x + h.l0.y * q.y + h.l0.z,
        h.l1.x * q.x + h.l1.y * q.y + h.l1.z,
        h.l2.x * q.x + h.l2.y * q.y + h.l2.z,
    );
    let g = vec3<f32>(lambda.x * h.l0.w, lambda.y * h.l1.w, lambda.z * h.l2.w);
    var kstar = 0u;
    var gmin = g.x;
    if (g.y < gmin) {
        kstar = 1u;
        gmin = g.y;
    }
    if (g.z < gmin) {
        kstar = 2u;
        gmin = g.z;
    }
    if (!(gmin > 0.0)) {
        return out;
    }
    let intensity = pow(gmin, h.o.w);
    let raw = h.o.z * intensity;
    let clamped = raw > params.alpha_max;
    var alpha = raw;
    if (clamped) {
        alpha = params.alpha_max;
    }
    if (alpha < params.alpha_min) {
        return out;
    }
    out.q = q;
    out.lambda = lambda;
    out.g = gmin;
    out.kstar = kstar;
    out.intensity = intensity;
    out.alpha = alpha;
    out.clamped = clamped;
    out.hit = true;
    return out;
}

fn face_corner_color(fi: u32, k: u32) -> vec3<f32> {
    return vec3<f32>(faces[fi].color[3u * k], faces[fi].color[3u * k + 1u], faces[fi].color[3u * k + 2u]);
}

fn fragment_color(fi: u32, fr: Fragment) -> vec3<f32> {
    return fr.lambda.x * face_corner_color(fi, 0u) + fr.lambda.y * face_corner_color(fi, 1u)
        + fr.lambda.z * face_corner_color(fi, 2u);
}

fn fragment_depth(fi: u32, fr: Fragment) -> f32 {
    return fr.lambda.x * faces[fi].z[0] + fr.lambda.y * faces[fi].z[1] + fr.lambda.z * faces[fi].z[2];
}

// Real SH basis up to `degree` (the 3DGS constants and signs of sh.rs).
fn sh_basis(d: vec3<f32>, degree: u32) -> array<f32, 16> {
    var out: array<f32, 16>;
    let x = d.x;
    let y = d.y;
    let z = d.z;
    out[0] = 0.28209479177387814;
    if (degree >= 1u) {
        out[1] = -0.4886025119029199 * y;
        out[2] = 0.4886025119029199 * z;
        out[3] = -0.4886025119029199 * x;
    }
    if (degree >= 2u) {
        let xx = x * x;
        let yy = y * y;
        let zz = z * z;
        out[4] = 1.0925484305920792 * x * y;
        out[5] = -1.0925484305920792 * y * z;
        out[6] = 0.31539156525252005 * (2.0 * zz - xx - yy);
        out[7] = -1.0925484305920792 * x * z;
        out[8] = 0.5462742152960396 * (xx - yy);
    }
    if (degree >= 3u) {
        let xx = x * x;
        let yy = y * y;
        let zz = z * z;
        out[9] = -0.5900435899266435 * y * (3.0 * xx - yy);
        out[10] = 2.890611442640554 * x * y * z;
        out[11] = -0.4570457994644658 * y * (4.0 * zz - xx - yy);
        out[12] = 0.3731763325901154 * z * (2.0 * zz - 3.0 * xx - 3.0 * yy);
        out[13] = -0.4570457994644658 * x * (4.0 * zz - xx - yy);
        out[14] = 1.445305721320277 * z * (xx - yy);
        out[15] = -0.5900435899266435 * x * (xx - 3.0 * yy);
    }
    return out;
}

fn sh_coeff_count(degree: u32) -> u32 {
    return (degree + 1u) * (degree + 1u);
}
