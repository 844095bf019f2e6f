//! Camera paths: where the camera is at any time of an animation, from a keyframe file
//! (`formats/camera-path.md`) or an animated camera node of a glTF (`import::animation`).
//! A frame's camera depends only on its time, so any frame renders alone exactly as it
//! renders inside its sequence.

use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::Deserialize;

use super::Camera;
use crate::import::{self, CameraAnimation};
use crate::input::InputError;
use crate::limits::Limits;

/// The keyframe file's `format`.
pub const FORMAT: &str = "texel-forest camera path 1";

/// Largest keyframe file read: far beyond any hand-written or exported path.
const MAX_BYTES: u64 = 16 << 20;

/// A camera that moves.
#[derive(Clone, Debug)]
pub enum CameraPath {
    Keys(Keyframes),
    Gltf(CameraAnimation),
}

/// A keyframe file, read and checked.
#[derive(Clone, Debug)]
pub struct Keyframes {
    interpolation: Interpolation,
    keys: Vec<Key>,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum Interpolation {
    /// Eye, target and field of view move at a constant rate from key to key.
    #[default]
    Linear,
    /// Each key holds until the next.
    Step,
}

#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Key {
    time: f64,
    eye: [f64; 3],
    target: [f64; 3],
    #[serde(default)]
    fov: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    format: String,
    #[serde(default)]
    interpolation: Interpolation,
    keys: Vec<Key>,
}

/// Where the camera is at one time: its eye, viewing direction, up, and vertical field of view
/// (radians) where the path gives one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub eye: DVec3,
    pub forward: DVec3,
    pub up: DVec3,
    pub yfov: Option<f64>,
}

/// Why a camera path could not be read. Names the file and the JSON path of the problem.
#[derive(Debug, thiserror::Error)]
pub enum PathError {
    #[error("{file}: {}{message}", if field.is_empty() { String::new() } else { format!("{field}: ") })]
    Keys {
        file: PathBuf,
        field: String,
        message: String,
    },
    #[error(transparent)]
    Gltf(#[from] import::ImportError),
}

impl CameraPath {
    /// Reads `path`: a keyframe file if it ends in `.json`, else a glTF whose camera `camera`
    /// (or, unnamed, the first one an animation moves) is followed. Also returns every file
    /// read, for depfiles.
    pub fn load(
        path: &Path,
        camera: Option<&str>,
        limits: &Limits,
    ) -> Result<(CameraPath, Vec<PathBuf>), PathError> {
        let is_json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        if is_json {
            if let Some(name) = camera {
                return Err(PathError::Keys {
                    file: path.to_path_buf(),
                    field: String::new(),
                    message: format!(
                        "--camera {name:?} names a glTF camera, and this is a keyframe file \
                         (.json), which holds one camera"
                    ),
                });
            }
            return Ok((
                CameraPath::Keys(Keyframes::read(path)?),
                vec![path.to_path_buf()],
            ));
        }
        let (animation, sources) = import::load_camera_animation(path, camera, limits)?;
        Ok((
            CameraPath::Gltf(animation),
            sources.into_iter().map(|s| s.path).collect(),
        ))
    }

    /// The first and last time the path moves (seconds).
    pub fn span(&self) -> (f64, f64) {
        match self {
            CameraPath::Keys(k) => (k.keys[0].time, k.keys[k.keys.len() - 1].time),
            CameraPath::Gltf(a) => (a.start, a.end),
        }
    }

    pub fn pose(&self, time: f64) -> Pose {
        match self {
            CameraPath::Keys(k) => k.pose(time),
            CameraPath::Gltf(a) => {
                let c = a.at(time);
                Pose {
                    eye: c.eye,
                    forward: c.forward,
                    up: c.up,
                    yfov: Some(c.yfov),
                }
            }
        }
    }

    /// The camera at `time`, `width` x `height` pixels; `fov` (degrees) overrides the path's
    /// and `default_fov` (degrees) stands in where the path gives none.
    pub fn camera(
        &self,
        time: f64,
        fov: Option<f64>,
        default_fov: f64,
        (width, height): (u32, u32),
    ) -> Result<Camera, String> {
        let p = self.pose(time);
        let vfov = fov
            .map(f64::to_radians)
            .or(p.yfov)
            .unwrap_or(default_fov.to_radians());
        Camera::from_frame(p.eye, p.forward, p.up, vfov, width, height)
            .map_err(|e| format!("the camera path at {time} s: {e}"))
    }
}

impl Keyframes {
    pub fn read(path: &Path) -> Result<Keyframes, PathError> {
        let error = |field: &str, message: String| PathError::Keys {
            file: path.to_path_buf(),
            field: field.to_string(),
            message,
        };
        let bytes =
            crate::input::read_bounded(path, MAX_BYTES, "camera path").map_err(|e| match e {
                InputError::Io { source, .. } => error("", format!("cannot read: {source}")),
                InputError::TooLarge { limit, what, .. } => error(
                    "",
                    format!("larger than the {limit} bytes a {what} may have"),
                ),
            })?;
        Keyframes::parse(&bytes).map_err(|(field, message)| error(&field, message))
    }

    /// Parses and checks; errors are (JSON path, problem).
    pub fn parse(bytes: &[u8]) -> Result<Keyframes, (String, String)> {
        let file: File = crate::json_file::parse(bytes)?;
        let bad = |field: String, message: String| Err((field, message));
        if file.format != FORMAT {
            return bad(
                "format".into(),
                format!("expected {FORMAT:?}, found {:?}", file.format),
            );
        }
        if file.keys.is_empty() {
            return bad("keys".into(), "is empty: give at least one key".into());
        }
        let with_fov = file.keys[0].fov.is_some();
        for (i, k) in file.keys.iter().enumerate() {
            let f = |name: &str| format!("keys[{i}].{name}");
            if !k.time.is_finite() {
                return bad(f("time"), "must be a finite number of seconds".into());
            }
            if i > 0 && k.time <= file.keys[i - 1].time {
                return bad(
                    f("time"),
                    format!(
                        "{} is not after keys[{}].time {} (times must increase)",
                        k.time,
                        i - 1,
                        file.keys[i - 1].time
                    ),
                );
            }
            for (name, v) in [("eye", k.eye), ("target", k.target)] {
                if !v.iter().all(|x| x.is_finite()) {
                    return bad(f(name), "must be three finite numbers (metres)".into());
                }
            }
            if let Some(e) = super::camera::eye_error(DVec3::from(k.eye)) {
                return bad(f("eye"), e);
            }
            if k.eye == k.target {
                return bad(
                    f("target"),
                    "is the eye: the camera would look nowhere".into(),
                );
            }
            match k.fov {
                Some(v) if !super::camera::fov_ok(v) => {
                    return bad(f("fov"), super::camera::fov_error(v));
                }
                Some(_) if !with_fov => {
                    return bad(
                        f("fov"),
                        "keys[0] has no fov: give every key a fov or none".into(),
                    );
                }
                None if with_fov => {
                    return bad(
                        f("fov"),
                        "is missing, and keys[0] has one: give every key a fov or none".into(),
                    );
                }
                _ => {}
            }
        }
        Ok(Keyframes {
            interpolation: file.interpolation,
            keys: file.keys,
        })
    }

    /// The pose at `time`: the first key's before it, the last's after.
    pub fn pose(&self, time: f64) -> Pose {
        let keys = &self.keys;
        let pose = |eye: DVec3, target: DVec3, fov: Option<f64>| Pose {
            eye,
            forward: crate::geom::direction(target - eye),
            up: DVec3::Y,
            yfov: fov.map(f64::to_radians),
        };
        let key = |k: &Key| pose(DVec3::from(k.eye), DVec3::from(k.target), k.fov);
        // NaN times fall to the first key.
        let k = keys.partition_point(|k| k.time <= time);
        if k == 0 {
            return key(&keys[0]);
        }
        if k == keys.len() || self.interpolation == Interpolation::Step {
            return key(&keys[k - 1]);
        }
        let (a, b) = (&keys[k - 1], &keys[k]);
        let u = (time - a.time) / (b.time - a.time);
        let lerp = |p: [f64; 3], q: [f64; 3]| DVec3::from(p).lerp(DVec3::from(q), u);
        let (eye, target) = (lerp(a.eye, b.eye), lerp(a.target, b.target));
        // Eye and target may meet between keys that never coincide: look along the segment's
        // mean direction there rather than nowhere.
        let target = if eye == target {
            eye + (DVec3::from(a.target) - DVec3::from(a.eye) + DVec3::from(b.target)
                - DVec3::from(b.eye))
        } else {
            target
        };
        let fov = a.fov.zip(b.fov).map(|(x, y)| x + (y - x) * u);
        pose(eye, target, fov)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(json: &str) -> Result<Keyframes, (String, String)> {
        Keyframes::parse(json.as_bytes())
    }

    const TWO: &str = r#"{ "format": "texel-forest camera path 1", "keys": [
        { "time": 1, "eye": [0, 10, 0], "target": [0, 10, -5], "fov": 30 },
        { "time": 3, "eye": [20, 10, 0], "target": [20, 10, -5], "fov": 50 } ] }"#;

    #[test]
    fn keyframes_move_linearly_between_keys_and_hold_outside_them() {
        let k = keys(TWO).unwrap();
        let p = k.pose(1.5);
        assert_eq!(p.eye, DVec3::new(5.0, 10.0, 0.0));
        assert_eq!(p.forward, DVec3::new(0.0, 0.0, -1.0));
        assert!((p.yfov.unwrap() - 35f64.to_radians()).abs() < 1e-12);
        for (t, eye) in [
            (-4.0, 0.0),
            (1.0, 0.0),
            (3.0, 20.0),
            (99.0, 20.0),
            (f64::NAN, 0.0),
        ] {
            assert_eq!(k.pose(t).eye.x, eye, "at {t}");
        }
        let step = keys(&TWO.replace("\"keys\"", "\"interpolation\": \"step\", \"keys\"")).unwrap();
        assert_eq!(step.pose(2.9).eye.x, 0.0);
        assert_eq!(step.pose(3.0).eye.x, 20.0);
        // Where eye and target cross between keys, the camera looks along the keys' mean
        // direction rather than nowhere.
        let crossing = keys(
            r#"{ "format": "texel-forest camera path 1", "keys": [
            { "time": 0, "eye": [0, 0, 0], "target": [10, 0, 0] },
            { "time": 3, "eye": [30, 0, 0], "target": [0, 0, 0] } ] }"#,
        )
        .unwrap();
        let p = crossing.pose(0.75);
        assert_eq!(
            (p.eye, p.forward, p.yfov),
            (DVec3::X * 7.5, DVec3::NEG_X, None)
        );
    }

    #[test]
    fn bad_keyframe_files_are_refused_naming_the_field() {
        for (json, field, needle) in [
            (TWO.replace("path 1", "path 2"), "format", "expected"),
            (
                r#"{ "format": "texel-forest camera path 1", "keys": [] }"#.to_string(),
                "keys",
                "empty",
            ),
            (
                TWO.replace("\"time\": 3", "\"time\": 1"),
                "keys[1].time",
                "not after",
            ),
            (
                TWO.replace("[20, 10, -5]", "[20, 10, 0]"),
                "keys[1].target",
                "is the eye",
            ),
            (
                TWO.replace("\"fov\": 50", "\"fov\": 180"),
                "keys[1].fov",
                "179",
            ),
            (TWO.replace(", \"fov\": 50", ""), "keys[1].fov", "every key"),
            (
                TWO.replace("\"fov\": 30", "\"zoom\": 30"),
                "keys[0]",
                "zoom",
            ),
            (TWO.replace("[0, 10, 0]", "[0, 10]"), "keys[0].eye", ""),
            (
                TWO.replace("\"keys\"", "\"interpolation\": \"cubic\", \"keys\""),
                "interpolation",
                "cubic",
            ),
        ] {
            let (f, message) = keys(&json)
                .err()
                .unwrap_or_else(|| panic!("{json} accepted"));
            assert!(f.starts_with(field), "{field:?}: {f:?} {message}");
            assert!(message.contains(needle), "{needle:?} not in {message:?}");
        }
    }
}
