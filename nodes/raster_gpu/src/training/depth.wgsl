// The two geometric losses of objectsplat_train on the device, as gradients
// added to the backward pass's upstream buffer (stride 6: colour, alpha,
// depth, median depth) after the photometric loss wrote it. With D the
// rendered expected depth Σ w z and α the coverage Σ w of a region pixel:
//
// - `point_depth` (one workgroup): the depth at the view's measured points,
//   λ · mean |D/α − d| / d over the points inside the region, a point whose
//   pixel is covered less than MIN_COVERAGE adding nothing (point_depth.rs).
// - `planar_inverse` → `planar_count` → `planar_gradient`: the planar prior,
//   λ · mean |q₋ − 2q₀ + q₊| / q₀ over every horizontal and vertical run of
//   three of the component's own region pixels covered at least MIN_COVERAGE,
//   with q = α/D (depth_smoothness.rs). The first kernel writes q (0 where a
//   pixel takes no part), the second counts the runs (an integer atomic: the
//   same total in any order), the third gathers each pixel's gradient from
//   the runs it belongs to, so no two threads write one pixel.
//
// The region is the frame record's; runs stay inside it, as on a host crop.

struct DepthParams {
    // Width of the view's image (flags are indexed in it).
    width: u32,
    // Measured points of the view (point_depth).
    point_count: u32,
    // Step slot whose status word takes STATUS_DEPTH.
    slot: u32,
    _pad: u32,
    weight: f32,
    _pad1: f32,
    _pad2: f32,
    _pad3: f32,
}

const IMAGE_STRIDE: u32 = 6u;
const ALPHA: u32 = 3u;
const DEPTH: u32 = 4u;
const MIN_COVERAGE: f32 = 0.5;

@group(0) @binding(0) var<uniform> params: DepthParams;
// The region's render, stride 6.
@group(0) @binding(1) var<storage, read> image: array<f32>;
@group(0) @binding(2) var<storage, read_write> upstream: array<f32>;
@group(0) @binding(3) var<storage, read> frame: array<u32>;
// (pixel index in the view's image, the point's camera depth as f32 bits).
@group(0) @binding(4) var<storage, read> points: array<vec2<u32>>;
// Per pixel of the view: FLAG_BACKGROUND, FLAG_OWN.
@group(0) @binding(5) var<storage, read> flags: array<u32>;
// Per region pixel: q = α/D, or 0 where the pixel takes no part.
@group(0) @binding(6) var<storage, read_write> inverse: array<f32>;
// The number of runs (word 0).
@group(0) @binding(7) var<storage, read_write> runs: array<atomic<u32>>;
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;

struct Region {
    x0: u32,
    y0: u32,
    width: u32,
    height: u32,
}

fn region() -> Region {
    return Region(frame[FRAME_X0], frame[FRAME_Y0], frame[FRAME_X1] - frame[FRAME_X0], frame[FRAME_Y1] - frame[FRAME_Y0]);
}

var<workgroup> counts: array<u32, 256>;

// The sum of every invocation's `n` over the workgroup, the same in all of them (call from
// uniform control flow).
fn workgroup_count(lid: u32, n: u32) -> u32 {
    counts[lid] = n;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride >>= 1u) {
        if (lid < stride) {
            counts[lid] += counts[lid + stride];
        }
        workgroupBarrier();
    }
    return workgroupUniformLoad(&counts[0]);
}

// The region index of a view pixel, or NONE outside the region.
fn region_index(r: Region, pixel: u32) -> u32 {
    let x = pixel % params.width;
    let y = pixel / params.width;
    if (x < r.x0 || y < r.y0 || x >= r.x0 + r.width || y >= r.y0 + r.height) {
        return 0xffffffffu;
    }
    return (y - r.y0) * r.width + (x - r.x0);
}

fn add_gradient(i: u32, d_depth: f32, d_alpha: f32) {
    if (!is_finite(d_depth) || !is_finite(d_alpha)) {
        atomicOr(&status[params.slot], STATUS_DEPTH);
        return;
    }
    upstream[i * IMAGE_STRIDE + DEPTH] += d_depth;
    upstream[i * IMAGE_STRIDE + ALPHA] += d_alpha;
}

@compute @workgroup_size(256)
fn point_depth(@builtin(local_invocation_index) lid: u32) {
    let r = region();
    var inside = 0u;
    for (var k = lid; k < params.point_count; k += 256u) {
        if (region_index(r, points[k].x) != 0xffffffffu) {
            inside += 1u;
        }
    }
    let count = workgroup_count(lid, inside);
    if (count == 0u) {
        return;
    }
    let scale = params.weight / f32(count);
    // One point per pixel (the nearest), so no two threads write one pixel.
    for (var k = lid; k < params.point_count; k += 256u) {
        let i = region_index(r, points[k].x);
        if (i == 0xffffffffu) {
            continue;
        }
        let alpha = image[i * IMAGE_STRIDE + ALPHA];
        if (!(alpha >= MIN_COVERAGE)) {
            continue;
        }
        let d = bitcast<f32>(points[k].y);
        // e = D/α − d: the depth of what covers the pixel, whatever its coverage.
        let depth = image[i * IMAGE_STRIDE + DEPTH] / alpha;
        let error = depth - d;
        let g = scale * sign(error) / (d * alpha);
        // d|e|/dD = sign/α, d|e|/dα = −sign·D/α²; both divided by d.
        add_gradient(i, g, -g * depth);
    }
}

@compute @workgroup_size(256)
fn planar_inverse(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let p = thread_index(wid, groups, lid);
    let r = region();
    if (p >= r.width * r.height) {
        return;
    }
    let pixel = (r.y0 + p / r.width) * params.width + r.x0 + p % r.width;
    let a = image[p * IMAGE_STRIDE + ALPHA];
    let d = image[p * IMAGE_STRIDE + DEPTH];
    var q = 0.0;
    if ((flags[pixel] & FLAG_OWN) != 0u && a >= MIN_COVERAGE && d > 0.0 && is_finite(d)) {
        q = a / d;
    }
    inverse[p] = q;
}

// q of region pixel (x, y) — 0 outside the region or where it takes no part.
fn q_at(r: Region, x: i32, y: i32) -> f32 {
    if (x < 0 || y < 0 || x >= i32(r.width) || y >= i32(r.height)) {
        return 0.0;
    }
    return inverse[u32(y) * r.width + u32(x)];
}

// Whether the run of three centred on (x, y) along (dx, dy) takes part.
fn run_counts(r: Region, x: i32, y: i32, dx: i32, dy: i32) -> bool {
    return q_at(r, x - dx, y - dy) > 0.0 && q_at(r, x, y) > 0.0 && q_at(r, x + dx, y + dy) > 0.0;
}

@compute @workgroup_size(256)
fn planar_count(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    // (Uniform: every thread returns or none does.)
    if (!(params.weight > 0.0)) {
        return;
    }
    let p = thread_index(wid, groups, lid);
    let r = region();
    var n = 0u;
    if (p < r.width * r.height) {
        let x = i32(p % r.width);
        let y = i32(p / r.width);
        n = u32(run_counts(r, x, y, 1, 0)) + u32(run_counts(r, x, y, 0, 1));
    }
    let total = workgroup_count(lid, n);
    if (lid == 0u && total > 0u) {
        atomicAdd(&runs[0], total);
    }
}

// d(|s|/q₀)/dq of the run centred on (cx, cy) along (dx, dy), for the pixel
// at offset k ∈ {−1, 0, 1} along it (0 when the run takes no part).
fn run_gradient(r: Region, cx: i32, cy: i32, dx: i32, dy: i32, k: i32) -> f32 {
    if (!run_counts(r, cx, cy, dx, dy)) {
        return 0.0;
    }
    let qa = q_at(r, cx - dx, cy - dy);
    let qb = q_at(r, cx, cy);
    let qc = q_at(r, cx + dx, cy + dy);
    let s = qa - 2.0 * qb + qc;
    let sg = sign(s);
    if (k == 0) {
        return -2.0 * sg / qb - abs(s) / (qb * qb);
    }
    return sg / qb;
}

@compute @workgroup_size(256)
fn planar_gradient(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let p = thread_index(wid, groups, lid);
    let r = region();
    let count = atomicLoad(&runs[0]);
    if (p >= r.width * r.height || count == 0u || !(inverse[p] > 0.0)) {
        return;
    }
    let x = i32(p % r.width);
    let y = i32(p / r.width);
    var g = 0.0;
    for (var axis = 0; axis < 2; axis++) {
        let dx = select(0, 1, axis == 0);
        let dy = 1 - dx;
        // The runs this pixel ends (centred one step before or after it) or centres.
        g += run_gradient(r, x + dx, y + dy, dx, dy, -1);
        g += run_gradient(r, x, y, dx, dy, 0);
        g += run_gradient(r, x - dx, y - dy, dx, dy, 1);
    }
    if (g == 0.0) {
        return;
    }
    g *= params.weight / f32(count);
    // q = α/D: dq/dD = −α/D², dq/dα = 1/D.
    let a = image[p * IMAGE_STRIDE + ALPHA];
    let d = image[p * IMAGE_STRIDE + DEPTH];
    add_gradient(p, -g * a / (d * d), g / d);
}
