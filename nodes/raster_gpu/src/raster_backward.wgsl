// Per-tile backward (backward_tile + accumulate_fragment of cpu/backward.rs):
// THREADS threads (a constant the host prepends: 128 on GPUs, 32 on CPU
// adapters where every workgroup barrier costs a coroutine switch per SIMD
// group), each owning PIXELS_PER_THREAD pixels of the 16×16 tile.
// Entries are walked back to front from the last one any pixel processed; the
// transmittance before a fragment is recovered as T_after/(1 − α) (α ≤
// alpha_max < 1). Each entry's per-pixel partials are summed in workgroup
// memory, then added once per face to the global accumulator with
// `add_face_grad` (native float atomics or a compare-exchange loop; prepended
// by the host, which also declares `face_grads` at binding 8). Workgroups,
// per-pixel state, upstream gradients and the background cover the frame
// record's region, as in the forward pass.

@group(0) @binding(0) var<uniform> params: RasterParams;
@group(0) @binding(1) var<storage, read> tile_ranges: array<u32>;
@group(0) @binding(2) var<storage, read> entries: array<u32>;
@group(0) @binding(3) var<storage, read> faces: array<Face>;
@group(0) @binding(4) var<storage, read> pixel_state: array<u32>;
// Per pixel: dL/d(r, g, b), dL/dalpha, dL/ddepth, dL/dmedian_depth.
@group(0) @binding(5) var<storage, read> upstream: array<f32>;
@group(0) @binding(6) var<storage, read> background: array<f32>;
@group(0) @binding(7) var<storage, read_write> background_grad: array<f32>;
@group(0) @binding(9) var<storage, read> frame: array<u32>;

var<workgroup> reduce_in: array<f32, PARTIAL * THREADS>;
var<workgroup> reduce_mid: array<f32, 92>; // PARTIAL × 4
var<workgroup> max_processed: atomic<u32>;
var<workgroup> max_processed_snapshot: u32;

@compute @workgroup_size(THREADS)
fn backward(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
            @builtin(local_invocation_index) lid: u32) {
    let rt = region_tile(wid, groups);
    if (!rt.exists) {
        return;
    }
    let start = tile_ranges[2u * rt.index];
    var xs: array<u32, PIXELS_PER_THREAD>;
    var ys: array<u32, PIXELS_PER_THREAD>;
    var inside: array<bool, PIXELS_PER_THREAD>;
    var t: array<f32, PIXELS_PER_THREAD>;
    var processed: array<u32, PIXELS_PER_THREAD>;
    var median_entry: array<u32, PIXELS_PER_THREAD>;
    var gc: array<vec3<f32>, PIXELS_PER_THREAD>;
    var gd: array<f32, PIXELS_PER_THREAD>;
    var gm: array<f32, PIXELS_PER_THREAD>;
    var behind: array<f32, PIXELS_PER_THREAD>;
    if (lid == 0u) {
        atomicStore(&max_processed, 0u);
    }
    workgroupBarrier();
    for (var h = 0u; h < PIXELS_PER_THREAD; h++) {
        let local = lid + h * THREADS;
        let pixel = tile_pixel(rt, local);
        xs[h] = pixel.x;
        ys[h] = pixel.y;
        inside[h] = in_region(rt, xs[h], ys[h]);
        processed[h] = 0u;
        if (!inside[h]) {
            continue;
        }
        let pix = region_pixel(rt, xs[h], ys[h]);
        let s = STATE_STRIDE * pix;
        t[h] = bitcast<f32>(pixel_state[s]);
        processed[h] = pixel_state[s + 1u];
        median_entry[h] = pixel_state[s + 2u];
        let u = 6u * pix;
        gc[h] = vec3<f32>(upstream[u], upstream[u + 1u], upstream[u + 2u]);
        let ga = upstream[u + 3u];
        gd[h] = upstream[u + 4u];
        gm[h] = upstream[u + 5u];
        let bg = background_at(pix);
        background_grad[3u * pix] = gc[h].x * t[h];
        background_grad[3u * pix + 1u] = gc[h].y * t[h];
        background_grad[3u * pix + 2u] = gc[h].z * t[h];
        behind[h] = t[h] * (bg.x * gc[h].x + bg.y * gc[h].y + bg.z * gc[h].z) - ga * t[h];
        atomicMax(&max_processed, processed[h]);
    }
    workgroupBarrier();
    if (lid == 0u) {
        max_processed_snapshot = atomicLoad(&max_processed);
    }
    let last = workgroupUniformLoad(&max_processed_snapshot);
    for (var j = last; j > start; j--) {
        let e = j - 1u;
        let fi = entries[e];
        let hf = hot_face(fi);
        var part: array<f32, 23>;
        for (var h = 0u; h < PIXELS_PER_THREAD; h++) {
            if (!inside[h] || e >= processed[h] || !pixel_in_box(hf, xs[h], ys[h])) {
                continue;
            }
            let fr = evaluate(hf, f32(xs[h]) + 0.5, f32(ys[h]) + 0.5);
            if (!fr.hit) {
                continue;
            }
            let t_before = t[h] / (1.0 - fr.alpha);
            t[h] = t_before;
            let c = fragment_color(fi, fr);
            let z = fragment_depth(fi, fr);
            let w = fr.alpha * t_before;
            let hsum = dot(c, gc[h]) + z * gd[h];
            let d_alpha = t_before * hsum - behind[h] / (1.0 - fr.alpha);
            behind[h] += hsum * w;
            let d_c = gc[h] * w;
            var d_zpix = w * gd[h];
            if (median_entry[h] == e) {
                d_zpix += gm[h];
            }
            var d_lambda: vec3<f32>;
            for (var k = 0u; k < 3u; k++) {
                let ck = face_corner_color(fi, k);
                d_lambda[k] = ck.x * d_c.x + ck.y * d_c.y + ck.z * d_c.z + faces[fi].z[k] * d_zpix;
                for (var ch = 0u; ch < 3u; ch++) {
                    part[P_COLOR + 3u * k + ch] += fr.lambda[k] * d_c[ch];
                }
                part[P_Z + k] += fr.lambda[k] * d_zpix;
            }
            if (!fr.clamped) {
                // α = o·G^σ.
                part[P_OPACITY] += d_alpha * fr.intensity;
                let d_g = d_alpha * faces[fi].opacity * faces[fi].sigma * fr.intensity / fr.g;
                let k = fr.kstar;
                d_lambda[k] += d_g * faces[fi].scale[k];
                part[P_SCALE + k] += d_g * fr.lambda[k];
            }
            // λ_k = cross(q_{k+1} − q, q_{k+2} − q)/A2 with A2 the doubled area.
            var area_term = 0.0;
            for (var k = 0u; k < 3u; k++) {
                let d = d_lambda[k] * faces[fi].inv_area2;
                let a = (k + 1u) % 3u;
                let b = (k + 2u) % 3u;
                let qa = vec2<f32>(faces[fi].q[2u * a], faces[fi].q[2u * a + 1u]);
                let qb = vec2<f32>(faces[fi].q[2u * b], faces[fi].q[2u * b + 1u]);
                part[2u * a] += d * (qb.y - fr.q.y);
                part[2u * a + 1u] -= d * (qb.x - fr.q.x);
                part[2u * b] -= d * (qa.y - fr.q.y);
                part[2u * b + 1u] += d * (qa.x - fr.q.x);
                area_term += d * fr.lambda[k];
            }
            part[P_AREA] += area_term;
        }
        for (var c = 0u; c < PARTIAL; c++) {
            reduce_in[c * THREADS + lid] = part[c];
        }
        workgroupBarrier();
        for (var r = lid; r < PARTIAL * 4u; r += THREADS) {
            let c = r / 4u;
            let base = c * THREADS + (r % 4u) * (THREADS / 4u);
            var sum = 0.0;
            for (var i = 0u; i < THREADS / 4u; i++) {
                sum += reduce_in[base + i];
            }
            reduce_mid[r] = sum;
        }
        workgroupBarrier();
        if (lid < PARTIAL) {
            let sum = reduce_mid[4u * lid] + reduce_mid[4u * lid + 1u] + reduce_mid[4u * lid + 2u]
                + reduce_mid[4u * lid + 3u];
            if (sum != 0.0) {
                add_face_grad(fi * PARTIAL + lid, sum);
            }
        }
    }
}
