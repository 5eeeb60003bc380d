// Not NaN and not ±∞, by the exponent bits (WGSL may assume finite floats in arithmetic).
fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}
