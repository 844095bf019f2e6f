//! Species file (JSON) parsing and validation.
#![no_main]

use libfuzzer_sys::fuzz_target;
use texel_forest::species::SpeciesFile;

fuzz_target!(|data: &[u8]| {
    let _ = SpeciesFile::parse(data);
});
