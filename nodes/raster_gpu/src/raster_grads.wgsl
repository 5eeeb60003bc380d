// Per-face and per-vertex backward (face_backward and the vertex stage of
// cpu/mod.rs): `face_backward` turns each visible face's summed partial into
// corner gradients and adds them to its vertices' accumulators;
// `vertex_backward` goes through the projection, the SH colour and the
// opacity activation. The host prepends `add_*`/`load_*` helpers declaring
// `face_grads` (binding 9) and `vertex_grads` (binding 10).

@group(0) @binding(0) var<uniform> params: RasterParams;
@group(0) @binding(1) var<storage, read> faces: array<Face>;
@group(0) @binding(2) var<storage, read> face_indices: array<u32>;
@group(0) @binding(3) var<storage, read> vertices: array<Vertex>;
@group(0) @binding(4) var<storage, read> sh: array<f32>;
@group(0) @binding(5) var<storage, read> opacity_logits: array<f32>;
@group(0) @binding(6) var<storage, read_write> position_grad: array<f32>;
@group(0) @binding(7) var<storage, read_write> sh_grad: array<f32>;
@group(0) @binding(8) var<storage, read_write> logit_grad: array<f32>;

fn add_vertex_nonzero(i: u32, v: f32) {
    if (v != 0.0) {
        add_vertex_grad(i, v);
    }
}

@compute @workgroup_size(256)
fn face_backward(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let fi = thread_index(wid, groups, lid);
    if (fi >= params.face_count) {
        return;
    }
    let f = faces[fi];
    if (f.visible != 1u) {
        return;
    }
    var p: array<f32, 23>;
    for (var c = 0u; c < PARTIAL; c++) {
        p[c] = load_face_grad(fi * PARTIAL + c);
    }
    var q: array<vec2<f32>, 3>;
    var d_q: array<vec2<f32>, 3>;
    for (var j = 0u; j < 3u; j++) {
        q[j] = vec2<f32>(f.q[2u * j], f.q[2u * j + 1u]);
        d_q[j] = vec2<f32>(p[2u * j], p[2u * j + 1u]);
    }
    // ∂A2/∂q_j = (q_{j+1}.y − q_{j−1}.y, q_{j−1}.x − q_{j+1}.x).
    for (var j = 0u; j < 3u; j++) {
        let n = q[(j + 1u) % 3u];
        let prev = q[(j + 2u) % 3u];
        d_q[j].x -= p[P_AREA] * (n.y - prev.y);
        d_q[j].y -= p[P_AREA] * (prev.x - n.x);
    }
    // scale_k = P/L_k, P = Σ L_m.
    var d_len = vec3<f32>(0.0);
    var d_perimeter = 0.0;
    for (var k = 0u; k < 3u; k++) {
        d_perimeter += p[P_SCALE + k] / f.len[k];
        d_len[k] -= p[P_SCALE + k] * f.perimeter / (f.len[k] * f.len[k]);
    }
    for (var k = 0u; k < 3u; k++) {
        let dl = d_len[k] + d_perimeter;
        let a = (k + 1u) % 3u;
        let b = (k + 2u) % 3u;
        let e = vec2<f32>((q[b].x - q[a].x) / f.len[k], (q[b].y - q[a].y) / f.len[k]);
        d_q[b] += dl * e;
        d_q[a] -= dl * e;
    }
    for (var k = 0u; k < 3u; k++) {
        let v = face_indices[3u * fi + k];
        let base = v * VACC;
        add_vertex_nonzero(base, d_q[k].x);
        add_vertex_nonzero(base + 1u, d_q[k].y);
        add_vertex_nonzero(base + 2u, p[P_Z + k]);
        for (var ch = 0u; ch < 3u; ch++) {
            add_vertex_nonzero(base + 3u + ch, p[P_COLOR + 3u * k + ch]);
        }
        if (k == f.argmin_corner) {
            add_vertex_nonzero(base + 6u, p[P_OPACITY]);
        }
    }
}

// ∂Y_k/∂(x, y, z) of the basis polynomials (basis_gradient of sh.rs).
fn sh_basis_gradient(d: vec3<f32>, degree: u32) -> array<vec3<f32>, 16> {
    var g: array<vec3<f32>, 16>;
    let x = d.x;
    let y = d.y;
    let z = d.z;
    let c1 = 0.4886025119029199;
    if (degree >= 1u) {
        g[1] = vec3<f32>(0.0, -c1, 0.0);
        g[2] = vec3<f32>(0.0, 0.0, c1);
        g[3] = vec3<f32>(-c1, 0.0, 0.0);
    }
    if (degree >= 2u) {
        let c20 = 1.0925484305920792;
        let c21 = -1.0925484305920792;
        let c22 = 0.31539156525252005;
        let c23 = -1.0925484305920792;
        let c24 = 0.5462742152960396;
        g[4] = vec3<f32>(c20 * y, c20 * x, 0.0);
        g[5] = vec3<f32>(0.0, c21 * z, c21 * y);
        g[6] = vec3<f32>(-2.0 * c22 * x, -2.0 * c22 * y, 4.0 * c22 * z);
        g[7] = vec3<f32>(c23 * z, 0.0, c23 * x);
        g[8] = vec3<f32>(2.0 * c24 * x, -2.0 * c24 * y, 0.0);
    }
    if (degree >= 3u) {
        let c30 = -0.5900435899266435;
        let c31 = 2.890611442640554;
        let c32 = -0.4570457994644658;
        let c33 = 0.3731763325901154;
        let c34 = -0.4570457994644658;
        let c35 = 1.445305721320277;
        let c36 = -0.5900435899266435;
        let xx = x * x;
        let yy = y * y;
        let zz = z * z;
        g[9] = vec3<f32>(6.0 * c30 * x * y, 3.0 * c30 * (xx - yy), 0.0);
        g[10] = vec3<f32>(c31 * y * z, c31 * x * z, c31 * x * y);
        g[11] = vec3<f32>(-2.0 * c32 * x * y, c32 * (4.0 * zz - xx - 3.0 * yy), 8.0 * c32 * y * z);
        g[12] = vec3<f32>(-6.0 * c33 * x * z, -6.0 * c33 * y * z, c33 * (6.0 * zz - 3.0 * xx - 3.0 * yy));
        g[13] = vec3<f32>(c34 * (4.0 * zz - 3.0 * xx - yy), -2.0 * c34 * x * y, 8.0 * c34 * x * z);
        g[14] = vec3<f32>(2.0 * c35 * x * z, -2.0 * c35 * y * z, c35 * (xx - yy));
        g[15] = vec3<f32>(3.0 * c36 * (xx - yy), -6.0 * c36 * x * y, 0.0);
    }
    return g;
}

@compute @workgroup_size(256)
fn vertex_backward(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let v = thread_index(wid, groups, lid);
    if (v >= params.vertex_count) {
        return;
    }
    var acc: array<f32, 7>;
    var any = false;
    for (var c = 0u; c < VACC; c++) {
        acc[c] = load_vertex_grad(v * VACC + c);
        any = any || acc[c] != 0.0;
    }
    for (var i = 0u; i < 48u; i++) {
        sh_grad[v * 48u + i] = 0.0;
    }
    position_grad[3u * v] = 0.0;
    position_grad[3u * v + 1u] = 0.0;
    position_grad[3u * v + 2u] = 0.0;
    logit_grad[v] = 0.0;
    if (!any) {
        return;
    }
    let vert = vertices[v];
    let x = vert.cam[0];
    let y = vert.cam[1];
    let z = vert.cam[2];
    // u = fx·x/z + cx, v = fy·y/z + cy.
    let gu = acc[0] * params.fx / z;
    let gv = acc[1] * params.fy / z;
    let d_cam = vec3<f32>(gu, gv, acc[2] - (gu * x + gv * y) / z);
    var position = vec3<f32>(
        params.rot0.x * d_cam.x + params.rot1.x * d_cam.y + params.rot2.x * d_cam.z,
        params.rot0.y * d_cam.x + params.rot1.y * d_cam.y + params.rot2.y * d_cam.z,
        params.rot0.z * d_cam.x + params.rot1.z * d_cam.y + params.rot2.z * d_cam.z,
    );
    // SH colour backward (vertex_color_backward of sh.rs).
    var dc = vec3<f32>(acc[3], acc[4], acc[5]);
    for (var ch = 0u; ch < 3u; ch++) {
        if ((vert.clamped & (1u << ch)) != 0u) {
            dc[ch] = 0.0;
        }
    }
    if (dc.x != 0.0 || dc.y != 0.0 || dc.z != 0.0) {
        let degree = params.sh_degree;
        let n = sh_coeff_count(degree);
        let dir = vec3<f32>(vert.dir[0], vert.dir[1], vert.dir[2]);
        let basis = sh_basis(dir, degree);
        for (var k = 0u; k < n; k++) {
            for (var ch = 0u; ch < 3u; ch++) {
                sh_grad[v * 48u + 3u * k + ch] = basis[k] * dc[ch];
            }
        }
        if (degree > 0u && vert.distance > 0.0) {
            let gy = sh_basis_gradient(dir, degree);
            var d_dir = vec3<f32>(0.0);
            for (var k = 1u; k < n; k++) {
                let base = v * 48u + 3u * k;
                let w = sh[base] * dc.x + sh[base + 1u] * dc.y + sh[base + 2u] * dc.z;
                d_dir += w * gy[k];
            }
            // d = v/|v|  ⇒  dL/dv = (g − d(d·g)) / |v|.
            let dot_dg = d_dir.x * dir.x + d_dir.y * dir.y + d_dir.z * dir.z;
            position += (d_dir - dir * dot_dg) / vert.distance;
        }
    }
    position_grad[3u * v] = position.x;
    position_grad[3u * v + 1u] = position.y;
    position_grad[3u * v + 2u] = position.z;
    let s = 1.0 / (1.0 + exp(-opacity_logits[v]));
    logit_grad[v] = acc[6] * (1.0 - params.opacity_floor) * s * (1.0 - s);
}
