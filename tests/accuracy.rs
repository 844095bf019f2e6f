//! Accuracy of baked textures against their meshes, with real assertions. The numbers are
//! printed (`cargo test --release --test accuracy -- --nocapture`); README and
//! formats/texel.md quote them, and `make accuracy` prints the fuller table.

mod common;

use common::*;
use glam::DVec3;
use texel_forest::bake::{self, BakeSettings};
use texel_forest::import;
use texel_forest::mesh_tracer::MeshTracer;
use texel_forest::silhouette::{Frame, axis_columns, compare, over_views, random_directions};
use texel_forest::volume::{DensityModel, Texel};

struct Measured {
    /// Relative error of the silhouette coverage seen along x, y, z through the trilinear
    /// texture, directional extinction included (as the renderer sees it).
    axis: [f64; 3],
    /// Per-column RMSE of coverage (column sums against rays through each column), worst axis.
    column_rmse: f64,
    /// Mean relative coverage error over random views through the trilinear texture.
    view_bias: f64,
}

fn measure(texel: &Texel, mesh: &import::Mesh, views: usize) -> Measured {
    let tracer = MeshTracer::new(mesh);
    let frame = Frame::of(texel);
    let extinction = |p, d| texel.extinction(0, p, d) as f64;
    let axis = [DVec3::X, DVec3::Y, DVec3::Z]
        .map(|d| compare(&tracer, frame, d, 3, &extinction).coverage_error());
    let columns = (0..3).map(|a| axis_columns(&tracer, texel, a, 8).pixel_rmse);
    let dirs = random_directions(views, 1);
    Measured {
        axis,
        column_rmse: columns.fold(0.0, f64::max),
        view_bias: over_views(&tracer, frame, &dirs, 2, &extinction).bias,
    }
}

fn report(name: &str, m: &Measured) {
    println!(
        "{name:<28} axis x {:+.3} y {:+.3} z {:+.3}  column rmse {:.3}  view bias {:+.3}",
        m.axis[0], m.axis[1], m.axis[2], m.column_rmse, m.view_bias
    );
}

/// The coverage targets: with each level's directional form fitted to the mesh, every axis
/// view and the mean over random views are within 4 % of the mesh's coverage (before the forms,
/// the broadleaf's axes were off by -18 % to +12 % and random views by +6 % to +11 %).
fn assert_coverage(name: &str, m: &Measured, axis_tolerance: f64) {
    assert!(
        m.axis.iter().all(|e| e.abs() < axis_tolerance),
        "{name}: axis views {:?}",
        m.axis
    );
    assert!(
        m.view_bias.abs() < 0.04,
        "{name}: view bias {}",
        m.view_bias
    );
    assert!(
        m.column_rmse < 0.25,
        "{name}: column rmse {}",
        m.column_rmse
    );
}

#[test]
fn the_texture_casts_the_mesh_silhouette_along_the_axes_and_random_views_for_the_fixtures() {
    for tree in FIXTURE_TREES {
        let model = import::load(&fixture(tree)).unwrap();
        let texel = bake::bake(&model.mesh, &BakeSettings::default()).unwrap();
        let m = measure(&texel, &model.mesh, 12);
        report(tree, &m);
        // Measured (32 cells, fine 256): axes within 2.6 %, views within 1.4 %, but the bare
        // tree's thin branches seen along z (+5.5 % of a coverage of 0.07: a few rays).
        let tolerance = if tree.contains("bare") { 0.07 } else { 0.04 };
        assert_coverage(tree, &m, tolerance);
    }
}

#[test]
fn the_texture_casts_the_mesh_silhouette_along_the_axes_and_random_views_for_the_real_trees() {
    let Some(trees) = realdata_trees() else {
        return;
    };
    for path in trees {
        let model = import::load(&path).unwrap();
        let texel = bake::bake(&model.mesh, &BakeSettings::default()).unwrap();
        let m = measure(&texel, &model.mesh, 12);
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        report(&name, &m);
        assert_coverage(&name, &m, 0.04);
    }
}

/// Every mip level blocks what level 0 blocks, along the axes and over random views: the
/// whole tree's coverage no longer grows with level (it grew by up to 88 % at the coarsest
/// before each level's form was fitted). Measured over the coarsest level's box, which coarse
/// levels fill out to: worst 1.6 % for these fixtures on the axes, 1.9 % over the views.
#[test]
fn every_mip_level_keeps_the_whole_trees_coverage() {
    for tree in FIXTURE_TREES {
        let model = import::load(&fixture(tree)).unwrap();
        let texel = bake::bake(&model.mesh, &BakeSettings::default()).unwrap();
        let tracer = MeshTracer::new(&model.mesh);
        let coarsest = texel.levels.last().unwrap();
        let frame = Frame {
            hi: texel.origin() + DVec3::from(coarsest.dims.map(|d| d as f64)) * coarsest.cell,
            ..Frame::of(&texel)
        };
        let dirs: Vec<DVec3> = [DVec3::X, DVec3::Y, DVec3::Z]
            .into_iter()
            .chain(random_directions(8, 3))
            .collect();
        let coverage = |level: usize| -> Vec<f64> {
            let extinction = |p, d| texel.extinction(level, p, d) as f64;
            dirs.iter()
                .map(|&d| compare(&tracer, frame, d, 1, &extinction).coverage_texture)
                .collect()
        };
        let base = coverage(0);
        for level in 1..texel.levels.len() {
            let c = coverage(level);
            let rel: Vec<f64> = c.iter().zip(&base).map(|(a, b)| a / b - 1.0).collect();
            let views = rel[3..].iter().sum::<f64>() / (rel.len() - 3) as f64;
            println!(
                "{tree} level {level}: axes {:+.3?}, views {views:+.3}",
                &rel[..3]
            );
            assert!(
                rel[..3].iter().all(|r| r.abs() < 0.035),
                "{tree} level {level}: axes {:?}",
                &rel[..3]
            );
            assert!(views.abs() < 0.035, "{tree} level {level}: views {views}");
        }
    }
}

/// Level 0's column optical depths along `axis` without its directional factor: what the
/// scan measured.
fn isotropic_column_depths(t: &Texel, axis: usize) -> Vec<f64> {
    let mut w = glam::Vec3::ZERO;
    w[axis] = 1.0;
    let k = f64::from(t.levels[0].directional_factor(w));
    t.column_depths(0, axis).iter().map(|d| d / k).collect()
}

#[test]
fn occupancy_gamma_is_fitted_to_the_mean_silhouette() {
    let model = import::load(&fixture("trees/conifer.glb")).unwrap();
    let settings = BakeSettings {
        density: DensityModel::Occupancy,
        ..Default::default()
    };
    let texel = bake::bake(&model.mesh, &settings).unwrap();
    assert!(texel.info.extinction_scale > 0.0);
    // gamma is fitted to the isotropic columns, before the directional forms.
    let predicted: f64 = (0..3)
        .map(|a| {
            let d = isotropic_column_depths(&texel, a);
            d.iter().map(|t| 1.0 - (-t).exp()).sum::<f64>() / d.len() as f64
        })
        .sum::<f64>()
        / 3.0;
    let mesh = texel.info.mesh_coverage.iter().sum::<f64>() / 3.0;
    assert!(
        (predicted - mesh).abs() < 1e-3,
        "predicted {predicted} mesh {mesh}"
    );
    // Occupancy is a fraction of fine cells.
    for part in 0..2 {
        assert!(
            texel.levels[0].density[part]
                .iter()
                .all(|&d| (0.0..=1.0).contains(&d))
        );
    }
}

#[test]
fn wood_and_foliage_are_split_by_material() {
    let part_mass = |tree: &str| {
        let model = import::load(&fixture(tree)).unwrap();
        let t = bake::bake(&model.mesh, &BakeSettings::default()).unwrap();
        [0, 1].map(|p| {
            t.levels[0].density[p]
                .iter()
                .map(|&d| d as f64)
                .sum::<f64>()
        })
    };
    let [wood, foliage] = part_mass("trees/bare.glb");
    assert!(
        wood > 0.0 && foliage == 0.0,
        "bare tree: wood {wood} foliage {foliage}"
    );
    let [wood, foliage] = part_mass("trees/conifer.glb");
    assert!(
        wood > 0.0 && foliage > wood,
        "conifer: wood {wood} needles {foliage}"
    );
    let [wood, foliage] = part_mass("trees/broadleaf.gltf");
    assert!(
        wood > 0.0 && foliage > 0.0,
        "broadleaf: wood {wood} leaves {foliage}"
    );
}

/// A solid box whose faces lie on cell boundaries: columns through it are opaque, columns
/// beside it transmit everything, the cells inside are the densest, and its albedo is the
/// material's.
#[test]
fn an_axis_aligned_box_bakes_to_an_opaque_block() {
    use texel_forest::procedural::builder::{self, MaterialSpec, ModelBuilder};
    let mut b = ModelBuilder::default();
    let m = b.material(MaterialSpec {
        name: "wood".into(),
        color: [0.25, 0.5, 0.75, 1.0],
        mask: None,
    });
    b.cuboid(
        m,
        glam::Vec3::new(-1.0, 0.0, -1.0),
        glam::Vec3::new(1.0, 4.0, 1.0),
    );
    // A thin post beside it fixes the grid so the box spans cells 1..3 along x and z.
    b.cuboid(
        m,
        glam::Vec3::new(-2.0, 0.0, -2.0),
        glam::Vec3::new(-1.75, 0.5, 2.0),
    );
    b.cuboid(
        m,
        glam::Vec3::new(1.75, 0.0, -2.0),
        glam::Vec3::new(2.0, 0.5, 2.0),
    );
    let f = b.to_gltf(None, "test");
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("box.glb");
    std::fs::write(&p, builder::glb(&f.doc, &f.bin)).unwrap();
    let model = import::load(&p).unwrap();
    let t = bake::bake(
        &model.mesh,
        &BakeSettings {
            resolution: 8,
            fine: 64,
            ..Default::default()
        },
    )
    .unwrap();
    let l = &t.levels[0];
    assert_eq!(l.dims, [8, 8, 8]);
    assert!((l.cell - 0.5).abs() < 1e-9);
    // Looking down y, the box covers columns x, z in 2..6 (the scan's own depths, before the
    // directional form, which thins the interior so the widened trilinear edges do not
    // overshoot the box's silhouette).
    let depth = isotropic_column_depths(&t, 1);
    for z in 0..8 {
        for x in 0..8 {
            let d = depth[z + 8 * x]; // columns along y are indexed z + nz * x
            let inside = (2..6).contains(&x) && (2..6).contains(&z);
            if inside {
                assert!(d > 4.0, "column {x},{z} should be opaque: {d}");
            }
        }
    }
    // Along x at mid height, z in 2..6: opaque through the box.
    let depth_x = isotropic_column_depths(&t, 0);
    for z in 2..6 {
        assert!(depth_x[4 + 8 * z] > 4.0, "{}", depth_x[4 + 8 * z]);
    }
    // Above the posts and away from the box nothing is there.
    let (top, front) = (7, 0);
    assert!(depth_x[top + 8 * front] < 1e-6);
    let i = (0..l.cell_count())
        .max_by(|&a, &b| l.density[0][a].total_cmp(&l.density[0][b]))
        .unwrap();
    for c in 0..3 {
        assert!(
            (l.albedo[0][i][c] - [0.25, 0.5, 0.75][c]).abs() < 2e-3,
            "{:?}",
            l.albedo[0][i]
        );
    }
}

/// Texel over mesh radiance summed over the frame, per colour channel and for alpha: one
/// fixture tree alone (no terrain), seen from `eye_dir` with the sun `g` degrees from the eye,
/// the texture read `lod_bias` levels coarser than the finest.
fn tree_radiance_ratio(tree: &str, g: f64, lod_bias: f32) -> [f64; 4] {
    use texel_forest::render::scene::TreeMesh;
    use texel_forest::render::{
        Camera, Lighting, Look, March, Method, Placed, RenderSettings, Scene, Shading, Sun, render,
    };
    let model = import::load(&fixture(tree)).unwrap();
    let texel = bake::bake(&model.mesh, &BakeSettings::default()).unwrap();
    let foliage = bake::foliage_triangles(&model.mesh, &texel.info.parameters).unwrap();
    let height = texel.info.model_max[1] - texel.info.model_min[1];
    let centre = DVec3::new(0.0, 0.5 * height, 0.0);
    // A view from the south-south-west, 25 degrees up; the sun turned from the eye about the
    // vertical plane's normal, up and away.
    let to_eye = DVec3::new(-0.35, 0.42, 0.84).normalize();
    let axis = to_eye.cross(DVec3::Y).normalize();
    let to_sun = glam::DQuat::from_axis_angle(axis, g.to_radians()) * to_eye;
    assert!(to_sun.y > to_eye.y, "the sun above the eye");
    let sun = Sun {
        direction: to_sun.as_vec3(),
        irradiance: std::f32::consts::PI,
    };
    let scene = Scene::new(
        centre + to_eye * 4.0 * height,
        vec![texel],
        vec![Look {
            texel: 0,
            foliage: 1.0,
            foliage_albedo: glam::Vec3::new(0.05, 0.12, 0.04),
        }],
        &[Placed {
            look: 0,
            position: DVec3::ZERO,
            rotation: 0.0,
            scale: 1.0,
        }],
        None,
        Lighting {
            sun,
            shading: Shading::default(),
            sky: None,
        },
    )
    .with_meshes(vec![TreeMesh::new(model.mesh, foliage)]);
    let camera = Camera::look_at(scene.origin, centre, 18.0, 96, 96).unwrap();
    let image = |method, spp| {
        render(
            &scene,
            &camera,
            &RenderSettings {
                method,
                spp,
                march: March {
                    lod_bias,
                    ..March::default()
                },
                ..RenderSettings::default()
            },
            &|_| {},
        )
    };
    let (texel, mesh) = (image(Method::Texel, 16), image(Method::Mesh, 64));
    // Over the whole frame: the tree's light, whatever its silhouette's blur.
    std::array::from_fn(|c| {
        let sum =
            |f: &texel_forest::render::Film| f.rgba.iter().map(|p| f64::from(p[c])).sum::<f64>();
        sum(&texel) / sum(&mesh)
    })
}

/// The foliage shades as a cloud of leaves, shows as much wood and shadows itself as the mesh
/// does, at the finest level and at a coarse one, near the hot spot and away from it: a lone
/// tree's light (the frame's sum, per channel) is within 12 % of the mesh method's, and its
/// light per unit of coverage within 10 % (the coverage from one view is the silhouette's own
/// error, 3-6 % here). With the gradient's normal, independent-media shadows and wood shown by
/// its extinction, the forest's trees were 9-15 % darker and 9 % redder.
#[test]
fn a_lone_tree_is_as_bright_as_its_mesh_at_every_level_and_sun() {
    for tree in ["trees/conifer.glb", "trees/broadleaf.gltf"] {
        for g in [20.0, 60.0] {
            for lod_bias in [0.0, 2.0] {
                let r = tree_radiance_ratio(tree, g, lod_bias);
                println!(
                    "{tree:<22} sun {g:>2} degrees from the eye, level +{lod_bias}: texel / mesh R {:.3} G {:.3} B {:.3} A {:.3}",
                    r[0], r[1], r[2], r[3]
                );
                for c in 0..3 {
                    assert!((r[c] - 1.0).abs() < 0.12, "{tree} {g} {lod_bias}: {r:?}");
                    let shading = r[c] / r[3];
                    assert!((shading - 1.0).abs() < 0.1, "{tree} {g} {lod_bias}: {r:?}");
                }
            }
        }
    }
}
