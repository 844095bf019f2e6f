//! Accuracy of baked textures against their meshes, with real assertions. The numbers are
//! printed (`cargo test --release --test accuracy -- --nocapture`); README and
//! formats/texel.md quote them, and `make accuracy` prints the fuller table.

mod common;

use common::*;
use glam::DVec3;
use texel_forest::bake::{self, BakeSettings};
use texel_forest::import;
use texel_forest::mesh_tracer::MeshTracer;
use texel_forest::render::{Method, ShadowRays};
use texel_forest::silhouette::{Frame, axis_columns, compare, over_views, random_directions};
use texel_forest::volume::{DensityModel, PartFacing, Texel};

struct Measured {
    /// Relative error of the silhouette coverage seen along x, y, z through the trilinear
    /// texture, directional extinction included (as the renderer sees it).
    axis: [f64; 3],
    /// Per-column RMSE of coverage (column sums against rays through each column), worst axis.
    /// The cells' sums along a column are what the axis scans fit; since level 0 is fitted to
    /// rays read trilinearly (`bake::refine`) they are no longer the column's mean (conifer
    /// 0.076 -> 0.143), and `view_rmse` is the measure of what a renderer shows.
    column_rmse: f64,
    /// Mean relative coverage error over random views through the trilinear texture.
    view_bias: f64,
    /// Per-pixel (one cell) coverage RMSE over the same random views, jittered rays through
    /// the trilinear texture against the mesh's: how sharp the crown's light and shade are
    /// (fixtures 0.17, 0.18, 0.15; the real trees 0.06-0.12).
    view_rmse: f64,
}

/// Rays per cell edge for the axis views: 36 a cell. Thin branches cover few cells, and at 9
/// rays a cell the mesh's own hit count is noisy by some 5 % (the bare tree seen along z
/// measured +5.5 % at 9 rays a cell, +0.8 % at 64).
const AXIS_RAYS: usize = 8;

fn measure(texel: &Texel, mesh: &import::Mesh, views: usize) -> Measured {
    let tracer = MeshTracer::new(mesh);
    let frame = Frame::of(texel);
    let facing = PartFacing::of(&texel.levels[0]);
    let extinction = |p, d| texel.extinction(0, &facing, p, d) as f64;
    let axis = [DVec3::X, DVec3::Y, DVec3::Z]
        .map(|d| compare(&tracer, frame, d, AXIS_RAYS, &extinction).coverage_error());
    let columns = (0..3).map(|a| axis_columns(&tracer, texel, a, 8).pixel_rmse);
    let dirs = random_directions(views, 1);
    let views = over_views(&tracer, frame, &dirs, 2, &extinction);
    Measured {
        axis,
        column_rmse: columns.fold(0.0, f64::max),
        view_bias: views.bias,
        view_rmse: views.rmse,
    }
}

fn report(name: &str, m: &Measured) {
    println!(
        "{name:<28} axis x {:+.3} y {:+.3} z {:+.3}  column rmse {:.3}  view bias {:+.3}  view rmse {:.3}",
        m.axis[0], m.axis[1], m.axis[2], m.column_rmse, m.view_bias, m.view_rmse
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
    assert!(m.view_rmse < 0.2, "{name}: view rmse {}", m.view_rmse);
}

/// The coverage targets on the fixtures, and how sharp their crowns are: per cell-sized pixel
/// over 12 random views, the coverage RMSE against the mesh's averages 0.167 over the three
/// (conifer 0.168, broadleaf 0.179, bare 0.154; the broadleaf 0.181 before its form was fitted
/// to each part as drawn, stop 61); 0.176 before level 0 was fitted ray by ray
/// (`bake::refine`: 0.181, 0.191, 0.157), whose interpolated fringe blocked what the mesh
/// does not. Over the real trees 0.106 -> 0.097. The texture is read as the renderer's view
/// rays read it, each part turned by its surfaces' facing (`volume::PartFacing`): so read,
/// the broadleaf's form fitted to both parts alike blocked +5.1 % and +4.2 % along x and z.
#[test]
fn the_texture_casts_the_mesh_silhouette_along_the_axes_and_random_views_for_the_fixtures() {
    let mut rmse = 0.0;
    for tree in FIXTURE_TREES {
        let model = import::load(&fixture(tree)).unwrap();
        let texel = bake::bake(&model.mesh, &BakeSettings::default()).unwrap();
        let m = measure(&texel, &model.mesh, 12);
        report(tree, &m);
        assert_coverage(tree, &m, 0.04);
        rmse += m.view_rmse / FIXTURE_TREES.len() as f64;
    }
    println!("mean per-pixel coverage rmse over random views: {rmse:.4}");
    assert!(rmse < 0.172, "{rmse}");
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

/// Every mip level blocks what level 0 blocks, within 2 %, along the axes and over random
/// views: the whole tree's coverage no longer grows with level (it grew by up to 88 % at the
/// coarsest before each level's form was fitted). Measured over the coarsest level's box,
/// which coarse levels fill out to, at 9 rays a cell (at 1 the bare tree's thin branches made
/// level 0's own estimate 3 % off): worst 0.8 % on the axes, 1.4 % over the views.
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
            let facing = PartFacing::of(&texel.levels[level]);
            let extinction = |p, d| texel.extinction(level, &facing, p, d) as f64;
            dirs.iter()
                .map(|&d| compare(&tracer, frame, d, 3, &extinction).coverage_texture)
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
                rel[..3].iter().all(|r| r.abs() < 0.02),
                "{tree} level {level}: axes {:?}",
                &rel[..3]
            );
            assert!(views.abs() < 0.02, "{tree} level {level}: views {views}");
        }
    }
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
            let d = texel.scanned_column_depths(0, a);
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
    let depth = t.scanned_column_depths(0, 1);
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
    let depth_x = t.scanned_column_depths(0, 0);
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

/// One fixture tree alone (no terrain), baked once, to be rendered by both methods, seen from
/// four tree heights away.
#[derive(Clone)]
struct LoneTree {
    name: String,
    model: import::Model,
    texel: Texel,
    foliage: Vec<bool>,
    /// The species' leaf colour, in both methods.
    leaf_albedo: glam::Vec3,
}

/// How a [`LoneTree`] is seen and lit: from `eye` (the direction from the tree), the sun `g`
/// degrees from the eye, turned up from it in the vertical plane and then `turn` degrees about
/// the eye's line of sight (0: the sun above it, 90: beside it, 180: below it); with shadow
/// rays crossing the textures as `rays` says, or none; the paper's shading terms as `shading`
/// says.
#[derive(Clone, Copy)]
struct Light {
    eye: DVec3,
    g: f64,
    turn: f64,
    shadows: bool,
    rays: ShadowRays,
    shading: texel_forest::render::Shading,
}

/// The paper's shading without the highlight and the ambient term: only the sun's Lambert
/// term, so that shadowed over unshadowed light is the share the sun reaches.
fn sunlit_lambert_only() -> texel_forest::render::Shading {
    texel_forest::render::Shading {
        ks: 0.0,
        ambient: 0.0,
        ..texel_forest::render::Shading::default()
    }
}

/// The demo's view: from the south-south-west, 25 degrees up.
const FROM_SSW: DVec3 = DVec3::new(-0.35, 0.42, 0.84);
/// A low eye, 10 degrees up (the height of the bake's lowest views), from the east, 35 degrees
/// from the nearest of their azimuths.
const FROM_LOW: DVec3 = DVec3::new(0.951, 0.174, 0.255);
/// A higher eye from another side, 51 degrees up: between the bake's views (10, 35 and 60).
const FROM_HIGH: DVec3 = DVec3::new(0.6, 0.9, 0.4);

impl LoneTree {
    fn new(tree: &str) -> LoneTree {
        let model = import::load(&fixture(tree)).unwrap();
        let texel = bake::bake(&model.mesh, &BakeSettings::default()).unwrap();
        let foliage = bake::foliage_triangles(&model.mesh, &texel.info.parameters).unwrap();
        LoneTree {
            name: tree.to_string(),
            model,
            texel,
            foliage,
            leaf_albedo: glam::Vec3::new(0.05, 0.12, 0.04),
        }
    }

    /// The same tree with black wood, in the texture and in the mesh: only its leaves give
    /// light (the wood still hides and shadows them).
    fn with_black_wood(mut self) -> LoneTree {
        for l in &mut self.texel.levels {
            l.albedo[0].fill([0.0; 3]);
        }
        let mut wood_only = vec![true; self.model.mesh.materials.len()];
        for (t, tri) in self.model.mesh.triangles.iter().enumerate() {
            if self.foliage[t] {
                wood_only[tri.material as usize] = false;
            }
        }
        for (m, wood) in self.model.mesh.materials.iter_mut().zip(wood_only) {
            if wood {
                m.base_color = glam::Vec4::new(0.0, 0.0, 0.0, m.base_color.w);
            }
        }
        self
    }

    /// The same tree with black leaves, in both methods: only its wood gives light (the leaves
    /// still hide and shadow it).
    fn with_black_leaves(mut self) -> LoneTree {
        self.leaf_albedo = glam::Vec3::ZERO;
        self
    }

    /// The frame's sum per channel (R, G, B, A) by `method` at `spp`, the texture read
    /// `lod_bias` levels coarser than the finest.
    fn sums(&self, light: Light, method: Method, spp: u32, lod_bias: f32) -> [f64; 4] {
        self.sums_beside(light, method, spp, lod_bias, &[])
    }

    /// [`LoneTree::sums`] with copies of the tree (turned a quarter, their leaves black: they
    /// hide and shadow it, and give no light) standing `neighbours` crown widths from it
    /// towards the sun's azimuth.
    fn sums_beside(
        &self,
        light: Light,
        method: Method,
        spp: u32,
        lod_bias: f32,
        neighbours: &[f64],
    ) -> [f64; 4] {
        use texel_forest::render::scene::TreeMesh;
        use texel_forest::render::{
            Camera, Lighting, Look, March, Placed, RenderSettings, Scene, Sun, render,
        };
        let info = &self.texel.info;
        let height = info.model_max[1] - info.model_min[1];
        let centre = DVec3::new(0.0, 0.5 * height, 0.0);
        let width = info.model_max[0] - info.model_min[0];
        let to_eye = light.eye.normalize();
        let across = to_eye.cross(DVec3::Y).normalize();
        let to_sun = glam::DQuat::from_axis_angle(to_eye, light.turn.to_radians())
            * glam::DQuat::from_axis_angle(across, light.g.to_radians())
            * to_eye;
        assert!(to_sun.y > 0.0, "the sun above the horizon");
        let mut scene = Scene::new(
            centre + to_eye * 4.0 * height,
            vec![self.texel.clone()],
            // The neighbours' leaves black: they hide and shadow, and give no light.
            vec![
                Look {
                    texel: 0,
                    foliage: 1.0,
                    foliage_albedo: self.leaf_albedo,
                },
                Look {
                    texel: 0,
                    foliage: 1.0,
                    foliage_albedo: glam::Vec3::ZERO,
                },
            ],
            &std::iter::once((0, 0.0, 0.0))
                .chain(
                    neighbours
                        .iter()
                        .map(|&d| (1, d, std::f32::consts::FRAC_PI_2)),
                )
                .map(|(look, d, rotation)| Placed {
                    look,
                    position: DVec3::new(to_sun.x, 0.0, to_sun.z).normalize_or_zero() * d * width,
                    rotation,
                    scale: 1.0,
                })
                .collect::<Vec<_>>(),
            None,
            Lighting {
                sun: Sun {
                    direction: to_sun.as_vec3(),
                    irradiance: std::f32::consts::PI,
                },
                shading: light.shading,
                sky: None,
            },
        )
        .with_meshes(vec![TreeMesh::new(
            self.model.mesh.clone(),
            self.foliage.clone(),
        )]);
        scene.shadows = light.shadows;
        let camera = Camera::look_at(scene.origin, centre, 18.0, 96, 96).unwrap();
        let film = render(
            &scene,
            &camera,
            &RenderSettings {
                method,
                spp,
                march: March {
                    lod_bias,
                    shadows: light.rays,
                    ..March::default()
                },
                ..RenderSettings::default()
            },
            &|_| {},
        );
        // Over the whole frame: the tree's light, whatever its silhouette's blur.
        std::array::from_fn(|c| film.rgba.iter().map(|p| f64::from(p[c])).sum::<f64>())
    }
}

/// Texel over mesh radiance summed over the frame, per colour channel and for alpha, of a lone
/// tree under `light`, the texture read `lod_bias` levels coarser than the finest.
fn tree_radiance_ratio(tree: &LoneTree, light: Light, lod_bias: f32) -> [f64; 4] {
    let texel = tree.sums(light, Method::Texel, 16, lod_bias);
    let mesh = tree.sums(light, Method::Mesh, 64, 0.0);
    std::array::from_fn(|c| texel[c] / mesh[c])
}

/// The foliage shades as a cloud of leaves, shows as much wood and shadows itself as the mesh
/// does, and the wood shades as the surfaces its cells hold, near the hot spot and away from
/// it: at the finest level a lone tree's light (the frame's sum, per channel) is within 12 %
/// of the mesh method's, and its light per unit of coverage within 10 % (the coverage from one
/// view is the silhouette's own error, 3-6 % here). With the gradient's normal,
/// independent-media shadows and wood shown by its extinction, the forest's trees were 9-15 %
/// darker and 9 % redder; the bare tree, its branches shaded on their density's gradient
/// (before texel 1.4), had 0.67 of the mesh's light with the sun 20 degrees from the eye.
///
/// A coarse level (level 2 of 6, read by a bias of 6 at 16 spp on this near tree: its
/// footprint is below a finest cell, 2^-4 of one) is held to 20 % and 15 %: there the wood lit
/// 60 degrees from the eye is too bright, the bare tree 1.111 (1.165 before the wood's
/// moments were mixed by the wood each cell holds, 1.096 when it was shaded on its gradient,
/// and 0.686 at 20 degrees), and the broadleaf 1.062 at 20 degrees (1.155 in texel 1.5, 1.12
/// before its leaves shadowed themselves by the sun's height). At level 0 the bare tree lit at 60
/// degrees reads 1.000 (1.073 before), at 20 degrees 0.954 (0.987). Texel 1.5 took these sums
/// further from 1 for the broadleaf at 20 degrees (1.057 to 1.090 at level 0) and the conifer
/// at 60 (0.971 to 0.953), though both parts of their light came nearer the mesh's: the share
/// of the leaves the sun reaches (next test) and the unshadowed leaves' light (0.87 to 0.93 of
/// the mesh's for the conifer at 60 degrees). The errors had cancelled. With texel 1.6's rows
/// by the eye's height and the sun's turn, 1.010 and 0.962 (level 2: 1.062 and 0.945); with
/// stop 54's fit, 1.007 and 0.957 (1.055 and 0.935); with level 0 fitted ray by ray
/// (`bake::refine`, stop 55), 1.002 and 0.962 (1.048 and 0.930), the bare tree at 60 degrees
/// 1.009 (1.103). Since a point weighs its cells' chances of showing wood by their extinction
/// (stop 59; the next test), the broadleaf at 20 degrees reads R / G / B 0.954 / 1.018 / 0.994
/// at level 0 and 1.024 / 1.049 / 1.039 at level 2; since each part's extinction along a view
/// turns with its surfaces (stop 60, `each_part_of_a_lone_tree_shows_as_much_as_its_meshs_part`),
/// 0.972 / 1.005 / 0.993 and 1.042 / 1.027 / 1.033.
#[test]
fn a_lone_tree_is_as_bright_as_its_mesh_at_every_level_and_sun() {
    for tree in [
        "trees/conifer.glb",
        "trees/broadleaf.gltf",
        "trees/bare.glb",
    ] {
        let tree = LoneTree::new(tree);
        let name = &tree.name;
        for g in [20.0, 60.0] {
            let sun = Light {
                eye: FROM_SSW,
                g,
                turn: 0.0,
                shadows: true,
                rays: ShadowRays::Exact,
                shading: texel_forest::render::Shading::default(),
            };
            for (lod_bias, light, shading) in [(0.0, 0.12, 0.1), (6.0, 0.2, 0.15)] {
                let r = tree_radiance_ratio(&tree, sun, lod_bias);
                println!(
                    "{name:<22} sun {g:>2} degrees from the eye, level +{lod_bias}: texel / mesh R {:.3} G {:.3} B {:.3} A {:.3}",
                    r[0], r[1], r[2], r[3]
                );
                for c in 0..3 {
                    assert!((r[c] - 1.0).abs() < light, "{name} {g} {lod_bias}: {r:?}");
                    let per_coverage = r[c] / r[3];
                    assert!(
                        (per_coverage - 1.0).abs() < shading,
                        "{name} {g} {lod_bias}: {r:?}"
                    );
                }
            }
        }
    }
}

/// A lone tree shows its wood as its mesh does on every level: the hue of its unshadowed light
/// (red over green and blue over green, the frame's sums; the wood is brown, the leaves
/// green), texel over mesh, levels 0 to 3, sun 30 degrees from the eye. A cell's chance of
/// showing wood (`formats/texel.md`, *Wood shown per cell*) is its own; a sample between cells
/// weighs their chances by the extinction each gives it. Interpolating the shown wood itself
/// let a trunk's cell lend its weight (up to 64) to the leafy cells around it: the broadleaf's
/// red over green read 0.953 / 0.964 / 1.022 / **1.141** of its mesh's on levels 0-3 (blue
/// over green up to 1.052); so weighted 0.953 / 0.959 / 0.975 / 0.983 (0.994). The conifer,
/// whose trunk hides in its cells, 0.99-1.00 either way. Level 0's 5 % was the wood a crown's
/// leaves hid from the side (`each_part_of_a_lone_tree_shows_as_much_as_its_meshs_part`):
/// with each part's extinction turned by its surfaces (stop 60), 0.979 / 0.986 / 1.008 /
/// 1.022.
#[test]
fn a_lone_tree_shows_as_much_wood_as_its_mesh_on_every_level() {
    for tree in ["trees/conifer.glb", "trees/broadleaf.gltf"] {
        let tree = LoneTree::new(tree);
        let name = &tree.name;
        let light = Light {
            eye: FROM_SSW,
            g: 30.0,
            turn: 0.0,
            shadows: false,
            rays: ShadowRays::Exact,
            shading: texel_forest::render::Shading::default(),
        };
        let mesh = tree.sums(light, Method::Mesh, 64, 0.0);
        let hue = |s: [f64; 4]| [s[0] / s[1], s[2] / s[1]];
        for level in 0..4 {
            // The footprint here is 2^-4 of a finest cell (see the test above).
            let texel = tree.sums(light, Method::Texel, 16, 4.0 + level as f32);
            let [red, blue] = [0, 1].map(|c| hue(texel)[c] / hue(mesh)[c]);
            println!(
                "{name:<22} level {level}: hue texel / mesh, R/G {red:.3} B/G {blue:.3}, G {:.3}",
                texel[1] / mesh[1]
            );
            assert!((red - 1.0).abs() < 0.06, "{name} level {level}: R/G {red}");
            assert!(
                (blue - 1.0).abs() < 0.06,
                "{name} level {level}: B/G {blue}"
            );
        }
    }
}

/// The share of a lone tree's leaf light that its own crown lets the sun reach, through the
/// texture against through the mesh: shadowed over unshadowed green by the texel method, over
/// the same by the mesh method, with black wood and no ambient or highlight, so that only the
/// leaves' sunlit Lambert term counts. The self-shadowing factors are fitted to this; they
/// depend on the eye's height and on the sun's turn about the eye's line of sight as well as on
/// its angle from the eye (texel 1.6). Two trees, the sun 20 and 60 degrees from the eye, at
/// the finest level and a coarse one, seen from the demo's eye (25 degrees up) with the sun
/// above its line of sight (45 and 85 degrees high) and beside it (23 and 12), and from a
/// higher eye (51 degrees up, between the table's) with the sun above it (over the top at 60
/// degrees) and turned 45 and 135 degrees: 40 cases. Measured: mean distance from the mesh's
/// share 0.037 over the first 16 (0.086 by the sun's height alone, texel 1.5; 0.113 with one
/// row for every sun, 1.2) and 0.055 over the other 24 (1.5: 0.082); 0.034 over the 40 since
/// stop 54's fit (0.048 before), 0.031 since level 0 is fitted ray by ray (`bake::refine`,
/// stop 55). The largest, 1.22, is the conifer's coarse level under a sun over the top of it
/// (1.24 before stop 55, 1.36 before stop 54, 1.42 in 1.5). And from a low eye (10 degrees up,
/// the bake's lowest views' height, between their azimuths) with the sun turned 45 and 90
/// degrees, apart: 0.036 over 16 cases (0.042 before stop 54; the same before stop 55).
#[test]
fn a_lone_trees_own_shadow_lets_through_as_much_sun_as_its_meshs() {
    let shading = sunlit_lambert_only();
    // The demo's eye with the sun above and beside its line of sight, and a higher eye with
    // the sun at turns between the table's.
    let views = [
        (FROM_SSW, &[0.0, 90.0][..]),
        (FROM_HIGH, &[0.0, 45.0, 135.0][..]),
        (FROM_LOW, &[45.0, 90.0][..]),
    ];
    let mut distances = Vec::new();
    let mut low = Vec::new();
    for tree in ["trees/conifer.glb", "trees/broadleaf.gltf"] {
        let tree = LoneTree::new(tree).with_black_wood();
        for (eye, turns) in views {
            for g in [20.0, 60.0] {
                for &turn in turns {
                    let light = |shadows| Light {
                        eye,
                        g,
                        turn,
                        shadows,
                        rays: ShadowRays::Exact,
                        shading,
                    };
                    let lit = |method, spp, lod_bias| {
                        tree.sums(light(true), method, spp, lod_bias)[1]
                            / tree.sums(light(false), method, spp, lod_bias)[1]
                    };
                    let mesh = lit(Method::Mesh, 64, 0.0);
                    for lod_bias in [0.0, 6.0] {
                        let share = lit(Method::Texel, 16, lod_bias) / mesh;
                        println!(
                            "{:<22} eye {:>2.0} degrees high, sun {g:>2} degrees from it, turned {turn:>3}, level +{lod_bias}: sunlit share texel / mesh {share:.3}",
                            tree.name,
                            eye.normalize().y.asin().to_degrees(),
                        );
                        assert!((share - 1.0).abs() < 0.4, "{}: {share}", tree.name);
                        if eye == FROM_LOW {
                            low.push((share - 1.0).abs());
                        } else {
                            distances.push((share - 1.0).abs());
                        }
                    }
                }
            }
        }
    }
    let mean = distances.iter().sum::<f64>() / distances.len() as f64;
    println!("mean distance from the mesh's sunlit share: {mean:.3}");
    assert!(mean < 0.05, "{mean}");
    let low = low.iter().sum::<f64>() / low.len() as f64;
    println!("from the low eye: {low:.3}");
    assert!(low < 0.06, "{low}");
}

/// The cached shadow rays (`--shadows cached`, the product's default) let as much sun through
/// a lone tree and its neighbour as the exact march the self-shadowing fit models: the
/// texture's sunlit share of the frame's green (black wood, no ambient or highlight), cached
/// over exact, from the demo's eye and the low one. The cache's grid reads a depth between
/// columns a cell apart; a seen leaf's shadow ray runs through the gaps the eye sees by, and
/// the grid's lookup read it as deep as its neighbours': before the first cells of the own
/// tree were marched, the leaf-card tree read 0.87-0.90, the fixtures 0.95-0.99 (mean
/// distance 0.058, largest 0.128); then 0.98-1.00 (0.009-0.010, 0.018-0.019), beyond the
/// marched cells the grid's interpolated depth darkening the light on a sharp field; read by
/// transmittance where the columns drift across the cells, 0.99-1.01 (0.006, 0.010: README,
/// *The own tree's shadow near the leaf, marched*, *The sun-depth grid read by
/// transmittance*). The exact march's noise brightens exp(-depth) a little: what is left.
#[test]
fn cached_shadow_rays_let_through_as_much_sun_as_the_exact_march() {
    let shading = sunlit_lambert_only();
    let mut trees = vec![
        fixture("trees/conifer.glb"),
        fixture("trees/broadleaf.gltf"),
    ];
    // The leaf-card tree whose shadows the cache read darkest, where ../shared is present.
    trees.extend(
        texel_forest::corpus::real_trees()
            .unwrap_or_default()
            .into_iter()
            .filter(|p| p.file_stem().is_some_and(|s| s == "CommonTree_1")),
    );
    let mut distances = Vec::new();
    for path in trees {
        let tree = LoneTree::new(&path.to_string_lossy()).with_black_wood();
        for (eye, g, turn, neighbours) in [
            (FROM_SSW, 20.0, 60.0, &[][..]),
            (FROM_SSW, 60.0, 90.0, &[]),
            (FROM_SSW, 20.0, 0.0, &[]),
            (FROM_LOW, 60.0, 90.0, &[]),
            (FROM_SSW, 20.0, 60.0, &[0.7]),
        ] {
            let green = |rays| {
                let light = Light {
                    eye,
                    g,
                    turn,
                    shadows: true,
                    rays,
                    shading,
                };
                tree.sums_beside(light, Method::Texel, 32, 0.0, neighbours)[1]
            };
            let ratio = green(ShadowRays::Cached) / green(ShadowRays::Exact);
            println!(
                "{:<22} eye {:>2.0} degrees high, sun {g:>2} degrees from it, turned {turn:>2}, {} neighbour: sunlit share cached / exact {ratio:.3}",
                path.file_name().unwrap_or_default().to_string_lossy(),
                eye.normalize().y.asin().to_degrees(),
                neighbours.len()
            );
            distances.push((ratio - 1.0).abs());
        }
    }
    let worst = distances.iter().fold(0.0f64, |m, &d| m.max(d));
    let mean = distances.iter().sum::<f64>() / distances.len() as f64;
    println!("distance from the exact march: mean {mean:.3}, largest {worst:.3}");
    assert!(
        mean < 0.008 && worst < 0.015,
        "mean {mean}, largest {worst}"
    );
}

/// A neighbour's shadow on a tree, through the textures against through the meshes: the
/// share of the tree's leaf light the sun reaches (as in the test above, black wood, no ambient
/// or highlight) with a copy of the tree, turned a quarter, 0.7 crown widths from it towards
/// the sun, whose leaves are black (it hides and shadows the tree, and gives no light), with
/// exact shadow rays. The renderer crosses the neighbour as an independent medium (factor
/// one). Measured, against the tree alone: with the sun 20 degrees from the demo's eye, turned 60
/// (as the demo's sun is), the conifer reads 1.136 (alone 1.014), the broadleaf 1.022 (1.022);
/// with the sun 60 degrees from the eye, beside its line of sight, 1.162 (0.987) and 0.945
/// (0.998); mean distance 0.094. Before level 0 was fitted ray by ray (`bake::refine`, stop
/// 55): 1.185, 1.011, 1.207 and 0.924, mean 0.120: the fringe the interpolation blurs around
/// the crown's dense columns was paid for by a core that let through too much (rays past the
/// conifer's upper axis 43 % where the mesh lets through 30 %; 35 % with the fit). What is
/// left is mostly the conifer's core (a single isotropic field cannot hold the trunk's and
/// whorls' opacity along every direction at once).
#[test]
fn a_neighbours_shadow_lets_through_as_much_sun_as_its_meshs() {
    let shading = sunlit_lambert_only();
    let mut distances = Vec::new();
    for tree in ["trees/conifer.glb", "trees/broadleaf.gltf"] {
        let tree = LoneTree::new(tree).with_black_wood();
        for (g, turn) in [(20.0, 60.0), (60.0, 90.0)] {
            let light = |shadows| Light {
                eye: FROM_SSW,
                g,
                turn,
                shadows,
                rays: ShadowRays::Exact,
                shading,
            };
            // The sunlit share of the frame's green, with the neighbour and without.
            let share = |method, spp| {
                let green = |shadows, neighbours: &[f64]| {
                    tree.sums_beside(light(shadows), method, spp, 0.0, neighbours)[1]
                };
                [
                    green(true, &[0.7]) / green(false, &[0.7]),
                    green(true, &[]) / green(false, &[]),
                ]
            };
            let (texel, mesh) = (share(Method::Texel, 16), share(Method::Mesh, 64));
            let (pair, alone) = (texel[0] / mesh[0], texel[1] / mesh[1]);
            println!(
                "{:<22} sun {g:>2} degrees from the eye, turned {turn:>2}: sunlit share texel / mesh {pair:.3} with the neighbour, {alone:.3} alone",
                tree.name
            );
            assert!((pair - 1.0).abs() < 0.25, "{}: {pair}", tree.name);
            distances.push((pair - 1.0).abs());
        }
    }
    let mean = distances.iter().sum::<f64>() / distances.len() as f64;
    println!("mean distance from the meshes' sunlit share: {mean:.3}");
    assert!(mean < 0.12, "{mean}");
}

/// Two trees whose crowns overlap, as a forest's neighbours do. The renderer sums their
/// extinctions and so multiplies their transmittances: it treats them as independent media
/// (Vicini et al. 2021 on the error this makes where media are correlated). Measured per view,
/// on the meshes alone: how far the pair's transmittance per cell-sized pixel is from the
/// product of each tree's (the error independence makes, whatever the texture); printed next
/// to the texture pair's coverage error against the mesh pair's, and one tree's. Measured
/// (conifer and broadleaf, 0.5 to 1 crown apart, the second turned 90°): under 1 % of the
/// pair's coverage (mostly under 0.3 %) wherever the crowns are not exactly in line; +5.9 %
/// for two identical cones exactly in line with the eye, whose silhouettes' edges coincide
/// cell for cell (a forest's varied heights and positions make that case rare). Next to the
/// other parts of the error budget it does not matter.
#[test]
fn overlapping_trees_block_as_independent_media() {
    use texel_forest::geom::Ray;
    for tree in ["trees/conifer.glb", "trees/broadleaf.gltf"] {
        let model = import::load(&fixture(tree)).unwrap();
        let texel = bake::bake(&model.mesh, &BakeSettings::default()).unwrap();
        let one = Frame::of(&texel);
        let c = (one.lo + one.hi) * 0.5;
        let width = one.hi.x - one.lo.x;
        // The second tree turned a quarter about the vertical through the box's centre.
        let turn = |v: DVec3| DVec3::new(v.z, v.y, -v.x);
        let unturn = |v: DVec3| DVec3::new(-v.z, v.y, v.x);
        for (apart, aside) in [(0.5, 0.0), (0.5, 0.3), (1.0, 0.3), (0.75, 0.6)] {
            let offset = DVec3::new(apart * width, 0.0, aside * width);
            let mut second = model.mesh.clone();
            for p in &mut second.positions {
                *p = (c + turn(p.as_dvec3() - c) + offset).as_vec3();
            }
            let mut pair = model.mesh.clone();
            let base = pair.positions.len() as u32;
            pair.positions.extend(&second.positions);
            pair.uvs.extend(&second.uvs);
            pair.colors.extend(&second.colors);
            pair.triangles
                .extend(second.triangles.iter().map(|t| import::Triangle {
                    vertices: t.vertices.map(|v| v + base),
                    ..*t
                }));
            let (first, second, both) = (
                MeshTracer::new(&model.mesh),
                MeshTracer::new(&second),
                MeshTracer::new(&pair),
            );
            let frame = Frame {
                lo: one.lo.min(one.lo + offset),
                hi: one.hi.max(one.hi + offset),
                pixel: one.pixel,
            };
            let facing = PartFacing::of(&texel.levels[0]);
            let extinction = |p: DVec3, d: DVec3| {
                let q = c + unturn(p - offset - c);
                (texel.extinction(0, &facing, p, d) + texel.extinction(0, &facing, q, unturn(d)))
                    as f64
            };
            for d in [DVec3::X, DVec3::new(1.0, 0.3, 0.6).normalize()] {
                // Independence, on the meshes alone: per pixel, the mean of "passes both"
                // against the product of the means.
                let (e1, e2) = (
                    d.cross(if d.y.abs() < 0.9 { DVec3::Y } else { DVec3::X })
                        .normalize(),
                    d,
                );
                let e2 = e2.cross(e1);
                let radius = (frame.hi - frame.lo).length() * 0.5;
                let centre = (frame.lo + frame.hi) * 0.5;
                let n = (2.0 * radius / frame.pixel).ceil() as i64;
                let k = 4;
                let (mut gap, mut covered) = (0.0, 0.0);
                for pa in -n / 2..n / 2 {
                    for pb in -n / 2..n / 2 {
                        let (mut p1, mut p2, mut p12) = (0.0, 0.0, 0.0);
                        for s in 0..k * k {
                            let a = (pa as f64 + ((s % k) as f64 + 0.5) / k as f64) * frame.pixel;
                            let b = (pb as f64 + ((s / k) as f64 + 0.5) / k as f64) * frame.pixel;
                            let ray = Ray {
                                origin: (centre + e1 * a + e2 * b - d * (radius + 1.0)).as_vec3(),
                                dir: d.as_vec3(),
                            };
                            let key = (pa * 7919 + pb * 104_729 + s) as u64;
                            let pass1 = !first.occluded(&ray, 0.0, f32::INFINITY, key);
                            let pass2 = !second.occluded(&ray, 0.0, f32::INFINITY, key);
                            p1 += f64::from(u8::from(pass1));
                            p2 += f64::from(u8::from(pass2));
                            p12 += f64::from(u8::from(pass1 && pass2));
                        }
                        let m = (k * k) as f64;
                        gap += p12 / m - (p1 / m) * (p2 / m);
                        covered += 1.0 - p12 / m;
                    }
                }
                let independence = gap / covered;
                let paired = compare(&both, frame, d, 4, &extinction).coverage_error();
                let single = compare(&first, one, d, 4, &|p, d| {
                    texel.extinction(0, &facing, p, d) as f64
                })
                .coverage_error();
                println!(
                    "{tree:<22} {apart:.2} crowns apart, {aside:.1} aside, view {:+.2?}: independence off by {independence:+.4} of the pair's coverage; coverage error pair {paired:+.4}, one tree {single:+.4}",
                    d.to_array()
                );
                // Exactly in line (the same cone twice, one behind the other) is the worst
                // case, printed; anything else is a forest's case.
                if aside > 0.0 {
                    assert!(
                        independence.abs() < 0.01,
                        "{tree} {apart} {aside} {d}: {independence}"
                    );
                }
            }
        }
    }
}

/// Each part of a lone tree shows as much of itself as the mesh's: the frame's light from the
/// wood alone (black leaves, which still hide it) and from the leaves alone (black wood), lit
/// by the sky alone, so that only what shows counts, texel over mesh, from three heights of
/// the eye (10, 25 and 51 degrees up), at the finest level and a coarse one.
///
/// With both parts' extinction turned alike by the level's directional form, the broadleaf's
/// wood read 0.66 / 0.79 / 1.16 of its mesh's at level 0 from 10 / 25 / 51 degrees up (level 2:
/// 0.68 / 0.89 / 1.34) and its leaves 1.17 / 1.08 / 0.96: its leaf cards lie flatter than its
/// branches stand, so from the side the mesh's leaves hide less of the crown's inside than the
/// texture's did. Since each part's extinction along a view follows its surfaces' projected
/// area (`volume::PartFacing`, stop 60), 0.88 / 0.91 / 0.97 (level 2: 0.91 / 1.01 / 1.13), the
/// leaves 1.11 / 1.05 / 0.98. The bake then fitted the level's directional form to a texture
/// whose parts turned alike, and the crown, as drawn, blocked 3-5 % more of the view from the
/// side than its mesh (`the_texture_casts_the_mesh_silhouette_...`); fitted as drawn (stop
/// 61), the leaves read 1.07 / 1.04 / 0.98 and the wood 0.84 / 0.89 / 0.98 (level 2: 0.90 /
/// 1.01 / 1.12): what the too-wide crown hid is the wood's share from the side, 0.79 of its
/// mesh's from 10 degrees up. The conifer's wood from 51 degrees up, 1.23 at level 0 and 1.32
/// at level 2 (1.30 and 1.39 before stop 60), is the rest: seen from above, its texture shows
/// more of its trunk through the crown than the mesh does (README, *The wood a crown shows,
/// by the eye's height*, and *Each part as drawn, in the bake's fits*).
#[test]
fn each_part_of_a_lone_tree_shows_as_much_as_its_meshs_part() {
    // The sun a thousandth of the sky's light: what shows, by its albedo.
    let sky = texel_forest::render::Shading {
        kd: 1.0,
        ks: 0.0,
        ambient: 1000.0,
        ..texel_forest::render::Shading::default()
    };
    for (tree, bounds) in [
        ("trees/conifer.glb", [0.35, 0.08]),
        ("trees/broadleaf.gltf", [0.18, 0.08]),
    ] {
        let baked = LoneTree::new(tree);
        for (part, bound) in ["wood", "leaves"].into_iter().zip(bounds) {
            let lone = if part == "wood" {
                baked.clone().with_black_leaves()
            } else {
                baked.clone().with_black_wood()
            };
            for (height, eye) in [(10, FROM_LOW), (25, FROM_SSW), (51, FROM_HIGH)] {
                let light = Light {
                    eye,
                    g: 30.0,
                    turn: 0.0,
                    shadows: false,
                    rays: ShadowRays::Exact,
                    shading: sky,
                };
                let mesh = lone.sums(light, Method::Mesh, 64, 0.0);
                for level in [0, 2] {
                    // The footprint here is 2^-4 of a finest cell.
                    let texel = lone.sums(light, Method::Texel, 16, 4.0 + level as f32);
                    // Green holds most of the leaves' light, red the bark's.
                    let c = usize::from(part == "leaves");
                    let ratio = texel[c] / mesh[c];
                    println!(
                        "{tree:<22} {part:<6} eye {height} degrees up, level {level}: texel / mesh {ratio:.3} (coverage {:.3})",
                        texel[3] / mesh[3]
                    );
                    assert!(
                        (ratio - 1.0).abs() < bound,
                        "{tree} {part}, eye {height} degrees up, level {level}: {ratio}"
                    );
                }
            }
        }
    }
}
