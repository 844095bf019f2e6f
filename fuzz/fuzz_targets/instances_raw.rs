//! `.instances` decoding past the container's checksum and compression: the input is
//! `minor: u16 LE, header length: u32 LE, header, raw payload`, which this target wraps in a
//! valid container (checksum, zstd frame) before the same calls as the `instances` target.
//! Every input therefore corresponds to a real `.instances` file: `wrap(input)`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use texel_forest::formats::{container, instances};
use texel_forest::inspect::instances::summarize;
use texel_forest::inspect::FileFacts;

fn wrap(data: &[u8]) -> Option<Vec<u8>> {
    let minor = u16::from_le_bytes(data.get(0..2)?.try_into().ok()?);
    let h = u32::from_le_bytes(data.get(2..6)?.try_into().ok()?) as usize;
    let rest = &data[6..];
    let (header, payload) = rest.split_at(h.min(rest.len()));
    container::write(instances::MAGIC, instances::MAJOR, minor, header, payload).ok()
}

fuzz_target!(|data: &[u8]| {
    let Some(file) = wrap(data) else { return };
    if let Ok(f) = instances::decode_stored(&file) {
        let facts = FileFacts {
            bytes: file.len() as u64,
            minor: 1,
            raw_bytes: 0,
        };
        let _ = summarize(&f, facts);
    }
});
