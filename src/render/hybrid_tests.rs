//! The hybrid method: each regime gives its pure method's image, the transition band gives the
//! blend in expectation, textures composite over meshes in depth order, and a tree drawn from
//! its model is never darkened by its own texture.

use glam::{DVec3, Vec3};

use super::integrate;
use super::lod::{Draw, Lod};
use super::mesh_tests::{SQUARE, cuboid, material, quads};
use super::scene::{Lighting, Look, Placed, Scene, Shading, Sun, TreeMesh};
use super::tests::{HEAD_ON, PLAIN, ground, look, placed, uniform_texel};
use super::walk::March;
use super::{Camera, Edges, Film, Method, RenderSettings, draws_models, render};
use crate::bake::{self, BakeSettings};
use crate::import::{AlphaMode, Mesh};
use crate::rng::{self, purpose};

/// An opaque box 2 m across standing on the origin, its mesh and its texture baked from it.
pub(super) fn boxed_tree() -> (crate::volume::Texel, TreeMesh) {
    let faces = cuboid(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0));
    let model = bark(&faces, 0.5);
    let texel = bake::bake(
        &model,
        &BakeSettings {
            resolution: 16,
            fine: 64,
            ..BakeSettings::default()
        },
    )
    .unwrap();
    let n = model.triangles.len();
    (texel, TreeMesh::new(model, vec![false; n]))
}

/// Opaque quads of grey `albedo`.
fn bark(faces: &[[Vec3; 4]], albedo: f32) -> Mesh {
    quads(faces, material("bark", albedo, 1.0, AlphaMode::Opaque))
}

fn lone_tree_scene(eye: DVec3, sun: Sun) -> Scene {
    let (texel, mesh) = boxed_tree();
    lone_tree_without_model(eye, sun, texel).with_meshes(vec![mesh])
}

/// [`lone_tree_scene`] without the tree's model, as a render that reads none builds it.
fn lone_tree_without_model(eye: DVec3, sun: Sun, texel: crate::volume::Texel) -> Scene {
    Scene::new(
        eye,
        vec![texel],
        vec![look()],
        &[placed(DVec3::ZERO)],
        Some(ground(0.0, 40.0, 0.3)),
        Lighting {
            sun,
            shading: Shading::default(),
            sky: None,
        },
    )
}

fn image(scene: &Scene, camera: &Camera, method: Method, lod: Lod, spp: u32) -> Film {
    render(
        scene,
        camera,
        &RenderSettings {
            method,
            spp,
            lod,
            ..RenderSettings::default()
        },
        &|_| {},
    )
}

fn bits(f: &Film) -> Vec<[u32; 4]> {
    f.rgba.iter().map(|p| p.map(f32::to_bits)).collect()
}

/// The switch is the one given up to 4 samples per pixel and grows with the square of the
/// count over 4 beyond, the band unchanged: a lone tree whose samples' footprint keeps it a
/// texture at 1 and 4 spp is drawn from its model at 8 and 16.
#[test]
fn past_four_samples_a_pixel_the_switch_grows() {
    let lod = Lod {
        switch: 1.5,
        band: 0.5,
    };
    for spp in [1, 2, 4] {
        assert_eq!(lod.for_samples(spp), lod);
    }
    assert_eq!(lod.for_samples(8).switch, 6.0);
    assert_eq!(lod.for_samples(16).switch, 24.0);
    assert_eq!(lod.for_samples(16).band, 0.5);

    let target = DVec3::new(0.0, 1.0, 0.0);
    let distance = 20.0;
    let eye = DVec3::new(0.4, 1.3, 1.0).normalize() * distance + target;
    let scene = lone_tree_scene(eye, HEAD_ON);
    // Half a metre a pixel: four of the box's 1/8 m cells, two at 4 spp, 1.4 at 8.
    let fov = (16.0f64 / 2.0 / distance).atan().to_degrees() * 2.0;
    let camera = Camera::look_at(eye, target, fov, 32, 32).unwrap();
    for (spp, models) in [(1, false), (4, false), (8, true), (16, true)] {
        let settings = RenderSettings {
            method: Method::Hybrid,
            spp,
            ..RenderSettings::default()
        };
        assert_eq!(
            draws_models(&scene, &camera, &settings),
            models,
            "{spp} spp"
        );
    }
}

/// A frame needs the tree models only where it draws one: a hybrid frame whose samples'
/// footprint makes the lone tree a texture does not, and renders without the model the same
/// bits as with it; one whose footprint makes it a model does, as does the mesh method
/// always and the texel method never; and a frame whose own samples draw no model needs them
/// where its edges' finer samples would (`--edge-spp`).
#[test]
fn a_frame_needs_the_models_only_where_it_draws_one() {
    let target = DVec3::new(0.0, 1.0, 0.0);
    let distance = 20.0;
    let eye = DVec3::new(0.4, 1.3, 1.0).normalize() * distance + target;
    let scene = lone_tree_scene(eye, HEAD_ON);
    let camera = |across: f64| {
        let fov = (across / 2.0 / distance).atan().to_degrees() * 2.0;
        Camera::look_at(eye, target, fov, 32, 32).unwrap()
    };
    let settings = |method, spp, edges| RenderSettings {
        method,
        spp,
        edges,
        ..RenderSettings::default()
    };
    // 16 m across at 32 pixels: half a metre a pixel, four of the box's 1/8 m cells; 3 m: a
    // twelfth of a cell.
    let (far, near) = (camera(16.0), camera(3.0));
    let hybrid = settings(Method::Hybrid, 1, None);
    assert!(!draws_models(&scene, &far, &hybrid));
    assert!(draws_models(&scene, &near, &hybrid));
    assert!(draws_models(&scene, &far, &settings(Method::Mesh, 1, None)));
    assert!(!draws_models(
        &scene,
        &near,
        &settings(Method::Texel, 1, None)
    ));
    let edges = Some(Edges {
        spp: 64,
        contrast: 0.05,
        colour: true,
    });
    assert!(draws_models(
        &scene,
        &far,
        &settings(Method::Hybrid, 1, edges)
    ));

    let (texel, _) = boxed_tree();
    let without = lone_tree_without_model(eye, HEAD_ON, texel);
    let a = render(&without, &far, &hybrid, &|_| {});
    let b = render(&scene, &far, &hybrid, &|_| {});
    assert_eq!(bits(&a), bits(&b));
    assert!(
        a.canopy.iter().any(|&c| c > 0.5),
        "the tree is in the frame"
    );
}

/// A tree whose texture cells are well below a sample's footprint is drawn as its texture,
/// and one whose cells span several pixels as its mesh, each exactly as the pure method draws
/// it: the same samples, the same bits. The near one is lit head on (the sun behind the eye),
/// where its own texture, if the mesh's shadow rays crossed it, would darken its faces.
#[test]
fn a_tree_well_inside_each_regime_renders_as_the_pure_method() {
    let target = DVec3::new(0.0, 1.0, 0.0);
    let lod = Lod::default();
    let distance = 20.0;
    // Frames 16 m and 3 m across, 32 pixels: the box's 1/8 m cells against footprints of 1/4
    // and 3/64 m per sample (four samples a pixel).
    for (across, method, covered_at_least) in [(16.0, Method::Texel, 8), (3.0, Method::Mesh, 500)] {
        let eye = DVec3::new(0.4, 1.3, 1.0).normalize() * distance + target;
        let toward_eye = (eye - target).normalize().as_vec3();
        let sun = Sun {
            direction: toward_eye,
            ..HEAD_ON
        };
        let scene = lone_tree_scene(eye, sun);
        let width = 32;
        let fov = (across / 2.0 / distance).atan().to_degrees() * 2.0;
        let camera = Camera::look_at(eye, target, fov, width, width).unwrap();
        let spread = camera.pixel_angle() as f32 / 2.0;
        let p = Draw::texel_probability(&scene, &lod, spread, 0);
        assert_eq!(
            p,
            f32::from(u8::from(method == Method::Texel)),
            "{across} m"
        );
        let hybrid = image(&scene, &camera, Method::Hybrid, lod, 4);
        let pure = image(&scene, &camera, method, lod, 4);
        assert_eq!(bits(&hybrid), bits(&pure), "{method:?}");
        assert_eq!(hybrid.canopy, pure.canopy);
        // Outside the band no tree is drawn by chance.
        assert!(hybrid.band_canopy.iter().all(|&b| b == 0.0));
        let covered = pure.canopy.iter().filter(|&&c| c > 0.5).count();
        assert!(covered >= covered_at_least, "{method:?}: {covered} pixels");
        if method == Method::Mesh {
            // Lit head on, every face the eye sees is lit: none is black.
            let lit = hybrid
                .rgba
                .iter()
                .zip(&hybrid.canopy)
                .filter(|(p, c)| **c > 0.99 && p[1] > 0.05)
                .count();
            assert!(lit as f64 > 0.95 * covered as f64, "{lit} of {covered}");
        }
    }
}

/// Inside the band each tree is drawn one way or the other for the whole frame (and for
/// every frame of a sequence that shares the frame's `lod_seed`), the texture with the
/// probability `lod::Draw::texel_probability` gives: each frame is one of the pure frames, bit
/// for bit, and over seeds the expected frame is their blend.
#[test]
fn in_the_band_each_frame_draws_a_tree_one_way_and_the_seeds_blend_them() {
    // A texture and a model that look different: a grey cloud against a white slab.
    let cloud = uniform_texel([8, 8, 2], 0.5, DVec3::new(-2.0, -2.0, -0.5), 0.7, [0.2; 3]);
    let slab = bark(&[SQUARE.map(|p| p * 0.75)], 0.9);
    let eye = DVec3::new(0.0, 0.0, 200.0);
    let scene = Scene::new(
        eye,
        vec![cloud],
        vec![look()],
        &[placed(DVec3::ZERO)],
        None,
        Lighting {
            sun: HEAD_ON,
            shading: PLAIN,
            sky: None,
        },
    )
    .with_meshes(vec![TreeMesh::new(slab, vec![false; 2])]);
    let camera = Camera::look_at(eye, DVec3::ZERO, 1.5, 24, 24).unwrap();
    let spp = 64;
    let spread = camera.pixel_angle() as f32 / 8.0;
    // The switch where this tree's texture has probability about 0.3 in a band of two octaves
    // (its box, the union of its levels', is centred a little off the origin).
    let cells = 200.0 * spread / 0.5;
    let lod = Lod {
        switch: cells * 2f32.powf(0.2 * 2.0),
        band: 2.0,
    };
    let p = Draw::texel_probability(&scene, &lod, spread, 0);
    assert!((p - 0.3).abs() < 0.02, "{p}");
    // The switch to give for it at this many samples (a power of two off: exact).
    let given = Lod {
        switch: lod.switch / 256.0,
        ..lod
    };
    assert_eq!(given.for_samples(spp), lod);
    let pure = |method| {
        let f = image(&scene, &camera, method, lod, spp);
        (bits(&f), f)
    };
    let ((texel, texel_film), (mesh, _)) = (pure(Method::Texel), pure(Method::Mesh));
    assert_ne!(texel, mesh, "the two must differ");
    let mut drawn = [false; 2];
    for lod_seed in 0..8 {
        let hybrid = render(
            &scene,
            &camera,
            &RenderSettings {
                method: Method::Hybrid,
                spp,
                lod: given,
                lod_seed,
                ..RenderSettings::default()
            },
            &|_| {},
        );
        let key = rng::hash3(lod_seed, 0, purpose::LOD);
        let as_texture = Draw::hybrid(lod, spread, key).texel(&scene, 0);
        drawn[usize::from(as_texture)] = true;
        let expected = if as_texture { &texel } else { &mesh };
        assert!(bits(&hybrid) == *expected, "seed {lod_seed}");
        // The one tree is in the band: all of the canopy is the band's, however it was drawn.
        for (b, c) in hybrid.band_canopy.iter().zip(&hybrid.canopy) {
            assert!((b - c).abs() < 1e-5, "band {b} of canopy {c}");
        }
        assert!(hybrid.band_canopy.iter().any(|&b| b > 0.5));
    }
    assert_eq!(drawn, [true; 2], "these seeds draw the tree both ways");
    assert!(texel_film.band_canopy.iter().all(|&b| b == 0.0));
    // Over seeds the tree is a texture with probability p: the expected frame is the blend.
    // 40,000 draws: a standard deviation of 0.0023 in the fraction.
    let n = 40_000;
    let textures = (0..n)
        .filter(|&s| {
            let key = rng::hash3(s, 0, purpose::LOD);
            Draw::hybrid(lod, spread, key).texel(&scene, 0)
        })
        .count();
    let fraction = textures as f64 / n as f64;
    assert!(
        (fraction - f64::from(p)).abs() < 0.01,
        "{fraction} against {p}"
    );
}

/// A cloud of black texture (transmittance 1/2 through it) in front of an opaque white slab
/// drawn as a mesh, both lit head on: the slab is seen through the cloud and lit through it,
/// 0.6 x 1/2 x 1/2; the slab in front of the cloud hides it and is fully lit, and the ray never
/// marches the cloud behind it.
#[test]
fn textures_composite_over_meshes_in_depth_order() {
    let sigma = std::f32::consts::LN_2;
    // The cloud: 4 x 4 m, 1 m deep along z, fine cells; the slab's texture: empty, coarse.
    let cloud = uniform_texel(
        [16, 16, 4],
        0.25,
        DVec3::new(-2.0, -2.0, -0.5),
        sigma,
        [0.0; 3],
    );
    let slab_box = uniform_texel([2, 2, 1], 2.0, DVec3::new(-2.0, -2.0, -1.0), 0.0, [0.0; 3]);
    let slab = bark(&[SQUARE], 0.6);
    let looks = [0, 1].map(|texel| Look { texel, ..look() });
    // Off the slab's diagonal, which a ray exactly on it would meet on an edge.
    let eye = DVec3::new(0.3, 0.2, 10.0);
    let at = |cloud_z: f64| {
        let trees = [
            Placed {
                look: 0,
                ..placed(DVec3::new(0.0, 0.0, cloud_z))
            },
            Placed {
                look: 1,
                ..placed(DVec3::ZERO)
            },
        ];
        Scene::new(
            eye,
            vec![cloud.clone(), slab_box.clone()],
            looks.to_vec(),
            &trees,
            None,
            Lighting {
                sun: HEAD_ON,
                shading: PLAIN,
                sky: None,
            },
        )
        .with_meshes(vec![
            TreeMesh::new(Mesh::default(), vec![]),
            TreeMesh::new(slab.clone(), vec![false; 2]),
        ])
    };
    // Hard switch between the two: the cloud's cells are 8 times finer than the slab's.
    let spread = 0.01;
    let lod = Lod {
        switch: 0.12,
        band: 0.0,
    };
    let draw = Draw::hybrid(lod, spread, 1);
    let march = March {
        cutoff: 0.0,
        ..March::default()
    };
    let ray = |scene: &Scene| {
        let draw = Draw::hybrid(lod, spread, 1).simplified(scene);
        integrate::hybrid(scene, Vec3::NEG_Z, spread, 9, &march, draw)
    };
    let front = at(3.0);
    assert!(draw.texel(&front, 0) && !draw.texel(&front, 1));
    let r = ray(&front);
    assert!(
        (r.rgb - Vec3::splat(0.15)).abs().max_element() < 1e-4,
        "{r:?}"
    );
    assert_eq!((r.canopy, r.transmittance), (1.0, 0.0));
    assert!((r.mesh_canopy - 0.5).abs() < 1e-4, "{r:?}");
    // The cloud's samples cast shadow rays of their own (black, they add nothing).
    assert!(r.samples > 0 && r.shadow_rays >= 1);
    // Its box reaches 4 m towards the eye (its coarsest level's cell is 4 m deep).
    let behind = at(-5.0);
    assert!(draw.texel(&behind, 0) && !draw.texel(&behind, 1));
    let r = ray(&behind);
    assert!(
        (r.rgb - Vec3::splat(0.6)).abs().max_element() < 1e-5,
        "{r:?}"
    );
    assert_eq!((r.samples, r.mesh_canopy), (0, 1.0));
    assert!((r.distance - 10.0).abs() < 1e-4, "{r:?}");
}

/// The switch and band settings the horizon tests try: the defaults, a hard switch at coarse
/// footprints, and a wide band around a fine one.
const SETTINGS: [Lod; 3] = [
    Lod {
        switch: 1.0,
        band: 1.0,
    },
    Lod {
        switch: 4.0,
        band: 0.0,
    },
    Lod {
        switch: 0.5,
        band: 3.0,
    },
];

/// `trees` of the boxed tree, with its mesh, seen from `eye`, lit head on, on no terrain.
fn boxed_forest(eye: DVec3, trees: &[Placed]) -> Scene {
    let (texel, mesh) = boxed_tree();
    Scene::new(
        eye,
        vec![texel],
        vec![look()],
        trees,
        None,
        Lighting {
            sun: HEAD_ON,
            shading: Shading::default(),
            sky: None,
        },
    )
    .with_meshes(vec![mesh])
}

/// The hybrid method looks for the models' surfaces only up to the model horizon: every tree
/// it may draw as a model (texture probability below one) lies wholly within it, whatever
/// the tree's turn and scale, for footprints from fine to coarse and three bands; so the search
/// stopping there misses no surface. And the horizon is not a bound that never bites: at the
/// coarser footprints some trees lie beyond it.
#[test]
fn every_tree_drawn_as_a_model_lies_within_the_model_horizon() {
    let mut s = crate::rng::Stream::new(5, 0);
    let mut u = || s.unit();
    // Half the trees at the largest scale, whose cells set the horizon: those just inside it
    // reach furthest past it.
    let trees: Vec<Placed> = (0..300)
        .map(|k| Placed {
            look: 0,
            position: DVec3::new(u() * 400.0 - 200.0, u() * 10.0, u() * 400.0 - 200.0),
            rotation: (u() * std::f64::consts::TAU) as f32,
            scale: if k % 2 == 0 {
                3.3
            } else {
                (0.3 + u() * 3.0) as f32
            },
        })
        .collect();
    let scene = boxed_forest(DVec3::new(3.0, 4.0, -2.0), &trees);
    let mut beyond = 0;
    for spread in (0..40).map(|k| 1e-4f32 * 1.15f32.powi(k)) {
        for lod in SETTINGS {
            let draw = Draw::hybrid(lod, spread, 0);
            let horizon = draw.model_horizon(&scene);
            for i in 0..scene.instances.len() as u32 {
                let (centre, _) = scene.instances.centre_and_cell(i);
                if Draw::texel_probability(&scene, &lod, spread, i) >= 1.0 {
                    beyond += usize::from(centre.length() > horizon);
                    continue;
                }
                // Rays from the eye through the box, centre and scattered about it.
                for k in 0..16 {
                    let jitter = Vec3::new(u() as f32, u() as f32, u() as f32) - 0.5;
                    let aim = centre + jitter * if k == 0 { 0.0 } else { 6.0 };
                    let ray = crate::geom::Ray {
                        origin: Vec3::ZERO,
                        dir: aim.normalize(),
                    };
                    if let Some((_, exit)) = scene.instances.interval(i, &ray, f32::INFINITY) {
                        assert!(
                            exit <= horizon,
                            "tree {i} leaves at {exit}, horizon {horizon}"
                        );
                    }
                }
            }
        }
    }
    assert!(beyond > 1000, "{beyond}");
}

/// A sample whose model horizon lies nearer than every tree is drawn as the texture method
/// draws it (`Draw::simplified`), and one whose footprint is below every tree's band as the
/// mesh method draws it, and only then: every tree's texture probability is one, or zero,
/// there. All three cases occur over footprints from fine to coarse, so neither shortcut is
/// never taken nor taken where a tree could still be drawn the other way.
#[test]
fn a_sample_is_drawn_by_a_pure_method_only_where_every_tree_is_drawn_so() {
    // A ring of trees 60 to 300 m from the eye, large and small; the first at the largest
    // scale, whose cells set the horizon.
    let mut trees = ring_of_trees(8, 200, 60.0..300.0);
    trees[0].scale = 3.3;
    let scene = boxed_forest(DVec3::new(0.0, 5.0, 0.0), &trees);
    let (mut textures, mut models, mut hybrid) = (0, 0, 0);
    for spread in (0..60).map(|k| 1e-5f32 * 1.15f32.powi(k)) {
        for lod in SETTINGS {
            let every = match Draw::hybrid(lod, spread, 0).simplified(&scene) {
                Draw::Hybrid { .. } => {
                    hybrid += 1;
                    continue;
                }
                Draw::Texel => {
                    textures += 1;
                    1.0
                }
                Draw::Mesh => {
                    models += 1;
                    0.0
                }
            };
            for i in 0..scene.instances.len() as u32 {
                let p = Draw::texel_probability(&scene, &lod, spread, i);
                assert_eq!(p, every, "tree {i}, spread {spread}, {lod:?}");
            }
        }
    }
    assert!(
        textures > 10 && models > 10 && hybrid > 10,
        "{textures} textures, {models} models, {hybrid} hybrid"
    );
}

/// The frame's choices (`Scene::choose`) are the footprint rule's, tree by tree, in and out
/// of the band; and a drawing other than the one chosen for (another footprint, another key)
/// is still drawn by the rule, not by the table.
#[test]
fn a_frames_choices_are_the_footprint_rules() {
    let trees = ring_of_trees(11, 300, 10.0..310.0);
    let (mut texture, mut model, mut band, mut keys_differ) = (0, 0, 0, 0);
    for spread in (0..12).map(|k| 2e-4f32 * 1.5f32.powi(k)) {
        for lod in SETTINGS {
            let scene = boxed_forest(DVec3::new(0.0, 5.0, 0.0), &trees);
            let draw = Draw::hybrid(lod, spread, 7);
            let other = Draw::hybrid(lod, spread, 8);
            let rule = |d: &Draw| -> Vec<(bool, bool)> {
                (0..scene.instances.len() as u32)
                    .map(|i| (d.texel(&scene, i), d.in_band(&scene, i)))
                    .collect()
            };
            let (want, want_other) = (rule(&draw), rule(&other));
            keys_differ += want.iter().zip(&want_other).filter(|(a, b)| a != b).count();
            scene.choose(&draw);
            assert!(scene.choices.get().is_some());
            assert_eq!(rule(&draw), want, "spread {spread}, {lod:?}");
            assert_eq!(rule(&other), want_other, "spread {spread}, {lod:?}");
            for (t, b) in want {
                texture += usize::from(t);
                model += usize::from(!t);
                band += usize::from(b);
            }
        }
    }
    assert!(
        texture > 1000 && model > 1000 && band > 300,
        "{texture} {model} {band}"
    );
    // The other key draws some band trees the other way: a table read for it would show.
    assert!(keys_differ > 50, "{keys_differ}");
}

/// `count` boxed trees around the eye's foot, `distance` metres from it (uniformly), at any
/// turn, scales 0.3 to 3.3, drawn from stream `seed`.
fn ring_of_trees(seed: u64, count: usize, distance: std::ops::Range<f64>) -> Vec<Placed> {
    let mut s = crate::rng::Stream::new(seed, 0);
    let mut u = || s.unit();
    (0..count)
        .map(|_| {
            let r = distance.start + u() * (distance.end - distance.start);
            let a = u() * std::f64::consts::TAU;
            Placed {
                look: 0,
                position: DVec3::new(r * a.cos(), u() * 10.0, r * a.sin()),
                rotation: (u() * std::f64::consts::TAU) as f32,
                scale: (0.3 + u() * 3.0) as f32,
            }
        })
        .collect()
}
