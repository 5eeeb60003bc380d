// The training loss on the device: (1 − λ)·L1 + λ·(1 − SSIM) of the rendered
// colour against a view's target, weighted per pixel, with the gradient of
// objectsplat_raster::loss::PhotometricLoss (same taps, same summation order
// of the separable blurs). The gradient is written as the backward pass's
// upstream buffer (stride 6: colour, alpha, depth, median depth).
//
// Every kernel covers the render's region (the frame record's rectangle;
// the rendered image, the scratch planes and the gradient are region-sized,
// row-major) and treats it as a crop: the blurs are zero-padded at its border,
// as objectsplat_raster::loss does for a crop. Targets and weights are those
// of the whole view. Outside the region render and target agree, so there
// L1 adds 0 and the SSIM map is exactly 1: with u = w/(3·Σ_view w),
// 1 − SSIM = Σ_region Σ_c u·(1 − S), and the pixels outside need no sum at
// all (the crop normalization of PhotometricLoss, whose outside weight
// cancels in 1 − SSIM).
//
// Per step, after the forward pass: `ssim_rows` → `ssim_maps` (SSIM, its
// partials when a gradient is wanted, per-workgroup sums) → `ssim_grad_rows`
// → `loss_grad` → `loss_total`; an evaluation runs `ssim_rows`, `ssim_maps`
// and `loss_total` only. Dispatches are 2D over groups of 256 threads:
// i = (wid.y·groups.x + wid.x)·256 + lid; threads past the region's pixels do
// nothing (an evaluation dispatches for the whole image, not knowing the region).

struct LossParams {
    // Width of the view's image (targets are indexed in it).
    width: u32,
    // Entry of `results`/`status` this pass writes.
    slot: u32,
    partial_count: u32,
    // 0: the value only (no partial maps).
    gradient: u32,
    background: vec4<f32>,
    // 1 / (3·Σ weights of the whole view); 0 when no pixel is supervised.
    norm: f32,
    l1_weight: f32,
    ssim_weight: f32,
    supervised: u32,
    // Tile entries the render's buffers hold: a render that needed more
    // raises STATUS_OVERFLOW (u32 max: the buffers were sized to the render).
    entry_capacity: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    // The 11 Gaussian taps (σ = 1.5, normalised), four per vector.
    taps: array<vec4<f32>, 3>,
}

const HALF: i32 = 5;
const MAP_COUNT: u32 = 9u;
const IMAGE_STRIDE: u32 = 6u;
const C1: f32 = 0.0001;
const C2: f32 = 0.0009;

@group(0) @binding(0) var<uniform> params: LossParams;
// The region's render, stride 6.
@group(0) @binding(1) var<storage, read> image: array<f32>;
// Per pixel of the view: target colour and weight (0 = not supervised).
@group(0) @binding(2) var<storage, read> targets: array<vec4<f32>>;
// Per pixel of the view: FLAG_BACKGROUND where the target is the step's
// background colour (with FLAG_LAYERED: times its share, plus the target's
// colour) and FLAG_OWN on the component's own pixels.
@group(0) @binding(3) var<storage, read> flags: array<u32>;
@group(0) @binding(4) var<storage, read_write> rows: array<f32>;
@group(0) @binding(5) var<storage, read_write> maps: array<f32>;
@group(0) @binding(6) var<storage, read_write> upstream: array<f32>;
// Per workgroup: Σ u·|x − y|, Σ u·(1 − S), Σ w·(x − y)² (supervised pixels).
@group(0) @binding(7) var<storage, read_write> partials: array<vec4<f32>>;
// Per slot: loss and weighted squared error (f32 bits), the render's tile entries and region pixels.
@group(0) @binding(8) var<storage, read_write> results: array<vec4<u32>>;
@group(0) @binding(9) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(10) var<storage, read> frame: array<u32>;

var<workgroup> sums: array<vec4<f32>, 256>;

fn tap(i: i32) -> f32 {
    let k = u32(i);
    return params.taps[k / 4u][k % 4u];
}

// The frame record's region, read once per invocation.
struct Region {
    x0: u32,
    y0: u32,
    width: u32,
    height: u32,
    pixels: u32,
}

fn region() -> Region {
    var r: Region;
    r.x0 = frame[FRAME_X0];
    r.y0 = frame[FRAME_Y0];
    r.width = frame[FRAME_X1] - r.x0;
    r.height = frame[FRAME_Y1] - r.y0;
    r.pixels = r.width * r.height;
    return r;
}

// The view's pixel index of the region's pixel (x, y) (region coordinates).
fn view_pixel(r: Region, x: u32, y: u32) -> u32 {
    return (r.y0 + y) * params.width + r.x0 + x;
}

fn target_color(q: u32) -> vec3<f32> {
    let f = flags[q];
    if ((f & FLAG_LAYERED) != 0u) {
        return targets[q].xyz + params.background.xyz * (f32(f >> SHARE_SHIFT) / SHARE_ONE);
    }
    if ((f & FLAG_BACKGROUND) != 0u) {
        return params.background.xyz;
    }
    return targets[q].xyz;
}

// Scratch maps are stored plane by plane (value k of region pixel p at
// k·pixels + p), so neighbouring threads read neighbouring words.
fn plane(k: u32, p: u32, pixels: u32) -> u32 {
    return k * pixels + p;
}

fn rendered(p: u32, c: u32) -> f32 {
    return image[p * IMAGE_STRIDE + c];
}

// The blur window around region pixel p along its row or column: positions
// `lo` to `hi` (clipped to the region: zero padding) around `centre`; the
// pixel at position k is base + k·stride.
struct Window {
    centre: i32,
    lo: i32,
    hi: i32,
    base: u32,
    stride: u32,
}

fn window(centre: i32, extent: u32, base: u32, stride: u32) -> Window {
    return Window(centre, max(centre - HALF, 0), min(centre + HALF, i32(extent) - 1), base, stride);
}

fn row_window(r: Region, p: u32) -> Window {
    let x = p % r.width;
    return window(i32(x), r.width, p - x, 1u);
}

fn column_window(r: Region, p: u32) -> Window {
    return window(i32(p / r.width), r.height, p % r.width, r.width);
}

fn window_pixel(win: Window, k: i32) -> u32 {
    return win.base + u32(k) * win.stride;
}

// Adds `value` over the workgroup into `sums[0]` (a fixed tree order).
fn workgroup_sum(lid: u32, value: vec4<f32>) {
    sums[lid] = value;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride >>= 1u) {
        if (lid < stride) {
            sums[lid] += sums[lid + stride];
        }
        workgroupBarrier();
    }
}

// Horizontal blur of x, y, x², y², xy per channel.
@compute @workgroup_size(256)
fn ssim_rows(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let p = thread_index(wid, groups, lid);
    let r = region();
    if (p >= r.pixels) {
        return;
    }
    let win = row_window(r, p);
    let view_row = view_pixel(r, 0u, p / r.width);
    for (var c = 0u; c < 3u; c++) {
        var acc = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
        for (var xx = win.lo; xx <= win.hi; xx++) {
            let t = tap(xx + HALF - win.centre);
            let q = window_pixel(win, xx);
            let vy = target_color(view_row + u32(xx))[c];
            // An unsupervised pixel enters the windows with its target (as objectsplat_raster::loss).
            var vx = vy;
            if (targets[view_row + u32(xx)].w > 0.0) {
                vx = rendered(q, c);
            }
            acc[0] += t * vx;
            acc[1] += t * vy;
            acc[2] += t * (vx * vx);
            acc[3] += t * (vy * vy);
            acc[4] += t * (vx * vy);
        }
        for (var k = 0u; k < 5u; k++) {
            rows[plane(5u * c + k, p, r.pixels)] = acc[k];
        }
    }
}

// Vertical blur, then per channel the SSIM map and (for a gradient) its
// partials with respect to the blurred moments; per workgroup the sums.
@compute @workgroup_size(256)
fn ssim_maps(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let p = thread_index(wid, groups, lid);
    let r = region();
    var contribution = vec4<f32>(0.0);
    if (p < r.pixels) {
        let win = column_window(r, p);
        var finite = true;
        for (var k = 0u; k < IMAGE_STRIDE; k++) {
            finite = finite && is_finite(image[p * IMAGE_STRIDE + k]);
        }
        if (!finite) {
            atomicOr(&status[params.slot], STATUS_RENDER);
        }
        let q = view_pixel(r, win.base, u32(win.centre));
        let weight = targets[q].w;
        let u = weight * params.norm;
        let goal = target_color(q);
        for (var c = 0u; c < 3u; c++) {
            var m = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
            for (var yy = win.lo; yy <= win.hi; yy++) {
                let t = tap(yy + HALF - win.centre);
                let above = window_pixel(win, yy);
                for (var k = 0u; k < 5u; k++) {
                    m[k] += t * rows[plane(5u * c + k, above, r.pixels)];
                }
            }
            let mux = m[0];
            let muy = m[1];
            let vx = m[2] - mux * mux;
            let vy = m[3] - muy * muy;
            let cxy = m[4] - mux * muy;
            let a1 = 2.0 * mux * muy + C1;
            let a2 = 2.0 * cxy + C2;
            let b1 = mux * mux + muy * muy + C1;
            let b2 = vx + vy + C2;
            let s = a1 * a2 / (b1 * b2);
            if (params.gradient != 0u) {
                let ds_dmux = 2.0 * muy * a2 / (b1 * b2) - 2.0 * mux * s / b1;
                let ds_dvx = -s / b2;
                let ds_dcxy = 2.0 * a1 / (b1 * b2);
                // μx also enters σx² = E[x²] − μx² and σxy = E[xy] − μx·μy.
                maps[plane(3u * c, p, r.pixels)] = u * (ds_dmux - 2.0 * mux * ds_dvx - muy * ds_dcxy);
                maps[plane(3u * c + 1u, p, r.pixels)] = u * ds_dvx;
                maps[plane(3u * c + 2u, p, r.pixels)] = u * ds_dcxy;
            }
            let d = rendered(p, c) - goal[c];
            var squared = 0.0;
            if (weight > 0.0) {
                squared = weight * d * d;
            }
            contribution += vec4<f32>(u * abs(d), u * (1.0 - s), squared, 0.0);
        }
    }
    workgroup_sum(lid, contribution);
    if (lid == 0u) {
        partials[wid.y * groups.x + wid.x] = sums[0];
    }
}

// Horizontal blur of the nine partial maps (the blur is its own adjoint).
@compute @workgroup_size(256)
fn ssim_grad_rows(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let p = thread_index(wid, groups, lid);
    let r = region();
    if (p >= r.pixels) {
        return;
    }
    let win = row_window(r, p);
    var acc = array<f32, 9>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (var xx = win.lo; xx <= win.hi; xx++) {
        let t = tap(xx + HALF - win.centre);
        let q = window_pixel(win, xx);
        for (var k = 0u; k < MAP_COUNT; k++) {
            acc[k] += t * maps[plane(k, q, r.pixels)];
        }
    }
    for (var k = 0u; k < MAP_COUNT; k++) {
        rows[plane(k, p, r.pixels)] = acc[k];
    }
}

// Vertical blur of the partials and the loss gradient per colour channel.
@compute @workgroup_size(256)
fn loss_grad(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let p = thread_index(wid, groups, lid);
    let r = region();
    if (p >= r.pixels) {
        return;
    }
    let win = column_window(r, p);
    var b = array<f32, 9>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (var yy = win.lo; yy <= win.hi; yy++) {
        let t = tap(yy + HALF - win.centre);
        let above = window_pixel(win, yy);
        for (var k = 0u; k < MAP_COUNT; k++) {
            b[k] += t * rows[plane(k, above, r.pixels)];
        }
    }
    let q = view_pixel(r, win.base, u32(win.centre));
    let u = targets[q].w * params.norm;
    let goal = target_color(q);
    for (var c = 0u; c < 3u; c++) {
        let xv = rendered(p, c);
        let d = xv - goal[c];
        var l1 = 0.0;
        if (d > 0.0) {
            l1 = u;
        } else if (d < 0.0) {
            l1 = -u;
        }
        var s = 0.0;
        if (targets[q].w > 0.0) {
            s = b[3u * c] + 2.0 * xv * b[3u * c + 1u] + goal[c] * b[3u * c + 2u];
        }
        upstream[p * IMAGE_STRIDE + c] = params.l1_weight * l1 - params.ssim_weight * s;
    }
    for (var k = 3u; k < IMAGE_STRIDE; k++) {
        upstream[p * IMAGE_STRIDE + k] = 0.0;
    }
}

// One workgroup: the loss from the per-workgroup sums, in a fixed order (so
// the value does not depend on scheduling), with the weighted squared error
// and the render's entry count and region pixels.
@compute @workgroup_size(256)
fn loss_total(@builtin(local_invocation_index) lid: u32) {
    var acc = vec4<f32>(0.0);
    for (var g = lid; g < params.partial_count; g += 256u) {
        acc += partials[g];
    }
    workgroup_sum(lid, acc);
    if (lid == 0u) {
        var value = 0.0;
        if (params.supervised != 0u) {
            value = params.l1_weight * sums[0].x + params.ssim_weight * sums[0].y;
        }
        let pixels = (frame[FRAME_X1] - frame[FRAME_X0]) * (frame[FRAME_Y1] - frame[FRAME_Y0]);
        results[params.slot] = vec4<u32>(bitcast<u32>(value), bitcast<u32>(sums[0].z), frame[FRAME_ENTRIES], pixels);
        if (frame[FRAME_ENTRIES] > params.entry_capacity) {
            atomicOr(&status[params.slot], STATUS_OVERFLOW);
        }
        if (!is_finite(value)) {
            atomicOr(&status[params.slot], STATUS_LOSS);
        }
    }
}
