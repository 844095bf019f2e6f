//! The accessor reader against a plain reference decoder, over generated layouts: every
//! component type and width, accessor offsets, strides, several accessors interleaved in one
//! view, views ending exactly at the end of their buffer or followed by slack, sparse
//! substitution on top, in `.gltf` (data URI) and `.glb` containers.

use std::path::Path;

use base64::Engine as _;
use proptest::prelude::*;
use serde_json::{Value, json};

use super::{read, read_indices};
use crate::import::document::Document;

/// glTF component types: (code, bytes, integer range or float).
const COMPONENT_TYPES: [(u32, usize); 6] = [
    (5120, 1), // BYTE
    (5121, 1), // UNSIGNED_BYTE
    (5122, 2), // SHORT
    (5123, 2), // UNSIGNED_SHORT
    (5125, 4), // UNSIGNED_INT
    (5126, 4), // FLOAT
];

/// One component value as it is stored, and what it must decode to, written out the long way
/// from the glTF specification (section 3.11) rather than from the reader's code.
fn reference(code: u32, normalized: bool, raw: u32) -> (Vec<u8>, f64) {
    match code {
        5120 => {
            let v = raw as u8 as i8;
            let x = if normalized {
                f64::max(v as f64 / 127.0, -1.0)
            } else {
                v as f64
            };
            (vec![v as u8], x)
        }
        5121 => {
            let v = raw as u8;
            (
                vec![v],
                if normalized {
                    v as f64 / 255.0
                } else {
                    v as f64
                },
            )
        }
        5122 => {
            let v = raw as u16 as i16;
            let x = if normalized {
                f64::max(v as f64 / 32767.0, -1.0)
            } else {
                v as f64
            };
            (v.to_le_bytes().to_vec(), x)
        }
        5123 => {
            let v = raw as u16;
            (
                v.to_le_bytes().to_vec(),
                if normalized {
                    v as f64 / 65535.0
                } else {
                    v as f64
                },
            )
        }
        5125 => (raw.to_le_bytes().to_vec(), raw as f64),
        _ => {
            // Finite floats only: a float from the raw bits, with its exponent tamed.
            let f = f32::from_bits(raw & 0xbfff_ffff);
            let f = if f.is_finite() { f } else { 1.5 };
            (f.to_le_bytes().to_vec(), f as f64)
        }
    }
}

#[derive(Clone, Debug)]
struct Layout {
    type_index: usize,
    components: usize,
    normalized: bool,
    count: usize,
    /// Extra bytes per element beyond its own (0 = no byteStride, tightly packed).
    stride_padding: usize,
    /// Component-size units before the element inside each stride (interleaving).
    lead: usize,
    /// Whole strides skipped before the first element (an accessor offset).
    skip: usize,
    /// Bytes of the buffer before the view (multiples of 4).
    view_offset: usize,
    /// Bytes of the view after the accessor's last element, and of the buffer after the view.
    view_slack: usize,
    buffer_slack: usize,
    sparse: Option<Sparse>,
    glb: bool,
    noise: u64,
}

#[derive(Clone, Debug)]
struct Sparse {
    index_type: usize,
    /// Element indices substituted (deduplicated and sorted when built).
    targets: Vec<usize>,
    has_base: bool,
}

fn layouts() -> impl Strategy<Value = Layout> {
    (
        (0..6usize, 1..=4usize, any::<bool>(), 1..24usize),
        (0..3usize, 0..3usize, 0..3usize, 0..4usize),
        (
            prop_oneof![Just(0usize), 1..9usize],
            prop_oneof![Just(0usize), 1..9usize],
        ),
        proptest::option::of((
            0..3usize,
            proptest::collection::vec(0..24usize, 1..6),
            any::<bool>(),
        )),
        any::<bool>(),
        any::<u64>(),
    )
        .prop_map(
            |(
                (type_index, components, normalized, count),
                (stride_padding, lead, skip, view_offset),
                (view_slack, buffer_slack),
                sparse,
                glb,
                noise,
            )| {
                let float = COMPONENT_TYPES[type_index].0 == 5126;
                Layout {
                    type_index,
                    components,
                    normalized: normalized && !float,
                    count,
                    stride_padding,
                    lead: if stride_padding == 0 {
                        0
                    } else {
                        lead.min(stride_padding)
                    },
                    skip,
                    view_offset: view_offset * 4,
                    view_slack,
                    buffer_slack,
                    sparse: sparse.map(|(index_type, targets, has_base)| Sparse {
                        index_type,
                        targets,
                        has_base,
                    }),
                    glb,
                    noise,
                }
            },
        )
}

/// A small deterministic byte source for filler and values.
struct Noise(u64);
impl Noise {
    fn next(&mut self) -> u32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 32) as u32
    }
}

/// The document's bytes and what accessor 0 must decode to.
fn build(l: &Layout) -> (Vec<u8>, Vec<f64>) {
    let (code, csize) = COMPONENT_TYPES[l.type_index];
    let elem = csize * l.components;
    let mut noise = Noise(l.noise);
    let stride = if l.stride_padding == 0 {
        elem
    } else {
        elem + l.stride_padding * csize
    };
    // The accessor's offset: whole strides skipped plus its lead inside the stride.
    let accessor_offset = l.skip * stride + l.lead * csize;
    let span = (l.count - 1) * stride + elem;
    let view_length = accessor_offset + span + l.view_slack;

    let mut buffer: Vec<u8> = (0..l.view_offset + view_length)
        .map(|_| noise.next() as u8)
        .collect();
    let mut expected = Vec::new();
    for i in 0..l.count {
        for c in 0..l.components {
            let (bytes, value) = reference(code, l.normalized, noise.next());
            let at = l.view_offset + accessor_offset + i * stride + c * csize;
            buffer[at..at + csize].copy_from_slice(&bytes);
            expected.push(value);
        }
    }
    let mut views = vec![json!({
        "buffer": 0, "byteOffset": l.view_offset, "byteLength": view_length,
    })];
    if l.stride_padding > 0 {
        views[0]["byteStride"] = json!(stride);
    }
    let type_name = ["SCALAR", "VEC2", "VEC3", "VEC4"][l.components - 1];
    let mut accessor = json!({
        "componentType": code,
        "count": l.count,
        "type": type_name,
        "normalized": l.normalized,
    });
    let has_base = l.sparse.as_ref().is_none_or(|s| s.has_base);
    if has_base {
        accessor["bufferView"] = json!(0);
        accessor["byteOffset"] = json!(accessor_offset);
    } else {
        expected.iter_mut().for_each(|v| *v = 0.0);
    }
    if let Some(sparse) = &l.sparse {
        let mut targets: Vec<usize> = sparse.targets.iter().map(|&t| t % l.count).collect();
        targets.sort();
        targets.dedup();
        let (icode, isize_) = [(5121u32, 1usize), (5123, 2), (5125, 4)][sparse.index_type];
        let align = |b: &mut Vec<u8>| {
            while !b.len().is_multiple_of(4) {
                b.push(0xa5);
            }
        };
        align(&mut buffer);
        let indices_at = buffer.len();
        for &t in &targets {
            buffer.extend_from_slice(&(t as u32).to_le_bytes()[..isize_]);
        }
        align(&mut buffer);
        let values_at = buffer.len();
        for &t in &targets {
            for c in 0..l.components {
                let (bytes, value) = reference(code, l.normalized, noise.next());
                buffer.extend_from_slice(&bytes);
                expected[t * l.components + c] = value;
            }
        }
        views.push(
            json!({ "buffer": 0, "byteOffset": indices_at, "byteLength": targets.len() * isize_ }),
        );
        views.push(
            json!({ "buffer": 0, "byteOffset": values_at, "byteLength": targets.len() * elem }),
        );
        accessor["sparse"] = json!({
            "count": targets.len(),
            "indices": { "bufferView": 1, "componentType": icode },
            "values": { "bufferView": 2 },
        });
    }
    buffer.extend((0..l.buffer_slack).map(|_| noise.next() as u8));

    let mut doc = json!({
        "asset": { "version": "2.0" },
        "accessors": [accessor],
        "bufferViews": views,
    });
    let bytes = if l.glb {
        doc["buffers"] = json!([{ "byteLength": buffer.len() }]);
        glb(&doc, &buffer)
    } else {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&buffer)
        );
        doc["buffers"] = json!([{ "byteLength": buffer.len(), "uri": uri }]);
        serde_json::to_vec(&doc).unwrap()
    };
    (bytes, expected)
}

/// A binary glTF: header, JSON chunk (space-padded), BIN chunk (zero-padded).
pub(crate) fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).unwrap();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x4E4F_534Au32.to_le_bytes());
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E_4942u32.to_le_bytes());
    out.extend_from_slice(&bin);
    out
}

fn document(bytes: Vec<u8>, glb: bool) -> Document {
    let name = if glb { "layout.glb" } else { "layout.gltf" };
    Document::parse(Path::new(name), bytes).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn every_layout_decodes_as_the_reference_does(l in layouts()) {
        let (bytes, expected) = build(&l);
        let mut doc = document(bytes, l.glb);
        let values = read(&mut doc, 0, "test").unwrap();
        prop_assert_eq!(values.components, l.components);
        // Bit-exact: both sides convert the same integers and floats to f64.
        prop_assert_eq!(values.data, expected);
    }

    #[test]
    fn a_view_one_byte_short_is_an_error_not_a_panic(l in layouts()) {
        let (bytes, _) = build(&Layout { sparse: None, glb: false, view_slack: 0, ..l.clone() });
        let mut doc: Value = serde_json::from_slice(&bytes).unwrap();
        let length = doc["bufferViews"][0]["byteLength"].as_u64().unwrap();
        doc["bufferViews"][0]["byteLength"] = json!(length - 1);
        let mut doc = document(serde_json::to_vec(&doc).unwrap(), false);
        let e = read(&mut doc, 0, "test").unwrap_err().to_string();
        prop_assert!(e.contains("bufferView 0"), "{}", e);
    }
}

#[test]
fn an_accessor_offset_near_the_end_of_its_buffer_reads_its_own_bytes() {
    // The Khronos `Box` sample's shape: normals and positions share one view, positions at
    // byteOffset 288 of a 576-byte view that ends exactly at the buffer's end.
    let normals: Vec<f32> = (0..72).map(|i| i as f32).collect();
    let positions: Vec<f32> = (0..72).map(|i| 100.0 + i as f32).collect();
    let bin: Vec<u8> = normals
        .iter()
        .chain(&positions)
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let doc = json!({
        "asset": { "version": "2.0" },
        "buffers": [{ "byteLength": bin.len() }],
        "bufferViews": [{ "buffer": 0, "byteOffset": 0, "byteLength": 576, "byteStride": 12 }],
        "accessors": [
            { "bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 24, "type": "VEC3" },
            { "bufferView": 0, "byteOffset": 288, "componentType": 5126, "count": 24, "type": "VEC3" },
        ],
    });
    let mut doc = document(glb(&doc, &bin), true);
    let p = read(&mut doc, 1, "POSITION").unwrap();
    assert_eq!(
        p.data,
        positions.iter().map(|&v| v as f64).collect::<Vec<_>>()
    );
}

#[test]
fn sparse_indices_out_of_range_are_an_error() {
    let l = Layout {
        type_index: 5,
        components: 3,
        normalized: false,
        count: 4,
        stride_padding: 0,
        lead: 0,
        skip: 0,
        view_offset: 0,
        view_slack: 0,
        buffer_slack: 0,
        sparse: Some(Sparse {
            index_type: 1,
            targets: vec![1],
            has_base: true,
        }),
        glb: false,
        noise: 3,
    };
    let (bytes, _) = build(&l);
    let mut doc: Value = serde_json::from_slice(&bytes).unwrap();
    doc["accessors"][0]["count"] = json!(1);
    let mut doc = document(serde_json::to_vec(&doc).unwrap(), false);
    let e = read(&mut doc, 0, "test").unwrap_err().to_string();
    assert!(e.contains("out of range"), "{e}");
}

/// glTF requires sparse indices to strictly increase: a repeat (or a step back) leaves which
/// value stands to the reader, so it is refused, naming the indices.
#[test]
fn sparse_indices_that_do_not_increase_are_an_error() {
    for indices in [[2u8, 2], [2, 1]] {
        // Three floats of base, then the two indices (padded to 4), then two values.
        let mut bin: Vec<u8> = [0.0f32, 1.0, 2.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        bin.extend_from_slice(&[indices[0], indices[1], 0, 0]);
        bin.extend([5.0f32, 6.0].iter().flat_map(|v| v.to_le_bytes()));
        let doc = json!({
            "asset": { "version": "2.0" },
            "buffers": [{ "byteLength": bin.len() }],
            "bufferViews": [
                { "buffer": 0, "byteLength": 12 },
                { "buffer": 0, "byteOffset": 12, "byteLength": 2 },
                { "buffer": 0, "byteOffset": 16, "byteLength": 8 },
            ],
            "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "SCALAR",
                "sparse": { "count": 2, "indices": { "bufferView": 1, "componentType": 5121 },
                            "values": { "bufferView": 2 } } }],
        });
        let mut doc = document(glb(&doc, &bin), true);
        let e = read(&mut doc, 0, "test").unwrap_err().to_string();
        assert!(
            e.contains("sparse.indices") && e.contains("strictly increase"),
            "{e}"
        );
    }
}

#[test]
fn index_accessors_must_be_unsigned_scalars() {
    let doc = json!({
        "asset": { "version": "2.0" },
        "buffers": [{ "byteLength": 4, "uri": "data:application/octet-stream;base64,AAAAAA==" }],
        "bufferViews": [{ "buffer": 0, "byteLength": 4 }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 1, "type": "SCALAR" }],
    });
    let mut doc = document(serde_json::to_vec(&doc).unwrap(), false);
    let e = read_indices(&mut doc, 0, "indices")
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a scalar of unsigned integers"), "{e}");
}
