//! Pictures of a texture for people: a slice through its cells and its projection along an
//! axis. Both look at the texture from the + side of the axis, with +Y up in side views and
//! north (-Z) up in the top view, and are enlarged with square pixels.

use image::RgbImage;

use crate::color::{ramp, to_srgb8};
use crate::volume::{Level, Texel};

/// Long side of a picture, pixels (cells are enlarged by a whole factor up to this).
const TARGET: usize = 512;
const GAP: u32 = 4;

/// Image columns and rows of a view along `axis`, and the cell under pixel (col, row) at
/// `depth` cells from the viewer.
struct View {
    axis: usize,
    dims: [usize; 3],
}

impl View {
    fn size(&self) -> (usize, usize) {
        let [nx, ny, nz] = self.dims;
        match self.axis {
            0 => (nz, ny),
            1 => (nx, nz),
            _ => (nx, ny),
        }
    }

    fn depth(&self) -> usize {
        self.dims[self.axis]
    }

    fn cell(&self, col: usize, row: usize, depth: usize) -> [usize; 3] {
        let [nx, ny, nz] = self.dims;
        match self.axis {
            0 => [nx - 1 - depth, ny - 1 - row, nz - 1 - col],
            1 => [col, ny - 1 - depth, row],
            _ => [col, ny - 1 - row, nz - 1 - depth],
        }
    }

    /// Unit vector from the texture towards the viewer.
    fn towards_viewer(&self) -> [f32; 3] {
        let mut v = [0.0; 3];
        v[self.axis] = 1.0;
        v
    }
}

fn scale_for(w: usize, h: usize) -> usize {
    (TARGET / w.max(h).max(1)).max(1)
}

/// Whether cell `i` is inside the level's solids (full foliage): its centre reaches the level.
fn solid_cell(l: &Level, i: usize) -> bool {
    l.has_solid() && l.solid[0][i] + l.solid[1][i] >= crate::volume::SOLID_LEVEL
}

/// Cell `i`'s optical depth across one cell, `scale` its extinction per density; infinite in
/// a solid.
fn cell_depth(l: &Level, i: usize, scale: f64) -> f64 {
    if solid_cell(l, i) {
        f64::INFINITY
    } else {
        scale * (l.density[0][i] + l.density[1][i]) as f64
    }
}

/// Blends the parts' albedo by their density (by their solid in a solid); mid grey where the
/// cell is empty.
fn cell_albedo(l: &Level, i: usize) -> [f32; 3] {
    let (w, f) = if solid_cell(l, i) {
        (l.solid[0][i], l.solid[1][i])
    } else {
        (l.density[0][i], l.density[1][i])
    };
    if w + f <= 0.0 {
        return [0.18; 3];
    }
    std::array::from_fn(|c| (w * l.albedo[0][i][c] + f * l.albedo[1][i][c]) / (w + f))
}

fn cell_normal(l: &Level, i: usize) -> Option<[f32; 3]> {
    if solid_cell(l, i) {
        let [nx, ny, _] = l.dims;
        let c = glam::Vec3::new(
            (i % nx) as f32,
            (i / nx % ny) as f32,
            (i / (nx * ny)) as f32,
        );
        return l.solid_normal(c + 0.5, 1.0).map(|n| n.to_array());
    }
    crate::volume::normal(std::array::from_fn(|c| {
        l.gradient[0][i][c] + l.gradient[1][i][c]
    }))
}

/// Three panels of the slice `index` along `axis`: cell opacity on a colour ramp, albedo, and
/// normals as RGB (grey where there is none).
pub fn slice(texel: &Texel, level: usize, axis: usize, index: usize) -> RgbImage {
    let l = &texel.levels[level];
    let view = View { axis, dims: l.dims };
    let (w, h) = view.size();
    let s = scale_for(3 * w, h);
    let panel = (w * s) as u32;
    let mut img = RgbImage::from_pixel(
        3 * panel + 2 * GAP,
        (h * s) as u32,
        image::Rgb([255, 255, 255]),
    );
    // Slices are numbered in cell coordinates, not from the viewer.
    let depth = view.depth() - 1 - index.min(view.depth() - 1);
    let scale = texel.info.extinction_scale * l.cell;
    for row in 0..h {
        for col in 0..w {
            let [x, y, z] = view.cell(col, row, depth);
            let i = l.index(x, y, z);
            let tau = cell_depth(l, i, scale);
            let opacity = ramp((1.0 - (-tau).exp()) as f32);
            let albedo = to_srgb8(cell_albedo(l, i));
            let normal = cell_normal(l, i).map_or([128; 3], |n| {
                n.map(|c| ((c * 0.5 + 0.5) * 255.0 + 0.5) as u8)
            });
            for (p, rgb) in [opacity, albedo, normal].into_iter().enumerate() {
                let x0 = p as u32 * (panel + GAP) + (col * s) as u32;
                for dy in 0..s as u32 {
                    for dx in 0..s as u32 {
                        img.put_pixel(x0 + dx, (row * s) as u32 + dy, image::Rgb(rgb));
                    }
                }
            }
        }
    }
    img
}

/// The texture seen along `axis` from its + side over white: each cell's albedo, lit by a
/// light from the viewer's upper left with the cell's normal, composited front to back with
/// opacity 1 - exp(-extinction x cell). Its alpha is the silhouette the renderer will see.
pub fn projection(texel: &Texel, level: usize, axis: usize) -> RgbImage {
    let l = &texel.levels[level];
    let view = View { axis, dims: l.dims };
    let (w, h) = view.size();
    let s = scale_for(w, h);
    let toward = view.towards_viewer();
    // A light above and to the left of the viewer.
    let mut light = toward.map(|c| c * 0.8);
    light[1] += 0.5;
    let side = if axis == 1 { 2 } else { (axis + 2) % 3 };
    light[side] -= 0.3;
    let len = light.iter().map(|c| c * c).sum::<f32>().sqrt();
    let light = light.map(|c| c / len);
    // Seen along `axis`, the level blocks light with that axis's directional factor.
    let mut along = glam::Vec3::ZERO;
    along[axis] = 1.0;
    let scale = texel.info.extinction_scale * l.cell * f64::from(l.directional_factor(along));
    let mut img = RgbImage::new((w * s) as u32, (h * s) as u32);
    for row in 0..h {
        for col in 0..w {
            let (mut color, mut transmittance) = ([0.0f32; 3], 1.0f32);
            for d in 0..view.depth() {
                let [x, y, z] = view.cell(col, row, d);
                let i = l.index(x, y, z);
                let tau = cell_depth(l, i, scale);
                if tau <= 0.0 {
                    continue;
                }
                let alpha = 1.0 - (-tau).exp() as f32;
                let shade = cell_normal(l, i).map_or(0.6, |n| {
                    0.25 + 0.75 * (n[0] * light[0] + n[1] * light[1] + n[2] * light[2]).max(0.0)
                });
                let a = cell_albedo(l, i);
                for c in 0..3 {
                    color[c] += transmittance * alpha * a[c] * shade;
                }
                transmittance *= 1.0 - alpha;
            }
            let rgb = to_srgb8(color.map(|c| c + transmittance));
            for dy in 0..s as u32 {
                for dx in 0..s as u32 {
                    img.put_pixel(
                        (col * s) as u32 + dx,
                        (row * s) as u32 + dy,
                        image::Rgb(rgb),
                    );
                }
            }
        }
    }
    img
}
