//! File formats, each mirroring its byte-level spec in `formats/*.md`, and the container they
//! share.

pub mod container;
pub mod instances;
pub mod texel;

pub use crate::hex::hex;
