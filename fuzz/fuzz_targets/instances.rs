//! `.instances` decoding, then the inspect summary of what decoded.
#![no_main]

use libfuzzer_sys::fuzz_target;
use texel_forest::formats::instances::decode_stored;
use texel_forest::inspect::instances::summarize;
use texel_forest::inspect::FileFacts;

fuzz_target!(|data: &[u8]| {
    if let Ok(f) = decode_stored(data) {
        let facts = FileFacts {
            bytes: data.len() as u64,
            minor: 1,
            raw_bytes: 0,
        };
        let _ = summarize(&f, facts);
    }
});
