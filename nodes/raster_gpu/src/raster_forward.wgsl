// Front-to-back compositing (render_tile of cpu/forward.rs): one workgroup
// per 16×16 tile of FWD_THREADS threads (a constant the host prepends: 256 on
// GPUs, fewer on CPU adapters, where per-SIMD-group overheads dominate), each
// owning FWD_PIXELS pixels; faces in the tile's sorted order. Face data is
// staged per batch of 64 entries in workgroup memory, and per-face max weight
// and pixel count are gathered there before one global atomic per entry.
// Workgroups cover the tiles of the frame record's region (row-major); images
// and the per-pixel state cover the region's pixels, row-major.

@group(0) @binding(0) var<uniform> params: RasterParams;
@group(0) @binding(1) var<storage, read> tile_ranges: array<u32>;
@group(0) @binding(2) var<storage, read> entries: array<u32>;
@group(0) @binding(3) var<storage, read> faces: array<Face>;
@group(0) @binding(4) var<storage, read> background: array<f32>;
@group(0) @binding(5) var<storage, read_write> image: array<f32>;
@group(0) @binding(6) var<storage, read_write> pixel_state: array<u32>;
// Per face: max weight (f32 bits; non-negative floats order like their bits), pixel count.
@group(0) @binding(7) var<storage, read_write> face_stats: array<atomic<u32>>;
@group(0) @binding(8) var<storage, read> frame: array<u32>;

const BATCH: u32 = 64u;

var<workgroup> batch_max: array<atomic<u32>, BATCH>;
var<workgroup> batch_count: array<atomic<u32>, BATCH>;
var<workgroup> batch_faces: array<HotFace, BATCH>;
var<workgroup> alive: atomic<u32>;
var<workgroup> alive_snapshot: u32;

@compute @workgroup_size(FWD_THREADS)
fn forward(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
           @builtin(local_invocation_index) lid: u32) {
    let rt = region_tile(wid, groups);
    if (!rt.exists) {
        return;
    }
    let start = tile_ranges[2u * rt.index];
    let end = tile_ranges[2u * rt.index + 1u];
    var xs: array<u32, FWD_PIXELS>;
    var ys: array<u32, FWD_PIXELS>;
    var inside: array<bool, FWD_PIXELS>;
    var t: array<f32, FWD_PIXELS>;
    var color: array<vec3<f32>, FWD_PIXELS>;
    var depth: array<f32, FWD_PIXELS>;
    var median: array<f32, FWD_PIXELS>;
    var processed: array<u32, FWD_PIXELS>;
    var median_entry: array<u32, FWD_PIXELS>;
    var done: array<bool, FWD_PIXELS>;
    if (lid == 0u) {
        atomicStore(&alive, 0u);
    }
    workgroupBarrier();
    for (var h = 0u; h < FWD_PIXELS; h++) {
        let local = lid + h * FWD_THREADS;
        let pixel = tile_pixel(rt, local);
        xs[h] = pixel.x;
        ys[h] = pixel.y;
        inside[h] = in_region(rt, xs[h], ys[h]);
        t[h] = 1.0;
        color[h] = vec3<f32>(0.0);
        depth[h] = 0.0;
        median[h] = 0.0;
        processed[h] = 0u;
        median_entry[h] = NONE;
        done[h] = !inside[h];
        if (inside[h]) {
            atomicAdd(&alive, 1u);
        }
    }
    for (var batch = start; batch < end; batch += BATCH) {
        for (var i = lid; i < BATCH; i += FWD_THREADS) {
            atomicStore(&batch_max[i], 0u);
            atomicStore(&batch_count[i], 0u);
            if (batch + i < end) {
                batch_faces[i] = hot_face(entries[batch + i]);
            }
        }
        workgroupBarrier();
        if (lid == 0u) {
            alive_snapshot = atomicLoad(&alive);
        }
        // Every pixel of the tile is saturated: the rest cannot contribute.
        if (workgroupUniformLoad(&alive_snapshot) == 0u) {
            break;
        }
        let batch_end = min(batch + BATCH, end);
        for (var j = batch; j < batch_end; j++) {
            let hf = batch_faces[j - batch];
            for (var h = 0u; h < FWD_PIXELS; h++) {
                if (done[h] || !pixel_in_box(hf, xs[h], ys[h])) {
                    continue;
                }
                let fr = evaluate(hf, f32(xs[h]) + 0.5, f32(ys[h]) + 0.5);
                if (!fr.hit) {
                    continue;
                }
                let fi = entries[j];
                let w = fr.alpha * t[h];
                let z = fragment_depth(fi, fr);
                color[h] += w * fragment_color(fi, fr);
                depth[h] += w * z;
                if (t[h] > 0.5) {
                    median[h] = z;
                    median_entry[h] = j;
                }
                atomicMax(&batch_max[j - batch], bitcast<u32>(w));
                atomicAdd(&batch_count[j - batch], 1u);
                t[h] *= 1.0 - fr.alpha;
                processed[h] = j + 1u;
                if (t[h] < params.transmittance_min) {
                    done[h] = true;
                    atomicSub(&alive, 1u);
                }
            }
        }
        workgroupBarrier();
        for (var i = lid; i < batch_end - batch; i += FWD_THREADS) {
            let count = atomicLoad(&batch_count[i]);
            if (count > 0u) {
                let fi = entries[batch + i];
                atomicMax(&face_stats[2u * fi], atomicLoad(&batch_max[i]));
                atomicAdd(&face_stats[2u * fi + 1u], count);
            }
        }
        workgroupBarrier();
    }
    for (var h = 0u; h < FWD_PIXELS; h++) {
        if (!inside[h]) {
            continue;
        }
        let pix = region_pixel(rt, xs[h], ys[h]);
        let c = color[h] + t[h] * background_at(pix);
        let o = IMAGE_STRIDE * pix;
        image[o] = c.x;
        image[o + 1u] = c.y;
        image[o + 2u] = c.z;
        image[o + 3u] = 1.0 - t[h];
        image[o + 4u] = depth[h];
        image[o + 5u] = median[h];
        let s = STATE_STRIDE * pix;
        pixel_state[s] = bitcast<u32>(t[h]);
        pixel_state[s + 1u] = processed[h];
        pixel_state[s + 2u] = median_entry[h];
    }
}
