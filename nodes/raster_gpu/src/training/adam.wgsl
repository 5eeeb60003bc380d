// One Adam update of a parameter tensor in place, as the trainer's Adam
// (objectsplat_train::adam): m ← β1·m + (1−β1)·g, v ← β2·v + (1−β2)·g²,
// p ← p − lr·(m/bc1)/(√(v/bc2) + ε), with the bias corrections bc1, bc2
// computed on the host. Rows of `row_width` values take `lr_first` for their
// first `split` values and `lr_rest` for the others (SH: DC vs higher bands).
// Only the first `active` values of a row move (SH bands above the trained
// model's degree stay as they are, as on the host, even where a composite with
// occluders renders them). A non-finite gradient leaves its value untouched
// and raises `grad_bit` in the step's status; a non-finite result raises
// `grad_bit << 1`. A step whose render overflowed (STATUS_OVERFLOW) moves nothing.

struct AdamParams {
    count: u32,
    row_width: u32,
    split: u32,
    grad_bit: u32,
    lr_first: f32,
    lr_rest: f32,
    beta1: f32,
    beta2: f32,
    // 1 − β1 and 1 − β2 rounded from f64, as the host's Adam computes them.
    complement1: f32,
    complement2: f32,
    eps: f32,
    bias1: f32,
    bias2: f32,
    slot: u32,
    active_width: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: AdamParams;
@group(0) @binding(1) var<storage, read_write> values: array<f32>;
@group(0) @binding(2) var<storage, read> grads: array<f32>;
@group(0) @binding(3) var<storage, read_write> first_moment: array<f32>;
@group(0) @binding(4) var<storage, read_write> second_moment: array<f32>;
@group(0) @binding(5) var<storage, read_write> status: array<atomic<u32>>;

@compute @workgroup_size(256)
fn adam_step(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, groups, lid);
    if (i >= params.count || i % params.row_width >= params.active_width) {
        return;
    }
    if ((atomicLoad(&status[params.slot]) & STATUS_OVERFLOW) != 0u) {
        return;
    }
    let g = grads[i];
    if (!is_finite(g)) {
        atomicOr(&status[params.slot], params.grad_bit);
        return;
    }
    let m = params.beta1 * first_moment[i] + params.complement1 * g;
    let v = params.beta2 * second_moment[i] + params.complement2 * g * g;
    first_moment[i] = m;
    second_moment[i] = v;
    var lr = params.lr_rest;
    if (i % params.row_width < params.split) {
        lr = params.lr_first;
    }
    let updated = values[i] - lr * (m / params.bias1) / (sqrt(v / params.bias2) + params.eps);
    if (!is_finite(updated)) {
        atomicOr(&status[params.slot], params.grad_bit << 1u);
    }
    values[i] = updated;
}
