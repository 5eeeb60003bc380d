// Nearest-face-per-pixel rasterization, bit-identical to the CPU rasterizer of
// `objectsplat-synth` (src/raster.rs).
//
// One invocation owns one pixel and walks, in face order, the triangles binned to its
// 8×8 tile, keeping the strictly nearest one, exactly as the CPU keeps the first face
// of greatest inverse depth. No atomics, so no race decides a tie.
//
// Exactness needs two things WGSL does not promise:
// - 64-bit integers, for the fixed-point edge functions (products reach 2^53): they are
//   emulated with (lo, hi) pairs of u32;
// - the CPU's f32 rounding of `(w0·iz0 + w1·iz1 + w2·iz2) / area`: WGSL may fuse the
//   products into the sums, flush subnormals, and divide to only 2.5 ULP. So the
//   depth is computed with integer "soft float" instead: non-negative f32 values as
//   bit patterns, every operation rounded to nearest, ties to even, subnormals kept.
//   All operands are ≥ 0 (a covered pixel has every edge weight ≥ 0), so no sign
//   handling is needed, and for non-negative floats the order of the bit patterns is
//   the order of the values, which is how depths are compared.

struct Params {
    width: u32,
    height: u32,
    tiles_x: u32,
    unused: u32,
}

// A triangle as set up on the host: fixed-point vertices (1/256 pixel) in
// positive orientation, their inverse depths, the f32 area, the face, its inclusive
// pixel bounding box, and which edges own the pixels exactly on them (top-left rule).
struct Triangle {
    // (ax, ay, bx, by) as i32 bit patterns
    ab: vec4<u32>,
    // (cx, cy, f32 bits of 1/z at a, at b)
    c_iz: vec4<u32>,
    // (f32 bits of 1/z at c, f32 bits of the area, face, bias mask: bit k for edge k)
    iz_area_face_bias: vec4<u32>,
    // (x0 | x1 << 16, y0 | y1 << 16, unused, unused)
    bbox: vec4<u32>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> triangles: array<Triangle>;
// Members of tile t are tile_members[tile_offsets[t] .. tile_offsets[t + 1]], in face order.
@group(0) @binding(2) var<storage, read> tile_offsets: array<u32>;
@group(0) @binding(3) var<storage, read> tile_members: array<u32>;
// Running best per pixel across dispatches: f32 bits of the inverse depth (0 = none),
// and face + 1 (0 = none).
@group(0) @binding(4) var<storage, read_write> best_inv_depth: array<u32>;
@group(0) @binding(5) var<storage, read_write> best_face_plus_one: array<u32>;

const SUBPIXEL: i32 = 256;
const TILE: u32 = 8u;

// ---------------------------------------------------------------- 64-bit integers

// Full 64-bit product of two u32, as (lo, hi).
fn mul_wide_u32(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let low = a0 * b0;
    let cross_a = a0 * b1;
    let cross = cross_a + a1 * b0;
    let cross_carry = select(0u, 0x10000u, cross < cross_a);
    let lo = low + (cross << 16u);
    let lo_carry = select(0u, 1u, lo < low);
    let hi = a1 * b1 + (cross >> 16u) + cross_carry + lo_carry;
    return vec2<u32>(lo, hi);
}

fn negate_64(v: vec2<u32>) -> vec2<u32> {
    let lo = ~v.x + 1u;
    let hi = ~v.y + select(0u, 1u, lo == 0u);
    return vec2<u32>(lo, hi);
}

// Two's complement 64-bit product of two i32 of magnitude below 2^31.
fn mul_wide_i32(a: i32, b: i32) -> vec2<u32> {
    let product = mul_wide_u32(u32(abs(a)), u32(abs(b)));
    if (a < 0) != (b < 0) {
        return negate_64(product);
    }
    return product;
}

fn sub_64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x - b.x;
    let hi = a.y - b.y - select(0u, 1u, a.x < b.x);
    return vec2<u32>(lo, hi);
}

// Edge function of (p, q) at `pixel`: twice the signed area of (p, q, pixel).
fn edge_function(p: vec2<i32>, q: vec2<i32>, pixel: vec2<i32>) -> vec2<u32> {
    return sub_64(
        mul_wide_i32(q.x - p.x, pixel.y - p.y),
        mul_wide_i32(q.y - p.y, pixel.x - p.x),
    );
}

// `e + bias > 0` for a 64-bit edge value and a bias of 0 or 1.
fn inside_edge(e: vec2<u32>, bias: bool) -> bool {
    return bitcast<i32>(e.y) > 0 || (e.y == 0u && (e.x != 0u || bias));
}

// ---------------------------------------------------------------- soft float (x ≥ 0)

const F32_INFINITY: u32 = 0x7f800000u;

// The f32 nearest to (m + ε)·2^e, ties to even, where ε ∈ (0, 1) stands for nonzero
// bits below m when `sticky` (callers keep m ≥ 2^30 then, so normalizing shifts
// it left by at most one bit and the sticky part stays below the rounding point).
fn round_pack(m_in: u32, e_in: i32, sticky: bool) -> u32 {
    if m_in == 0u {
        return 0u;
    }
    let shift_left = 31u - firstLeadingBit(m_in);
    let m = m_in << shift_left;
    let e = e_in - i32(shift_left);
    // Exponent of the result's last bit: 24 significant bits, or the subnormal quantum.
    let quantum = max(e + 8, -149);
    let drop_bits = u32(quantum - e); // ≥ 8
    var kept: u32;
    var rest: u32;
    var half: u32;
    if drop_bits > 32u {
        // Below half the smallest subnormal.
        return 0u;
    } else if drop_bits == 32u {
        kept = 0u;
        rest = m;
        half = 0x80000000u;
    } else {
        kept = m >> drop_bits;
        rest = m & ((1u << drop_bits) - 1u);
        half = 1u << (drop_bits - 1u);
    }
    let round_up = rest > half || (rest == half && (sticky || (kept & 1u) == 1u));
    let mantissa = kept + select(0u, 1u, round_up);
    let biased = quantum + 149;
    if biased >= 254 {
        return F32_INFINITY;
    }
    // Normal numbers carry the implicit bit in `mantissa`, which adds one to the
    // exponent field; a subnormal that rounds up to 2^23, or a normal that rounds up
    // to 2^24, carries into the exponent field by the same addition.
    return (u32(biased) << 23u) + mantissa;
}

// (m, e) with value m·2^e and m in [2^23, 2^24), for a positive finite f32.
fn unpack(bits: u32) -> vec2<i32> {
    let field = bits >> 23u;
    let fraction = bits & 0x7fffffu;
    if field == 0u {
        let shift = 23u - firstLeadingBit(fraction);
        return vec2<i32>(i32(fraction << shift), -149 - i32(shift));
    }
    return vec2<i32>(i32(fraction | 0x800000u), i32(field) - 150);
}

fn soft_mul(a: u32, b: u32) -> u32 {
    if a == 0u || b == 0u {
        return 0u;
    }
    let x = unpack(a);
    let y = unpack(b);
    // A 24 × 24-bit product: 47 or 48 bits, of which the top 32 are kept.
    let p = mul_wide_u32(u32(x.x), u32(y.x));
    let m = (p.y << 16u) | (p.x >> 16u);
    return round_pack(m, x.y + y.y + 16, (p.x & 0xffffu) != 0u);
}

fn soft_add(a: u32, b: u32) -> u32 {
    if a == 0u {
        return b;
    }
    if b == 0u {
        return a;
    }
    var x = unpack(a);
    var y = unpack(b);
    if x.y < y.y {
        let t = x;
        x = y;
        y = t;
    }
    // Seven guard bits below the larger operand's mantissa; its top stays below bit 31
    // so the sum cannot overflow.
    let big = u32(x.x) << 7u;
    let small = u32(y.x) << 7u;
    let gap = u32(x.y - y.y);
    var aligned = 0u;
    var sticky = small != 0u;
    if gap < 32u {
        aligned = small >> gap;
        sticky = (small & ((1u << gap) - 1u)) != 0u;
    }
    return round_pack(big + aligned, x.y - 7, sticky);
}

fn soft_div(a: u32, b: u32) -> u32 {
    if a == 0u {
        return 0u;
    }
    let x = unpack(a);
    let y = unpack(b);
    let divisor = u32(y.x);
    // Restoring division: 32 quotient bits of x.m / y.m, the first being the integer bit.
    var remainder = u32(x.x);
    var quotient = 0u;
    for (var i = 0u; i < 32u; i += 1u) {
        quotient = quotient << 1u;
        if remainder >= divisor {
            remainder -= divisor;
            quotient |= 1u;
        }
        remainder = remainder << 1u;
    }
    return round_pack(quotient, x.y - y.y - 31, remainder != 0u);
}

// Nearest f32 of a non-negative 64-bit integer.
fn u64_to_f32(v: vec2<u32>) -> u32 {
    if v.y == 0u {
        return round_pack(v.x, 0, false);
    }
    let shift = firstLeadingBit(v.y) + 1u; // 1..=32: brings the top bit to bit 31
    if shift == 32u {
        return round_pack(v.y, 32, v.x != 0u);
    }
    let m = (v.y << (32u - shift)) | (v.x >> shift);
    return round_pack(m, i32(shift), (v.x << (32u - shift)) != 0u);
}

// ---------------------------------------------------------------- the rasterizer

// Flags in the fourth word of `iz_area_face_bias`, above the three edge-bias bits.
// Every product in the edge functions fits i32 (the host checked the triangle's extent).
const FLAG_SMALL: u32 = 8u;
// All inverse depths are at least 2^-60, so the hardware estimate of the depth meets no
// subnormal and stays within a few ULP of the exact value.
const FLAG_ESTIMABLE: u32 = 16u;
// Relative gap between two hardware estimates beyond which their order is certain:
// each estimate is within about 2^-20 of the exact value (five rounded steps of at
// most 2.5 ULP, all on non-negative operands, so no cancellation).
const ESTIMATE_MARGIN: f32 = 1.52587890625e-05; // 2^-16

struct Weights {
    w0: vec2<u32>,
    w1: vec2<u32>,
    w2: vec2<u32>,
    covered: bool,
}

fn small_edge_function(p: vec2<i32>, q: vec2<i32>, pixel: vec2<i32>) -> vec2<u32> {
    let e = (q.x - p.x) * (pixel.y - p.y) - (q.y - p.y) * (pixel.x - p.x);
    return vec2<u32>(bitcast<u32>(e), select(0u, 0xffffffffu, e < 0));
}

// The edge function of `p`→`q` at `pixel`, in the precision the triangle's size calls for.
fn edge_at(small: bool, p: vec2<i32>, q: vec2<i32>, pixel: vec2<i32>) -> vec2<u32> {
    if small {
        return small_edge_function(p, q, pixel);
    }
    return edge_function(p, q, pixel);
}

// The three edge weights at `pixel`, and whether the top-left rule puts it inside.
fn weights_at(t: Triangle, pixel: vec2<i32>) -> Weights {
    var out: Weights;
    out.covered = false;
    let a = vec2<i32>(bitcast<i32>(t.ab.x), bitcast<i32>(t.ab.y));
    let b = vec2<i32>(bitcast<i32>(t.ab.z), bitcast<i32>(t.ab.w));
    let c = vec2<i32>(bitcast<i32>(t.c_iz.x), bitcast<i32>(t.c_iz.y));
    let flags = t.iz_area_face_bias.w;
    let small = (flags & FLAG_SMALL) != 0u;
    // Weight k is the edge function of the edge opposite vertex k.
    out.w0 = edge_at(small, b, c, pixel);
    if !inside_edge(out.w0, (flags & 1u) != 0u) {
        return out;
    }
    out.w1 = edge_at(small, c, a, pixel);
    if !inside_edge(out.w1, (flags & 2u) != 0u) {
        return out;
    }
    out.w2 = edge_at(small, a, b, pixel);
    out.covered = inside_edge(out.w2, (flags & 4u) != 0u);
    return out;
}

// (w0·iz0 + w1·iz1 + w2·iz2) / area, each step rounded as the CPU's f32 code does.
fn exact_inv_depth(t: Triangle, w: Weights) -> u32 {
    let sum = soft_add(
        soft_add(soft_mul(u64_to_f32(w.w0), t.c_iz.z), soft_mul(u64_to_f32(w.w1), t.c_iz.w)),
        soft_mul(u64_to_f32(w.w2), t.iz_area_face_bias.x),
    );
    return soft_div(sum, t.iz_area_face_bias.y);
}

// The same quantity in hardware floats, only ever compared with a margin.
fn estimated_inv_depth(t: Triangle, w: Weights) -> f32 {
    let to_f32 = vec3<f32>(
        f32(w.w0.y) * 4294967296.0 + f32(w.w0.x),
        f32(w.w1.y) * 4294967296.0 + f32(w.w1.x),
        f32(w.w2.y) * 4294967296.0 + f32(w.w2.x),
    );
    let iz = vec3<f32>(
        bitcast<f32>(t.c_iz.z),
        bitcast<f32>(t.c_iz.w),
        bitcast<f32>(t.iz_area_face_bias.x),
    );
    return dot(to_f32, iz) / bitcast<f32>(t.iz_area_face_bias.y);
}

@compute @workgroup_size(8, 8, 1)
fn raster_tile(
    @builtin(workgroup_id) tile: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
) {
    let x = tile.x * TILE + local.x;
    let y = tile.y * TILE + local.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let tile_index = tile.y * params.tiles_x + tile.x;
    let first = tile_offsets[tile_index];
    let end = tile_offsets[tile_index + 1u];
    if first == end {
        return;
    }
    let pixel_index = y * params.width + x;
    // The best so far: its exact inverse depth (valid when `exact_known`), a hardware
    // estimate of it, and its triangle, to compute the exact value lazily: most
    // candidates are decided by the estimates alone, and the soft-float division is
    // needed only for near-ties and once for the final winner.
    var best_exact = best_inv_depth[pixel_index];
    var exact_known = true;
    var best_estimate = bitcast<f32>(best_exact);
    // A stored value below 2^-100 could be flushed to zero by hardware arithmetic.
    var best_estimable = best_exact == 0u || best_exact >= 0x0d800000u;
    var best_triangle = 0u;
    var best_face = best_face_plus_one[pixel_index];
    var changed = false;
    // Pixel centre in fixed point; width and height ≤ 65536 keep it below 2^24.
    let pixel = vec2<i32>(i32(x) * SUBPIXEL + SUBPIXEL / 2, i32(y) * SUBPIXEL + SUBPIXEL / 2);
    for (var member = first; member < end; member += 1u) {
        let index = tile_members[member];
        let t = triangles[index];
        let x_span = t.bbox.x;
        let y_span = t.bbox.y;
        if x < (x_span & 0xffffu) || x > (x_span >> 16u) || y < (y_span & 0xffffu) || y > (y_span >> 16u) {
            continue;
        }
        let w = weights_at(t, pixel);
        if !w.covered {
            continue;
        }
        let estimable = (t.iz_area_face_bias.w & FLAG_ESTIMABLE) != 0u;
        var estimate = 0.0;
        if estimable && best_estimable {
            estimate = estimated_inv_depth(t, w);
            if estimate < best_estimate * (1.0 - ESTIMATE_MARGIN) {
                continue;
            }
            if estimate > best_estimate * (1.0 + ESTIMATE_MARGIN) {
                best_estimate = estimate;
                best_estimable = true;
                best_triangle = index;
                exact_known = false;
                best_face = t.iz_area_face_bias.z + 1u;
                changed = true;
                continue;
            }
        }
        // Too close to call, or no safe estimate: compare exactly.
        if !exact_known {
            best_exact = exact_inv_depth(triangles[best_triangle], weights_at(triangles[best_triangle], pixel));
            exact_known = true;
        }
        let exact = exact_inv_depth(t, w);
        if exact > best_exact {
            best_exact = exact;
            best_estimate = select(bitcast<f32>(exact), estimate, estimable && best_estimable);
            best_estimable = estimable;
            best_triangle = index;
            best_face = t.iz_area_face_bias.z + 1u;
            changed = true;
        }
    }
    if changed {
        if !exact_known {
            best_exact = exact_inv_depth(triangles[best_triangle], weights_at(triangles[best_triangle], pixel));
        }
        best_inv_depth[pixel_index] = best_exact;
        best_face_plus_one[pixel_index] = best_face;
    }
}

// ---------------------------------------------------------------- soft-float self-test

// Each case is (a, b, w_lo, w_hi); the answer is (a·b, a + b, a / b, f32 of w) as bits,
// for a test to compare with the host's IEEE arithmetic.
// Bindings distinct from the rasterizer's, so neither entry point's layout sees the other's.
@group(0) @binding(6) var<storage, read> check_cases: array<vec4<u32>>;
@group(0) @binding(7) var<storage, read_write> check_results: array<vec4<u32>>;

@compute @workgroup_size(64, 1, 1)
fn soft_float_check(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&check_cases) {
        return;
    }
    let operands = check_cases[i];
    check_results[i] = vec4<u32>(
        soft_mul(operands.x, operands.y),
        soft_add(operands.x, operands.y),
        soft_div(operands.x, operands.y),
        u64_to_f32(operands.zw),
    );
}
