//! Human-readable views of our files: summaries as text or JSON, and pictures.

pub mod instances;
pub mod pictures;
pub mod texel;
