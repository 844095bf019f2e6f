//! A pinhole camera: primary rays per pixel and the matrices OpenEXR records.
//!
//! Rays start at the eye, which is the origin of the renderer's frame: every scene position is
//! stored relative to it, so a terrain 100 km from the world origin loses no precision in f32.

use glam::{DVec3, Vec3};

use crate::number::shortest;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// World position of the eye.
    pub eye: DVec3,
    /// Unit vectors: viewing direction, image right, image up.
    pub forward: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    /// Vertical field of view, radians.
    pub vfov: f64,
    pub width: u32,
    pub height: u32,
}

/// How far from the origin an eye may be (m). The frame's camera matrices are written in f32,
/// and every point is rendered relative to the eye in f32: beyond this they could not hold it
/// (and nothing placed on a terrain is this far off).
pub const EYE_LIMIT: f64 = 1e12;

/// The vertical fields of view a camera may have (degrees): from this up to, and not
/// including, [`FOV_MAX`]. Narrower, a pixel's direction is lost to rounding.
pub const FOV_MIN: f64 = 1e-3;
/// Wider, the image's edge runs to infinity on the image plane.
pub const FOV_MAX: f64 = 179.0;

/// Whether `degrees` is a vertical field of view a camera may have.
pub fn fov_ok(degrees: f64) -> bool {
    (FOV_MIN..FOV_MAX).contains(&degrees)
}

/// Why a field of view is refused, for `degrees` that [`fov_ok`] refuses.
pub fn fov_error(degrees: f64) -> String {
    format!(
        "{} degrees is not a field of view from {FOV_MIN} up to (not including) {FOV_MAX}",
        shortest(degrees)
    )
}

/// Why an eye is refused, where it lies beyond [`EYE_LIMIT`] (or is not finite).
pub fn eye_error(eye: DVec3) -> Option<String> {
    // NaN is beyond too.
    let within = eye.abs().max_element() <= EYE_LIMIT;
    (!within).then(|| {
        format!(
            "the eye ({}, {}, {}) lies beyond {EYE_LIMIT:e} m of the origin, more than the frame's f32 matrices hold",
            shortest(eye.x),
            shortest(eye.y),
            shortest(eye.z)
        )
    })
}

impl Camera {
    /// A camera at `eye` looking at `target`, +Y up (or +Z when looking straight up or down).
    pub fn look_at(
        eye: DVec3,
        target: DVec3,
        vfov_degrees: f64,
        width: u32,
        height: u32,
    ) -> Result<Camera, String> {
        if let Some(e) = eye_error(eye) {
            return Err(e);
        }
        let d = target - eye;
        if !d.is_finite() {
            return Err(format!(
                "the camera's eye {eye} and target {target} are too far apart to look along"
            ));
        }
        let forward = crate::geom::direction(d);
        if forward == DVec3::ZERO || !forward.is_finite() {
            return Err("the camera's eye and target coincide".into());
        }
        if !fov_ok(vfov_degrees) {
            return Err(fov_error(vfov_degrees));
        }
        if width == 0 || height == 0 {
            return Err("the image needs a width and a height of at least 1 pixel".into());
        }
        let hint = if forward.y.abs() > 0.999 {
            DVec3::Z
        } else {
            DVec3::Y
        };
        let right = forward.cross(hint).normalize();
        let up = right.cross(forward);
        Ok(Camera {
            eye,
            forward,
            right,
            up,
            vfov: vfov_degrees.to_radians(),
            width,
            height,
        })
    }

    /// A camera from a frame: viewing direction and an up hint (a glTF camera node's -Z, +Y).
    pub fn from_frame(
        eye: DVec3,
        forward: DVec3,
        up: DVec3,
        vfov: f64,
        width: u32,
        height: u32,
    ) -> Result<Camera, String> {
        if crate::geom::direction(forward) == DVec3::ZERO {
            return Err(
                "the camera has no viewing direction: its eye and target coincide (or lie beyond f64 apart), or its node's transform scales it to nothing (or beyond f64)"
                    .into(),
            );
        }
        Camera::look_at(eye, eye + forward, vfov.to_degrees(), width, height).map(|mut c| {
            let right = c.forward.cross(up).normalize_or_zero();
            if right != DVec3::ZERO {
                c.right = right;
                c.up = right.cross(c.forward);
            }
            c
        })
    }

    fn half_extent(&self) -> (f64, f64) {
        let h = (0.5 * self.vfov).tan();
        (h * self.width as f64 / self.height as f64, h)
    }

    /// Unit direction (renderer frame) through image point (px, py) in pixels, y down.
    pub fn direction(&self, px: f64, py: f64) -> Vec3 {
        let (hx, hy) = self.half_extent();
        let sx = (2.0 * px / self.width as f64 - 1.0) * hx;
        let sy = (1.0 - 2.0 * py / self.height as f64) * hy;
        (self.forward + self.right * sx + self.up * sy)
            .normalize()
            .as_vec3()
    }

    /// Angle a pixel subtends at the image centre, radians: the cone a ray stands for.
    pub fn pixel_angle(&self) -> f64 {
        2.0 * (0.5 * self.vfov).tan() / self.height as f64
    }

    /// OpenEXR `worldToCamera`: camera space is left-handed, x right, y up, z forward;
    /// stored for row vectors (p' = p M), as Imath does.
    pub fn world_to_camera(&self) -> [f32; 16] {
        let (r, u, f, e) = (self.right, self.up, self.forward, self.eye);
        let m = [
            [r.x, u.x, f.x, 0.0],
            [r.y, u.y, f.y, 0.0],
            [r.z, u.z, f.z, 0.0],
            [-r.dot(e), -u.dot(e), -f.dot(e), 1.0],
        ];
        std::array::from_fn(|i| m[i / 4][i % 4] as f32)
    }

    /// OpenEXR `worldToNDC`: to the image plane with (0, 0) the top-left and (1, 1) the
    /// bottom-right corner of the display window (after dividing by w), for row vectors.
    pub fn world_to_ndc(&self) -> [f32; 16] {
        let (hx, hy) = self.half_extent();
        // Camera (x, y, z) -> NDC ((x / (z hx) + 1) / 2, (1 - y / (z hy)) / 2) = (X / W, Y / W)
        // with X = x / (2 hx) + z / 2, Y = -y / (2 hy) + z / 2, W = z.
        let projection = [
            [0.5 / hx, 0.0, 0.0, 0.0],
            [0.0, -0.5 / hy, 0.0, 0.0],
            [0.5, 0.5, 1.0, 1.0],
            [0.0, 0.0, 0.0, 0.0],
        ];
        let c = self.world_to_camera();
        let cam: [[f64; 4]; 4] =
            std::array::from_fn(|i| std::array::from_fn(|j| c[4 * i + j] as f64));
        let mut m = [0.0f32; 16];
        for i in 0..4 {
            for j in 0..4 {
                m[4 * i + j] = (0..4).map(|k| cam[i][k] * projection[k][j]).sum::<f64>() as f32;
            }
        }
        m
    }

    /// A view of the box `lo..hi` from the compass `azimuth` (degrees clockwise from north,
    /// -Z), `elevation` degrees above it, aimed and distanced so that the box's eight corners
    /// span 90% of the frame's tighter side.
    pub fn framing(
        lo: DVec3,
        hi: DVec3,
        (azimuth, elevation): (f64, f64),
        vfov_degrees: f64,
        width: u32,
        height: u32,
    ) -> Result<Camera, String> {
        if !(lo.is_finite() && hi.is_finite()) {
            return Err("the box to frame is not finite".into());
        }
        let corners = crate::geom::box_corners(lo.to_array(), hi.to_array()).map(DVec3::from);
        let (az, el) = (azimuth.to_radians(), elevation.to_radians());
        let towards_eye = DVec3::new(az.sin() * el.cos(), el.sin(), -az.cos() * el.cos());
        let mut target = (lo + hi) * 0.5;
        let mut distance = (hi - lo).length().max(1.0);
        let mut camera = Camera::look_at(
            target + towards_eye * distance,
            target,
            vfov_degrees,
            width,
            height,
        )?;
        // A few rounds of: project the box, re-aim at the middle of its image, and move in or
        // out until it spans 90% of the tighter side.
        for _ in 0..6 {
            let m = camera.world_to_ndc();
            let ndc: Vec<(f64, f64)> = corners
                .iter()
                .map(|p| {
                    let v = [p.x, p.y, p.z, 1.0];
                    let c: [f64; 4] =
                        std::array::from_fn(|j| (0..4).map(|i| v[i] * m[4 * i + j] as f64).sum());
                    (c[0] / c[3], c[1] / c[3])
                })
                .collect();
            let span = |f: fn(&(f64, f64)) -> f64| {
                ndc.iter()
                    .map(f)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                        (a.min(v), b.max(v))
                    })
            };
            let ((x0, x1), (y0, y1)) = (span(|p| p.0), span(|p| p.1));
            let (cx, cy) = ((x0 + x1) * 0.5, (y0 + y1) * 0.5);
            let aim = camera
                .direction(cx * width as f64, cy * height as f64)
                .as_dvec3();
            target = camera.eye + aim * (target - camera.eye).length();
            distance *= ((x1 - x0).max(y1 - y0) / 0.9).clamp(0.5, 2.0);
            camera = Camera::look_at(
                target + towards_eye * distance,
                target,
                vfov_degrees,
                width,
                height,
            )?;
        }
        Ok(camera)
    }

    /// Camera-space depth (along the viewing direction) of a renderer-frame point.
    pub fn depth(&self, p: Vec3) -> f32 {
        p.as_dvec3().dot(self.forward) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(m: &[f32; 16], p: DVec3) -> [f64; 4] {
        let v = [p.x, p.y, p.z, 1.0];
        std::array::from_fn(|j| (0..4).map(|i| v[i] * m[4 * i + j] as f64).sum())
    }

    #[test]
    fn the_centre_ray_looks_at_the_target_and_corners_span_the_field_of_view() {
        let c = Camera::look_at(
            DVec3::new(10.0, 5.0, 10.0),
            DVec3::new(10.0, 5.0, 0.0),
            60.0,
            200,
            100,
        )
        .unwrap();
        let d = c.direction(100.0, 50.0);
        assert!((d - Vec3::NEG_Z).length() < 1e-6);
        let top = c.direction(100.0, 0.0);
        assert!((top.angle_between(Vec3::NEG_Z).to_degrees() - 30.0).abs() < 1e-3);
        assert!(
            c.direction(0.0, 50.0).x < 0.0,
            "left of the image is -x when looking down -z"
        );
    }

    /// An eye beyond what the frame's f32 matrices hold, a field of view outside
    /// [FOV_MIN, FOV_MAX), and a camera node scaled to nothing are refused with what is wrong,
    /// not as an eye that meets its target.
    #[test]
    fn cameras_the_frame_cannot_hold_are_refused_with_the_reason() {
        let far = Camera::look_at(DVec3::new(1e300, 0.0, 0.0), DVec3::ZERO, 40.0, 4, 4);
        assert!(
            far.unwrap_err()
                .contains("(1e300, 0, 0) lies beyond 1e12 m")
        );
        let edge = DVec3::new(super::EYE_LIMIT, 0.0, 0.0);
        let c = Camera::look_at(edge, DVec3::ZERO, 40.0, 4, 4).unwrap();
        assert!(c.world_to_camera().iter().all(|x| x.is_finite()));
        assert!(c.world_to_ndc().iter().all(|x| x.is_finite()));
        for fov in [0.0, 1e-40, 179.0, 179.5, f64::NAN] {
            let e = Camera::look_at(DVec3::ZERO, DVec3::X, fov, 4, 4).unwrap_err();
            assert!(e.contains("is not a field of view"), "{fov}: {e}");
        }
        for fov in [super::FOV_MIN, 178.9] {
            assert!(
                Camera::look_at(DVec3::ZERO, DVec3::X, fov, 4, 4).is_ok(),
                "{fov}"
            );
        }
        let flat = Camera::from_frame(DVec3::ZERO, DVec3::ZERO, DVec3::Y, 0.6, 4, 4);
        assert!(flat.unwrap_err().contains("no viewing direction"));
    }

    #[test]
    fn a_target_far_beyond_a_squared_lengths_range_still_gives_the_direction() {
        let c = Camera::look_at(DVec3::ZERO, DVec3::new(1e300, 0.0, 1e300), 40.0, 4, 4).unwrap();
        assert!((c.forward - DVec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-12);
        let e = DVec3::splat(1e11);
        assert!(
            Camera::look_at(e, e, 40.0, 4, 4)
                .unwrap_err()
                .contains("coincide")
        );
        let far = Camera::look_at(-e, DVec3::splat(f64::INFINITY), 40.0, 4, 4).unwrap_err();
        assert!(far.contains("too far apart"), "{far}");
    }

    #[test]
    fn exr_matrices_map_points_as_openexr_defines() {
        let c = Camera::look_at(
            DVec3::new(100_000.0, 10.0, 0.0),
            DVec3::new(100_000.0, 10.0, -50.0),
            90.0,
            400,
            200,
        )
        .unwrap();
        let p = c.eye + c.forward * 20.0 + c.right * 3.0 + c.up * 2.0;
        let cam = apply(&c.world_to_camera(), p);
        assert!(
            (cam[0] - 3.0).abs() < 0.02
                && (cam[1] - 2.0).abs() < 0.02
                && (cam[2] - 20.0).abs() < 0.02,
            "{cam:?}"
        );
        // A point projecting through pixel (300, 50) lands at NDC (0.75, 0.25).
        let dir = c.direction(300.0, 50.0).as_dvec3();
        let ndc = apply(&c.world_to_ndc(), c.eye + dir * 40.0);
        assert!(
            (ndc[0] / ndc[3] - 0.75).abs() < 1e-3 && (ndc[1] / ndc[3] - 0.25).abs() < 1e-3,
            "{ndc:?}"
        );
    }
}
