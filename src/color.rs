//! Colour conversions shared by every picture we write.

/// Linear to sRGB-encoded (IEC 61966-2-1), both in [0, 1].
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Linear RGB to 8-bit sRGB.
pub fn to_srgb8(rgb: [f32; 3]) -> [u8; 3] {
    rgb.map(|c| (linear_to_srgb(c) * 255.0 + 0.5) as u8)
}

/// A perceptually ordered dark-to-bright colour ramp (after matplotlib's "inferno"), `t` in
/// [0, 1], returned as 8-bit sRGB.
pub fn ramp(t: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 6] = [
        [0.001, 0.000, 0.014],
        [0.258, 0.039, 0.406],
        [0.578, 0.148, 0.404],
        [0.865, 0.317, 0.226],
        [0.988, 0.645, 0.040],
        [0.988, 0.998, 0.645],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    } * (STOPS.len() - 1) as f32;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f32;
    std::array::from_fn(|c| ((STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f) * 255.0 + 0.5) as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_matches_known_values() {
        assert_eq!(to_srgb8([0.0, 1.0, 0.2]), [0, 255, 124]);
    }
}
