//! sRGB transfer function: glTF vertex colours are linear, captures are sRGB-encoded.

/// Decodes one sRGB-encoded value in [0, 1] to linear light with the exact
/// piecewise IEC 61966-2-1 formula (not the 2.2 power approximation).
pub fn srgb_to_linear(encoded: f32) -> f32 {
    let c = encoded as f64;
    let linear = if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    };
    linear as f32
}

/// Decodes an 8-bit sRGB channel to linear light.
pub fn srgb8_to_linear(encoded: u8) -> f32 {
    srgb_to_linear(encoded as f32 / 255.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn end_points_and_knee_match_the_standard() {
        assert_eq!(srgb8_to_linear(0), 0.0);
        assert_eq!(srgb8_to_linear(255), 1.0);
        // Both branches meet at the knee (0.04045 → 0.0031308) to within f32 precision.
        let below = 0.04045f64 / 12.92;
        let above = ((0.04045f64 + 0.055) / 1.055).powf(2.4);
        assert!((below - above).abs() < 1e-7);
        // Mid grey 0.5 sRGB is 0.21404 linear (published value).
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
    }
}
