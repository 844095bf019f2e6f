//! Species descriptions (`formats/species.md`): what each tree species is (the paper's five
//! traits), where it grows (habitat suitability over terrain attributes), how far apart and how
//! tall, and how its foliage changes over the year.
//!
//! Parsing refuses unknown keys and names the JSON path of every problem.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::input::InputError;

/// The value of `format` every species file carries.
pub const FORMAT: &str = "texel-forest species 1";

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpeciesFile {
    pub format: String,
    #[serde(default)]
    pub analysis: Analysis,
    pub species: Vec<Species>,
}

/// How the terrain is analysed for every species.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Analysis {
    /// Radius (m) of the neighbourhood topographic position compares a point with.
    pub tpi_radius: f64,
    /// Below this suitability for every species, ground stays open.
    pub min_suitability: f64,
}

impl Default for Analysis {
    fn default() -> Self {
        Analysis {
            tpi_radius: 250.0,
            min_suitability: 0.05,
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Species {
    pub name: String,
    /// The tree's texture, relative to the species file.
    pub texel: PathBuf,
    /// A leafless texture for deciduous trees in winter, relative to the species file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub leafless_texel: Option<PathBuf>,
    pub traits: Traits,
    #[serde(default)]
    pub habitat: Habitat,
    /// Radius (m) of the disc a tree of the species' mean height keeps free of other trees;
    /// it scales with the tree's height.
    pub spacing: f64,
    /// Tree height (m), drawn uniformly between these.
    pub height: Range,
    pub seasons: Seasons,
}

/// The paper's five traits.
#[derive(
    Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, bincode::Encode, bincode::Decode,
)]
#[serde(deny_unknown_fields)]
pub struct Traits {
    pub form: Form,
    pub light: Light,
    pub leaf_habit: LeafHabit,
    pub leaf_out: LeafOut,
    #[serde(rename = "autumn_colour")]
    pub autumn_color: AutumnColor,
}

#[derive(
    Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, bincode::Encode, bincode::Decode,
)]
#[serde(rename_all = "snake_case")]
pub enum Form {
    Conifer,
    Broadleaf,
}

#[derive(
    Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, bincode::Encode, bincode::Decode,
)]
#[serde(rename_all = "snake_case")]
pub enum Light {
    ShadeTolerant,
    SunLoving,
}

#[derive(
    Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, bincode::Encode, bincode::Decode,
)]
#[serde(rename_all = "snake_case")]
pub enum LeafHabit {
    Evergreen,
    Deciduous,
}

#[derive(
    Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, bincode::Encode, bincode::Decode,
)]
#[serde(rename_all = "snake_case")]
pub enum LeafOut {
    Successive,
    Simultaneous,
}

#[derive(
    Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq, bincode::Encode, bincode::Decode,
)]
#[serde(rename_all = "snake_case")]
pub enum AutumnColor {
    Red,
    Yellow,
    None,
}

#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Range {
    pub min: f64,
    pub max: f64,
}

/// Suitability over terrain attributes: the product of the factors given (absent = no
/// preference).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Habitat {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elevation: Option<Band>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slope: Option<Band>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aspect: Option<Preference>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub topographic_position: Option<Preference>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wetness: Option<Preference>,
}

/// 1 within [min, max], falling linearly to 0 over `margin` outside.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Band {
    #[serde(default = "neg_inf")]
    pub min: f64,
    #[serde(default = "pos_inf")]
    pub max: f64,
    #[serde(default)]
    pub margin: f64,
}

fn neg_inf() -> f64 {
    f64::NEG_INFINITY
}
fn pos_inf() -> f64 {
    f64::INFINITY
}

/// `exp(-((x - preferred) / tolerance)^2 / 2)`: 1 at the preferred value, 0.61 one tolerance away.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Preference {
    pub preferred: f64,
    pub tolerance: f64,
}

/// Foliage through the year: keyframes by day of year (1..=366), interpolated linearly and
/// wrapping from the last keyframe of one year to the first of the next.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq, bincode::Encode, bincode::Decode)]
#[serde(deny_unknown_fields)]
pub struct Seasons {
    pub foliage: Vec<ColorKey>,
    pub leaf_fraction: Vec<FractionKey>,
}

#[derive(
    Clone, Copy, Debug, Deserialize, Serialize, PartialEq, bincode::Encode, bincode::Decode,
)]
#[serde(deny_unknown_fields)]
pub struct ColorKey {
    pub day: f64,
    /// Linear RGB albedo of the foliage.
    pub albedo: [f64; 3],
}

#[derive(
    Clone, Copy, Debug, Deserialize, Serialize, PartialEq, bincode::Encode, bincode::Decode,
)]
#[serde(deny_unknown_fields)]
pub struct FractionKey {
    pub day: f64,
    /// Fraction of the full foliage present, 0..1.
    pub value: f64,
}

/// A species file that cannot be read or is not valid: the file, the JSON path of the field
/// at fault (empty for the file as a whole) and the problem.
#[derive(Debug, thiserror::Error)]
#[error("{}: {}{message}", file.display(), if field.is_empty() { String::new() } else { format!("{field}: ") })]
pub struct SpeciesError {
    pub file: PathBuf,
    pub field: String,
    pub message: String,
}

impl Band {
    pub fn factor(&self, x: f64) -> f64 {
        let outside = (self.min - x).max(x - self.max);
        if outside <= 0.0 {
            1.0
        } else if self.margin > 0.0 {
            (1.0 - outside / self.margin).max(0.0)
        } else {
            0.0
        }
    }
}

impl Preference {
    pub fn factor(&self, x: f64) -> f64 {
        let d = (x - self.preferred) / self.tolerance;
        (-0.5 * d * d).exp()
    }

    /// For angles in degrees: the difference wraps around the circle.
    pub fn circular_factor(&self, degrees: f64) -> f64 {
        let d = (degrees - self.preferred + 180.0).rem_euclid(360.0) - 180.0;
        self.factor(self.preferred + d)
    }
}

impl Habitat {
    /// Suitability in 0..1 from the attributes at a point: elevation (m), slope (degrees),
    /// aspect (degrees, -1 on flats: no aspect preference applies there), topographic
    /// position (m) and wetness (index).
    pub fn suitability(&self, attributes: [f64; 5]) -> f64 {
        let [elevation, slope, aspect, tpi, wetness] = attributes;
        if attributes.iter().any(|a| a.is_nan()) {
            return 0.0;
        }
        let mut s = 1.0;
        if let Some(b) = &self.elevation {
            s *= b.factor(elevation);
        }
        if let Some(b) = &self.slope {
            s *= b.factor(slope);
        }
        if let (Some(p), true) = (&self.aspect, aspect >= 0.0) {
            s *= p.circular_factor(aspect);
        }
        if let Some(p) = &self.topographic_position {
            s *= p.factor(tpi);
        }
        if let Some(p) = &self.wetness {
            s *= p.factor(wetness);
        }
        s
    }
}

/// Linear interpolation over the year with wrap-around. `keys` are sorted by day.
fn interpolate<const N: usize>(keys: &[(f64, [f64; N])], day: f64) -> [f64; N] {
    let day = (day - 1.0).rem_euclid(366.0) + 1.0;
    let n = keys.len();
    if n == 1 {
        return keys[0].1;
    }
    // The keyframe at or before `day`, wrapping to the previous year's last.
    let next = keys.iter().position(|k| k.0 > day).unwrap_or(n);
    let (a, b) = if next == 0 || next == n {
        (keys[n - 1], keys[0])
    } else {
        (keys[next - 1], keys[next])
    };
    let span = (b.0 - a.0).rem_euclid(366.0);
    let t = if span > 0.0 {
        (day - a.0).rem_euclid(366.0) / span
    } else {
        0.0
    };
    std::array::from_fn(|i| a.1[i] + (b.1[i] - a.1[i]) * t)
}

impl Seasons {
    /// Foliage albedo (linear RGB) on `day` of the year.
    pub fn albedo(&self, day: f64) -> [f64; 3] {
        let keys: Vec<(f64, [f64; 3])> = self.foliage.iter().map(|k| (k.day, k.albedo)).collect();
        interpolate(&keys, day)
    }

    /// Leaf fraction on `day` of the year.
    pub fn leaf_fraction(&self, day: f64) -> f64 {
        let keys: Vec<(f64, [f64; 1])> = self
            .leaf_fraction
            .iter()
            .map(|k| (k.day, [k.value]))
            .collect();
        interpolate(&keys, day)[0]
    }
}

impl Species {
    /// The mean height, at which a tree keeps exactly `spacing` free around it.
    pub fn reference_height(&self) -> f64 {
        0.5 * (self.height.min + self.height.max)
    }

    /// Radius of the disc a tree of height `h` keeps free.
    pub fn radius(&self, h: f64) -> f64 {
        self.spacing * h / self.reference_height()
    }
}

impl SpeciesFile {
    /// Reads (no more than a species file may hold) and validates a species file.
    pub fn load(path: &Path) -> Result<SpeciesFile, SpeciesError> {
        Ok(SpeciesFile::read(path)?.1)
    }

    /// [`SpeciesFile::load`], with the bytes read (to record the file by its hash).
    pub fn read(path: &Path) -> Result<(Vec<u8>, SpeciesFile), SpeciesError> {
        let error = |field: &str, message: String| SpeciesError {
            file: path.to_path_buf(),
            field: field.to_string(),
            message,
        };
        let bytes = crate::input::read_bounded(path, crate::input::MAX_SPECIES, "species file")
            .map_err(|e| match e {
                InputError::Io { source, .. } => error("", format!("cannot read: {source}")),
                InputError::TooLarge { limit, what, .. } => error(
                    "",
                    format!("larger than the {limit} bytes a {what} may have"),
                ),
            })?;
        let file = SpeciesFile::parse(&bytes).map_err(|(field, message)| error(&field, message))?;
        Ok((bytes, file))
    }

    /// Parses and validates; errors are (JSON path, problem).
    pub fn parse(bytes: &[u8]) -> Result<SpeciesFile, (String, String)> {
        let file: SpeciesFile = crate::json_file::parse(bytes)?;
        file.validate()?;
        Ok(file)
    }

    fn validate(&self) -> Result<(), (String, String)> {
        let bad = |field: String, message: &str| Err((field, message.to_string()));
        if self.format != FORMAT {
            return bad(
                "format".into(),
                &format!("expected {FORMAT:?}, found {:?}", self.format),
            );
        }
        let a = &self.analysis;
        if !(a.tpi_radius.is_finite() && a.tpi_radius > 0.0) {
            return bad(
                "analysis.tpi_radius".into(),
                "must be a positive number of metres",
            );
        }
        if !(0.0..1.0).contains(&a.min_suitability) {
            return bad("analysis.min_suitability".into(), "must be in [0, 1)");
        }
        if self.species.is_empty() {
            return bad("species".into(), "is empty: name at least one species");
        }
        if self.species.len() > 255 {
            return bad("species".into(), "more than 255 species");
        }
        for (i, s) in self.species.iter().enumerate() {
            let f = |name: &str| format!("species[{i}].{name}");
            if s.name.trim().is_empty() {
                return bad(f("name"), "is empty");
            }
            if self.species[..i].iter().any(|o| o.name == s.name) {
                return bad(f("name"), &format!("{:?} names two species", s.name));
            }
            if !(s.spacing.is_finite() && s.spacing > 0.0) {
                return bad(f("spacing"), "must be a positive number of metres");
            }
            let h = s.height;
            if !(h.min.is_finite() && h.max.is_finite() && h.min > 0.0 && h.min <= h.max) {
                return bad(f("height"), "needs 0 < min <= max, in metres");
            }
            for (name, p) in [
                ("aspect", &s.habitat.aspect),
                ("topographic_position", &s.habitat.topographic_position),
                ("wetness", &s.habitat.wetness),
            ] {
                if let Some(p) = p
                    && !(p.tolerance.is_finite() && p.tolerance > 0.0 && p.preferred.is_finite())
                {
                    return bad(
                        f(&format!("habitat.{name}")),
                        "needs a finite preferred value and a positive tolerance",
                    );
                }
            }
            for (name, b) in [
                ("elevation", &s.habitat.elevation),
                ("slope", &s.habitat.slope),
            ] {
                if let Some(b) = b
                    && !(b.min <= b.max && b.margin >= 0.0 && b.margin.is_finite())
                {
                    return bad(
                        f(&format!("habitat.{name}")),
                        "needs min <= max and a margin >= 0",
                    );
                }
            }
            s.seasons.validate(&f("seasons"))?;
        }
        Ok(())
    }
}

impl Seasons {
    /// Keyframe days within 1..=366 and increasing, albedos and leaf fractions within [0, 1];
    /// `field` is the JSON path of the series, for the error.
    pub fn validate(&self, field: &str) -> Result<(), (String, String)> {
        let bad = |at: String, message: &str| Err((at, message.to_string()));
        validate_keys(
            &self.foliage.iter().map(|k| k.day).collect::<Vec<_>>(),
            &format!("{field}.foliage"),
        )?;
        validate_keys(
            &self.leaf_fraction.iter().map(|k| k.day).collect::<Vec<_>>(),
            &format!("{field}.leaf_fraction"),
        )?;
        for (k, key) in self.foliage.iter().enumerate() {
            if key.albedo.iter().any(|c| !(0.0..=1.0).contains(c)) {
                return bad(
                    format!("{field}.foliage[{k}].albedo"),
                    "components must be linear values in [0, 1]",
                );
            }
        }
        for (k, key) in self.leaf_fraction.iter().enumerate() {
            if !(0.0..=1.0).contains(&key.value) {
                return bad(
                    format!("{field}.leaf_fraction[{k}].value"),
                    "must be in [0, 1]",
                );
            }
        }
        Ok(())
    }
}

fn validate_keys(days: &[f64], field: &str) -> Result<(), (String, String)> {
    if days.is_empty() {
        return Err((
            field.to_string(),
            "is empty: give at least one keyframe".into(),
        ));
    }
    for (k, d) in days.iter().enumerate() {
        if !(1.0..=366.0).contains(d) {
            return Err((
                format!("{field}[{k}].day"),
                format!("{d} is not a day of the year (1 to 366)"),
            ));
        }
        if k > 0 && *d <= days[k - 1] {
            return Err((format!("{field}[{k}].day"), "days must increase".into()));
        }
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) const MINIMAL: &str = r#"{
        "format": "texel-forest species 1",
        "species": [{
            "name": "beech", "texel": "beech.texel",
            "traits": { "form": "broadleaf", "light": "shade_tolerant", "leaf_habit": "deciduous",
                        "leaf_out": "successive", "autumn_colour": "yellow" },
            "spacing": 4, "height": { "min": 10, "max": 20 },
            "seasons": {
                "foliage": [{ "day": 120, "albedo": [0.05, 0.12, 0.03] }, { "day": 300, "albedo": [0.25, 0.12, 0.03] }],
                "leaf_fraction": [{ "day": 100, "value": 0 }, { "day": 130, "value": 1 }, { "day": 310, "value": 1 }, { "day": 330, "value": 0 }]
            }
        }]
    }"#;

    #[test]
    fn a_minimal_file_parses_with_defaults() {
        let f = SpeciesFile::parse(MINIMAL.as_bytes()).unwrap();
        assert_eq!(f.analysis, Analysis::default());
        assert_eq!(f.species[0].radius(15.0), 4.0);
        assert_eq!(f.species[0].radius(20.0), 4.0 * 20.0 / 15.0);
    }

    fn error_of(edit: impl Fn(&mut serde_json::Value)) -> (String, String) {
        let mut v: serde_json::Value = serde_json::from_str(MINIMAL).unwrap();
        edit(&mut v);
        SpeciesFile::parse(&serde_json::to_vec(&v).unwrap()).unwrap_err()
    }

    /// A second document after the first (a paste gone wrong) is refused, not ignored.
    #[test]
    fn anything_after_the_document_is_refused() {
        let twice = format!("{MINIMAL}\n{{\"format\": \"bogus\"}}");
        let (field, why) = SpeciesFile::parse(twice.as_bytes()).unwrap_err();
        assert!(
            field.is_empty() && why.contains("trailing characters"),
            "{why}"
        );
    }

    #[test]
    fn errors_name_the_field() {
        let (field, msg) = error_of(|v| v["species"][0]["heigth"] = serde_json::json!(3));
        assert_eq!(field, "species[0].heigth");
        assert!(msg.contains("unknown field `heigth`"), "{msg}");
        assert_eq!(
            error_of(|v| v["species"][0]["spacing"] = serde_json::json!(0)).0,
            "species[0].spacing"
        );
        assert_eq!(
            error_of(|v| v["species"][0]["spacing"] = serde_json::json!(-2.5)).0,
            "species[0].spacing"
        );
        assert_eq!(
            error_of(|v| v["species"][0]["seasons"]["foliage"] = serde_json::json!([])).0,
            "species[0].seasons.foliage"
        );
        assert_eq!(
            error_of(|v| v["species"][0]["traits"]["form"] = serde_json::json!("fern")).0,
            "species[0].traits.form"
        );
        assert_eq!(
            error_of(|v| v["species"] = serde_json::json!([])).0,
            "species"
        );
        assert_eq!(
            error_of(|v| v["format"] = serde_json::json!("v2")).0,
            "format"
        );
        let (field, _) = error_of(|v| {
            v["species"][0]["seasons"]["leaf_fraction"][2]["day"] = serde_json::json!(120)
        });
        assert_eq!(field, "species[0].seasons.leaf_fraction[2].day");
    }

    #[test]
    fn seasons_interpolate_and_wrap_around_the_year() {
        let f = SpeciesFile::parse(MINIMAL.as_bytes()).unwrap();
        let s = &f.species[0].seasons;
        assert_eq!(s.leaf_fraction(115.0), 0.5);
        assert_eq!(s.leaf_fraction(200.0), 1.0);
        assert_eq!(s.leaf_fraction(20.0), 0.0); // winter, wrapping from day 330 to day 100
        let mid = s.albedo(210.0);
        assert!((mid[0] - 0.15).abs() < 1e-12);
        // Between day 300 and next year's day 120 the colour goes back.
        let winter = s.albedo(1.0);
        assert!(winter[0] > 0.05 && winter[0] < 0.25);
    }

    #[test]
    fn suitability_factors() {
        let b = Band {
            min: 0.0,
            max: 10.0,
            margin: 5.0,
        };
        assert_eq!(
            (b.factor(5.0), b.factor(12.5), b.factor(20.0)),
            (1.0, 0.5, 0.0)
        );
        let p = Preference {
            preferred: 350.0,
            tolerance: 30.0,
        };
        assert!((p.circular_factor(20.0) - (-0.5f64).exp()).abs() < 1e-12);
        let h = Habitat {
            slope: Some(Band {
                min: f64::NEG_INFINITY,
                max: 30.0,
                margin: 0.0,
            }),
            ..Default::default()
        };
        assert_eq!(h.suitability([100.0, 35.0, 0.0, 0.0, 5.0]), 0.0);
        assert_eq!(h.suitability([100.0, 25.0, 0.0, 0.0, f64::NAN]), 0.0);
    }
}
