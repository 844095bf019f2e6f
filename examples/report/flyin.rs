//! Flicker along the fly-in (`make flicker`, part of `make report`): the demo forest rendered
//! along `fixtures/paths/flyin.json` (from the far view down to the mountain's flank) by each
//! method, every frame, and `texel compare --temporal` of each sequence inside the canopy
//! (`canopy.A`), the camera's motion undone by reprojection. The hybrid's is also split
//! between the trees in its transition band (`lod_band.A`: drawn either way by chance, where a
//! tree could pop) and the rest of the canopy.
//!
//! Each frame is a new seed, so a method's noise is part of its flicker, as a viewer sees it.

use std::fmt::Write as _;
use std::path::Path;

use texel_forest::plot::{Bars, PALETTE};

use crate::{HEIGHT, Report, WIDTH};

/// The fly-in's frame rate: 4 s of path, 49 frames.
const FPS: &str = "12";

/// One method's fly-in: its wall time for the whole sequence (one process: the scene is
/// loaded once), and the mean absolute frame-to-frame change of R, G, B inside the canopy;
/// for the hybrid, also inside its transition band and in the rest of the canopy.
pub struct Flicker {
    pub method: &'static str,
    pub seconds: f64,
    pub frames: usize,
    pub canopy: f64,
    pub band: Option<f64>,
    pub outside_band: Option<f64>,
    /// Pixels measured inside the band, over all pairs.
    pub band_pixels: usize,
}

pub fn run(report: &Report, forest: &str, dir: &Path) -> (Vec<Flicker>, String) {
    eprintln!("report: flicker along the fly-in...");
    let path = report.root.join("fixtures/paths/flyin.json");
    let path = path.to_str().unwrap();
    let mut rows = Vec::new();
    for (method, extra) in [
        ("mesh 1 spp", &["--method", "mesh"][..]),
        ("mesh 16 spp", &["--method", "mesh", "--spp", "16"][..]),
        ("texel 1 spp", &["--method", "texel"][..]),
        ("hybrid 1 spp", &["--method", "hybrid"][..]),
        // Each sample through a random point of its pixel, not its centre (before stop 37).
        (
            "hybrid 1 spp, jittered",
            &["--method", "hybrid", "--jitter"][..],
        ),
        // Models only where a tree's footprint is under half a cell: fewer, less aliased.
        (
            "hybrid 1 spp, switch 0.5",
            &["--method", "hybrid", "--lod-switch", "0.5"][..],
        ),
    ] {
        let name = method.replace([' ', ','], "-");
        let frames_dir = report.work.join("flyin").join(&name);
        // Frames of an earlier run with other settings must not join this sequence.
        let _ = std::fs::remove_dir_all(&frames_dir);
        let pattern = format!("flyin/{name}/f.####.exr");
        let (w, h) = (WIDTH.to_string(), HEIGHT.to_string());
        let mut args = vec![
            "render",
            forest,
            "--camera-path",
            path,
            "--fps",
            FPS,
            "--width",
            &w,
            "--height",
            &h,
            "--aov",
            "canopy,lod",
            "-o",
            &pattern,
            "-q",
        ];
        args.extend_from_slice(extra);
        let seconds = report.run(&args);
        let mut frames: Vec<String> = std::fs::read_dir(&frames_dir)
            .unwrap()
            .map(|e| e.unwrap().path().to_str().unwrap().to_string())
            .filter(|p| p.ends_with(".exr"))
            .collect();
        frames.sort();
        let measure = |mask: &[&str]| -> (f64, usize) {
            let mut a = vec!["compare", "--json", "--temporal"];
            a.extend(frames.iter().map(String::as_str));
            a.extend_from_slice(mask);
            let out = report.output(&a);
            let json: serde_json::Value = serde_json::from_slice(&out).unwrap();
            let total = &json["total"];
            (
                total["mean_absolute"].as_f64().unwrap_or(f64::NAN),
                total["measured"].as_u64().unwrap_or(0) as usize,
            )
        };
        let (canopy, _) = measure(&["--mask-channel", "canopy.A"]);
        let hybrid = method.starts_with("hybrid");
        let (band, band_pixels) = if hybrid {
            let (b, n) = measure(&["--mask-channel", "lod_band.A"]);
            (Some(b), n)
        } else {
            (None, 0)
        };
        let outside_band = hybrid.then(|| {
            measure(&[
                "--mask-channel",
                "canopy.A",
                "--exclude-channel",
                "lod_band.A",
            ])
            .0
        });
        rows.push(Flicker {
            method,
            seconds,
            frames: frames.len(),
            canopy,
            band,
            outside_band,
            band_pixels,
        });
    }
    let md = write(dir, &rows);
    (rows, md)
}

/// The fly-in's table (markdown, for report/README.md) and its bar chart (flicker.png).
fn write(dir: &Path, rows: &[Flicker]) -> String {
    let mut md = String::new();
    let frames = rows.first().map_or(0, |r| r.frames);
    writeln!(
        md,
        "\n## Flicker along the fly-in\n\n\
         `fixtures/paths/flyin.json`, {frames} frames at {WIDTH} x {HEIGHT}, each method from the \
         far view down to the mountain's flank; `texel compare --temporal` of each sequence \
         (mean absolute change of R, G, B from frame to frame, the camera's motion undone by \
         reprojection), inside the canopy (`canopy.A` > 0.5), and for the hybrid inside its \
         transition band (`lod_band.A` > 0.5) and in the rest of the canopy. Time: the whole \
         sequence, one process.\n\n\
         ![](flicker.png)\n\n\
         | method | seconds | flicker in the canopy | in the band | rest of the canopy |\n\
         |---|---|---|---|---|"
    )
    .unwrap();
    let cell = |v: Option<f64>| v.map_or("".to_string(), |v| format!("{v:.5}"));
    for r in rows {
        writeln!(
            md,
            "| {} | {:.1} | {:.5} | {} | {} |",
            r.method,
            r.seconds,
            r.canopy,
            cell(r.band),
            cell(r.outside_band)
        )
        .unwrap();
    }
    if let Some(h) = rows.iter().find(|r| r.band.is_some()) {
        writeln!(
            md,
            "\nThe hybrid's band held {} measured pixels over the sequence.",
            h.band_pixels
        )
        .unwrap();
    }
    let bars = Bars {
        title: format!("flicker along the fly-in, {frames} frames"),
        y_label: "change".into(),
        groups: rows.iter().map(|r| r.method.to_string()).collect(),
        series: vec![
            (
                "canopy".into(),
                PALETTE[0],
                rows.iter().map(|r| r.canopy).collect(),
            ),
            (
                "band".into(),
                PALETTE[1],
                rows.iter().map(|r| r.band.unwrap_or(f64::NAN)).collect(),
            ),
            (
                "rest of canopy".into(),
                PALETTE[2],
                rows.iter()
                    .map(|r| r.outside_band.unwrap_or(f64::NAN))
                    .collect(),
            ),
        ],
    };
    bars.draw(900, 500).save(dir.join("flicker.png")).unwrap();
    md
}
