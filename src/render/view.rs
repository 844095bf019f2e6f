//! Where a render's camera and sun come from: the flags, a glTF's camera node or directional
//! light, or defaults that frame the forest in afternoon light.

use glam::DVec3;

use super::{Camera, Sun};
use crate::import::{SceneCamera, SceneSun};

/// Afternoon light from the south-west (compass azimuth and elevation, degrees).
pub const DEFAULT_SUN: (f64, f64) = (225.0, 35.0);
/// Vertical field of view, degrees.
pub const DEFAULT_FOV: f64 = 35.0;
/// The default view: from the south-south-west, 25 degrees up.
pub const DEFAULT_VIEW: (f64, f64) = (200.0, 25.0);

/// How the camera is chosen.
pub enum CameraChoice<'a> {
    /// `--eye` and `--target`, world metres.
    LookAt { eye: [f64; 3], target: [f64; 3] },
    /// A camera node of the glTF, by name.
    Named(&'a str),
    /// A view that frames the box `lo..hi` from [`DEFAULT_VIEW`].
    Frame { lo: DVec3, hi: DVec3 },
}

/// The camera `choice` asks for, `width` x `height` pixels; `fov` (degrees) overrides the
/// glTF camera's and the default; `cameras` are the glTF's perspective camera nodes and
/// `orthographic` the names its orthographic cameras answer to. Errors name the flag.
pub fn camera(
    choice: CameraChoice,
    fov: Option<f64>,
    (width, height): (u32, u32),
    cameras: &[SceneCamera],
    orthographic: &[String],
) -> Result<Camera, String> {
    let degrees = fov.unwrap_or(DEFAULT_FOV);
    match choice {
        CameraChoice::LookAt { eye, target } => Camera::look_at(
            DVec3::from(eye),
            DVec3::from(target),
            degrees,
            width,
            height,
        )
        .map_err(|e| format!("--eye/--target: {e}")),
        CameraChoice::Named(name) => {
            let found = cameras
                .iter()
                .find(|c| c.name == name)
                .or_else(|| cameras.iter().find(|c| c.node.as_deref() == Some(name)));
            let Some(c) = found else {
                if orthographic.iter().any(|o| o == name) {
                    return Err(format!(
                        "--camera {name:?} is an orthographic camera: texel render draws \
                         perspective cameras only"
                    ));
                }
                // Each camera once (nodes may share one), with its node where that is named
                // otherwise.
                let mut names: Vec<String> = Vec::new();
                for c in cameras {
                    let shown = match &c.node {
                        Some(n) if *n != c.name => format!("{} (node {n})", c.name),
                        _ => c.name.clone(),
                    };
                    if !names.contains(&shown) {
                        names.push(shown);
                    }
                }
                return Err(format!(
                    "--camera {name:?}: no perspective camera or camera node of that name (the glTF has: {})",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                ));
            };
            let vfov = fov.map_or(c.yfov, f64::to_radians);
            Camera::from_frame(c.eye, c.forward, c.up, vfov, width, height)
                .map_err(|e| format!("--camera {name:?}: {e}"))
        }
        CameraChoice::Frame { lo, hi } => {
            Camera::framing(lo, hi, DEFAULT_VIEW, degrees, width, height)
                .map_err(|e| format!("framing the forest: {e}"))
        }
    }
}

/// The sun: `angles` (compass azimuth and elevation, degrees) where given, else the glTF's
/// first directional light, else [`DEFAULT_SUN`]. Irradiance pi: a white Lambertian surface
/// facing it unshadowed has radiance 1.
pub fn sun(angles: Option<[f64; 2]>, suns: &[SceneSun]) -> Sun {
    let irradiance = std::f32::consts::PI;
    match (angles, suns.first()) {
        (Some([az, el]), _) => Sun::from_angles(az, el, irradiance),
        (None, Some(light)) => Sun {
            direction: light.towards.as_vec3(),
            irradiance,
        },
        (None, None) => Sun::from_angles(DEFAULT_SUN.0, DEFAULT_SUN.1, irradiance),
    }
}
