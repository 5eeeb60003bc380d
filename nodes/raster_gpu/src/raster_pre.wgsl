// Projection, culling, tile binning: `vertex_pre`, `face_pre` (every culling
// rule of cpu/preprocess.rs; it also reduces the drawn faces' pixel boxes into
// the frame record), then after the faces are sorted by the tile of their
// top-left corner, `tile_counts` → scan → `frame_region` (entry count and
// rendered region) → `emit_entries` (→ `pad_entries` when the entry buffers
// were sized without reading the count back); after the depth sort,
// `gather_tiles`; after the tile sort, `tile_ranges`. Tiles are those of the
// whole image: the region only decides which of them are composited.
// Dispatches are 2D over groups of 256 threads: i = (wid.y·groups.x + wid.x)·256 + lid.

@group(0) @binding(0) var<uniform> params: RasterParams;
@group(0) @binding(1) var<storage, read> positions: array<f32>;
@group(0) @binding(2) var<storage, read> face_indices: array<u32>;
@group(0) @binding(3) var<storage, read> sh: array<f32>;
@group(0) @binding(4) var<storage, read> opacity_logits: array<f32>;
@group(0) @binding(5) var<storage, read_write> vertices: array<Vertex>;
@group(0) @binding(6) var<storage, read_write> faces: array<Face>;
@group(0) @binding(7) var<storage, read_write> order_keys: array<u32>;
@group(0) @binding(8) var<storage, read_write> order_faces: array<u32>;
@group(0) @binding(9) var<storage, read_write> entry_offsets: array<u32>;
@group(0) @binding(10) var<storage, read_write> entry_depth_keys: array<u32>;
@group(0) @binding(11) var<storage, read_write> entry_ids: array<u32>;
@group(0) @binding(12) var<storage, read_write> entry_tiles: array<u32>;
@group(0) @binding(13) var<storage, read_write> entry_faces: array<u32>;
@group(0) @binding(14) var<storage, read_write> sorted_tile_keys: array<u32>;
@group(0) @binding(15) var<storage, read_write> sorted_faces: array<u32>;
@group(0) @binding(16) var<storage, read_write> tile_ranges_out: array<u32>;
@group(0) @binding(17) var<storage, read_write> frame: array<atomic<u32>>;
// Per face from `params.sigma_from` on: its window sharpness (see RasterParams).
@group(0) @binding(18) var<storage, read> face_sigma: array<f32>;

fn sigmoid(x: f32) -> f32 {
    // Written so that neither branch overflows exp.
    if (x >= 0.0) {
        return 1.0 / (1.0 + exp(-x));
    }
    let e = exp(x);
    return e / (1.0 + e);
}

@compute @workgroup_size(256)
fn vertex_pre(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let v = thread_index(wid, groups, lid);
    if (v >= params.vertex_count) {
        return;
    }
    let p = vec3<f32>(positions[3u * v], positions[3u * v + 1u], positions[3u * v + 2u]);
    let c = vec3<f32>(
        params.rot0.x * p.x + params.rot0.y * p.y + params.rot0.z * p.z + params.rot0.w,
        params.rot1.x * p.x + params.rot1.y * p.y + params.rot1.z * p.z + params.rot1.w,
        params.rot2.x * p.x + params.rot2.y * p.y + params.rot2.z * p.z + params.rot2.w,
    );
    var out: Vertex;
    out.cam = array<f32, 3>(c.x, c.y, c.z);
    // Points at or behind the camera only belong to faces culled by z_near.
    out.screen = array<f32, 2>(0.0, 0.0);
    if (c.z > 0.0) {
        out.screen = array<f32, 2>(params.fx * c.x / c.z + params.cx, params.fy * c.y / c.z + params.cy);
    }
    let view = p - params.center.xyz;
    let len = sqrt(view.x * view.x + view.y * view.y + view.z * view.z);
    var dir = vec3<f32>(0.0);
    var distance = 0.0;
    if (len > 0.0) {
        dir = vec3<f32>(view.x / len, view.y / len, view.z / len);
        distance = len;
    }
    out.dir = array<f32, 3>(dir.x, dir.y, dir.z);
    out.distance = distance;
    let m = params.opacity_floor;
    out.opacity = m + (1.0 - m) * sigmoid(opacity_logits[v]);
    let y = sh_basis(dir, params.sh_degree);
    var rgb = vec3<f32>(0.5);
    let n = sh_coeff_count(params.sh_degree);
    for (var k = 0u; k < n; k++) {
        let base = v * 48u + 3u * k;
        rgb += y[k] * vec3<f32>(sh[base], sh[base + 1u], sh[base + 2u]);
    }
    var clamped = 0u;
    for (var ch = 0u; ch < 3u; ch++) {
        if (rgb[ch] < 0.0) {
            clamped |= 1u << ch;
            rgb[ch] = 0.0;
        }
    }
    out.color = array<f32, 3>(rgb.x, rgb.y, rgb.z);
    out.clamped = clamped;
    vertices[v] = out;
}

fn cross2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.y - a.y * b.x;
}

// Writes the face record (visible = 0 when any culling rule applies) and its
// tile-order sort pair (invisible faces get the key tiles_x·tiles_y, last).
@compute @workgroup_size(256)
fn face_pre(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let fi = thread_index(wid, groups, lid);
    if (fi >= params.face_count) {
        return;
    }
    order_faces[fi] = fi;
    order_keys[fi] = params.tiles_x * params.tiles_y;
    var f: Face;
    f.visible = 0u;
    faces[fi] = f;
    let idx = vec3<u32>(face_indices[3u * fi], face_indices[3u * fi + 1u], face_indices[3u * fi + 2u]);
    var c: array<vec3<f32>, 3>;
    for (var k = 0u; k < 3u; k++) {
        let vc = vertices[idx[k]].cam;
        c[k] = vec3<f32>(vc[0], vc[1], vc[2]);
        if (!(c[k].z > params.z_near)) {
            return;
        }
    }
    let centroid = vec3<f32>(
        (c[0].x + c[1].x + c[2].x) / 3.0,
        (c[0].y + c[1].y + c[2].y) / 3.0,
        (c[0].z + c[1].z + c[2].z) / 3.0,
    );
    if (!(centroid.z > params.min_centroid_depth)) {
        return;
    }
    let e1 = c[1] - c[0];
    let e2 = c[2] - c[0];
    let n = vec3<f32>(e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x);
    let n_len = sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    let c_len = sqrt(centroid.x * centroid.x + centroid.y * centroid.y + centroid.z * centroid.z);
    let dot_nc = abs(n.x * centroid.x + n.y * centroid.y + n.z * centroid.z);
    if (!(n_len > 0.0) || !(dot_nc >= params.min_abs_cos * n_len * c_len)) {
        return;
    }
    var op = vec3<f32>(vertices[idx[0]].opacity, vertices[idx[1]].opacity, vertices[idx[2]].opacity);
    var argmin = 0u;
    for (var k = 1u; k < 3u; k++) {
        if (op[k] < op[argmin]) {
            argmin = k;
        }
    }
    let opacity = op[argmin];
    if (!(opacity >= params.min_opacity)) {
        return;
    }
    var p: array<vec2<f32>, 3>;
    for (var k = 0u; k < 3u; k++) {
        let s = vertices[idx[k]].screen;
        p[k] = vec2<f32>(s[0], s[1]);
    }
    let pc = vec2<f32>((p[0].x + p[1].x + p[2].x) / 3.0, (p[0].y + p[1].y + p[2].y) / 3.0);
    var extent = 0.0;
    for (var k = 0u; k < 3u; k++) {
        let dx = p[k].x - pc.x;
        let dy = p[k].y - pc.y;
        extent = max(extent, sqrt(dx * dx + dy * dy));
    }
    if (!(extent <= params.max_screen_extent) || !(extent >= params.min_screen_extent)) {
        return;
    }
    let origin = floor(pc);
    var q: array<vec2<f32>, 3>;
    for (var k = 0u; k < 3u; k++) {
        q[k] = p[k] - origin;
    }
    let area2 = cross2(q[1] - q[0], q[2] - q[0]);
    var len: vec3<f32>;
    for (var k = 0u; k < 3u; k++) {
        let a = q[(k + 1u) % 3u];
        let b = q[(k + 2u) % 3u];
        let dx = b.x - a.x;
        let dy = b.y - a.y;
        len[k] = sqrt(dx * dx + dy * dy);
    }
    let perimeter = len.x + len.y + len.z;
    let inradius = abs(area2) / perimeter;
    if (!(inradius >= params.min_inradius)) {
        return;
    }
    let inv_area2 = 1.0 / area2;
    // Pixel i is sampled at i + 0.5; keep the centres within the bounding box.
    let lo = min(min(p[0], p[1]), p[2]);
    let hi = max(max(p[0], p[1]), p[2]);
    let x0 = max(ceil(lo.x - 0.5), 0.0);
    let x1 = min(floor(hi.x - 0.5), f32(params.width) - 1.0);
    let y0 = max(ceil(lo.y - 0.5), 0.0);
    let y1 = min(floor(hi.y - 0.5), f32(params.height) - 1.0);
    if (x0 > x1 || y0 > y1) {
        return;
    }
    for (var k = 0u; k < 3u; k++) {
        let a = q[(k + 1u) % 3u];
        let b = q[(k + 2u) % 3u];
        // λ_k(q) = (cross(a, b) + cross(b − a, q))/A2.
        f.lam[3u * k] = -(b.y - a.y) * inv_area2;
        f.lam[3u * k + 1u] = (b.x - a.x) * inv_area2;
        f.lam[3u * k + 2u] = cross2(a, b) * inv_area2;
        f.scale[k] = perimeter / len[k];
        f.q[2u * k] = q[k].x;
        f.q[2u * k + 1u] = q[k].y;
        f.len[k] = len[k];
        let col = vertices[idx[k]].color;
        f.color[3u * k] = col[0];
        f.color[3u * k + 1u] = col[1];
        f.color[3u * k + 2u] = col[2];
        f.z[k] = c[k].z;
    }
    f.origin_x = origin.x;
    f.origin_y = origin.y;
    f.area2 = area2;
    f.inv_area2 = inv_area2;
    f.perimeter = perimeter;
    f.opacity = opacity;
    f.depth = centroid.z;
    f.pixels = array<u32, 4>(u32(x0), u32(y0), u32(x1), u32(y1));
    f.argmin_corner = argmin;
    f.sigma = params.sigma;
    if (fi >= params.sigma_from) {
        f.sigma = face_sigma[fi];
    }
    f.visible = 1u;
    f.tile_key = (u32(y0) / TILE) * params.tiles_x + u32(x0) / TILE;
    faces[fi] = f;
    order_keys[fi] = f.tile_key;
    atomicMax(&frame[FRAME_FOOTPRINT], ~u32(x0));
    atomicMax(&frame[FRAME_FOOTPRINT + 1u], ~u32(y0));
    atomicMax(&frame[FRAME_FOOTPRINT + 2u], u32(x1) + 1u);
    atomicMax(&frame[FRAME_FOOTPRINT + 3u], u32(y1) + 1u);
}

fn saturating_sub(a: u32, b: u32) -> u32 {
    return select(0u, a - b, a > b);
}

fn saturating_add(a: u32, b: u32) -> u32 {
    return select(0xffffffffu, a + b, a <= 0xffffffffu - b);
}

// One thread, after the scan: the entry count, and the rendered region as
// objectsplat_raster's `Region` defines it: the whole image, or the drawn
// faces' pixel box ∪ include (`PixelRect::union`), grown by the margin and
// rounded out to whole tiles (`PixelRect::grown_to_tiles`).
@compute @workgroup_size(1)
fn frame_region() {
    atomicStore(&frame[FRAME_ENTRIES], entry_offsets[params.face_count]);
    let w = params.width;
    let h = params.height;
    var x0 = 0u;
    var y0 = 0u;
    var x1 = w;
    var y1 = h;
    if (params.region_mode == 1u) {
        var empty = true;
        let fx1 = atomicLoad(&frame[FRAME_FOOTPRINT + 2u]);
        if (fx1 != 0u) {
            x0 = ~atomicLoad(&frame[FRAME_FOOTPRINT]);
            y0 = ~atomicLoad(&frame[FRAME_FOOTPRINT + 1u]);
            x1 = fx1;
            y1 = atomicLoad(&frame[FRAME_FOOTPRINT + 3u]);
            empty = false;
        }
        let include_empty = params.include_x0 >= params.include_x1 || params.include_y0 >= params.include_y1;
        if (!include_empty) {
            if (empty) {
                x0 = params.include_x0;
                y0 = params.include_y0;
                x1 = params.include_x1;
                y1 = params.include_y1;
                empty = false;
            } else {
                x0 = min(x0, params.include_x0);
                y0 = min(y0, params.include_y0);
                x1 = max(x1, params.include_x1);
                y1 = max(y1, params.include_y1);
            }
        }
        if (empty) {
            x0 = 0u;
            y0 = 0u;
            x1 = 0u;
            y1 = 0u;
        } else {
            let m = params.margin;
            let gx0 = saturating_sub(x0, m) / TILE * TILE;
            let gy0 = saturating_sub(y0, m) / TILE * TILE;
            let gx1 = (min(saturating_add(x1, m), w) + TILE - 1u) / TILE * TILE;
            let gy1 = (min(saturating_add(y1, m), h) + TILE - 1u) / TILE * TILE;
            x0 = min(gx0, w);
            y0 = min(gy0, h);
            x1 = min(gx1, w);
            y1 = min(gy1, h);
        }
    }
    atomicStore(&frame[FRAME_X0], x0);
    atomicStore(&frame[FRAME_Y0], y0);
    atomicStore(&frame[FRAME_X1], x1);
    atomicStore(&frame[FRAME_Y1], y1);
}

// Tiles covered by the face in slot s (0 when culled); entry_offsets has face_count + 1 slots.
@compute @workgroup_size(256)
fn tile_counts(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let s = thread_index(wid, groups, lid);
    if (s > params.face_count) {
        return;
    }
    if (s == params.face_count) {
        entry_offsets[s] = 0u;
        return;
    }
    let f = faces[order_faces[s]];
    var count = 0u;
    if (f.visible == 1u) {
        count = (f.pixels[2] / TILE - f.pixels[0] / TILE + 1u) * (f.pixels[3] / TILE - f.pixels[1] / TILE + 1u);
    }
    entry_offsets[s] = count;
}

// One entry per (face, covered tile), in slot order: the sort ties break by slot.
@compute @workgroup_size(256)
fn emit_entries(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let s = thread_index(wid, groups, lid);
    if (s >= params.face_count) {
        return;
    }
    let fi = order_faces[s];
    let f = faces[fi];
    if (f.visible != 1u) {
        return;
    }
    // Positive floats order like their bit patterns.
    let depth_key = bitcast<u32>(f.depth);
    var at = entry_offsets[s];
    for (var ty = f.pixels[1] / TILE; ty <= f.pixels[3] / TILE; ty++) {
        for (var tx = f.pixels[0] / TILE; tx <= f.pixels[2] / TILE; tx++) {
            // Past the buffers' capacity (a render that did not read the count
            // back): dropped, and the caller discards the render.
            if (at < params.entry_count) {
                entry_depth_keys[at] = depth_key;
                entry_ids[at] = at;
                entry_tiles[at] = ty * params.tiles_x + tx;
                entry_faces[at] = fi;
            }
            at++;
        }
    }
}

// Entries past the real count up to the sorted count (the buffers' capacity)
// sort after every real one: largest depth key, tile key one past the last tile.
@compute @workgroup_size(256)
fn pad_entries(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, groups, lid);
    if (i >= params.entry_count || i < atomicLoad(&frame[FRAME_ENTRIES])) {
        return;
    }
    entry_depth_keys[i] = 0xffffffffu;
    entry_ids[i] = i;
    entry_tiles[i] = params.tiles_x * params.tiles_y;
    entry_faces[i] = 0u;
}

// After the depth sort: the tile and face of each entry in depth order.
@compute @workgroup_size(256)
fn gather_tiles(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, groups, lid);
    if (i >= params.entry_count) {
        return;
    }
    let e = entry_ids[i];
    sorted_tile_keys[i] = entry_tiles[e];
    sorted_faces[i] = entry_faces[e];
}

// After the tile sort: tile t holds entries [ranges[2t], ranges[2t+1]) (zeroed beforehand).
@compute @workgroup_size(256)
fn tile_ranges(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = thread_index(wid, groups, lid);
    let n = params.entry_count;
    if (i >= n) {
        return;
    }
    let t = sorted_tile_keys[i];
    if (t >= params.tiles_x * params.tiles_y) {
        // Padding (see pad_entries).
        return;
    }
    if (i == 0u || sorted_tile_keys[i - 1u] != t) {
        tile_ranges_out[2u * t] = i;
    }
    if (i == n - 1u || sorted_tile_keys[i + 1u] != t) {
        tile_ranges_out[2u * t + 1u] = i + 1u;
    }
}
