//! The rendered image: linear, scene-referred, premultiplied RGBA with depth and optional
//! arbitrary output values, written as OpenEXR; and an sRGB preview for people.

use exr::prelude::*;
use glam::Vec3;

use super::Mattes;
use super::matte::{self, MatteNames};
use crate::color::to_srgb8;
use crate::cryptomatte;

/// Extra layers a render can write beside RGBA and Z.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Aovs {
    pub normal: bool,
    pub albedo: bool,
    pub canopy: bool,
    pub species: bool,
    /// Which representation drew the canopy (the hybrid method's transitions).
    pub lod: bool,
    /// Where the time goes: volume samples and shadow rays per pixel.
    pub samples: bool,
    /// Cryptomatte ID mattes by species and by tree (needs the film's `mattes`).
    pub cryptomatte: bool,
}

impl Aovs {
    /// Every layer a film keeps per pixel (Cryptomatte's coverage is kept apart, by
    /// [`super::RenderSettings::mattes`]).
    pub const ALL: Aovs = Aovs {
        normal: true,
        albedo: true,
        canopy: true,
        species: true,
        lod: true,
        samples: true,
        cryptomatte: false,
    };

    /// The most bytes a render writing these layers holds per pixel: the layers the film
    /// keeps, and the EXR's channels twice, as samples and encoded (Cryptomatte: the film's
    /// ranks and 32 float channels). A render is checked for it before it starts
    /// ([`crate::limits::check_memory`]); a test in `render` sums it from the types.
    pub fn bytes_per_pixel(&self) -> u64 {
        // RGBA and Z: 20 bytes in the film, five channels.
        let (mut film, mut channels) = (20u64, 5u64);
        let mut add = |kept: bool, bytes: u64, count: u64| {
            if kept {
                film += bytes;
                channels += count;
            }
        };
        add(self.normal, 12, 3);
        add(self.albedo, 12, 3);
        add(self.canopy || self.lod, 4, 0);
        add(self.canopy, 0, 1);
        add(self.lod, 8, 3);
        add(self.species, 4, 1);
        add(self.samples, 8, 2);
        add(self.cryptomatte, 128, 32);
        film + 2 * 4 * channels
    }
}

/// An encoded OpenEXR file, and how many values were clamped to fit half floats.
pub struct Exr {
    pub bytes: Vec<u8>,
    pub clamped: usize,
}

/// What the frames' `software` attribute begins with (then the version): how `texel inspect`
/// knows a frame from a heightmap.
pub const SOFTWARE: &str = "texel-forest";

/// Puts the attributes of a single-part OpenEXR file's header in the order of their names.
/// The `exr` crate writes attributes it does not know (Cryptomatte's) in the order of a
/// `std::collections::HashMap`, which each process seeds at random: the same render would
/// differ from run to run in the order of its header's attributes. The format leaves their
/// order free, and sorting them changes no length, so the offset table after the header still
/// points where it did.
fn sort_attributes(bytes: &mut [u8]) -> std::result::Result<(), String> {
    let bad = |what: &str| format!("the encoded header is not as expected: {what}");
    // Magic number, then the version field, whose bit 12 marks a multi-part file.
    let version = bytes.get(4..8).ok_or_else(|| bad("too short"))?;
    if u32::from_le_bytes([version[0], version[1], version[2], version[3]]) & 0x1000 != 0 {
        return Err(bad("several parts"));
    }
    let start = 8;
    // Each attribute: its name and its type (both ending in a zero byte), its size (4 bytes,
    // little-endian) and its value; a zero byte where a name would begin ends the header.
    let mut attributes = Vec::new();
    let mut at = start;
    loop {
        let zero = |from: usize| {
            bytes
                .get(from..)
                .and_then(|b| b.iter().position(|&c| c == 0))
                .map(|k| from + k)
                .ok_or_else(|| bad("a name without its end"))
        };
        let name_end = zero(at)?;
        if name_end == at {
            break;
        }
        let type_end = zero(name_end + 1)?;
        let size = bytes
            .get(type_end + 1..type_end + 5)
            .ok_or_else(|| bad("an attribute without its size"))?;
        let size = u32::from_le_bytes([size[0], size[1], size[2], size[3]]) as usize;
        let end = type_end + 5 + size;
        if end > bytes.len() {
            return Err(bad("an attribute past the end"));
        }
        attributes.push((at, name_end, end));
        at = end;
    }
    attributes.sort_by_key(|&(a, name_end, _)| &bytes[a..name_end]);
    let sorted: Vec<u8> = attributes
        .iter()
        .flat_map(|&(a, _, e)| &bytes[a..e])
        .copied()
        .collect();
    bytes[start..at].copy_from_slice(&sorted);
    Ok(())
}

/// Largest finite half float.
const HALF_MAX: f32 = 65504.0;

/// Pixels of a window of the frame, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// The window: x0, y0 (inclusive) and size, within the full frame.
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
    /// Size of the full frame (the display window).
    pub frame: (u32, u32),
    pub rgba: Vec<[f32; 4]>,
    /// Camera-space depth of the pixel's surface (see `Radiance::distance`); +infinity exactly
    /// where nothing covers the pixel (alpha 0, or only the sky).
    pub z: Vec<f32>,
    pub normal: Vec<Vec3>,
    pub albedo: Vec<Vec3>,
    pub canopy: Vec<f32>,
    /// The part of `canopy` drawn from polygon models.
    pub mesh_canopy: Vec<f32>,
    /// The part of `canopy` drawn from trees in the hybrid method's transition band.
    pub band_canopy: Vec<f32>,
    pub species: Vec<f32>,
    /// Volume samples along the pixel's view rays (all of its samples), and shadow rays cast.
    pub samples: Vec<f32>,
    pub shadow_rays: Vec<f32>,
    /// Each pixel's coverage by tree and species, where the render recorded it
    /// ([`super::RenderSettings::mattes`]); else empty.
    pub mattes: Vec<Mattes>,
    /// The volume samples and shadow rays of every pixel put in, summed ([`Film::work`]).
    work: [f64; 2],
    /// Pixels rendered again with more samples, at edges (`RenderSettings::edges`).
    pub sampled_again: u64,
}

impl Film {
    /// A film that keeps every layer.
    pub fn new(x0: u32, y0: u32, width: u32, height: u32, frame: (u32, u32)) -> Film {
        Film::keeping(x0, y0, width, height, frame, Aovs::ALL)
    }

    /// A film that keeps RGBA, Z and the layers `layers` asks for; the others stay empty
    /// (48 bytes a pixel, 100 MB at 1920 x 1080, that no file would carry).
    pub fn keeping(
        x0: u32,
        y0: u32,
        width: u32,
        height: u32,
        frame: (u32, u32),
        layers: Aovs,
    ) -> Film {
        let n = width as usize * height as usize;
        fn layer<T: Clone>(kept: bool, empty: T, n: usize) -> Vec<T> {
            if kept { vec![empty; n] } else { Vec::new() }
        }
        Film {
            x0,
            y0,
            width,
            height,
            frame,
            rgba: vec![[0.0; 4]; n],
            z: vec![f32::INFINITY; n],
            normal: layer(layers.normal, Vec3::ZERO, n),
            albedo: layer(layers.albedo, Vec3::ZERO, n),
            // The lod layers split the canopy between the representations.
            canopy: layer(layers.canopy || layers.lod, 0.0, n),
            mesh_canopy: layer(layers.lod, 0.0, n),
            band_canopy: layer(layers.lod, 0.0, n),
            species: layer(layers.species, 0.0, n),
            samples: layer(layers.samples, 0.0, n),
            shadow_rays: layer(layers.samples, 0.0, n),
            mattes: Vec::new(),
            work: [0.0; 2],
            sampled_again: 0,
        }
    }

    /// Counts the work of a pixel put in ([`Film::work`]). Whole numbers, summed exactly
    /// (below 2^53) in whatever order the tiles finish.
    pub(super) fn add_work(&mut self, samples: f32, shadow_rays: f32) {
        self.work[0] += f64::from(samples);
        self.work[1] += f64::from(shadow_rays);
    }

    /// An OpenEXR file: channels R, G, B, A, Z (half or float) and the asked-for AOVs, the data
    /// window placed within the full frame's display window, the camera matrices as
    /// `worldToCamera` and `worldToNDC`. Cryptomatte names its objects by `names`.
    pub fn exr_bytes(
        &self,
        half: bool,
        aovs: Aovs,
        world_to_camera: [f32; 16],
        world_to_ndc: [f32; 16],
        names: Option<&MatteNames>,
    ) -> std::result::Result<Exr, String> {
        let (mut channels, clamped) = self.channels(half, aovs)?;
        let mut other = std::collections::HashMap::new();
        if aovs.cryptomatte {
            let names = names.ok_or("Cryptomatte needs the names of the scene's objects")?;
            if self.mattes.len() != self.rgba.len() {
                return Err("Cryptomatte needs a render that recorded coverage by object".into());
            }
            for layer in self.cryptomatte_layers(names) {
                for (key, value) in layer.attributes() {
                    other.insert(
                        Text::from(key.as_str()),
                        AttributeValue::Text(Text::from_slice_unchecked(value.as_bytes())),
                    );
                }
                for (name, values) in layer.into_channels() {
                    channels.push(AnyChannel::new(name.as_str(), FlatSamples::F32(values)));
                }
            }
        }
        let attributes = LayerAttributes {
            other,
            world_to_camera: Some(world_to_camera),
            world_to_normalized_device: Some(world_to_ndc),
            software_name: Some(Text::from(
                format!("{SOFTWARE} {}", env!("CARGO_PKG_VERSION")).as_str(),
            )),
            layer_position: Vec2(self.x0 as i32, self.y0 as i32),
            ..LayerAttributes::default()
        };
        let layer = Layer::new(
            (self.width as usize, self.height as usize),
            attributes,
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(channels.into()),
        );
        let mut image = Image::from_layer(layer);
        image.attributes.display_window =
            IntegerBounds::from_dimensions((self.frame.0 as usize, self.frame.1 as usize));
        let mut bytes = Vec::new();
        image
            .write()
            .to_buffered(std::io::Cursor::new(&mut bytes))
            .map_err(|e| e.to_string())?;
        sort_attributes(&mut bytes)?;
        Ok(Exr { bytes, clamped })
    }

    /// The EXR's channels, with how many values a half could not hold; an error where an AOV
    /// asked for is a layer this film did not keep.
    fn channels(
        &self,
        half: bool,
        aovs: Aovs,
    ) -> std::result::Result<(Vec<AnyChannel<FlatSamples>>, usize), String> {
        let n = self.rgba.len();
        for (asked, kept, name) in [
            (aovs.normal, self.normal.len(), "normal"),
            (aovs.albedo, self.albedo.len(), "albedo"),
            (aovs.canopy, self.canopy.len(), "canopy"),
            (
                aovs.lod,
                self.canopy
                    .len()
                    .min(self.mesh_canopy.len())
                    .min(self.band_canopy.len()),
                "lod",
            ),
            (aovs.species, self.species.len(), "species"),
            (
                aovs.samples,
                self.samples.len().min(self.shadow_rays.len()),
                "samples",
            ),
        ] {
            if asked && kept != n {
                return Err(format!("the render did not keep the {name} layer"));
            }
        }
        // No image may carry a NaN or an infinity in colour or an AOV (a compositor's blur
        // would spread it); half floats hold at most 65504, beyond which values are clamped
        // and counted rather than turned into infinities.
        let clamped = std::cell::Cell::new(0usize);
        let samples = |v: Vec<f32>| {
            let v = v.into_iter().map(|x| if x.is_finite() { x } else { 0.0 });
            if half {
                FlatSamples::F16(
                    v.map(|x| {
                        if x.abs() > HALF_MAX {
                            clamped.set(clamped.get() + 1);
                        }
                        f16::from_f32(x.clamp(-HALF_MAX, HALF_MAX))
                    })
                    .collect(),
                )
            } else {
                FlatSamples::F32(v.collect())
            }
        };
        let finite = |v: &[f32]| -> Vec<f32> {
            v.iter()
                .map(|&x| if x.is_finite() { x } else { 0.0 })
                .collect()
        };
        let column = |f: &dyn Fn(usize) -> f32| (0..self.rgba.len()).map(f).collect::<Vec<f32>>();
        let mut channels = vec![
            AnyChannel::new("R", samples(column(&|i| self.rgba[i][0]))),
            AnyChannel::new("G", samples(column(&|i| self.rgba[i][1]))),
            AnyChannel::new("B", samples(column(&|i| self.rgba[i][2]))),
            AnyChannel::new("A", samples(column(&|i| self.rgba[i][3]))),
            // Depth stays float: half would lose metres at a few kilometres.
            AnyChannel::new(
                "Z",
                FlatSamples::F32(
                    self.z
                        .iter()
                        .map(|&z| if z.is_nan() { f32::INFINITY } else { z })
                        .collect(),
                ),
            ),
        ];
        if aovs.normal {
            for (c, name) in ["N.X", "N.Y", "N.Z"].iter().enumerate() {
                channels.push(AnyChannel::new(
                    *name,
                    samples(column(&|i| self.normal[i][c])),
                ));
            }
        }
        if aovs.albedo {
            for (c, name) in ["albedo.R", "albedo.G", "albedo.B"].iter().enumerate() {
                channels.push(AnyChannel::new(
                    *name,
                    samples(column(&|i| self.albedo[i][c])),
                ));
            }
        }
        if aovs.canopy {
            channels.push(AnyChannel::new("canopy.A", samples(self.canopy.clone())));
        }
        if aovs.lod {
            // Coverage by representation: the two add up to canopy.A.
            channels.push(AnyChannel::new(
                "lod_mesh.A",
                samples(self.mesh_canopy.clone()),
            ));
            channels.push(AnyChannel::new(
                "lod_texel.A",
                samples(column(&|i| (self.canopy[i] - self.mesh_canopy[i]).max(0.0))),
            ));
            // Of that canopy, what trees in the transition band drew (either way, by chance):
            // where a moving camera would see trees change representation.
            channels.push(AnyChannel::new(
                "lod_band.A",
                samples(self.band_canopy.clone()),
            ));
        }
        if aovs.species {
            channels.push(AnyChannel::new(
                "species.X",
                FlatSamples::F32(finite(&self.species)),
            ));
        }
        if aovs.samples {
            channels.push(AnyChannel::new(
                "samples_view.X",
                FlatSamples::F32(finite(&self.samples)),
            ));
            channels.push(AnyChannel::new(
                "samples_shadow.X",
                FlatSamples::F32(finite(&self.shadow_rays)),
            ));
        }
        Ok((channels, clamped.get()))
    }

    /// The Cryptomatte types: species (with the terrain and the sky) and trees. Each pixel's
    /// objects, and the background (the transparent sky) covering the rest.
    fn cryptomatte_layers(&self, names: &MatteNames) -> [cryptomatte::Layer; 2] {
        let n = self.mattes.len();
        let layer = |name: &str,
                     ranks: &dyn Fn(&Mattes) -> &matte::Ranks,
                     object_name: &dyn Fn(u32) -> String| {
            cryptomatte::Layer::new(
                name,
                matte::RANKS,
                n,
                |i| {
                    let background = (None, 1.0 - self.rgba[i][3]);
                    ranks(&self.mattes[i])
                        .iter()
                        .map(|&(o, c)| (Some(o), c))
                        .chain(std::iter::once(background))
                },
                object_name,
            )
        };
        [
            layer("CryptoSpecies", &|m| &m.species, &|o| {
                names.species(o).to_string()
            }),
            layer("CryptoInstance", &|m| &m.trees, &|o| names.tree(o)),
        ]
    }

    /// Mean volume samples and shadow rays per pixel over the whole window, as rendered
    /// (whether or not the film kept them per pixel).
    pub fn work(&self) -> (f64, f64) {
        let n = self.rgba.len().max(1) as f64;
        (self.work[0] / n, self.work[1] / n)
    }

    /// An sRGB picture for people: the radiance composited over `sky` (linear), clipped.
    pub fn preview(&self, sky: Vec3) -> image::RgbImage {
        image::RgbImage::from_fn(self.width, self.height, |x, y| {
            let p = self.rgba[(x + self.width * y) as usize];
            let rgb = Vec3::new(p[0], p[1], p[2]) + sky * (1.0 - p[3]);
            image::Rgb(to_srgb8(rgb.to_array()))
        })
    }
}
