//! Cryptomatte v1.1 ID mattes (Psyop's specification, as Nuke's and Blender's Cryptomatte
//! nodes read them): per pixel, the objects it covers as (id, coverage) pairs, most coverage
//! first, two pairs to an RGBA layer `<Type>00`, `<Type>01`, ...; an object's id is its
//! name's MurmurHash3_x86_32 (seed 0) read as a float; the header names the type and maps
//! every name to its hash (the manifest).

use std::collections::BTreeMap;

/// MurmurHash3_x86_32 of `data` with `seed` (Austin Appleby's reference, little-endian
/// blocks).
pub fn murmur3_32(data: &[u8], seed: u32) -> u32 {
    const C1: u32 = 0xcc9e_2d51;
    const C2: u32 = 0x1b87_3593;
    let mix = |k: u32| k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
    let mut h = seed;
    let mut blocks = data.chunks_exact(4);
    for b in &mut blocks {
        h ^= mix(u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        h = h.rotate_left(13).wrapping_mul(5).wrapping_add(0xe654_6b64);
    }
    let tail = blocks.remainder();
    if !tail.is_empty() {
        let k = tail
            .iter()
            .rev()
            .fold(0u32, |k, &byte| (k << 8) | u32::from(byte));
        h ^= mix(k);
    }
    // The length is mixed in modulo 2^32, as the reference's int does.
    h ^= data.len() as u32;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// The 32 bits an id is stored as: the name's hash with bit 23 flipped where its exponent
/// would make the float an infinity, a NaN, zero or a denormal (the specification's
/// `uint32_to_float32` conversion), so every id survives any float pipeline.
pub fn id_bits(name: &str) -> u32 {
    let h = murmur3_32(name.as_bytes(), 0);
    let exponent = (h >> 23) & 0xff;
    if exponent == 0 || exponent == 255 {
        h ^ (1 << 23)
    } else {
        h
    }
}

/// The float a name's id is stored as in the rank channels.
pub fn id(name: &str) -> f32 {
    f32::from_bits(id_bits(name))
}

/// The key of type `name`'s header attributes, `cryptomatte/<key>/...`: the first seven hex
/// digits of its name's hash.
pub fn key(name: &str) -> String {
    format!("{:08x}", murmur3_32(name.as_bytes(), 0))[..7].to_string()
}

/// One Cryptomatte type (e.g. `CryptoSpecies`) of an image: its ranks per pixel, written as
/// EXR channels and header attributes.
pub struct Layer {
    /// The type's name, the prefix of its channels.
    pub name: String,
    /// How many (id, coverage) pairs each pixel keeps, a multiple of two.
    pub ranks: usize,
    /// Per rank, per pixel: the id's float and the coverage (rank-major, so each channel is
    /// one slice).
    pub ids: Vec<Vec<f32>>,
    pub coverage: Vec<Vec<f32>>,
    /// Every name an id of this image stands for.
    pub manifest: BTreeMap<String, u32>,
}

impl Layer {
    /// A type over `pixels` pixels whose pixel `i` covers `objects(i)`: (object, coverage),
    /// the background `None` (id 0, as the specification's reference filter keeps it), in any
    /// order; object `o` is named `name(o)`. Each pixel keeps the `ranks` (a multiple of two)
    /// with most coverage.
    pub fn new<I: IntoIterator<Item = (Option<u32>, f32)>>(
        name: &str,
        ranks: usize,
        pixels: usize,
        objects: impl Fn(usize) -> I,
        object_name: impl Fn(u32) -> String,
    ) -> Layer {
        debug_assert!(ranks.is_multiple_of(2));
        let mut ids = vec![vec![0.0f32; pixels]; ranks];
        let mut coverage = vec![vec![0.0f32; pixels]; ranks];
        let mut manifest = BTreeMap::new();
        // Each object hashed once, however many pixels it covers.
        let mut bits_of = std::collections::HashMap::new();
        let mut covered: Vec<(u32, f32)> = Vec::new();
        for i in 0..pixels {
            covered.clear();
            for (object, c) in objects(i) {
                if c <= 0.0 {
                    continue;
                }
                let bits = object.map_or(0, |o| {
                    *bits_of.entry(o).or_insert_with(|| {
                        let name = object_name(o);
                        let bits = id_bits(&name);
                        manifest.insert(name, bits);
                        bits
                    })
                });
                covered.push((bits, c));
            }
            // Most coverage first; ties by id, so the order is the same however found.
            covered.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            for (r, &(bits, c)) in covered.iter().take(ranks).enumerate() {
                ids[r][i] = f32::from_bits(bits);
                coverage[r][i] = c;
            }
        }
        Layer {
            name: name.to_string(),
            ranks,
            ids,
            coverage,
            manifest,
        }
    }

    /// The channels, `<name>00.R` (rank 0's id), `.G` (its coverage), `.B`, `.A` (rank 1's),
    /// `<name>01.R` ...: name and values, always 32-bit floats (a half would change the ids).
    pub fn into_channels(self) -> Vec<(String, Vec<f32>)> {
        let mut out = Vec::with_capacity(self.ranks * 2);
        for (r, (ids, coverage)) in self.ids.into_iter().zip(self.coverage).enumerate() {
            let layer = format!("{}{:02}", self.name, r / 2);
            let (id, cov) = if r % 2 == 0 { ("R", "G") } else { ("B", "A") };
            out.push((format!("{layer}.{id}"), ids));
            out.push((format!("{layer}.{cov}"), coverage));
        }
        out
    }

    /// The header attributes: `cryptomatte/<key>/name`, `hash`, `conversion` and `manifest`
    /// (a JSON object from each name to its id's 32 bits as eight hex digits).
    pub fn attributes(&self) -> Vec<(String, String)> {
        let key = key(&self.name);
        let manifest = serde_json::to_string(
            &self
                .manifest
                .iter()
                .map(|(name, bits)| (name.as_str(), format!("{bits:08x}")))
                .collect::<BTreeMap<_, _>>(),
        )
        .expect("a map of strings is JSON");
        vec![
            (format!("cryptomatte/{key}/name"), self.name.clone()),
            (format!("cryptomatte/{key}/hash"), "MurmurHash3_32".into()),
            (
                format!("cryptomatte/{key}/conversion"),
                "uint32_to_float32".into(),
            ),
            (format!("cryptomatte/{key}/manifest"), manifest),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference values of MurmurHash3_x86_32 (the SMHasher implementation).
    #[test]
    fn murmur3_matches_the_reference() {
        assert_eq!(murmur3_32(b"", 0), 0);
        assert_eq!(murmur3_32(b"", 1), 0x514e_28b7);
        assert_eq!(murmur3_32(b"", 0xffff_ffff), 0x81f1_6f39);
        assert_eq!(murmur3_32(&[0; 4], 0), 0x2362_f9de);
        assert_eq!(murmur3_32(b"Hello, world!", 1234), 0xfaf6_cdb3);
        assert_eq!(murmur3_32(b"hello", 0), 0x248b_fa47);
        assert_eq!(
            murmur3_32(b"The quick brown fox jumps over the lazy dog", 0),
            0x2e4f_f723
        );
    }

    /// The specification's examples (bunny, default, bunny_porcelain_mat) and the Psyop Nuke
    /// tests' (hello, cube, ..., a UTF-8 name), with names whose hash has exponent 255
    /// and 0 (tree_97, tree_169) and the empty name.
    #[test]
    fn ids_match_the_specification_and_its_reference_tests() {
        for (name, bits) in [
            ("hello", 0x248b_fa47),
            ("cube", 0xd968_2f08),
            ("sphere", 0x591e_9a8d),
            ("plane", 0x2e21_36b8),
            ("bunny", 0x1385_1a76),
            ("default", 0x42c9_679f),
            ("bunny_porcelain_mat", 0xb24b_26d4),
            ("mädchen", 0x6a4e_5613),
            ("tree_97", 0xff6e_d3b0),
            ("tree_169", 0x808c_b812),
            ("", 0x0080_0000),
        ] {
            assert_eq!(id_bits(name), bits, "{name}");
        }
        assert!((id("hello") / 6.070_563e-17 - 1.0).abs() < 1e-6);
        assert!((id("default") - 100.702_39).abs() < 1e-4);
        assert_eq!(key("CryptoSpecies"), "7bc3981");
    }

    #[test]
    fn a_layer_ranks_each_pixel_and_lists_every_name() {
        let pixels: [Vec<(Option<u32>, f32)>; 2] = [
            vec![(Some(0), 0.25), (None, 0.25), (Some(1), 0.5)],
            vec![(None, 1.0)],
        ];
        let names = ["a", "b"];
        let layer = Layer::new(
            "CryptoTest",
            2,
            2,
            |i| pixels[i].clone(),
            |o| names[o as usize].to_string(),
        );
        let attributes = layer.attributes();
        let manifest = attributes[3].1.clone();
        let channels = layer.into_channels();
        let names: Vec<&str> = channels.iter().map(|c| c.0.as_str()).collect();
        assert_eq!(
            names,
            [
                "CryptoTest00.R",
                "CryptoTest00.G",
                "CryptoTest00.B",
                "CryptoTest00.A"
            ]
        );
        // Pixel 0: b (0.5), then the background and a tied at 0.25, the background's id (0)
        // first; only two ranks are kept. Pixel 1: all background.
        assert_eq!(channels[0].1, [id("b"), 0.0]);
        assert_eq!(channels[1].1, [0.5, 1.0]);
        assert_eq!(channels[2].1, [0.0, 0.0]);
        assert_eq!(channels[3].1, [0.25, 0.0]);
        let key = key("CryptoTest");
        assert_eq!(
            attributes[0],
            (format!("cryptomatte/{key}/name"), "CryptoTest".into())
        );
        assert_eq!(
            manifest,
            format!(
                "{{\"a\":\"{:08x}\",\"b\":\"{:08x}\"}}",
                id_bits("a"),
                id_bits("b")
            )
        );
    }

    #[test]
    fn ids_are_never_infinite_nan_zero_or_denormal() {
        for i in 0..20_000 {
            let name = format!("tree/{i}");
            let id = id(&name);
            assert!(id.is_normal(), "{name}: {id}");
            let h = murmur3_32(name.as_bytes(), 0);
            // Only bit 23 may differ from the hash.
            assert_eq!((id.to_bits() ^ h) & !(1 << 23), 0);
        }
    }
}
