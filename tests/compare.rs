//! `texel compare` end to end on images written here with known differences.

mod common;

use std::path::Path;

use common::*;
use exr::prelude::*;

/// Writes an RGBA float EXR whose pixel (x, y) is `f(x, y)`.
fn write(path: &Path, width: usize, height: usize, f: impl Fn(usize, usize) -> [f32; 4] + Sync) {
    write_rgba_file(path, width, height, |x, y| {
        let p = f(x, y);
        (p[0], p[1], p[2], p[3])
    })
    .unwrap();
}

#[test]
fn compare_measures_known_differences_and_draws_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(&d.join("ref.exr"), 8, 4, |_, _| [0.5, 0.5, 0.5, 1.0]);
    // Off by 0.2 in every colour channel in the left half.
    write(&d.join("a.exr"), 8, 4, |x, _| {
        let v = if x < 4 { 0.7 } else { 0.5 };
        [v, v, v, 1.0]
    });
    let mask = image::GrayImage::from_fn(8, 4, |x, _| image::Luma([if x < 4 { 255 } else { 0 }]));
    mask.save(d.join("mask.png")).unwrap();
    let o = run(
        &[
            "compare",
            "a.exr",
            "ref.exr",
            "--json",
            "--mask",
            "mask.png",
            "--heatmap",
            "diff.png",
        ],
        d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rmse = json["all"]["rgb"]["rmse"].as_f64().unwrap();
    assert!((rmse - (0.04f64 / 2.0).sqrt()).abs() < 1e-6, "{json}");
    assert!((json["mask"]["rgb"]["rmse"].as_f64().unwrap() - 0.2).abs() < 1e-6);
    assert_eq!(json["mask"]["pixels"], 16);
    assert_eq!(json["all"]["alpha"]["max"], 0.0);
    let heat = image::open(d.join("diff.png")).unwrap().to_rgb8();
    assert_eq!(heat.dimensions(), (8, 4));
    assert!(
        heat.get_pixel(0, 0)
            .0
            .iter()
            .map(|&v| v as u32)
            .sum::<u32>()
            > 500
    );
    assert_eq!(heat.get_pixel(7, 0).0, texel_forest::color::ramp(0.0));
    // Text names both files and the measures.
    let o = run(&["compare", "a.exr", "ref.exr"], d);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("a.exr") && text.contains("ref.exr") && text.contains("rmse"));
    // A build can fail on too large an error, with its own status.
    let o = run(&["compare", "a.exr", "ref.exr", "--fail-above", "0.1"], d);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("above the limit 0.1 (--fail-above)"));
    assert!(
        run(&["compare", "a.exr", "ref.exr", "--fail-above", "0.2"], d)
            .status
            .success()
    );
}

#[test]
fn compare_refuses_images_that_do_not_match() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(&d.join("ref.exr"), 8, 4, |_, _| [0.5; 4]);
    write(&d.join("small.exr"), 4, 4, |_, _| [0.5; 4]);
    assert_error(
        &run(&["compare", "small.exr", "ref.exr"], d),
        &["small.exr", "ref.exr", "4x4", "8x4", "same size"],
    );
    // Colour without alpha.
    write_rgb_file(d.join("rgb.exr"), 8, 4, |_, _| (0.5f32, 0.5f32, 0.5f32)).unwrap();
    assert_error(
        &run(&["compare", "rgb.exr", "ref.exr"], d),
        &["rgb.exr", "no channel A"],
    );
    std::fs::write(d.join("junk.exr"), b"not an image").unwrap();
    assert_error(
        &run(&["compare", "junk.exr", "ref.exr"], d),
        &["junk.exr", "cannot read"],
    );
    image::GrayImage::new(3, 3)
        .save(d.join("mask.png"))
        .unwrap();
    assert_error(
        &run(&["compare", "ref.exr", "ref.exr", "--mask", "mask.png"], d),
        &["mask.png", "3x3"],
    );
    let o = run(
        &["compare", "ref.exr", "ref.exr", "--heatmap", "out/d.png"],
        d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

/// An EXR mask may name its channel: `canopy.A` of a render marks where trees are, and the
/// mean ratio there says how much darker or brighter the image is than the reference.
#[test]
fn compare_takes_a_mask_from_a_named_channel_and_reports_mean_ratios() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(&d.join("ref.exr"), 8, 4, |_, _| [0.5, 0.5, 0.5, 1.0]);
    write(&d.join("a.exr"), 8, 4, |x, _| {
        let v = if x < 4 { 0.45 } else { 0.5 };
        [v, v, 0.55, 1.0]
    });
    let column = |f: &dyn Fn(usize) -> f32| FlatSamples::F32((0..32).map(f).collect());
    let channels = vec![
        AnyChannel::new("A", column(&|_| 1.0)),
        AnyChannel::new("canopy.A", column(&|i| if i % 8 < 4 { 1.0 } else { 0.0 })),
    ];
    Image::from_layer(Layer::new(
        (8, 4),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(channels.into()),
    ))
    .write()
    .to_file(d.join("mask.exr"))
    .unwrap();
    let json = |extra: &[&str]| {
        let mut args = vec![
            "compare", "a.exr", "ref.exr", "--json", "--mask", "mask.exr",
        ];
        args.extend_from_slice(extra);
        let o = run(&args, d);
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    // Alpha covers everything; canopy.A the left half, where R and G are 10 % darker.
    assert_eq!(json(&[])["mask"]["pixels"], 32);
    let j = json(&["--mask-channel", "canopy.A"]);
    assert_eq!(j["mask"]["pixels"], 16);
    let ratio = |c: usize| j["mask"]["mean_ratio"][c].as_f64().unwrap();
    assert!(
        (ratio(0) - 0.9).abs() < 1e-6 && (ratio(2) - 1.1).abs() < 1e-6,
        "{j}"
    );
    // In blocks of 4 the left half (canopy in every pixel) is in, the right half out; in
    // blocks of 8 each block is half in, which is not more than half: none is in.
    assert_eq!(
        json(&["--mask-channel", "canopy.A", "--mask-block", "4"])["mask"]["pixels"],
        16
    );
    assert_eq!(
        json(&["--mask-channel", "canopy.A", "--mask-block", "8"])["mask"]["pixels"],
        0
    );
    // A channel the mask lacks is named in the error.
    let o = run(
        &[
            "compare",
            "a.exr",
            "ref.exr",
            "--mask",
            "mask.exr",
            "--mask-channel",
            "x.Y",
        ],
        d,
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("x.Y") && stderr(&o).contains("mask.exr"),
        "{}",
        stderr(&o)
    );
    // The text names the ratios too.
    let o = run(&["compare", "a.exr", "ref.exr"], d);
    assert!(String::from_utf8_lossy(&o.stdout).contains("mean ratio R"));
}

/// Writes a frame as `texel render` does: premultiplied RGBA `rgba(x, y)`, Z 10 m everywhere,
/// `canopy.A` over the left half, and the matrices of a camera at the origin looking down -Z.
fn write_frame(path: &Path, rgba: impl Fn(u32, u32) -> [f32; 4]) {
    use texel_forest::render::{Aovs, Camera, Film};
    let (width, height) = (8, 4);
    let camera =
        Camera::look_at(glam::DVec3::ZERO, glam::DVec3::NEG_Z, 40.0, width, height).unwrap();
    let mut film = Film::new(0, 0, width, height, (width, height));
    for (i, p) in film.rgba.iter_mut().enumerate() {
        let (x, y) = (i as u32 % width, i as u32 / width);
        *p = rgba(x, y);
        film.z[i] = 10.0;
        film.canopy[i] = if x < width / 2 { 1.0 } else { 0.0 };
    }
    let aovs = Aovs {
        canopy: true,
        ..Aovs::default()
    };
    let exr = film
        .exr_bytes(
            false,
            aovs,
            camera.world_to_camera(),
            camera.world_to_ndc(),
            None,
        )
        .unwrap();
    std::fs::write(path, exr.bytes).unwrap();
}

/// `--temporal`: frames alternating 0.6 and 0.4 (a flicker of +-0.1 about 0.5) change by 0.2
/// from each to the next; inside `canopy.A`, where they do not flicker, by nothing.
#[test]
fn compare_temporal_measures_a_known_flicker() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for n in 0..3 {
        let v = if n % 2 == 0 { 0.6 } else { 0.4 };
        write_frame(&d.join(format!("f{n}.exr")), |x, _| {
            let v = if x < 4 { 0.5 } else { v };
            [v, v, v, 1.0]
        });
    }
    let frames = ["compare", "--temporal", "f0.exr", "f1.exr", "f2.exr"];
    let o = run(&[&frames[..], &["--json"]].concat(), d);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["pairs"].as_array().unwrap().len(), 2, "{json}");
    assert_eq!(json["pairs"][1]["from"], "f1.exr");
    assert_eq!(json["pairs"][1]["to"], "f2.exr");
    assert_eq!(json["pairs"][0]["camera_moved"], false);
    assert_eq!(json["total"]["measured"], 64);
    // Half the pixels change by 0.2 in R, G and B, the other half not at all.
    let mean = json["total"]["mean_absolute"].as_f64().unwrap();
    assert!((mean - 0.1).abs() < 1e-6, "{json}");
    let rms = json["total"]["rms"].as_f64().unwrap();
    assert!((rms - (0.02f64).sqrt()).abs() < 1e-6, "{json}");
    let o = run(
        &[&frames[..], &["--json", "--mask-channel", "canopy.A"]].concat(),
        d,
    );
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["mask_channel"], "canopy.A");
    assert_eq!(json["total"]["inside_mask"], 32);
    assert_eq!(json["total"]["mean_absolute"], 0.0);
    // Text names each pair and the measures.
    let o = run(&frames, d);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("f0.exr -> f1.exr, same camera")
            && text.contains("all 2 pairs")
            && text.contains("mean |change| 0.100000"),
        "{text}"
    );
}

#[test]
fn compare_temporal_refuses_what_it_cannot_measure() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_frame(&d.join("f0.exr"), |_, _| [0.5; 4]);
    // A render's colour without its depth.
    write(&d.join("flat.exr"), 8, 4, |_, _| [0.5; 4]);
    assert_error(
        &run(&["compare", "--temporal", "f0.exr", "flat.exr"], d),
        &["flat.exr", "no channel Z"],
    );
    assert_error(
        &run(&["compare", "--temporal", "f0.exr", "gone.exr"], d),
        &["gone.exr", "cannot read"],
    );
    // Usage errors (status 2): one frame; three images without --temporal; both modes at once.
    for args in [
        &["compare", "--temporal", "f0.exr"][..],
        &["compare", "f0.exr", "f0.exr", "f0.exr"],
        &["compare", "f0.exr", "--temporal", "f0.exr", "f0.exr"],
        &["compare", "f0.exr", "f0.exr", "--depth-tolerance", "0.1"],
    ] {
        let o = run(args, d);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
    let o = run(&["compare", "--temporal", "f0.exr"], d);
    assert!(stderr(&o).contains("2 values required"), "{}", stderr(&o));
}
