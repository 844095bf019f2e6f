//! Procedural tree models: a conifer with needle clusters, a broadleaf tree with alpha-masked
//! leaf cards, and a bare deciduous tree. Metres, +Y up, trunk base at the origin. Branches are
//! closed tubes (solids), leaves and needles are open cards, as in real assets.

use glam::{Quat, Vec3};
use image::RgbaImage;

use super::builder::{MaterialSpec, ModelBuilder};
use crate::rng::Stream;

fn bark(builder: &mut ModelBuilder) -> usize {
    builder.material(MaterialSpec {
        name: "bark".into(),
        color: [0.09, 0.055, 0.035, 1.0],
        mask: None,
    })
}

/// A unit vector `angle` radians away from `dir`, at azimuth `turn` around it.
fn deviate(dir: Vec3, angle: f32, turn: f32) -> Vec3 {
    let side = dir.any_orthonormal_vector();
    let axis = Quat::from_axis_angle(dir, turn) * side;
    (Quat::from_axis_angle(axis, angle) * dir).normalize()
}

#[allow(clippy::too_many_arguments)]
/// A slightly bending branch path of `segments` from `start` along `dir`.
fn branch_path(
    s: &mut Stream,
    start: Vec3,
    dir: Vec3,
    length: f32,
    r0: f32,
    r1: f32,
    segments: usize,
    lift: f32,
) -> Vec<(Vec3, f32)> {
    let mut path = vec![(start, r0)];
    let (mut p, mut d) = (start, dir);
    for i in 1..=segments {
        let t = i as f32 / segments as f32;
        d = deviate(
            d,
            s.range(0.0, 0.12) as f32,
            s.range(0.0, std::f64::consts::TAU) as f32,
        );
        d = (d + Vec3::Y * lift).normalize();
        p += d * (length / segments as f32);
        path.push((p, r0 + (r1 - r0) * t));
    }
    path
}

/// A spruce-like conifer, 14 m: a tapering trunk, whorls of drooping branches, each clothed in
/// needle clusters (three crossed cards, a bottle brush).
pub fn conifer(seed: u64) -> ModelBuilder {
    let mut b = ModelBuilder::default();
    let wood = bark(&mut b);
    let needles = b.material(MaterialSpec {
        name: "needles".into(),
        color: [0.018, 0.05, 0.022, 1.0],
        mask: None,
    });
    let mut s = Stream::new(seed, 1);
    let height = 14.0;
    let trunk: Vec<(Vec3, f32)> = (0..=10)
        .map(|i| {
            let t = i as f32 / 10.0;
            (
                Vec3::new(0.0, -0.1 + t * height, 0.0),
                0.26 * (1.0 - t) + 0.03 * t,
            )
        })
        .collect();
    b.tube(wood, &trunk, 8);
    let mut h = 1.6;
    while h < height - 0.6 {
        let t = (h - 1.6) / (height - 2.2);
        let length = 3.4 * (1.0 - t) + 0.35;
        let count = 5 + (s.unit() * 2.0) as usize;
        let phase = s.range(0.0, std::f64::consts::TAU) as f32;
        for i in 0..count {
            let az = phase + i as f32 / count as f32 * std::f32::consts::TAU;
            let out = Vec3::new(az.cos(), 0.0, az.sin());
            let dir = (out - Vec3::Y * s.range(0.15, 0.4) as f32).normalize();
            let start = Vec3::new(0.0, h, 0.0) + out * 0.15;
            let path = branch_path(
                &mut s,
                start,
                dir,
                length,
                0.045 * length / 3.0 + 0.012,
                0.01,
                3,
                0.06,
            );
            b.tube(wood, &path, 5);
            // Needle clusters every 0.35 m along the branch.
            let clusters = (length / 0.35).ceil() as usize;
            for c in 0..clusters {
                let f = (c as f32 + 0.5) / clusters as f32;
                let seg = f * 3.0;
                let (i0, frac) = (seg.floor() as usize, seg.fract());
                let p = path[i0].0.lerp(path[(i0 + 1).min(3)].0, frac);
                let along = (path[(i0 + 1).min(3)].0 - path[i0].0).normalize();
                let size = 0.5 * (1.0 - 0.5 * f);
                for k in 0..3 {
                    let across =
                        Quat::from_axis_angle(along, k as f32 * 1.047 + s.range(0.0, 0.5) as f32)
                            * along.any_orthonormal_vector();
                    b.card(needles, p, along * 0.42, across * size);
                }
            }
        }
        h += s.range(0.45, 0.65) as f32;
    }
    // A leader of needles at the top.
    for k in 0..3 {
        let across = Quat::from_axis_angle(Vec3::Y, k as f32 * 1.047) * Vec3::X;
        b.card(
            needles,
            Vec3::new(0.0, height - 0.3, 0.0),
            Vec3::Y * 0.8,
            across * 0.3,
        );
    }
    b
}

/// A 64 x 64 leaf picture: an elongated leaf with a darker midrib on a transparent ground.
pub fn leaf_texture() -> RgbaImage {
    RgbaImage::from_fn(64, 64, |x, y| {
        let u = (x as f32 + 0.5) / 32.0 - 1.0;
        let v = (y as f32 + 0.5) / 32.0 - 1.0;
        let along = (1.0 - v) * 0.5; // 0 at the stalk, 1 at the tip
        let half_width = 0.62 * (along * std::f32::consts::PI).sin().powf(0.8);
        if u.abs() <= half_width && along > 0.04 {
            let rib = if u.abs() < 0.05 { 0.75 } else { 1.0 };
            let shade = 0.85 + 0.15 * (1.0 - u.abs() / half_width.max(1e-3));
            let g = (118.0 * shade * rib) as u8;
            image::Rgba([
                (62.0 * shade * rib) as u8,
                g,
                (34.0 * shade * rib) as u8,
                255,
            ])
        } else {
            image::Rgba([40, 70, 25, 0])
        }
    })
}

/// Shape of a recursive deciduous tree.
#[derive(Clone, Copy, Debug)]
pub struct Deciduous {
    pub height: f32,
    pub depth: usize,
    pub children: usize,
    /// Alpha-masked leaf cards per twig (0 = a bare tree).
    pub leaves_per_twig: usize,
}

impl Deciduous {
    /// A beech-like broadleaf, 11 m, with leaf cards.
    pub const BROADLEAF: Deciduous = Deciduous {
        height: 11.0,
        depth: 4,
        children: 3,
        leaves_per_twig: 28,
    };
    /// An oak-like tree in winter, 9 m, branches only.
    pub const BARE: Deciduous = Deciduous {
        height: 9.0,
        depth: 5,
        children: 3,
        leaves_per_twig: 0,
    };
}

pub fn deciduous(seed: u64, shape: Deciduous) -> ModelBuilder {
    let mut b = ModelBuilder::default();
    let wood = bark(&mut b);
    let leaves = (shape.leaves_per_twig > 0).then(|| {
        b.material(MaterialSpec {
            name: "leaves".into(),
            color: [1.0, 1.0, 1.0, 1.0],
            mask: Some((leaf_texture(), 0.5)),
        })
    });
    let mut s = Stream::new(seed, 2);
    let trunk_length = shape.height * 0.36;
    let trunk = branch_path(
        &mut s,
        Vec3::new(0.0, -0.1, 0.0),
        Vec3::Y,
        trunk_length,
        shape.height * 0.028,
        shape.height * 0.02,
        5,
        0.0,
    );
    b.tube(wood, &trunk, 8);
    let top = trunk[trunk.len() - 1];
    grow(
        &mut b,
        &mut s,
        wood,
        leaves,
        shape,
        top.0,
        Vec3::Y,
        shape.height * 0.42,
        top.1,
        1,
    );
    b
}

#[allow(clippy::too_many_arguments)]
fn grow(
    b: &mut ModelBuilder,
    s: &mut Stream,
    wood: usize,
    leaves: Option<usize>,
    shape: Deciduous,
    start: Vec3,
    parent: Vec3,
    length: f32,
    radius: f32,
    depth: usize,
) {
    let count = shape.children + (s.unit() < 0.3) as usize;
    let phase = s.range(0.0, std::f64::consts::TAU) as f32;
    for i in 0..count {
        let turn = phase + i as f32 / count as f32 * std::f32::consts::TAU;
        let spread = if depth == 1 {
            s.range(0.3, 0.6)
        } else {
            s.range(0.45, 0.8)
        } as f32;
        let dir = deviate(parent, spread, turn);
        let len = length * s.range(0.75, 1.0) as f32;
        let r0 = radius * 0.72;
        let path = branch_path(s, start, dir, len, r0, r0 * 0.62, 4, 0.05);
        b.tube(wood, &path, if depth < 2 { 7 } else { 5 });
        let tip = path[path.len() - 1];
        if depth < shape.depth {
            grow(
                b,
                s,
                wood,
                leaves,
                shape,
                tip.0,
                dir,
                length * 0.68,
                tip.1,
                depth + 1,
            );
        } else if let Some(leaf) = leaves {
            for _ in 0..shape.leaves_per_twig {
                let f = s.range(0.15, 1.0) as f32;
                let seg = f * 4.0;
                let (i0, frac) = ((seg.floor() as usize).min(3), seg.fract());
                let at = path[i0].0.lerp(path[i0 + 1].0, frac);
                let out = deviate(
                    Vec3::Y,
                    s.range(0.3, 1.4) as f32,
                    s.range(0.0, std::f64::consts::TAU) as f32,
                );
                let centre = at + out * s.range(0.1, 0.35) as f32;
                let normal = deviate(
                    Vec3::Y,
                    s.range(0.0, 0.9) as f32,
                    s.range(0.0, std::f64::consts::TAU) as f32,
                );
                let u = normal.any_orthonormal_vector();
                let u =
                    Quat::from_axis_angle(normal, s.range(0.0, std::f64::consts::TAU) as f32) * u;
                b.card(leaf, centre, u * 0.36, normal.cross(u) * 0.36);
            }
        }
    }
}
