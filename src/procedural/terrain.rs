//! Procedural terrain: a fractal mountain with ridges and valleys, for the fixtures, the demo
//! and the benchmarks. Metres, +Y up, x east, z south.

use super::builder::{MaterialSpec, ModelBuilder};
use crate::rng;

/// 2D gradient noise (Perlin's): a hashed unit gradient at every lattice point, blended with
/// a quintic fade; about -0.7..0.7, zero on the lattice.
fn gradient_noise(x: f64, z: f64, seed: u64) -> f64 {
    let (xi, zi) = (x.floor(), z.floor());
    let (fx, fz) = (x - xi, z - zi);
    let corner = |a: f64, b: f64, dx: f64, dz: f64| {
        let angle =
            rng::unit(rng::hash3(seed, a as i64 as u64, b as i64 as u64)) * std::f64::consts::TAU;
        angle.cos() * dx + angle.sin() * dz
    };
    let s = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let (sx, sz) = (s(fx), s(fz));
    let top = corner(xi, zi, fx, fz) * (1.0 - sx) + corner(xi + 1.0, zi, fx - 1.0, fz) * sx;
    let bottom = corner(xi, zi + 1.0, fx, fz - 1.0) * (1.0 - sx)
        + corner(xi + 1.0, zi + 1.0, fx - 1.0, fz - 1.0) * sx;
    top * (1.0 - sz) + bottom * sz
}

/// Ridged multifractal: sharp crests where the noise crosses zero, octave over octave, each
/// octave rotated so no lattice direction shows.
fn ridged(x: f64, z: f64, seed: u64, octaves: u32) -> f64 {
    let (mut sum, mut amplitude, mut norm) = (0.0, 1.0, 0.0);
    let (mut u, mut v) = (x, z);
    let (sin, cos) = 0.65f64.sin_cos();
    for o in 0..octaves {
        let n = 1.0 - (1.6 * gradient_noise(u, v, seed + o as u64)).abs().min(1.0);
        sum += n * n * amplitude;
        norm += amplitude;
        amplitude *= 0.5;
        (u, v) = (
            2.03 * (cos * u - sin * v) + 17.1,
            2.03 * (sin * u + cos * v) - 4.3,
        );
    }
    sum / norm
}

/// Height (m) of the mountain at (x, z), for a terrain `size` metres across centred on the
/// origin: a broad massif whose flanks are cut by ridges and valleys.
pub fn mountain_height(x: f64, z: f64, size: f64, seed: u64) -> f64 {
    let r = (x * x + z * z).sqrt() / (0.5 * size);
    let massif = (-(r * r) * 2.2).exp();
    let u = (x / size) * 3.0 + 10.0;
    let v = (z / size) * 3.0 + 10.0;
    let ridges = ridged(u, v, seed, 6);
    let rolling = gradient_noise(u * 0.6, v * 0.6, seed + 99);
    180.0 + size * (0.30 * massif * (0.4 + 0.6 * ridges) + 0.04 * rolling)
}

/// A square grid of `n` x `n` vertices over `size` metres, centred on the origin.
pub fn mountain(size: f64, n: usize, seed: u64) -> ModelBuilder {
    let mut b = ModelBuilder::default();
    let m = b.material(MaterialSpec {
        name: "ground".into(),
        color: [0.16, 0.2, 0.09, 1.0],
        mask: None,
    });
    let cell = size / (n - 1) as f64;
    let x0 = -0.5 * size;
    let heights: Vec<f32> = (0..n * n)
        .map(|k| {
            mountain_height(
                x0 + (k % n) as f64 * cell,
                x0 + (k / n) as f64 * cell,
                size,
                seed,
            ) as f32
        })
        .collect();
    b.grid(m, [x0 as f32; 2], cell as f32, [n, n], &heights);
    b
}

/// [`mountain_height`] over `n` x `n` samples `size` metres across as a 16-bit grey PNG, row 0
/// north, 0 and 65535 standing for heights `lo` and `hi` (clamped): a heightmap terrain.
pub fn mountain_png(size: f64, n: usize, seed: u64, [lo, hi]: [f64; 2]) -> Vec<u8> {
    let cell = size / (n - 1) as f64;
    let x0 = -0.5 * size;
    let mut data = Vec::with_capacity(2 * n * n);
    for k in 0..n * n {
        let h = mountain_height(
            x0 + (k % n) as f64 * cell,
            x0 + (k / n) as f64 * cell,
            size,
            seed,
        );
        let v = ((h - lo) / (hi - lo) * 65535.0).round().clamp(0.0, 65535.0) as u16;
        data.extend(v.to_be_bytes());
    }
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, n as u32, n as u32);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Sixteen);
    encoder.set_compression(png::Compression::High);
    // A PNG encoder writing to memory fails only on sizes PNG cannot hold.
    if let Ok(mut w) = encoder.write_header() {
        let _ = w.write_image_data(&data);
    }
    out
}
