//! `.texel` decoding, then the inspect summary of what decoded.
#![no_main]

use libfuzzer_sys::fuzz_target;
use texel_forest::formats::texel::decode;
use texel_forest::inspect::FileFacts;
use texel_forest::inspect::texel::summarize;

fuzz_target!(|data: &[u8]| {
    if let Ok(t) = decode(data) {
        let facts = FileFacts {
            bytes: data.len() as u64,
            minor: 1,
            raw_bytes: 0,
        };
        let _ = summarize(&t, facts);
    }
});
