//! Base-colour textures: decoded once from PNG or JPEG (embedded, data URI or file), kept as
//! 8-bit sRGB and sampled bilinearly in linear space with the glTF sampler's wrap modes.

use std::sync::{Arc, OnceLock};

use glam::{Vec2, Vec4};
use gltf_json as json;
use json::validation::Checked;

use super::ImportError;
use super::document::Document;

/// Largest texture side we decode; tree atlases are at most a few thousand texels.
const MAX_SIDE: u32 = 16384;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WrapMode {
    Repeat,
    Mirror,
    Clamp,
}

/// An image's pixels as decoded, for the textures that name it.
pub(super) struct Decoded {
    width: u32,
    height: u32,
    texels: Arc<[[u8; 4]]>,
    has_alpha: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    /// Row-major RGBA: RGB sRGB-encoded, alpha linear, as the glTF specification has it;
    /// shared by the textures that name one image.
    pub texels: Arc<[[u8; 4]]>,
    pub wrap: [WrapMode; 2],
    pub nearest: bool,
    /// Whether the image has an alpha channel (without one, alpha is 1 everywhere).
    pub has_alpha: bool,
}

/// sRGB-encoded 8-bit value to linear, per IEC 61966-2-1.
fn srgb_to_linear_lut() -> &'static [f32; 256] {
    static LUT: OnceLock<[f32; 256]> = OnceLock::new();
    LUT.get_or_init(|| {
        std::array::from_fn(|i| {
            let c = i as f32 / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        })
    })
}

fn wrap(coord: i64, size: u32, mode: WrapMode) -> usize {
    let n = size as i64;
    let i = match mode {
        WrapMode::Clamp => coord.clamp(0, n - 1),
        WrapMode::Repeat => coord.rem_euclid(n),
        WrapMode::Mirror => {
            let period = coord.rem_euclid(2 * n);
            if period < n {
                period
            } else {
                2 * n - 1 - period
            }
        }
    };
    i as usize
}

impl Texture {
    fn texel(&self, x: i64, y: i64) -> Vec4 {
        let lut = srgb_to_linear_lut();
        let t = self.texels[wrap(y, self.height, self.wrap[1]) * self.width as usize
            + wrap(x, self.width, self.wrap[0])];
        Vec4::new(
            lut[t[0] as usize],
            lut[t[1] as usize],
            lut[t[2] as usize],
            t[3] as f32 / 255.0,
        )
    }

    /// Linear RGBA at texture coordinate `uv` (glTF convention: origin at the top-left).
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        if !uv.is_finite() {
            return self.texel(0, 0);
        }
        // Texel coordinates far beyond any texture (2^40 texels) carry no fraction an f32 uv
        // could resolve: hold them there, so the integer texel indices cannot overflow.
        const FAR: f64 = (1u64 << 40) as f64;
        let x = (uv.x as f64 * self.width as f64 - 0.5).clamp(-FAR, FAR);
        let y = (uv.y as f64 * self.height as f64 - 0.5).clamp(-FAR, FAR);
        if self.nearest {
            return self.texel((x + 0.5).floor() as i64, (y + 0.5).floor() as i64);
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0).lerp(self.texel(x0 + 1, y0), fx);
        let bottom = self.texel(x0, y0 + 1).lerp(self.texel(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }
}

fn wrap_mode(mode: &Checked<json::texture::WrappingMode>) -> WrapMode {
    match mode {
        Checked::Valid(json::texture::WrappingMode::ClampToEdge) => WrapMode::Clamp,
        Checked::Valid(json::texture::WrappingMode::MirroredRepeat) => WrapMode::Mirror,
        _ => WrapMode::Repeat,
    }
}

/// Decodes `textures[index]` (its image and sampler).
pub(super) fn load_texture(
    doc: &mut Document,
    index: usize,
    field: &str,
) -> Result<Texture, ImportError> {
    let path = doc.path.clone();
    let Some(texture) = doc.root.textures.get(index) else {
        return Err(ImportError::invalid(
            &path,
            field,
            format!("texture {index} does not exist"),
        ));
    };
    let image_index = texture.source.value();
    let (wrap, nearest) = match texture.sampler.map(|s| s.value()) {
        None => ([WrapMode::Repeat; 2], false),
        Some(s) => {
            let Some(sampler) = doc.root.samplers.get(s) else {
                return Err(ImportError::invalid(
                    &path,
                    format!("textures[{index}].sampler"),
                    format!("sampler {s} does not exist"),
                ));
            };
            let nearest = matches!(
                sampler.mag_filter,
                Some(Checked::Valid(json::texture::MagFilter::Nearest))
            );
            (
                [wrap_mode(&sampler.wrap_s), wrap_mode(&sampler.wrap_t)],
                nearest,
            )
        }
    };
    let here = format!("images[{image_index}]");
    let Some(image) = doc.root.images.get(image_index) else {
        return Err(ImportError::invalid(
            &path,
            format!("textures[{index}].source"),
            format!("image {image_index} does not exist"),
        ));
    };
    // Textures that name one image (with their own samplers) share its pixels, decoded once.
    if let Some(d) = doc.images.get(&image_index) {
        return Ok(Texture {
            width: d.width,
            height: d.height,
            texels: Arc::clone(&d.texels),
            wrap,
            nearest,
            has_alpha: d.has_alpha,
        });
    }
    let (uri, view) = (image.uri.clone(), image.buffer_view.map(|v| v.value()));
    let bytes = match (uri, view) {
        (Some(uri), _) => doc.resolve_uri(&uri, &here, crate::input::MAX_IMAGE)?,
        (None, Some(view)) => {
            let Some(v) = doc.root.buffer_views.get(view) else {
                return Err(ImportError::invalid(
                    &path,
                    &here,
                    format!("bufferView {view} does not exist"),
                ));
            };
            let (buffer, offset, length) = (
                v.buffer.value(),
                v.byte_offset.map_or(0, |o| o.0),
                v.byte_length.0,
            );
            let data = doc.buffer(buffer, &format!("bufferViews[{view}].buffer"))?;
            let end = offset.saturating_add(length);
            if end > data.len() as u64 {
                return Err(ImportError::invalid(
                    &path,
                    format!("bufferViews[{view}]"),
                    "runs past the end of its buffer",
                ));
            }
            data[offset as usize..end as usize].to_vec()
        }
        (None, None) => {
            return Err(ImportError::invalid(
                &path,
                &here,
                "has neither uri nor bufferView",
            ));
        }
    };
    // Each image is bounded on its own by its sides; all of a file's together by
    // `--max-pixels`, each counted from its header before it is decoded (entries that name
    // one file are counted, and decoded, each). (An image whose header cannot be read is
    // refused by the decoder, which says why.)
    let (w, h) = dimensions(&bytes).unwrap_or((0, 0));
    doc.pixels_decoded += u64::from(w) * u64::from(h);
    if doc.pixels_decoded > doc.limits.pixels {
        return Err(ImportError::unsupported(
            &path,
            &here,
            format!(
                "its {w} x {h} pixels take the file's images past {} pixels in all (--max-pixels)",
                doc.limits.pixels
            ),
        ));
    }
    let (decoded, has_alpha) =
        decode(&bytes).map_err(|e| ImportError::unsupported(&path, &here, e))?;
    let (width, height) = decoded.dimensions();
    let texels: Arc<[[u8; 4]]> = decoded.pixels().map(|p| p.0).collect();
    doc.images.insert(
        image_index,
        Decoded {
            width,
            height,
            texels: Arc::clone(&texels),
            has_alpha,
        },
    );
    Ok(Texture {
        width,
        height,
        texels,
        wrap,
        nearest,
        has_alpha,
    })
}

/// The image's width and height, from its header.
fn dimensions(bytes: &[u8]) -> Option<(u32, u32)> {
    ::image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .ok()?
        .into_dimensions()
        .ok()
}

/// The image as RGBA, and whether it had an alpha channel of its own.
fn decode(bytes: &[u8]) -> Result<(::image::RgbaImage, bool), String> {
    let mut reader = ::image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| format!("cannot read image: {e}"))?;
    if reader.format().is_none() {
        return Err("image is neither PNG nor JPEG (the formats texel decodes)".into());
    }
    let mut limits = ::image::Limits::default();
    limits.max_image_width = Some(MAX_SIDE);
    limits.max_image_height = Some(MAX_SIDE);
    reader.limits(limits);
    let image = reader
        .decode()
        .map_err(|e| format!("cannot decode image: {e}"))?;
    let has_alpha = image.color().has_alpha();
    Ok((image.to_rgba8(), has_alpha))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Texture coordinates at the ends of f32 (as hostile files give them) sample without
    /// overflowing the texel arithmetic, in every wrap mode and filter.
    #[test]
    fn extreme_coordinates_sample_without_overflow() {
        for wrap in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
            for nearest in [false, true] {
                let t = Texture {
                    width: 3,
                    height: 2,
                    texels: vec![[255, 128, 0, 200]; 6].into(),
                    wrap: [wrap; 2],
                    nearest,
                    has_alpha: true,
                };
                for uv in [
                    Vec2::new(f32::MAX, f32::MIN),
                    Vec2::new(1e30, -1e30),
                    Vec2::new(-f32::MAX, 0.5),
                ] {
                    let c = t.sample(uv);
                    assert!(c.is_finite() && (c.w - 200.0 / 255.0).abs() < 1e-6, "{c}");
                }
            }
        }
    }
}
