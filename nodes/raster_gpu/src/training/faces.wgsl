// The running per-face maximum of the blending weight over training renders
// (objectsplat_train's face statistics, kept on the device): after each
// training step's forward pass `fold_face_weights` takes the maximum of the
// epoch's running value and the render's per-face maximum (the forward
// pass's face statistics: max weight as f32 bits, pixel count). Non-negative
// floats order like their bit patterns, so the maximum is taken on the bits.
// A step whose render overflowed its tile-entry buffers is left out.

struct FaceParams {
    face_count: u32,
    // Step slot whose status says whether the render is valid.
    slot: u32,
    // 0: fold whatever the status (a render the caller checks itself).
    check_status: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: FaceParams;
@group(0) @binding(1) var<storage, read> face_stats: array<u32>;
@group(0) @binding(2) var<storage, read_write> running_max: array<u32>;
@group(0) @binding(3) var<storage, read_write> status: array<atomic<u32>>;

@compute @workgroup_size(256)
fn fold_face_weights(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let f = thread_index(wid, groups, lid);
    if (f >= params.face_count) {
        return;
    }
    if (params.check_status != 0u && (atomicLoad(&status[params.slot]) & STATUS_OVERFLOW) != 0u) {
        return;
    }
    running_max[f] = max(running_max[f], face_stats[2u * f]);
}
