//! File formats, each mirroring its byte-level spec in `formats/*.md`, and the container they
//! share.

pub mod container;
pub mod instances;
pub mod texel;

/// Lower-case hexadecimal of a byte string.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Serialises a 32-byte hash as hexadecimal (for JSON output).
pub fn hex32<S: serde::Serializer>(bytes: &[u8; 32], s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&hex(bytes))
}
