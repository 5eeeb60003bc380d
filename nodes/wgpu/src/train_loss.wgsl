// The training loss on the device: (1 − λ)·L1 + λ·(1 − SSIM) of the rendered
// colour against a view's target, weighted per pixel, with the gradient of
// objectsplat_raster::loss::photometric (same taps, same summation order of
// the separable blurs). The gradient is written as the backward pass's
// upstream buffer (stride 6: colour, alpha, depth, median depth).
//
// Per step: `fill_background` (the background image the forward composites
// over) → forward → `ssim_rows` → `ssim_maps` (SSIM and its partials, the
// per-workgroup sums) → `ssim_grad_rows` → `loss_grad` → `loss_total`.
// Dispatches are 2D over groups of 256 threads: i = (wid.y·groups.x + wid.x)·256 + lid.

struct LossParams {
    width: u32,
    height: u32,
    // Entry of `losses`/`status` this step writes.
    slot: u32,
    partial_count: u32,
    background: vec4<f32>,
    // 1 / (3·Σ weights); 0 when no pixel is supervised.
    norm: f32,
    l1_weight: f32,
    ssim_weight: f32,
    supervised: u32,
    // The 11 Gaussian taps (σ = 1.5, normalised), four per vector.
    taps: array<vec4<f32>, 3>,
}

const HALF: i32 = 5;
const MAP_COUNT: u32 = 9u;
const IMAGE_STRIDE: u32 = 6u;
const C1: f32 = 0.0001;
const C2: f32 = 0.0009;
const STATUS_RENDER: u32 = 1u;
const STATUS_LOSS: u32 = 2u;

@group(0) @binding(0) var<uniform> params: LossParams;
@group(0) @binding(1) var<storage, read> image: array<f32>;
// Per pixel: target colour and weight (0 = not supervised).
@group(0) @binding(2) var<storage, read> targets: array<vec4<f32>>;
// Per pixel: 1 where the target is the step's background colour.
@group(0) @binding(3) var<storage, read> from_background: array<u32>;
@group(0) @binding(4) var<storage, read_write> rows: array<f32>;
@group(0) @binding(5) var<storage, read_write> maps: array<f32>;
@group(0) @binding(6) var<storage, read_write> upstream: array<f32>;
@group(0) @binding(7) var<storage, read_write> partials: array<f32>;
@group(0) @binding(8) var<storage, read_write> losses: array<f32>;
@group(0) @binding(9) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(10) var<storage, read_write> background_image: array<f32>;

var<workgroup> sums: array<vec2<f32>, 256>;

fn thread_index(wid: vec3<u32>, groups: vec3<u32>, lid: u32) -> u32 {
    return (wid.y * groups.x + wid.x) * 256u + lid;
}

fn tap(i: i32) -> f32 {
    let k = u32(i);
    return params.taps[k / 4u][k % 4u];
}

// Not NaN and not ±∞, by the exponent bits (WGSL may assume finite floats in arithmetic).
fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn target_color(p: u32) -> vec3<f32> {
    if (from_background[p] != 0u) {
        return params.background.xyz;
    }
    return targets[p].xyz;
}

// Scratch maps are stored plane by plane (value k of pixel p at k·pixels + p),
// so neighbouring threads read neighbouring words.
fn plane(k: u32, p: u32) -> u32 {
    return k * params.width * params.height + p;
}

fn rendered(p: u32, c: u32) -> f32 {
    return image[p * IMAGE_STRIDE + c];
}

@compute @workgroup_size(256)
fn fill_background(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let p = thread_index(wid, groups, lid);
    if (p >= params.width * params.height) {
        return;
    }
    for (var c = 0u; c < 3u; c++) {
        background_image[3u * p + c] = params.background[c];
    }
}

// Horizontal blur of x, y, x², y², xy per channel.
@compute @workgroup_size(256)
fn ssim_rows(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let p = thread_index(wid, groups, lid);
    let w = i32(params.width);
    if (p >= params.width * params.height) {
        return;
    }
    let x = i32(p % params.width);
    let row = p - u32(x);
    let lo = max(x - HALF, 0);
    let hi = min(x + HALF, w - 1);
    for (var c = 0u; c < 3u; c++) {
        var acc = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
        for (var xx = lo; xx <= hi; xx++) {
            let t = tap(xx + HALF - x);
            let q = row + u32(xx);
            let vx = rendered(q, c);
            let vy = target_color(q)[c];
            acc[0] += t * vx;
            acc[1] += t * vy;
            acc[2] += t * (vx * vx);
            acc[3] += t * (vy * vy);
            acc[4] += t * (vx * vy);
        }
        for (var k = 0u; k < 5u; k++) {
            rows[plane(5u * c + k, p)] = acc[k];
        }
    }
}

// Vertical blur, then per channel the SSIM map and its partials with respect
// to the blurred moments; per workgroup the weighted L1 and SSIM sums.
@compute @workgroup_size(256)
fn ssim_maps(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let p = thread_index(wid, groups, lid);
    var contribution = vec2<f32>(0.0, 0.0);
    if (p < params.width * params.height) {
        let h = i32(params.height);
        let x = p % params.width;
        let y = i32(p / params.width);
        let lo = max(y - HALF, 0);
        let hi = min(y + HALF, h - 1);
        var finite = true;
        for (var k = 0u; k < IMAGE_STRIDE; k++) {
            finite = finite && is_finite(image[p * IMAGE_STRIDE + k]);
        }
        if (!finite) {
            atomicOr(&status[params.slot], STATUS_RENDER);
        }
        let u = targets[p].w * params.norm;
        let goal = target_color(p);
        for (var c = 0u; c < 3u; c++) {
            var m = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
            for (var yy = lo; yy <= hi; yy++) {
                let t = tap(yy + HALF - y);
                let q = u32(yy) * params.width + x;
                for (var k = 0u; k < 5u; k++) {
                    m[k] += t * rows[plane(5u * c + k, q)];
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
            let ds_dmux = 2.0 * muy * a2 / (b1 * b2) - 2.0 * mux * s / b1;
            let ds_dvx = -s / b2;
            let ds_dcxy = 2.0 * a1 / (b1 * b2);
            // μx also enters σx² = E[x²] − μx² and σxy = E[xy] − μx·μy.
            maps[plane(3u * c, p)] = u * (ds_dmux - 2.0 * mux * ds_dvx - muy * ds_dcxy);
            maps[plane(3u * c + 1u, p)] = u * ds_dvx;
            maps[plane(3u * c + 2u, p)] = u * ds_dcxy;
            contribution += vec2<f32>(u * abs(rendered(p, c) - goal[c]), u * s);
        }
    }
    sums[lid] = contribution;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride >>= 1u) {
        if (lid < stride) {
            sums[lid] += sums[lid + stride];
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
        let g = wid.y * groups.x + wid.x;
        partials[2u * g] = sums[0].x;
        partials[2u * g + 1u] = sums[0].y;
    }
}

// Horizontal blur of the nine partial maps (the blur is its own adjoint).
@compute @workgroup_size(256)
fn ssim_grad_rows(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let p = thread_index(wid, groups, lid);
    let w = i32(params.width);
    if (p >= params.width * params.height) {
        return;
    }
    let x = i32(p % params.width);
    let row = p - u32(x);
    let lo = max(x - HALF, 0);
    let hi = min(x + HALF, w - 1);
    var acc = array<f32, 9>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (var xx = lo; xx <= hi; xx++) {
        let t = tap(xx + HALF - x);
        let q = row + u32(xx);
        for (var k = 0u; k < MAP_COUNT; k++) {
            acc[k] += t * maps[plane(k, q)];
        }
    }
    for (var k = 0u; k < MAP_COUNT; k++) {
        rows[plane(k, p)] = acc[k];
    }
}

// Vertical blur of the partials and the loss gradient per colour channel.
@compute @workgroup_size(256)
fn loss_grad(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let p = thread_index(wid, groups, lid);
    if (p >= params.width * params.height) {
        return;
    }
    let h = i32(params.height);
    let x = p % params.width;
    let y = i32(p / params.width);
    let lo = max(y - HALF, 0);
    let hi = min(y + HALF, h - 1);
    var b = array<f32, 9>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (var yy = lo; yy <= hi; yy++) {
        let t = tap(yy + HALF - y);
        let q = u32(yy) * params.width + x;
        for (var k = 0u; k < MAP_COUNT; k++) {
            b[k] += t * rows[plane(k, q)];
        }
    }
    let u = targets[p].w * params.norm;
    let goal = target_color(p);
    for (var c = 0u; c < 3u; c++) {
        let xv = rendered(p, c);
        let d = xv - goal[c];
        var l1 = 0.0;
        if (d > 0.0) {
            l1 = u;
        } else if (d < 0.0) {
            l1 = -u;
        }
        let s = b[3u * c] + 2.0 * xv * b[3u * c + 1u] + goal[c] * b[3u * c + 2u];
        upstream[p * IMAGE_STRIDE + c] = params.l1_weight * l1 - params.ssim_weight * s;
    }
    for (var k = 3u; k < IMAGE_STRIDE; k++) {
        upstream[p * IMAGE_STRIDE + k] = 0.0;
    }
}

// One workgroup: the step's loss from the per-workgroup sums, in a fixed order
// (so the value does not depend on scheduling).
@compute @workgroup_size(256)
fn loss_total(@builtin(local_invocation_index) lid: u32) {
    var acc = vec2<f32>(0.0, 0.0);
    for (var g = lid; g < params.partial_count; g += 256u) {
        acc += vec2<f32>(partials[2u * g], partials[2u * g + 1u]);
    }
    sums[lid] = acc;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride >>= 1u) {
        if (lid < stride) {
            sums[lid] += sums[lid + stride];
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
        var value = 0.0;
        if (params.supervised != 0u) {
            value = params.l1_weight * sums[0].x + params.ssim_weight * (1.0 - sums[0].y);
        }
        losses[params.slot] = value;
        if (!is_finite(value)) {
            atomicOr(&status[params.slot], STATUS_LOSS);
        }
    }
}
