//! OpenEXR reading as `texel compare` does it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use texel_forest::compare::Rgba;
use texel_forest::limits::Limits;

fuzz_target!(|data: &[u8]| {
    let _ = Rgba::from_bytes(data, std::path::Path::new("fuzz.exr"), &Limits::default());
});
