//! Error between two renders: the measure behind every claim of accuracy against a reference.
//!
//! Both images are read from OpenEXR (the first layer's R, G, B and A); the second is the
//! reference. Colour and alpha are measured separately, each as root mean square error,
//! relative mean square error (squared error over the reference squared plus 0.01, so dark
//! pixels do not dominate, as rendering papers report it), mean absolute error and the largest
//! absolute error with where it is.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::color::ramp;
use crate::limits::Limits;

/// The channels compared, in order.
pub const CHANNELS: [&str; 4] = ["R", "G", "B", "A"];

/// Keeps the relative error finite where the reference is black.
const RELATIVE_EPSILON: f64 = 0.01;

#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    #[error("{file}: cannot read as OpenEXR: {message}")]
    Read { file: PathBuf, message: String },
    #[error("{file}: has no channel {channel} (it has: {present})")]
    MissingChannel {
        file: PathBuf,
        channel: String,
        present: String,
    },
    #[error("{a} is {a_size} but {b} is {b_size}: only images of the same size and window compare")]
    Size {
        a: PathBuf,
        a_size: String,
        b: PathBuf,
        b_size: String,
    },
    #[error("{file}: cannot read the mask as a picture: {message}")]
    Mask { file: PathBuf, message: String },
    #[error("{file}: the mask is {mask_size} but the images are {image_size}")]
    MaskSize {
        file: PathBuf,
        mask_size: String,
        image_size: String,
    },
}

/// The R, G, B, A pixels of an EXR's data window.
#[derive(Clone, Debug, PartialEq)]
pub struct Rgba {
    /// Data window origin and size.
    pub x0: i32,
    pub y0: i32,
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<[f32; 4]>,
}

impl Rgba {
    /// Reads the first layer's R, G, B and A, refusing an image whose header claims more pixels
    /// than `limits` allow before any pixel is read.
    pub fn read(path: &Path, limits: &Limits) -> Result<Rgba, CompareError> {
        Rgba::read_channels(path, CHANNELS, limits)
    }

    /// [`Rgba::read`] of the four channels `names` (an AOV such as `canopy.A` may stand for
    /// any of them, several times).
    pub fn read_channels(
        path: &Path,
        names: [&str; 4],
        limits: &Limits,
    ) -> Result<Rgba, CompareError> {
        ExrLayer::read(path, limits, RGBA_BYTES)?.rgba(names)
    }

    /// [`Rgba::read`] from the bytes of an EXR file (`path` names it in errors).
    pub fn from_bytes(bytes: &[u8], path: &Path, limits: &Limits) -> Result<Rgba, CompareError> {
        ExrLayer::from_reader(std::io::Cursor::new(bytes), path, limits, RGBA_BYTES)?.rgba(CHANNELS)
    }

    fn describe(&self) -> String {
        format!(
            "{}x{} at ({}, {})",
            self.width, self.height, self.x0, self.y0
        )
    }
}

/// Bytes a pixel of an [`Rgba`] copy holds.
const RGBA_BYTES: u64 = 16;

/// The first layer of an OpenEXR file, every channel decoded, with its attributes and the
/// file's display window.
pub(crate) struct ExrLayer {
    path: PathBuf,
    layer: exr::image::Layer<exr::image::AnyChannels<exr::image::FlatSamples>>,
    display_window: exr::meta::attribute::IntegerBounds,
}

impl ExrLayer {
    /// Reads the file at `path`, refusing one whose header claims more pixels than `limits`
    /// allow, or more memory than the machine gives for its channels and the `held` bytes a
    /// pixel the caller will copy out of them, before any pixel is read.
    pub(crate) fn read(path: &Path, limits: &Limits, held: u64) -> Result<ExrLayer, CompareError> {
        let file = std::fs::File::open(path).map_err(|e| CompareError::Read {
            file: path.to_path_buf(),
            message: e.to_string(),
        })?;
        ExrLayer::from_reader(std::io::BufReader::new(file), path, limits, held)
    }

    fn from_reader(
        mut reader: impl std::io::Read + std::io::Seek,
        path: &Path,
        limits: &Limits,
        held: u64,
    ) -> Result<ExrLayer, CompareError> {
        let read_error = |message: String| CompareError::Read {
            file: path.to_path_buf(),
            message,
        };
        let meta = exr::meta::MetaData::read_from_unbuffered(&mut reader, false)
            .map_err(|e| read_error(e.to_string()))?;
        let pixels: u64 = meta
            .headers
            .iter()
            .map(|h| h.layer_size.area() as u64)
            .fold(0, u64::saturating_add);
        limits
            .check_pixels(pixels, "the pixels its header claims")
            .map_err(|e| read_error(e.to_string()))?;
        // The decoded channels (up to 4 bytes a sample) and the caller's copy.
        let samples: u64 = meta
            .headers
            .iter()
            .map(|h| h.layer_size.area() as u64 * h.channels.list.len() as u64)
            .fold(0, u64::saturating_add);
        crate::limits::check_memory(
            samples
                .saturating_mul(4)
                .saturating_add(pixels.saturating_mul(held)),
            "its pixels",
        )
        .map_err(|e| read_error(e.to_string()))?;
        reader
            .seek(std::io::SeekFrom::Start(0))
            .map_err(|e| read_error(e.to_string()))?;
        use exr::prelude::{ReadChannels, ReadLayers};
        let image = exr::image::read::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            // Decoded on this thread: a panic inside exr (none is known) would unwind to the
            // caller instead of aborting the process from exr's own thread pool.
            .non_parallel()
            .from_buffered(reader)
            .map_err(|e| read_error(e.to_string()))?;
        let display_window = image.attributes.display_window;
        let layer = image
            .layer_data
            .into_iter()
            .next()
            .ok_or_else(|| read_error("it has no layers".into()))?;
        Ok(ExrLayer {
            path: path.to_path_buf(),
            layer,
            display_window,
        })
    }

    /// The layer as the file holds it: its channels and attributes.
    pub(crate) fn layer(
        &self,
    ) -> &exr::image::Layer<exr::image::AnyChannels<exr::image::FlatSamples>> {
        &self.layer
    }

    /// The `worldToCamera` and `worldToNDC` attributes, where the file has them.
    pub(crate) fn camera_matrices(&self) -> (Option<[f32; 16]>, Option<[f32; 16]>) {
        let a = &self.layer.attributes;
        (
            a.world_to_camera
                .or_else(|| self.double_matrix("worldToCamera")),
            a.world_to_normalized_device
                .or_else(|| self.double_matrix("worldToNDC")),
        )
    }

    /// The attribute `name` where it is a double-precision matrix (OpenEXR's `m44d`, which
    /// some writers use for the camera; the `exr` crate reads only `m44f` by name), rounded
    /// to single precision as the renderer's own are.
    fn double_matrix(&self, name: &str) -> Option<[f32; 16]> {
        let value = self
            .layer
            .attributes
            .other
            .iter()
            .find(|(k, _)| *k == name)?
            .1;
        let exr::meta::attribute::AttributeValue::Custom { kind, bytes } = value else {
            return None;
        };
        if kind.as_slice() != b"m44d" || bytes.len() != 128 {
            return None;
        }
        Some(std::array::from_fn(|i| {
            f64::from_le_bytes(bytes[8 * i..8 * i + 8].try_into().expect("8 bytes")) as f32
        }))
    }

    /// The display window (the full frame NDC spans): its top-left corner and size.
    pub(crate) fn display_window(&self) -> ([i32; 2], [usize; 2]) {
        let w = self.display_window;
        (
            [w.position.x(), w.position.y()],
            [w.size.width(), w.size.height()],
        )
    }

    fn size(&self) -> (usize, usize) {
        (self.layer.size.width(), self.layer.size.height())
    }

    /// The samples of the channel `name`, row by row.
    pub(crate) fn channel(
        &self,
        name: &str,
    ) -> Result<impl Iterator<Item = f32> + '_, CompareError> {
        let list = &self.layer.channel_data.list;
        match list.iter().find(|ch| ch.name.to_string() == name) {
            Some(data) => Ok(data.sample_data.values_as_f32()),
            None => Err(CompareError::MissingChannel {
                file: self.path.clone(),
                channel: name.to_string(),
                present: list
                    .iter()
                    .map(|c| c.name.to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
            }),
        }
    }

    /// The channels `names` as the R, G, B and A of an [`Rgba`].
    pub(crate) fn rgba(&self, names: [&str; 4]) -> Result<Rgba, CompareError> {
        let (width, height) = self.size();
        let mut pixels = vec![[0.0f32; 4]; width * height];
        for (c, name) in names.iter().enumerate() {
            for (p, v) in pixels.iter_mut().zip(self.channel(name)?) {
                p[c] = v;
            }
        }
        Ok(Rgba {
            x0: self.layer.attributes.layer_position.x(),
            y0: self.layer.attributes.layer_position.y(),
            width,
            height,
            pixels,
        })
    }
}

/// Errors over one group of channels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Metrics {
    pub rmse: f64,
    pub relative_mse: f64,
    pub mean_absolute: f64,
    pub max: f64,
    /// Pixel (x, y within the data window) of the largest error.
    pub max_at: [usize; 2],
}

/// What `compare` finds over a set of pixels. As JSON, the metrics of a set with no finite
/// pixel are `null` (zeros would read as a perfect match), as `--temporal` writes them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Comparison {
    pub pixels: usize,
    /// Pixels where either image holds a NaN or an infinity; left out of the metrics.
    pub non_finite: usize,
    pub rgb: Metrics,
    pub alpha: Metrics,
    /// Per colour channel, the image's mean over the reference's: under 1 darker, over 1
    /// brighter (bias, where RMSE mixes bias and noise); `None` where the reference sums to 0.
    pub mean_ratio: [Option<f64>; 3],
    /// The same for alpha: coverage bias (under 1, the image lets more through).
    pub alpha_ratio: Option<f64>,
}

impl Serialize for Comparison {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Json<'a> {
            pixels: usize,
            non_finite: usize,
            rgb: Option<&'a Metrics>,
            alpha: Option<&'a Metrics>,
            mean_ratio: [Option<f64>; 3],
            alpha_ratio: Option<f64>,
        }
        let measured = self.pixels > self.non_finite;
        Json {
            pixels: self.pixels,
            non_finite: self.non_finite,
            rgb: measured.then_some(&self.rgb),
            alpha: measured.then_some(&self.alpha),
            mean_ratio: self.mean_ratio,
            alpha_ratio: self.alpha_ratio,
        }
        .serialize(serializer)
    }
}

impl Comparison {
    /// Why these images fail a check that allows a colour RMSE of `limit`, if they do: a
    /// pixel that is not finite fails it whatever the limit (an error no RMSE can show; a NaN
    /// limit passes nothing).
    pub fn fails(&self, limit: f64) -> Option<String> {
        if self.non_finite > 0 {
            return Some(format!(
                "{} pixels are not finite (NaN or infinite)",
                self.non_finite
            ));
        }
        if self.rgb.rmse > limit || limit.is_nan() {
            return Some(format!(
                "colour rmse {:.6} is above the limit {limit}",
                self.rgb.rmse
            ));
        }
        None
    }

    /// The error a false-colour picture of these images draws brightest by default: the
    /// largest, colour or alpha, kept finite for `f32`.
    pub fn heatmap_scale(&self) -> f32 {
        self.rgb.max.max(self.alpha.max).clamp(0.0, f32::MAX as f64) as f32
    }

    /// The metrics as a table under `title`, as `texel compare` prints them.
    pub fn to_text(&self, title: &str) -> String {
        let mut s = format!("{title}: {} pixels", self.pixels);
        if self.non_finite > 0 {
            s += &format!(", {} of them not finite (left out)", self.non_finite);
        }
        if self.pixels == self.non_finite {
            // An empty mask, or no finite pixel: zeros would read as a perfect match.
            return s + "\n  no pixels to measure\n";
        }
        s += "\n           rmse   rel. mse   mean |e|     max |e|\n";
        s += &self.rgb.line("rgb");
        s += &self.alpha.line("alpha");
        let ratio = |r: Option<f64>| r.map_or("-".to_string(), |r| format!("{r:.4}"));
        s += &format!(
            "  mean ratio R {}  G {}  B {}  A {}\n",
            ratio(self.mean_ratio[0]),
            ratio(self.mean_ratio[1]),
            ratio(self.mean_ratio[2]),
            ratio(self.alpha_ratio)
        );
        s
    }
}

impl Metrics {
    fn line(&self, name: &str) -> String {
        format!(
            "  {name:<6} {:>11.6} {:>11.6} {:>11.6} {:>11.6} at ({}, {})\n",
            self.rmse,
            self.relative_mse,
            self.mean_absolute,
            self.max,
            self.max_at[0],
            self.max_at[1]
        )
    }
}

#[derive(Default)]
struct Sums {
    squared: f64,
    relative: f64,
    absolute: f64,
    count: usize,
    max: f64,
    max_at: [usize; 2],
}

impl Sums {
    fn add(&mut self, a: f32, reference: f32, at: [usize; 2]) {
        let (a, b) = (f64::from(a), f64::from(reference));
        let e = a - b;
        self.squared += e * e;
        self.relative += e * e / (b * b + RELATIVE_EPSILON);
        self.absolute += e.abs();
        self.count += 1;
        if e.abs() > self.max {
            self.max = e.abs();
            self.max_at = at;
        }
    }

    fn metrics(&self) -> Metrics {
        let n = self.count.max(1) as f64;
        Metrics {
            rmse: (self.squared / n).sqrt(),
            relative_mse: self.relative / n,
            mean_absolute: self.absolute / n,
            max: self.max,
            max_at: self.max_at,
        }
    }
}

/// Which pixels (by index) a mask marks as inside: `channel` (alpha, `A`, unless asked) above
/// 0.5 in an EXR, luminance above 127 in any other picture. The mask must be `size` (width,
/// height) pixels.
pub fn read_mask(
    path: &Path,
    size: (usize, usize),
    channel: &str,
    limits: &Limits,
) -> Result<Vec<bool>, CompareError> {
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let (width, height, inside) = if is_exr {
        let m = Rgba::read_channels(path, [channel; 4], limits)?;
        let inside = m.pixels.iter().map(|p| p[3] > 0.5).collect();
        (m.width, m.height, inside)
    } else {
        let mask_error = |message: String| CompareError::Mask {
            file: path.to_path_buf(),
            message,
        };
        let mut reader = image::ImageReader::open(path)
            .and_then(|r| r.with_guessed_format())
            .map_err(|e| mask_error(e.to_string()))?;
        let mut image_limits = image::Limits::default();
        let side = (limits.pixels as f64).sqrt().min(u32::MAX as f64) as u32;
        image_limits.max_image_width = Some(side.max(size.0 as u32));
        image_limits.max_image_height = Some(side.max(size.1 as u32));
        reader.limits(image_limits);
        let m = reader
            .decode()
            .map_err(|e| mask_error(e.to_string()))?
            .to_luma8();
        let inside = m.pixels().map(|p| p.0[0] > 127).collect();
        (m.width() as usize, m.height() as usize, inside)
    };
    if (width, height) != size {
        return Err(CompareError::MaskSize {
            file: path.to_path_buf(),
            mask_size: format!("{width}x{height}"),
            image_size: format!("{}x{}", size.0, size.1),
        });
    }
    Ok(inside)
}

/// `inside` (a `width` x `height` mask) decided in blocks of `block` x `block` pixels from the
/// window's corner: every pixel of a block is inside when more than half of the block's pixels
/// are (blocks cut by the right and bottom edges count their own pixels). `block` 1 is `inside`.
pub fn block_mask(inside: &[bool], (width, height): (usize, usize), block: usize) -> Vec<bool> {
    if block <= 1 {
        return inside.to_vec();
    }
    let (bw, bh) = (width.div_ceil(block), height.div_ceil(block));
    let mut count = vec![(0usize, 0usize); bw * bh];
    for (i, &v) in inside.iter().enumerate() {
        let c = &mut count[(i / width / block) * bw + (i % width) / block];
        c.0 += usize::from(v);
        c.1 += 1;
    }
    (0..inside.len())
        .map(|i| {
            let (n, of) = count[(i / width / block) * bw + (i % width) / block];
            2 * n > of
        })
        .collect()
}

/// Checks that `a` and `b` (read from the named files) cover the same window.
pub fn check_same_window(
    a: &Rgba,
    a_file: &Path,
    b: &Rgba,
    b_file: &Path,
) -> Result<(), CompareError> {
    if (a.x0, a.y0, a.width, a.height) != (b.x0, b.y0, b.width, b.height) {
        return Err(CompareError::Size {
            a: a_file.to_path_buf(),
            a_size: a.describe(),
            b: b_file.to_path_buf(),
            b_size: b.describe(),
        });
    }
    Ok(())
}

/// Errors of `a` against the reference `b` over the pixels `inside` accepts (by index).
/// The images must cover the same window (see [`check_same_window`]).
pub fn compare(a: &Rgba, b: &Rgba, inside: impl Fn(usize) -> bool) -> Comparison {
    let (mut rgb, mut alpha) = (Sums::default(), Sums::default());
    let (mut pixels, mut non_finite) = (0, 0);
    let (mut sum_a, mut sum_b) = ([0.0f64; 4], [0.0f64; 4]);
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        if !inside(i) {
            continue;
        }
        pixels += 1;
        if !p.iter().chain(q).all(|v| v.is_finite()) {
            non_finite += 1;
            continue;
        }
        let at = [i % a.width, i / a.width];
        for c in 0..4 {
            sum_a[c] += f64::from(p[c]);
            sum_b[c] += f64::from(q[c]);
        }
        for c in 0..3 {
            rgb.add(p[c], q[c], at);
        }
        alpha.add(p[3], q[3], at);
    }
    Comparison {
        pixels,
        non_finite,
        rgb: rgb.metrics(),
        alpha: alpha.metrics(),
        mean_ratio: std::array::from_fn(|c| (sum_b[c] != 0.0).then(|| sum_a[c] / sum_b[c])),
        alpha_ratio: (sum_b[3] != 0.0).then(|| sum_a[3] / sum_b[3]),
    }
}

/// A false-colour picture of the error: each pixel's largest absolute difference over R, G, B
/// and A, from black (none) through purple and orange to pale yellow (`scale` or more).
/// Non-finite pixels are drawn cyan.
pub fn heatmap(a: &Rgba, b: &Rgba, scale: f32) -> image::RgbImage {
    image::RgbImage::from_fn(a.width as u32, a.height as u32, |x, y| {
        let i = x as usize + a.width * y as usize;
        let (p, q) = (a.pixels[i], b.pixels[i]);
        if !p.iter().chain(&q).all(|v| v.is_finite()) {
            return image::Rgb([0, 255, 255]);
        }
        let e = (0..4).map(|c| (p[c] - q[c]).abs()).fold(0.0f32, f32::max);
        image::Rgb(ramp(e / scale))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks go in or out whole, by majority; ragged edge blocks count their own pixels.
    #[test]
    fn block_masks_go_by_majority() {
        // 5 x 2, blocks of 2: [0..2) x [0..2) has 3 of 4 in, [2..4) has 2 of 4 (not more than
        // half), [4..5) has 2 of 2.
        let inside = [
            true, true, true, false, true, //
            true, false, false, true, true,
        ];
        let got = block_mask(&inside, (5, 2), 2);
        let want = [
            true, true, false, false, true, //
            true, true, false, false, true,
        ];
        assert_eq!(got, want);
        assert_eq!(block_mask(&inside, (5, 2), 1), inside.to_vec());
    }

    fn image(width: usize, height: usize, f: impl Fn(usize) -> [f32; 4]) -> Rgba {
        Rgba {
            x0: 0,
            y0: 0,
            width,
            height,
            pixels: (0..width * height).map(f).collect(),
        }
    }

    #[test]
    fn known_differences_give_their_metrics() {
        // A = B + 0.1 in R only on half the pixels; alpha off by 0.5 on one pixel.
        let b = image(4, 2, |_| [0.5, 0.5, 0.5, 1.0]);
        let a = image(4, 2, |i| {
            let r = if i % 2 == 0 { 0.6 } else { 0.5 };
            [r, 0.5, 0.5, if i == 5 { 0.5 } else { 1.0 }]
        });
        let c = compare(&a, &b, |_| true);
        assert_eq!((c.pixels, c.non_finite), (8, 0));
        // RGB: 4 of 24 values off by 0.1.
        let mse = 4.0 * 0.01 / 24.0;
        assert!((c.rgb.rmse - f64::sqrt(mse)).abs() < 1e-6, "{c:?}");
        assert!((c.rgb.mean_absolute - 0.4 / 24.0).abs() < 1e-6);
        assert!((c.rgb.relative_mse - mse / 0.26).abs() < 1e-6);
        assert!((c.rgb.max - 0.1).abs() < 1e-6);
        assert_eq!(c.rgb.max_at, [0, 0]);
        assert!((c.alpha.rmse - f64::sqrt(0.25 / 8.0)).abs() < 1e-9);
        assert_eq!(c.alpha.max_at, [1, 1]);
        // Inside a mask of the odd pixels only alpha differs.
        let m = compare(&a, &b, |i| i % 2 == 1);
        assert_eq!(m.pixels, 4);
        assert_eq!(m.rgb.rmse, 0.0);
        assert!((m.alpha.max - 0.5).abs() < 1e-9);
        // An image against itself has no error.
        assert_eq!(compare(&a, &a, |_| true).rgb, Metrics::default());
        // Mean ratios: R is 0.55 / 0.5 on average, G and B exact; a black reference has none.
        assert_eq!(c.mean_ratio[1], Some(1.0));
        assert!((c.mean_ratio[0].unwrap() - 1.1).abs() < 1e-6, "{c:?}");
        let black = image(4, 2, |_| [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(compare(&a, &black, |_| true).mean_ratio, [None; 3]);
    }

    #[test]
    fn non_finite_pixels_are_counted_not_averaged() {
        let b = image(2, 1, |_| [0.2; 4]);
        let a = image(2, 1, |i| if i == 0 { [f32::NAN; 4] } else { [0.2; 4] });
        let c = compare(&a, &b, |_| true);
        assert_eq!(c.non_finite, 1);
        assert!(c.rgb.rmse == 0.0 && c.rgb.max.is_finite());
        assert_eq!(heatmap(&a, &b, 1.0).get_pixel(0, 0).0, [0, 255, 255]);
    }

    /// An empty mask measures nothing, and says so: zeros would read as a perfect match.
    #[test]
    fn no_pixels_are_reported_as_none_measured() {
        let (a, b) = (image(2, 1, |_| [0.5; 4]), image(2, 1, |_| [0.25; 4]));
        let text = compare(&a, &b, |_| false).to_text("inside the mask");
        assert!(
            text.contains("inside the mask: 0 pixels") && text.contains("no pixels to measure")
        );
        assert!(!text.contains("rmse"), "{text}");
        let json = serde_json::to_value(compare(&a, &b, |_| false)).unwrap();
        assert_eq!(
            (json["rgb"].is_null(), json["alpha"].is_null()),
            (true, true)
        );
        assert_eq!(json["pixels"], 0);
        let json = serde_json::to_value(compare(&a, &b, |_| true)).unwrap();
        assert_eq!(json["rgb"]["max_at"], serde_json::json!([0, 0]));
    }
}
