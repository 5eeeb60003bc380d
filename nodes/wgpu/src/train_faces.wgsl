// The running per-face maximum of the blending weight over training renders
// (objectsplat_train's face statistics, kept on the device): after each
// training step's forward pass `fold_face_weights` takes the maximum of the
// epoch's running value and the render's per-face maximum (the forward
// pass's face statistics: max weight as f32 bits, pixel count). Non-negative
// floats order like their bit patterns, so the maximum is taken on the bits.

struct FaceParams {
    face_count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: FaceParams;
@group(0) @binding(1) var<storage, read> face_stats: array<u32>;
@group(0) @binding(2) var<storage, read_write> running_max: array<u32>;

@compute @workgroup_size(256)
fn fold_face_weights(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let f = (wid.y * groups.x + wid.x) * 256u + lid;
    if (f >= params.face_count) {
        return;
    }
    running_max[f] = max(running_max[f], face_stats[2u * f]);
}
