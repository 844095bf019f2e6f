//! texel-forest: forest scenery from volumetric tree textures.
//!
//! The pipeline has stages that talk only through files: `bake` turns a glTF tree into a
//! `.texel` 3D texture, `place` scatters instances over a terrain, `render` ray traces them.
//! This library holds every stage; the `texel` binary only parses arguments and dispatches.

// Numeric code indexes parallel arrays by the same small index, as the maths does.
#![allow(clippy::needless_range_loop)]

pub mod bake;
pub mod color;
pub mod compare;
#[cfg(feature = "dev-tools")]
pub mod corpus;
pub mod cryptomatte;
pub mod export;
pub mod formats;
pub mod geom;
pub mod hex;
pub mod import;
pub mod input;
pub mod inspect;
pub mod json_file;
pub mod limits;
pub mod mesh_tracer;
pub mod number;
pub mod output;
pub mod place;
#[cfg(feature = "dev-tools")]
pub mod plot;
pub mod png;
#[cfg(feature = "dev-tools")]
pub mod procedural;
pub mod provenance;
pub mod render;
pub mod rng;
pub mod silhouette;
pub mod species;
pub mod temporal;
pub mod terrain;
pub mod volume;
