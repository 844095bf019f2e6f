//! `make accuracy`: how well baked textures predict their meshes' silhouettes, for the fixtures
//! and (where present) the real trees.
//!
//! * axis columns: per texture column along x, y and z, exp(-optical depth) against the
//!   fraction of rays through the column that miss the mesh (traced independently);
//! * views: 24 random directions, parallel rays marched through the trilinear texture against
//!   the mesh, per pixel of one cell;
//! * with `--anisotropy`, the same views for per-axis extinction combined by direction, the
//!   alternative `formats/texel.md` weighs.

use glam::DVec3;
use texel_forest::bake::{self, BakeSettings};
use texel_forest::corpus;
use texel_forest::mesh_tracer::MeshTracer;
use texel_forest::silhouette::{Frame, axis_columns, over_views, random_directions};
use texel_forest::volume::{DensityModel, Level};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let anisotropy = args.iter().any(|a| a == "--anisotropy");
    let occupancy = args.iter().any(|a| a == "--occupancy");
    let res: usize = args
        .iter()
        .find_map(|a| a.strip_prefix("--resolution="))
        .map_or(32, |r| r.parse().expect("number"));
    let settings = BakeSettings {
        resolution: res,
        fine: res * 8,
        density: if occupancy {
            DensityModel::Occupancy
        } else {
            DensityModel::Transmittance
        },
        ..BakeSettings::default()
    };
    let dirs = random_directions(24, 1);
    println!(
        "density {}, {res} cells on the longest side, fine {}",
        settings.density.name(),
        res * 8
    );
    println!(
        "{:<26} {:>24} {:>24} {:>28}",
        "", "axis columns x/y/z", "", "24 random views (trilinear)"
    );
    println!(
        "{:<26} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>9} {:>9}",
        "model", "cov x", "cov y", "cov z", "err x", "err y", "err z", "bias", "|bias|", "rmse"
    );
    let models = corpus::fixture_trees()
        .into_iter()
        .chain(corpus::real_trees().into_iter().flatten());
    for path in models {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let model = texel_forest::import::load(&path).expect("imports");
        let texel = bake::bake(&model.mesh, &settings).expect("bakes");
        let tracer = MeshTracer::new(&model.mesh);
        let cols: Vec<_> = (0..3)
            .map(|a| axis_columns(&tracer, &texel, a, 8))
            .collect();
        let frame = Frame::of(&texel);
        let v = over_views(&tracer, frame, &dirs, 3, &|p, _| {
            texel.extinction(0, p) as f64
        });
        println!(
            "{:<26} {:>8.4} {:>8.4} {:>8.4} {:>+8.4} {:>+8.4} {:>+8.4} {:>+9.4} {:>9.4} {:>9.4}",
            name,
            cols[0].coverage_mesh,
            cols[1].coverage_mesh,
            cols[2].coverage_mesh,
            cols[0].coverage_error(),
            cols[1].coverage_error(),
            cols[2].coverage_error(),
            v.bias,
            v.abs_bias,
            v.rmse
        );
        if anisotropy {
            let (grid, axes) = bake::axis_extinctions(&model.mesh, &settings).expect("bakes");
            let level = Level::empty(grid.dims, grid.cell);
            let per_axis = |p: DVec3, d: DVec3| {
                let q = (p - grid.origin) / grid.cell;
                (0..3)
                    .map(|a| d[a] * d[a] * level.interpolate(&axes[a], q) as f64)
                    .sum::<f64>()
            };
            let v = over_views(&tracer, frame, &dirs, 3, &per_axis);
            println!(
                "{:<26} {:>53} {:>+9.4} {:>9.4} {:>9.4}",
                "  per-axis (anisotropic)", "", v.bias, v.abs_bias, v.rmse
            );
        }
    }
}
