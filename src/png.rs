//! PNG files, encoded one way everywhere (best compression, adaptive filters), so the same
//! picture always gives the same bytes: previews, maps, fixtures' textures.

use image::{ImageBuffer, ImageEncoder, PixelWithColorType};

/// PNG bytes of an 8-bit RGB or RGBA image.
pub fn encode<P: PixelWithColorType<Subpixel = u8>>(img: &ImageBuffer<P, Vec<u8>>) -> Vec<u8> {
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new_with_quality(
        &mut out,
        image::codecs::png::CompressionType::Best,
        image::codecs::png::FilterType::Adaptive,
    )
    .write_image(img.as_raw(), img.width(), img.height(), P::COLOR_TYPE)
    .unwrap_or_else(|_| unreachable!("encoding a PNG in memory cannot fail"));
    out
}
