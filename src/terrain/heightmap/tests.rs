//! Heightmaps of every kind written here from code, read back: exact heights at known
//! samples, corners where the conventions put them, and every bad input refused by name.

use std::path::{Path, PathBuf};

use glam::Vec3;
use tiff::encoder::{TiffEncoder, colortype};
use tiff::tags::Tag;

use super::*;
use crate::terrain::Terrain;

fn opts(size: Option<[f64; 2]>, range: Option<[f64; 2]>) -> HeightmapOptions {
    HeightmapOptions {
        size,
        height_range: range,
    }
}

fn load_file(path: &Path, options: &HeightmapOptions) -> Result<Model, HeightmapError> {
    let format = Format::of_file(path).expect("a heightmap format");
    load(path, format, options, &Limits::default())
}

/// The message `load_file` refuses `path` with.
fn refusal(path: &Path, options: &HeightmapOptions) -> String {
    load_file(path, options).unwrap_err().to_string()
}

/// The vertex of sample (col, row) of a `width`-wide grid.
fn at(model: &Model, width: usize, col: usize, row: usize) -> Vec3 {
    model.mesh.positions[col + width * row]
}

fn assert_close(a: Vec3, b: Vec3) {
    assert!((a - b).abs().max_element() < 1e-4, "{a} != {b}");
}

/// 16-bit grey values of a 4 x 3 image: distinct, so a transposed or flipped read shows.
fn values16() -> Vec<u16> {
    vec![
        0, 1000, 2000, 3000, //
        10000, 20000, 30000, 40000, //
        50000, 60000, 65000, 65535,
    ]
}

fn png16(dir: &Path, name: &str, w: u32, h: u32, values: &[u16]) -> PathBuf {
    let img = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, values.to_vec()).unwrap();
    let path = dir.join(name);
    img.save_with_format(&path, image::ImageFormat::Png)
        .unwrap();
    path
}

#[test]
fn png16_heights_and_corners_follow_the_conventions() {
    let dir = tempfile::tempdir().unwrap();
    let path = png16(dir.path(), "h.png", 4, 3, &values16());
    let m = load_file(&path, &opts(Some([30.0, 20.0]), Some([100.0, 200.0]))).unwrap();
    let h = |v: u16| 100.0 + v as f32 / 65535.0 * 100.0;
    // Row 0 is north (z = 0), column 0 west (x = 0); the size is first to last sample.
    assert_close(at(&m, 4, 0, 0), Vec3::new(0.0, 100.0, 0.0));
    assert_close(at(&m, 4, 3, 0), Vec3::new(30.0, h(3000), 0.0));
    assert_close(at(&m, 4, 0, 2), Vec3::new(0.0, h(50000), 20.0));
    assert_close(at(&m, 4, 3, 2), Vec3::new(30.0, 200.0, 20.0));
    assert_close(at(&m, 4, 1, 1), Vec3::new(10.0, h(20000), 10.0));
    assert_eq!(m.mesh.triangles.len(), 2 * 3 * 2);
    assert_eq!(m.sources.len(), 1);
    assert_eq!(m.sources[0].sha256, sha256(&std::fs::read(&path).unwrap()));
    // Every triangle faces up.
    for t in m.mesh.corners() {
        assert!((t[1] - t[0]).cross(t[2] - t[0]).y > 0.0);
    }
    // The surface between samples is the triangles': exact at a sample, linear along an edge.
    let terrain = Terrain::from_model(m);
    assert!((terrain.height_at(10.0, 10.0).unwrap() - h(20000) as f64).abs() < 1e-3);
    let mid = 0.5 * (h(20000) + h(30000)) as f64;
    assert!((terrain.height_at(15.0, 10.0).unwrap() - mid).abs() < 1e-3);
}

#[test]
fn png8_maps_255_to_the_top_of_the_range() {
    let dir = tempfile::tempdir().unwrap();
    let img = image::GrayImage::from_raw(2, 2, vec![0, 51, 102, 255]).unwrap();
    let path = dir.path().join("h8.png");
    img.save(&path).unwrap();
    let m = load_file(&path, &opts(Some([1.0, 1.0]), Some([-10.0, 40.0]))).unwrap();
    assert_close(at(&m, 2, 1, 0), Vec3::new(1.0, 0.0, 0.0));
    assert_close(at(&m, 2, 1, 1), Vec3::new(1.0, 40.0, 1.0));
}

fn exr(path: &Path, w: usize, h: usize, channels: &[(&str, Vec<f32>)]) {
    use exr::prelude::*;
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels
        .iter()
        .map(|(n, v)| AnyChannel::new(*n, FlatSamples::F32(v.clone())))
        .collect();
    let image = Image::from_channels((w, h), AnyChannels::sort(list));
    image.write().to_file(path).unwrap();
}

#[test]
fn exr_heights_are_metres_from_y_then_r() {
    let dir = tempfile::tempdir().unwrap();
    let heights: Vec<f32> = (0..6).map(|k| 1000.0 + k as f32 * 0.25).collect();
    let path = dir.path().join("h.exr");
    exr(&path, 3, 2, &[("R", vec![0.0; 6]), ("Y", heights.clone())]);
    let m = load_file(&path, &opts(Some([2.0, 4.0]), None)).unwrap();
    assert_close(at(&m, 3, 2, 1), Vec3::new(2.0, 1001.25, 4.0));
    assert_close(at(&m, 3, 1, 0), Vec3::new(1.0, 1000.25, 0.0));
    assert!(
        m.warnings[0].contains("channel Y of R, Y"),
        "{:?}",
        m.warnings
    );
    // Without Y, R.
    let path = dir.path().join("r.exr");
    exr(&path, 3, 2, &[("G", vec![0.0; 6]), ("R", heights)]);
    let m = load_file(&path, &opts(Some([2.0, 4.0]), None)).unwrap();
    assert_close(at(&m, 3, 2, 1), Vec3::new(2.0, 1001.25, 4.0));
    // A range would rescale metres: refused, naming the flag.
    let e = refusal(&path, &opts(Some([2.0, 4.0]), Some([0.0, 1.0])));
    assert!(e.contains("r.exr") && e.contains("--height-range"), "{e}");
    // NaN (a no-data sample) is refused, naming the pixel.
    let mut nan = vec![5.0; 6];
    nan[4] = f32::NAN;
    let path = dir.path().join("nan.exr");
    exr(&path, 3, 2, &[("Y", nan)]);
    let e = refusal(&path, &opts(Some([2.0, 4.0]), None));
    assert!(
        e.contains("nan.exr") && e.contains("column 1, row 1"),
        "{e}"
    );
}

/// Writes a TIFF of one grey channel with the GeoTIFF tags `scale`, `tiepoint`, and
/// `keys` (id, value) in a version 1.1.0 key directory.
fn geotiff<C: colortype::ColorType>(
    path: &Path,
    (w, h): (u32, u32),
    data: &[C::Inner],
    scale: Option<[f64; 3]>,
    tiepoint: Option<[f64; 6]>,
    keys: &[(u16, u16)],
) where
    [C::Inner]: tiff::encoder::TiffValue,
{
    let file = std::fs::File::create(path).unwrap();
    let mut enc = TiffEncoder::new(file).unwrap();
    let mut img = enc.new_image::<C>(w, h).unwrap();
    if let Some(s) = scale {
        img.encoder()
            .write_tag(Tag::ModelPixelScaleTag, &s[..])
            .unwrap();
    }
    if let Some(t) = tiepoint {
        img.encoder()
            .write_tag(Tag::ModelTiepointTag, &t[..])
            .unwrap();
    }
    if !keys.is_empty() {
        let mut dir = vec![1u16, 1, 0, keys.len() as u16];
        for &(id, v) in keys {
            dir.extend([id, 0, 1, v]);
        }
        img.encoder()
            .write_tag(Tag::GeoKeyDirectoryTag, &dir[..])
            .unwrap();
    }
    img.write_data(data).unwrap();
}

#[test]
fn geotiff_float_takes_spacing_from_its_tags_pixel_is_area() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dem.tif");
    let heights: Vec<f32> = (0..12).map(|k| 250.5 + k as f32).collect();
    // UTM-like: projected (1), pixel-is-area (1), metres.
    geotiff::<colortype::Gray32Float>(
        &path,
        (4, 3),
        &heights,
        Some([10.0, 5.0, 0.0]),
        Some([0.0, 0.0, 0.0, 500_000.0, 4_000_000.0, 0.0]),
        &[(1024, 1), (1025, 1), (3076, 9001)],
    );
    let m = load_file(&path, &HeightmapOptions::default()).unwrap();
    // Samples at pixel centres, half a pixel in from the north-west corner at (0, 0).
    assert_close(at(&m, 4, 0, 0), Vec3::new(5.0, 250.5, 2.5));
    assert_close(at(&m, 4, 3, 2), Vec3::new(35.0, 261.5, 12.5));
    assert!(
        m.warnings.iter().any(|w| w.contains("easting 500000.000")),
        "{:?}",
        m.warnings
    );
    // Pixel-is-point: the first sample is the corner.
    let path = dir.path().join("point.tif");
    geotiff::<colortype::Gray32Float>(
        &path,
        (4, 3),
        &heights,
        Some([10.0, 5.0, 0.0]),
        None,
        &[(1024, 1), (1025, 2)],
    );
    let m = load_file(&path, &HeightmapOptions::default()).unwrap();
    assert_close(at(&m, 4, 3, 2), Vec3::new(30.0, 261.5, 10.0));
}

/// A DEM's no-data value (GDAL_NODATA) is refused where a sample holds it, naming the pixel;
/// a file that declares one and has none loads; a no-data value that is no number is refused.
#[test]
fn geotiff_no_data_samples_are_refused_by_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let write_with = |name: &str, heights: &[f32], nodata: &str| {
        let path = dir.path().join(name);
        let file = std::fs::File::create(&path).unwrap();
        let mut enc = TiffEncoder::new(file).unwrap();
        let mut img = enc.new_image::<colortype::Gray32Float>(4, 3).unwrap();
        img.encoder()
            .write_tag(Tag::Unknown(42113), nodata)
            .unwrap();
        img.write_data(heights).unwrap();
        path
    };
    let write = |name: &str, heights: &[f32]| write_with(name, heights, "-9999");
    let mut heights: Vec<f32> = (0..12).map(|k| 250.0 + k as f32).collect();
    let size = opts(Some([30.0, 20.0]), None);
    load_file(&write("whole.tif", &heights), &size).unwrap();
    heights[6] = -9999.0;
    let e = refusal(&write("hole.tif", &heights), &size);
    for needle in ["hole.tif", "column 2, row 1", "GDAL_NODATA", "-9999"] {
        assert!(e.contains(needle), "{needle} missing from {e}");
    }
    heights[6] = 256.0;
    let e = refusal(&write_with("word.tif", &heights, "none"), &size);
    for needle in [
        "word.tif",
        "GDAL_NODATA (42113)",
        "\"none\" is not a number",
    ] {
        assert!(e.contains(needle), "{needle} missing from {e}");
    }
    // GDAL writes "nan" for a float raster's no-data: a number, held by no finite sample.
    load_file(&write_with("nan.tif", &heights, "nan"), &size).unwrap();
}

/// A GeoKey directory shorter than the keys its header declares is refused, not read short.
#[test]
fn geotiff_key_directory_shorter_than_its_count_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("keys.tif");
    let file = std::fs::File::create(&path).unwrap();
    let mut enc = TiffEncoder::new(file).unwrap();
    let mut img = enc.new_image::<colortype::Gray32Float>(2, 2).unwrap();
    img.encoder()
        .write_tag(Tag::ModelPixelScaleTag, &[1.0f64, 1.0, 0.0][..])
        .unwrap();
    // The header declares 3 keys; one follows.
    img.encoder()
        .write_tag(
            Tag::GeoKeyDirectoryTag,
            &[1u16, 1, 0, 3, 3076, 0, 1, 9002][..],
        )
        .unwrap();
    img.write_data(&[1.0f32; 4][..]).unwrap();
    let e = refusal(&path, &HeightmapOptions::default());
    for needle in [
        "keys.tif",
        "GeoKeyDirectoryTag (34735)",
        "8 shorts",
        "3 keys",
    ] {
        assert!(e.contains(needle), "{needle} missing from {e}");
    }
}

#[test]
fn tiff_integers_scale_by_the_range_or_are_metres_when_signed() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("u16.tif");
    geotiff::<colortype::Gray16>(&path, (4, 3), &values16(), None, None, &[]);
    let e = refusal(&path, &HeightmapOptions::default());
    assert!(e.contains("u16.tif") && e.contains("--height-range"), "{e}");
    let m = load_file(&path, &opts(Some([3.0, 2.0]), Some([0.0, 65535.0]))).unwrap();
    assert_close(at(&m, 4, 2, 1), Vec3::new(2.0, 30000.0, 1.0));
    let path = dir.path().join("i16.tif");
    let signed: Vec<i16> = vec![-5, 0, 5, 10];
    geotiff::<colortype::GrayI16>(&path, (2, 2), &signed, Some([1.0, 1.0, 0.0]), None, &[]);
    let m = load_file(&path, &HeightmapOptions::default()).unwrap();
    assert_close(at(&m, 2, 0, 0), Vec3::new(0.5, -5.0, 0.5));
}

#[test]
fn geotiff_in_feet_or_degrees_is_refused_unless_the_size_is_given() {
    let dir = tempfile::tempdir().unwrap();
    let heights = vec![1.0f32; 4];
    let feet = dir.path().join("feet.tif");
    geotiff::<colortype::Gray32Float>(
        &feet,
        (2, 2),
        &heights,
        Some([30.0, 30.0, 0.0]),
        None,
        &[(1024, 1), (3076, 9002)],
    );
    let e = refusal(&feet, &HeightmapOptions::default());
    assert!(
        e.contains("feet.tif") && e.contains("ProjLinearUnitsGeoKey (3076)") && e.contains("9002"),
        "{e}"
    );
    let m = load_file(&feet, &opts(Some([100.0, 50.0]), None)).unwrap();
    assert_close(at(&m, 2, 1, 1), Vec3::new(100.0, 1.0, 50.0));
    assert!(
        m.warnings[0].contains("using --terrain-size 100,50"),
        "{:?}",
        m.warnings
    );
    let degrees = dir.path().join("wgs84.tif");
    geotiff::<colortype::Gray32Float>(
        &degrees,
        (2, 2),
        &heights,
        Some([0.0002, 0.0002, 0.0]),
        None,
        &[(1024, 2)],
    );
    let e = refusal(&degrees, &HeightmapOptions::default());
    assert!(
        e.contains("wgs84.tif") && e.contains("GTModelTypeGeoKey (1024)") && e.contains("degrees"),
        "{e}"
    );
    // A plain TIFF without tags or size: the flag is named.
    let plain = dir.path().join("plain.tif");
    geotiff::<colortype::Gray32Float>(&plain, (2, 2), &heights, None, None, &[]);
    let e = refusal(&plain, &HeightmapOptions::default());
    assert!(e.contains("--terrain-size"), "{e}");
}

#[test]
fn r16_is_square_little_endian() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("h.r16");
    let bytes: Vec<u8> = (0..9u16).flat_map(|v| (v * 1000).to_le_bytes()).collect();
    std::fs::write(&path, &bytes).unwrap();
    let m = load_file(&path, &opts(Some([8.0, 8.0]), Some([0.0, 65.535]))).unwrap();
    assert_close(at(&m, 3, 2, 1), Vec3::new(8.0, 5.0, 4.0));
    std::fs::write(&path, &bytes[..16]).unwrap();
    let e = refusal(&path, &opts(Some([8.0, 8.0]), Some([0.0, 1.0])));
    assert!(
        e.contains("h.r16") && e.contains("16 bytes is not a square"),
        "{e}"
    );
    std::fs::write(&path, b"").unwrap();
    let e = refusal(&path, &opts(Some([8.0, 8.0]), Some([0.0, 1.0])));
    assert!(e.contains("0x0 pixels"), "{e}");
}

#[test]
fn bad_images_and_flags_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let good = opts(Some([1.0, 1.0]), Some([0.0, 1.0]));
    // One pixel wide: no surface.
    let thin = png16(dir.path(), "thin.png", 1, 3, &[1, 2, 3]);
    let e = refusal(&thin, &good);
    assert!(e.contains("thin.png") && e.contains("1x3 pixels"), "{e}");
    // Colour.
    let rgb = dir.path().join("rgb.png");
    image::RgbImage::new(2, 2).save(&rgb).unwrap();
    let e = refusal(&rgb, &good);
    assert!(e.contains("rgb.png") && e.contains("3 channel"), "{e}");
    // No size for a plain image.
    let path = png16(dir.path(), "h.png", 4, 3, &values16());
    let e = refusal(&path, &opts(None, Some([0.0, 1.0])));
    assert!(e.contains("h.png") && e.contains("--terrain-size"), "{e}");
    // LO >= HI, zero or non-finite sizes.
    let e = refusal(&path, &opts(Some([1.0, 1.0]), Some([5.0, 5.0])));
    assert!(e.contains("--height-range") && e.contains("LO < HI"), "{e}");
    let e = refusal(&path, &opts(Some([0.0, 1.0]), Some([0.0, 1.0])));
    assert!(e.contains("--terrain-size"), "{e}");
    let e = refusal(&path, &opts(Some([f64::NAN, 1.0]), Some([0.0, 1.0])));
    assert!(e.contains("--terrain-size"), "{e}");
    // Truncated.
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("cut.png");
    for n in [8, 30, bytes.len() / 2, bytes.len() - 5] {
        std::fs::write(&cut, &bytes[..n]).unwrap();
        let e = refusal(&cut, &good);
        assert!(e.contains("cut.png"), "{e}");
    }
    let exr_path = dir.path().join("h.exr");
    exr(&exr_path, 3, 2, &[("Y", vec![1.0; 6])]);
    let bytes = std::fs::read(&exr_path).unwrap();
    for n in [4, 20, bytes.len() / 2, bytes.len() - 3] {
        std::fs::write(&exr_path, &bytes[..n]).unwrap();
        let e = refusal(&exr_path, &opts(Some([1.0, 1.0]), None));
        assert!(e.contains("h.exr"), "{e}");
    }
    let tif = dir.path().join("h.tif");
    geotiff::<colortype::Gray16>(&tif, (4, 3), &values16(), None, None, &[]);
    let bytes = std::fs::read(&tif).unwrap();
    for n in [4, 20, bytes.len() / 2, bytes.len() - 3] {
        std::fs::write(&tif, &bytes[..n]).unwrap();
        let e = refusal(&tif, &good);
        assert!(e.contains("h.tif"), "{e}");
    }
}

#[test]
fn heightmaps_over_the_limits_are_refused_before_decoding() {
    let dir = tempfile::tempdir().unwrap();
    let path = png16(dir.path(), "h.png", 4, 3, &values16());
    let small = Limits {
        pixels: 11,
        ..Limits::default()
    };
    let o = opts(Some([1.0, 1.0]), Some([0.0, 1.0]));
    let e = load(&path, Format::Png, &o, &small)
        .unwrap_err()
        .to_string();
    assert!(e.contains("h.png") && e.contains("--max-pixels"), "{e}");
    let few = Limits {
        triangles: 11,
        ..Limits::default()
    };
    let e = load(&path, Format::Png, &o, &few).unwrap_err().to_string();
    assert!(e.contains("--max-triangles"), "{e}");
}

#[test]
fn formats_are_told_by_magic_then_name() {
    assert_eq!(
        Format::of(b"\x89PNG\r\n\x1a\n", Path::new("x")),
        Some(Format::Png)
    );
    assert_eq!(Format::of(b"II*\0", Path::new("x.bin")), Some(Format::Tiff));
    assert_eq!(Format::of(b"", Path::new("a.R16")), Some(Format::R16));
    assert_eq!(Format::of(b"glTF", Path::new("t.glb")), None);
}
