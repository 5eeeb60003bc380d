// Supersampled training steps (objectsplat_raster::supersample on the device):
// the forward pass renders the view's camera scaled by `factor`; `box_filter`
// averages its region (stride 6: colour, alpha, depth, median depth) over each
// pixel's factor² samples into a region of the view's pixels, with a frame
// record whose region is the fine one divided by the factor (the fine region
// is whole 16-sample tiles and the factor divides 16); the loss and the depth
// terms read those. `spread` is the adjoint: each sample's upstream gradient
// is its pixel's over factor².

struct SampleParams {
    factor: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

const STRIDE: u32 = 6u;

@group(0) @binding(0) var<uniform> params: SampleParams;
@group(0) @binding(1) var<storage, read> fine_frame: array<u32>;
@group(0) @binding(2) var<storage, read> fine: array<f32>;
@group(0) @binding(3) var<storage, read_write> coarse_frame: array<u32>;
@group(0) @binding(4) var<storage, read_write> coarse: array<f32>;

// The fine region's corners, in samples.
fn fine_region() -> vec4<u32> {
    return vec4<u32>(fine_frame[FRAME_X0], fine_frame[FRAME_Y0], fine_frame[FRAME_X1], fine_frame[FRAME_Y1]);
}

@compute @workgroup_size(256)
fn box_filter(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, groups, lid);
    let s = params.factor;
    let r = fine_region();
    let c = r / s;
    if (i == 0u) {
        coarse_frame[FRAME_ENTRIES] = fine_frame[FRAME_ENTRIES];
        coarse_frame[FRAME_X0] = c.x;
        coarse_frame[FRAME_Y0] = c.y;
        coarse_frame[FRAME_X1] = c.z;
        coarse_frame[FRAME_Y1] = c.w;
    }
    let width = c.z - c.x;
    let pixels = width * (c.w - c.y);
    if (i >= pixels) {
        return;
    }
    let fine_width = r.z - r.x;
    let x = (i % width) * s;
    let y = (i / width) * s;
    var sum = array<f32, 6>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (var dy = 0u; dy < s; dy++) {
        for (var dx = 0u; dx < s; dx++) {
            let j = ((y + dy) * fine_width + x + dx) * STRIDE;
            for (var k = 0u; k < STRIDE; k++) {
                sum[k] += fine[j + k];
            }
        }
    }
    let scale = 1.0 / f32(s * s);
    for (var k = 0u; k < STRIDE; k++) {
        coarse[i * STRIDE + k] = sum[k] * scale;
    }
}

// Bindings of `spread`: the coarse upstream gradient in, the fine one out.
@group(0) @binding(5) var<storage, read> coarse_upstream: array<f32>;
@group(0) @binding(6) var<storage, read_write> fine_upstream: array<f32>;

@compute @workgroup_size(256)
fn spread(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, groups, lid);
    let s = params.factor;
    let r = fine_region();
    let fine_width = r.z - r.x;
    if (i >= fine_width * (r.w - r.y)) {
        return;
    }
    let width = fine_width / s;
    let j = ((i / fine_width) / s * width + (i % fine_width) / s) * STRIDE;
    let scale = 1.0 / f32(s * s);
    for (var k = 0u; k < STRIDE; k++) {
        fine_upstream[i * STRIDE + k] = coarse_upstream[j + k] * scale;
    }
}
