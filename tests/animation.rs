//! Frame sequences end to end: camera paths (keyframe files and glTF animations), numbered
//! outputs, and frames that are the same bytes alone or in their sequence.

mod common;

use common::{assert_error, run, small_forest, stderr};
use std::path::Path;

/// Over `small_forest` from the south-west, in 2 s.
const PATH: &str = r#"{
  "format": "texel-forest camera path 1",
  "keys": [
    { "time": 0, "eye": [-150, 450, 260], "target": [0, 300, 0], "fov": 40 },
    { "time": 2, "eye": [-60, 400, 120], "target": [0, 320, 0], "fov": 30 }
  ]
}"#;

/// `texel render forest.instances` at 48 x 27 pixels with `extra`.
fn render(dir: &Path, extra: &[&str]) -> std::process::Output {
    let mut a = vec![
        "render",
        "forest.instances",
        "--width",
        "48",
        "--height",
        "27",
    ];
    a.extend_from_slice(extra);
    run(&a, dir)
}

fn world_to_camera(path: &Path) -> [f32; 16] {
    let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
    image.layer_data[0].attributes.world_to_camera.unwrap()
}

#[test]
fn a_frame_rendered_alone_equals_the_same_frame_inside_its_sequence() {
    let dir = small_forest();
    let d = dir.path();
    std::fs::write(d.join("fly.json"), PATH).unwrap();
    let o = render(
        d,
        &[
            "--camera-path",
            "fly.json",
            "--fps",
            "2",
            "-o",
            "seq/f.###.exr",
            "--preview",
            "seq/f.###.png",
            "--depfile",
            "seq.d",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // The whole path at 2 frames a second: frames 0 to 4.
    for f in 0..5 {
        for ext in ["exr", "png"] {
            assert!(d.join(format!("seq/f.{f:03}.{ext}")).is_file(), "frame {f}");
        }
    }
    assert!(!d.join("seq/f.005.exr").exists());
    let rule = std::fs::read_to_string(d.join("seq.d")).unwrap();
    let (targets, deps) = rule.split_once(':').unwrap();
    assert_eq!(targets.split_whitespace().count(), 5, "{rule}");
    assert!(
        deps.contains("fly.json") && deps.contains("forest.instances"),
        "{rule}"
    );

    let o = render(
        d,
        &[
            "--camera-path",
            "fly.json",
            "--fps",
            "2",
            "--frames",
            "3",
            "-o",
            "alone.exr",
            "--threads",
            "1",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let read = |n: &str| std::fs::read(d.join(n)).unwrap();
    assert_eq!(read("alone.exr"), read("seq/f.003.exr"));
    // The camera moves from frame to frame; the first and last are the keys' views.
    assert_ne!(
        world_to_camera(&d.join("seq/f.000.exr")),
        world_to_camera(&d.join("seq/f.001.exr"))
    );
    let o = render(
        d,
        &[
            "--eye=-150,450,260",
            "--target",
            "0,300,0",
            "--fov",
            "40",
            "-o",
            "key.exr",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let (a, b) = (
        world_to_camera(&d.join("key.exr")),
        world_to_camera(&d.join("seq/f.000.exr")),
    );
    assert!(
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-4),
        "{a:?} {b:?}"
    );
}

#[test]
fn a_still_camera_sequence_draws_new_noise_each_frame() {
    let dir = small_forest();
    let d = dir.path();
    let o = render(
        d,
        &[
            "--eye=-150,450,260",
            "--target",
            "0,300,0",
            "--frames",
            "7..8",
            "-o",
            "still.#.exr",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let read = |n: &str| std::fs::read(d.join(n)).unwrap();
    assert_eq!(
        world_to_camera(&d.join("still.7.exr")),
        world_to_camera(&d.join("still.8.exr"))
    );
    assert_ne!(read("still.7.exr"), read("still.8.exr"));
}

#[test]
fn a_gltf_camera_animation_drives_the_frames() {
    let dir = small_forest();
    let d = dir.path();
    // A camera node moved by a LINEAR translation from the first key's eye to the second's,
    // turned to look down the -Z axis towards the forest (no rotation: glTF cameras look
    // along -Z).
    let times: Vec<u8> = [0.0f32, 1.0].iter().flat_map(|x| x.to_le_bytes()).collect();
    let eyes: Vec<u8> = [0.0f32, 420.0, 300.0, 40.0, 420.0, 300.0]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let bin = [times, eyes].concat();
    use base64::Engine as _;
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let doc = serde_json::json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "camera": 0, "name": "drone" }],
        "cameras": [{ "type": "perspective", "perspective": { "yfov": 0.7, "znear": 0.1 } }],
        "animations": [{
            "channels": [{ "sampler": 0, "target": { "node": 0, "path": "translation" } }],
            "samplers": [{ "input": 0, "output": 1 }],
        }],
        "buffers": [{ "byteLength": bin.len(), "uri": uri }],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 8 },
            { "buffer": 0, "byteOffset": 8, "byteLength": 24 },
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 2, "type": "SCALAR",
              "min": [0.0], "max": [1.0] },
            { "bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC3" },
        ],
    });
    std::fs::write(d.join("cam.gltf"), serde_json::to_vec(&doc).unwrap()).unwrap();
    let o = render(
        d,
        &["--camera-path", "cam.gltf", "--fps", "4", "-o", "g.##.exr"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // Frames 0..4 at 4 fps; frame 2 (0.5 s) is half way: the eye at x = 20.
    let m = world_to_camera(&d.join("g.02.exr"));
    let eye = |m: [f32; 16]| -> [f32; 3] {
        // worldToCamera is a rotation then a translation (row vectors): eye = -t R^T.
        let t = [m[12], m[13], m[14]];
        std::array::from_fn(|i| -(0..3).map(|k| t[k] * m[4 * i + k]).sum::<f32>())
    };
    let e = eye(m);
    assert!(
        (e[0] - 20.0).abs() < 1e-2 && (e[1] - 420.0).abs() < 1e-2 && (e[2] - 300.0).abs() < 1e-2,
        "{e:?}"
    );
    assert!(d.join("g.04.exr").is_file() && !d.join("g.05.exr").exists());
    // By name; an unknown name is refused with the names there are.
    let o = render(
        d,
        &[
            "--camera-path",
            "cam.gltf",
            "--camera",
            "crane",
            "-o",
            "x.##.exr",
        ],
    );
    assert_error(&o, &["cam.gltf", "crane", "drone"]);
}

#[test]
fn sequences_that_cannot_be_written_or_read_are_refused_before_rendering() {
    let dir = small_forest();
    let d = dir.path();
    std::fs::write(d.join("fly.json"), PATH).unwrap();
    // Many frames to one file name.
    let o = render(d, &["--frames", "0..2", "-o", "one.exr"]);
    assert_error(&o, &["-o", "one.exr", "#"]);
    assert!(!d.join("one.exr").exists());
    // A character of more than one byte before the #s (the numbering cut it in two).
    let o = render(d, &["--frames", "0..2", "-o", "tr\u{e8}s##.exr"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["tr\u{e8}s00.exr", "tr\u{e8}s01.exr"] {
        assert!(d.join(f).exists(), "{f}");
    }
    let o = render(
        d,
        &[
            "--camera-path",
            "fly.json",
            "-o",
            "f.#.exr",
            "--preview",
            "p.png",
        ],
    );
    assert_error(&o, &["--preview", "p.png", "#"]);
    assert!(!d.join("f.0.exr").exists());
    // A key out of order names the file and the field.
    std::fs::write(
        d.join("bad.json"),
        PATH.replace("\"time\": 2", "\"time\": 0"),
    )
    .unwrap();
    let o = render(d, &["--camera-path", "bad.json", "-o", "f.#.exr"]);
    assert_error(&o, &["bad.json", "keys[1].time", "not after"]);
    // A camera name means nothing to a keyframe file.
    let o = render(
        d,
        &[
            "--camera-path",
            "fly.json",
            "--camera",
            "drone",
            "-o",
            "f.#.exr",
        ],
    );
    assert_error(&o, &["fly.json", "drone", "keyframe file"]);
    // Eye and target swap places over the path, meeting at its middle (frame 12 of 0..24):
    // refused before frame 0 is written.
    std::fs::write(
        d.join("swap.json"),
        r#"{
  "format": "texel-forest camera path 1",
  "keys": [
    { "time": 0, "eye": [0, 420, 0], "target": [10, 420, 0] },
    { "time": 1, "eye": [10, 420, 0], "target": [0, 420, 0] }
  ]
}"#,
    )
    .unwrap();
    let o = render(
        d,
        &[
            "--camera-path",
            "swap.json",
            "--frames",
            "0..24",
            "--fps",
            "24",
            "-o",
            "s.##.exr",
        ],
    );
    assert_error(&o, &["frame 12", "coincide"]);
    assert!(!d.join("s.00.exr").exists());
    // Frames backwards, and a path with --eye.
    // Previews of different sizes do not animate; the error names the odd one.
    for (name, size) in [("a.png", "16"), ("b.png", "17")] {
        let o = run(
            &[
                "render",
                "forest.instances",
                "--width",
                size,
                "--height",
                "9",
                "-o",
                "x.exr",
                "--preview",
                name,
            ],
            d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = run(&["animate", "a.png", "b.png", "-o", "ab.png"], d);
    assert_error(&o, &["b.png", "same size"]);
    assert!(!d.join("ab.png").exists());
    // A --width that scales the frames past --max-pixels is refused before any is scaled
    // (65535 x 36863 would take gigabytes).
    let o = run(
        &["animate", "a.png", "-o", "wide.png", "--width", "65535"],
        d,
    );
    assert_error(&o, &["--width 65535", "--max-pixels"]);
    assert!(!d.join("wide.png").exists());
    let o = render(d, &["--frames", "5..2", "-o", "f.#.exr"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = render(
        d,
        &[
            "--camera-path",
            "fly.json",
            "--eye=0,0,0",
            "--target",
            "1,0,0",
            "-o",
            "f.#.exr",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
