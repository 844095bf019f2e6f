//! Mattes by object: with every method, a pixel's coverages add up to its alpha, a pixel's
//! objects are the trees that drew it, and recording them leaves the image's bits unchanged.

use glam::DVec3;

use super::hybrid_tests::boxed_tree;
use super::lod::Lod;
use super::matte::TERRAIN;
use super::scene::{Lighting, Scene, Shading, Sun};
use super::tests::{ground, look, placed};
use super::{Camera, Film, Method, RenderSettings, render};

/// Two box trees, the second behind the first and to the side, over a ground that does not
/// reach the top of the frame (the transparent sky shows there).
fn two_trees() -> (Scene, Camera) {
    let (texel, mesh) = boxed_tree();
    let eye = DVec3::new(0.5, 1.5, 9.0);
    let scene = Scene::new(
        eye,
        vec![texel],
        vec![look()],
        &[placed(DVec3::ZERO), placed(DVec3::new(1.2, 0.0, -2.5))],
        Some(ground(0.0, 6.0, 0.3)),
        Lighting {
            sun: Sun::from_angles(200.0, 40.0, std::f32::consts::PI),
            shading: Shading::default(),
            sky: None,
        },
    )
    .with_meshes(vec![mesh]);
    let camera = Camera::look_at(eye, DVec3::new(0.5, 1.0, 0.0), 40.0, 40, 30).unwrap();
    (scene, camera)
}

fn image(scene: &Scene, camera: &Camera, method: Method, mattes: bool) -> Film {
    let settings = RenderSettings {
        method,
        spp: 4,
        // A band wide enough that both trees may be drawn either way.
        lod: Lod {
            switch: 1.0,
            band: 8.0,
        },
        mattes,
        ..RenderSettings::default()
    };
    render(scene, camera, &settings, &|_| {})
}

#[test]
fn coverages_add_up_to_alpha_and_recording_them_changes_no_pixel() {
    let (scene, camera) = two_trees();
    for method in [Method::Texel, Method::Mesh, Method::Hybrid] {
        let film = image(&scene, &camera, method, true);
        let plain = image(&scene, &camera, method, false);
        assert!(plain.mattes.is_empty());
        let bits =
            |f: &Film| -> Vec<[u32; 4]> { f.rgba.iter().map(|p| p.map(f32::to_bits)).collect() };
        assert!(
            bits(&film) == bits(&plain),
            "{method:?}: mattes changed the image"
        );
        let (mut both, mut sky) = (0, 0);
        for (i, m) in film.mattes.iter().enumerate() {
            let alpha = film.rgba[i][3];
            for ranks in [&m.trees, &m.species] {
                // Three objects at most (two trees, the terrain): every one is kept.
                assert!(ranks[3..].iter().all(|r| r.1 == 0.0));
                let sum: f32 = ranks.iter().map(|r| r.1).sum();
                assert!(
                    (sum - alpha).abs() < 1e-5,
                    "{method:?} pixel {i}: {sum} against alpha {alpha}"
                );
                assert!(ranks.windows(2).all(|w| w[0].1 >= w[1].1), "most first");
            }
            let trees: Vec<u32> = m.trees.iter().filter(|r| r.1 > 0.0).map(|r| r.0).collect();
            assert!(trees.iter().all(|&o| o < 2 || o == TERRAIN), "{trees:?}");
            both += usize::from(trees.contains(&0) && trees.contains(&1));
            sky += usize::from(alpha == 0.0);
            // One species: the trees' coverage is the species'.
            let tree_sum: f32 = m.trees.iter().filter(|r| r.0 < 2).map(|r| r.1).sum();
            let species = m.species.iter().find(|r| r.0 == 0).map_or(0.0, |r| r.1);
            assert!((tree_sum - species).abs() < 1e-5);
        }
        let mut seen: Vec<u32> = film
            .mattes
            .iter()
            .flat_map(|m| m.trees.iter().filter(|r| r.1 > 0.0).map(|r| r.0))
            .collect();
        seen.sort();
        seen.dedup();
        assert!(
            both > 0,
            "{method:?}: some pixel sees both trees; seen {seen:?}"
        );
        assert!(sky > 0, "{method:?}: some pixel sees only the sky");
    }
}

/// A species may be called `terrain` or `sky`: the ground and the background then take
/// names of their own, so a Cryptomatte id picks out one of them, not both.
#[test]
fn a_species_named_terrain_does_not_share_the_grounds_matte() {
    use super::matte::{MatteNames, SKY};
    let (scene, _) = two_trees();
    let plain = MatteNames::new(vec!["beech".into()], &scene);
    assert_eq!(
        (plain.species(TERRAIN), plain.species(SKY)),
        ("terrain", "sky")
    );
    let taken = MatteNames::new(vec!["terrain".into()], &scene);
    assert_eq!(taken.species(0), "terrain");
    assert_eq!(taken.species(TERRAIN), "terrain (ground)");
    assert_eq!(taken.tree(TERRAIN), "terrain (ground)");
    assert_eq!(taken.tree(0), "terrain/0");
    let sky = MatteNames::new(vec!["sky".into()], &scene);
    assert_eq!(sky.species(SKY), "sky (background)");
    // A file that takes the second names too.
    let both = MatteNames::new(
        vec![
            "terrain".into(),
            "terrain (ground)".into(),
            "sky".into(),
            "sky (background)".into(),
            "sky (background 2)".into(),
        ],
        &scene,
    );
    assert_eq!(both.species(TERRAIN), "terrain (ground 2)");
    assert_eq!(both.species(SKY), "sky (background 3)");
}
