//! The glTF importer (and the bake after it) never panics: damaged files give errors (or, where the damage is harmless,
//! a model), whatever bytes they hold.

use proptest::prelude::*;
use texel_forest::procedural::builder::{self, MaterialSpec, ModelBuilder};

fn small_glb() -> Vec<u8> {
    let mut b = ModelBuilder::default();
    let leaf = b.material(MaterialSpec {
        name: "leaf".into(),
        color: [1.0; 4],
        mask: Some((texel_forest::procedural::trees::leaf_texture(), 0.5)),
    });
    let wood = b.material(MaterialSpec {
        name: "bark".into(),
        color: [0.2, 0.1, 0.05, 1.0],
        mask: None,
    });
    b.card(
        leaf,
        glam::Vec3::new(0.0, 1.0, 0.0),
        glam::Vec3::X,
        glam::Vec3::Y,
    );
    b.tube(wood, &[(glam::Vec3::ZERO, 0.1), (glam::Vec3::Y, 0.08)], 5);
    let f = b.to_gltf(None, "fuzz");
    builder::glb(&f.doc, &f.bin)
}

fn load(bytes: &[u8]) -> bool {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("m.glb");
    std::fs::write(&p, bytes).unwrap();
    match texel_forest::import::load(&p) {
        // Whatever loads must also bake (or be refused) without a panic.
        Ok(model) => {
            let settings = texel_forest::bake::BakeSettings {
                resolution: 8,
                fine: 32,
                ..Default::default()
            };
            let _ = texel_forest::bake::bake(&model.mesh, &settings);
            true
        }
        Err(_) => false,
    }
}

#[test]
fn the_undamaged_model_loads() {
    assert!(load(&small_glb()));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn flipped_bytes_never_panic(flips in proptest::collection::vec((any::<prop::sample::Index>(), 1u8..=255), 1..6)) {
        let mut bytes = small_glb();
        for (at, x) in flips {
            let i = at.index(bytes.len());
            bytes[i] ^= x;
        }
        let _ = load(&bytes);
    }

    #[test]
    fn truncation_never_panics(at in any::<prop::sample::Index>()) {
        let bytes = small_glb();
        let _ = load(&bytes[..at.index(bytes.len())]);
    }

    /// JSON numbers replaced by arbitrary ones: indices, counts, offsets and strides out of
    /// range are the classic crash of glTF loaders.
    #[test]
    fn arbitrary_numbers_in_the_json_never_panic(which in any::<prop::sample::Index>(), value in prop_oneof![Just(0i64), Just(-1), Just(1 << 31), Just(u32::MAX as i64), any::<i32>().prop_map(i64::from)]) {
        let bytes = small_glb();
        let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let mut doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
        let mut numbers = vec![];
        collect_numbers(&doc, &mut vec![], &mut numbers);
        let path = &numbers[which.index(numbers.len())];
        *pointer_mut(&mut doc, path) = serde_json::json!(value);
        let bin_at = 20 + json_len + 8;
        let bin = &bytes[bin_at..];
        let _ = load(&builder::glb(&doc, bin));
    }
}

fn collect_numbers(v: &serde_json::Value, path: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match v {
        serde_json::Value::Number(_) => out.push(path.clone()),
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                path.push(i.to_string());
                collect_numbers(x, path, out);
                path.pop();
            }
        }
        serde_json::Value::Object(o) => {
            for (k, x) in o {
                path.push(k.clone());
                collect_numbers(x, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

fn pointer_mut<'a>(v: &'a mut serde_json::Value, path: &[String]) -> &'a mut serde_json::Value {
    path.iter().fold(v, |v, k| match v {
        serde_json::Value::Array(a) => &mut a[k.parse::<usize>().unwrap()],
        other => &mut other[k.as_str()],
    })
}
