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

/// An animated PNG (APNG) of `frames` (8-bit RGB, all one size) shown `fps` frames a second,
/// looping: a frame sequence's preview that browsers and image viewers play. Every frame is
/// kept whole (no palette), so it shows what the EXRs hold, at sRGB's 8 bits.
pub fn encode_animation(frames: &[image::RgbImage], fps: f64) -> Result<Vec<u8>, String> {
    let Some(first) = frames.first() else {
        return Err("no frames to animate".into());
    };
    let (width, height) = first.dimensions();
    if let Some(k) = frames
        .iter()
        .position(|f| f.dimensions() != (width, height))
    {
        return Err(format!(
            "frame {k} is {}x{}, frame 0 {width}x{height}: every frame must be the same size",
            frames[k].width(),
            frames[k].height()
        ));
    }
    let count = u32::try_from(frames.len()).map_err(|_| "too many frames".to_string())?;
    // The delay as a fraction of a second: exact for whole frame rates up to 65535, else in
    // milliseconds.
    let (num, den) = if fps.fract() == 0.0 && (1.0..=65535.0).contains(&fps) {
        (1, fps as u16)
    } else {
        ((1000.0 / fps).round().clamp(1.0, 65535.0) as u16, 1000)
    };
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::High);
    encoder.set_filter(png::Filter::Adaptive);
    let e = |e: png::EncodingError| e.to_string();
    encoder.set_animated(count, 0).map_err(e)?;
    encoder.set_frame_delay(num, den).map_err(e)?;
    let mut writer = encoder.write_header().map_err(e)?;
    for f in frames {
        writer.write_image_data(f.as_raw()).map_err(e)?;
    }
    writer.finish().map_err(e)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_animation_holds_every_frame_whole_at_its_rate() {
        let frames: Vec<image::RgbImage> = (0..3u8)
            .map(|k| image::RgbImage::from_fn(5, 4, |x, y| image::Rgb([k * 80, x as u8, y as u8])))
            .collect();
        let bytes = encode_animation(&frames, 24.0).unwrap();
        assert_eq!(bytes, encode_animation(&frames, 24.0).unwrap());
        let mut reader = png::Decoder::new(std::io::Cursor::new(&bytes))
            .read_info()
            .unwrap();
        let control = reader.info().animation_control.unwrap();
        assert_eq!((control.num_frames, control.num_plays), (3, 0));
        let mut buffer = vec![0; reader.output_buffer_size().unwrap()];
        for f in &frames {
            reader.next_frame(&mut buffer).unwrap();
            let fc = reader.info().frame_control.unwrap();
            assert_eq!((fc.delay_num, fc.delay_den), (1, 24));
            assert_eq!(&buffer[..f.as_raw().len()], f.as_raw().as_slice());
        }
        let odd = image::RgbImage::new(4, 4);
        let e = encode_animation(&[frames[0].clone(), odd], 24.0).unwrap_err();
        assert!(e.contains("frame 1 is 4x4"), "{e}");
    }
}
