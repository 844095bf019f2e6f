//! Foliage as a cloud of leaves: each cell's leaf-normal distribution (`Level::leaves`, the
//! second moment `M = E[n n^T]` of its leaves' unit normals, by area) shades the light it
//! scatters, instead of one normal from the density gradient.
//!
//! The derivation. A leaf is two-sided and opaque, diffuse on the side it is seen from, as the
//! mesh method shades it (normal turned towards the eye, lit where that side faces the sun).
//! In a cloud of such leaves with normal distribution `D(n)`, the light a unit of projected
//! area sends towards the eye `v` from the sun `l` is the mean over the leaves the eye sees —
//! distributed as `|n . v| D(n)`, the *visible normals* — of `max(0, n_v . l)`, `n_v` the
//! normal turned towards `v`:
//!
//! ```text
//! f(v, l) = E[ max(0, (n . v)(n . l)) ] / E[ |n . v| ]
//! ```
//!
//! This is the area scattering phase function of a canopy of bi-Lambertian leaves with no
//! transmission (Shultis and Myneni 1988; Ross 1981): for leaves facing every way alike it is
//! `(2 / 3 pi)(sin g - g cos g) + (2 / 3) cos g`, `g` the angle between `v` and `l` (2/3 head
//! on, 0 lit from straight behind); for horizontal leaves seen and lit from above it is
//! `cos(l, up)`, and 0 lit from below or from the side.
//!
//! The distribution is taken to be the SGGX microflake distribution (Heitz, Dupuy, Crassin and
//! Dachsbacher 2015) with matrix `S = M + eps I` (eps keeps flat leaves finite): exact for
//! leaves all alike and for leaves facing every way, and smooth between. `f` is estimated at
//! each lit volume sample by [`DRAWS`] visible normals, drawn by the paper's closed-form
//! sampler from a shifted lattice, each shaded with the same Lambert and Phong terms as a
//! surface: unbiased for the model, and the renderer's samples average it.

use glam::Vec3;

/// Keeps the matrix of perfectly flat leaves invertible.
const EPSILON: f32 = 1e-3;

/// How many leaf normals shade one lit foliage sample. Its shadow ray, which costs far more
/// than a normal, serves them all; a single normal left the leaves' own response as one of
/// the larger parts of a 1-spp frame's noise (README, *Leaf normals per sample*).
pub const DRAWS: usize = 5;

/// How many normals [`VisibleNormals::even`] gives: the Fibonacci lattice of 21 points,
/// generator (1, 13) (within 0.009 of the response where a 6 x 6 grid of 36 is within 0.008).
pub const EVEN: usize = 21;
/// The second coordinate's step of [`EVEN`]'s lattice, in units of 1 / [`EVEN`].
const EVEN_STEP: f32 = 13.0;

/// The second coordinate's step between the lattice's points: the Fibonacci lattice of
/// [`DRAWS`] = 5 points, generator (1, 3), spreads them evenly over the unit square (another
/// count needs its own generator: 8 points take (1, 5), 13 take (1, 8)).
const LATTICE_STEP: f32 = 3.0 / DRAWS as f32;

/// The visible normals of a leaf-normal distribution (`[xx, yy, zz, xy, xz, yz]`) seen from
/// one unit direction `v`, on the side `v` is on (`n . v >= 0`): the sampler's frame, worked
/// out once for as many draws as a sample takes.
pub struct VisibleNormals {
    v: Vec3,
    /// The view's orthonormal frame, `v` last.
    frame: [Vec3; 3],
    /// The distribution's axes in that frame.
    m: [Vec3; 3],
}

impl VisibleNormals {
    pub fn new(leaves: [f32; 6], v: Vec3) -> VisibleNormals {
        let [xx, yy, zz, xy, xz, yz] = leaves;
        let s = |a: Vec3, b: Vec3| {
            a.x * b.x * (xx + EPSILON)
                + a.y * b.y * (yy + EPSILON)
                + a.z * b.z * (zz + EPSILON)
                + (a.x * b.y + a.y * b.x) * xy
                + (a.x * b.z + a.z * b.x) * xz
                + (a.y * b.z + a.z * b.y) * yz
        };
        let wi = v;
        let (wk, wj) = wi.any_orthonormal_pair();
        let (s_kk, s_jj, s_ii) = (s(wk, wk), s(wj, wj), s(wi, wi));
        let (s_kj, s_ki, s_ji) = (s(wk, wj), s(wk, wi), s(wj, wi));
        let det = s_kk * s_jj * s_ii - s_kj * s_kj * s_ii - s_ki * s_ki * s_jj - s_ji * s_ji * s_kk
            + 2.0 * s_kj * s_ki * s_ji;
        let sqrt_det = det.abs().sqrt();
        let inv_sqrt_ii = 1.0 / s_ii.max(f32::MIN_POSITIVE).sqrt();
        let tmp = (s_jj * s_ii - s_ji * s_ji).max(f32::MIN_POSITIVE).sqrt();
        let mk = Vec3::new(sqrt_det / tmp, 0.0, 0.0);
        let mj = Vec3::new(
            -inv_sqrt_ii * (s_ki * s_ji - s_kj * s_ii) / tmp,
            inv_sqrt_ii * tmp,
            0.0,
        );
        let mi = Vec3::new(inv_sqrt_ii * s_ki, inv_sqrt_ii * s_ji, inv_sqrt_ii * s_ii);
        VisibleNormals {
            v,
            frame: [wk, wj, wi],
            m: [mk, mj, mi],
        }
    }

    /// [`DRAWS`] normals: the points of a rank-1 lattice shifted by the uniforms `u` (a
    /// Cranley-Patterson rotation). Each point alone is uniform, so each normal is a draw of
    /// the distribution and their mean is unbiased; together they cover the disc evenly,
    /// where as many independent draws would clump.
    pub fn lattice(&self, u: [f32; 2]) -> [Vec3; DRAWS] {
        std::array::from_fn(|k| {
            let k = k as f32;
            // fract of a sum in [0, 2): in [0, 1), as a draw must be.
            self.draw([
                (u[0] + k / DRAWS as f32).fract(),
                (u[1] + k * LATTICE_STEP).fract(),
            ])
        })
    }

    /// [`EVEN`] normals spread evenly over the distribution (an unshifted lattice, each point
    /// at the middle of its stratum): their mean response is, within a hundredth, the
    /// expectation the renderer's shifted lattices estimate; for what must model the renderer
    /// without its noise (the bake's self-shadowing fit).
    pub fn even(&self) -> [Vec3; EVEN] {
        std::array::from_fn(|k| {
            let k = k as f32;
            self.draw([
                (k + 0.5) / EVEN as f32,
                ((k * EVEN_STEP + 0.5) / EVEN as f32).fract(),
            ])
        })
    }

    /// The normal the uniforms `u` draw.
    pub fn draw(&self, u: [f32; 2]) -> Vec3 {
        let ([wk, wj, wi], [mk, mj, mi]) = (self.frame, self.m);
        // A cosine-distributed point of the unit disc lifted to the hemisphere.
        let r = u[0].sqrt();
        let phi = std::f32::consts::TAU * u[1];
        let (a, b) = (r * phi.cos(), r * phi.sin());
        let c = (1.0 - a * a - b * b).max(0.0).sqrt();
        let m = (mk * a + mj * b + mi * c).normalize_or(Vec3::Z);
        let n = (wk * m.x + wj * m.y + wi * m.z).normalize_or(self.v);
        if n.is_finite() { n } else { self.v }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::ISOTROPIC_LEAVES;

    /// The mean of `max(0, n . l)` over `count` visible normals of `leaves` seen from `v`.
    fn response(leaves: [f32; 6], v: Vec3, l: Vec3, count: u32) -> f64 {
        let side = (count as f64).sqrt() as u32;
        let mut sum = 0.0;
        for i in 0..side {
            for j in 0..side {
                let u = [
                    (i as f32 + 0.5) / side as f32,
                    (j as f32 + 0.5) / side as f32,
                ];
                let n = VisibleNormals::new(leaves, v).draw(u);
                assert!(n.dot(v) >= -1e-4, "{n} not facing {v}");
                sum += f64::from(n.dot(l).max(0.0));
            }
        }
        sum / (side * side) as f64
    }

    /// Leaves facing every way alike: the closed form of Shultis and Myneni's phase function
    /// for reflecting, non-transmitting leaves, at every angle between eye and sun.
    #[test]
    fn isotropic_leaves_give_the_closed_form() {
        let v = Vec3::new(0.3, 0.8, -0.52).normalize();
        let (e1, e2) = v.any_orthonormal_pair();
        for g in [0.0f64, 0.4, 1.0, 1.5, 2.2, 3.0] {
            let l =
                (v * g.cos() as f32 + e1 * (g.sin() * 0.6) as f32 + e2 * (g.sin() * 0.8) as f32)
                    .normalize();
            let want =
                2.0 / (3.0 * std::f64::consts::PI) * (g.sin() - g * g.cos()) + 2.0 / 3.0 * g.cos();
            let got = response(ISOTROPIC_LEAVES, v, l, 250_000);
            assert!((got - want).abs() < 2e-3, "angle {g}: {got} vs {want}");
        }
    }

    /// Horizontal leaves, seen from above at any angle: lit from straight above they send the
    /// full Lambert response, lit at 60 degrees its cosine, lit from the side nothing, and lit
    /// from below (through the leaf) nothing: two-sided, opaque.
    #[test]
    fn horizontal_leaves_lit_from_above_from_the_side_and_from_behind() {
        let flat = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
        for v in [
            Vec3::Y,
            Vec3::new(0.6, 0.8, 0.0),
            Vec3::new(-0.2, 0.3, 0.9).normalize(),
        ] {
            let above = response(flat, v, Vec3::Y, 10_000);
            assert!((above - 1.0).abs() < 0.02, "{v}: {above}");
            let slanted = response(flat, v, Vec3::new(0.0, 0.5, 0.75f32.sqrt()), 10_000);
            assert!((slanted - 0.5).abs() < 0.02, "{v}: {slanted}");
            let side = response(flat, v, Vec3::X, 10_000);
            assert!(side < 0.05, "{v}: {side}");
            let behind = response(flat, v, Vec3::NEG_Y, 10_000);
            assert!(behind < 5e-3, "{v}: {behind}");
        }
        // Seen from below, the same leaves turn their lower side to the eye: lit from below
        // they are lit, from above dark.
        assert!(response(flat, Vec3::NEG_Y, Vec3::NEG_Y, 10_000) > 0.98);
        assert!(response(flat, Vec3::NEG_Y, Vec3::Y, 10_000) < 5e-3);
    }

    /// A shifted lattice's normals are each a draw of the distribution, so their mean over
    /// the shifts is the response; and with the same shifts, the lattice's mean strays from
    /// it far less than a single draw does (the noise it takes out of a lit leaf).
    #[test]
    fn a_shifted_lattice_keeps_the_response_and_steadies_it() {
        let v = Vec3::new(0.3, 0.8, -0.52).normalize();
        let l = Vec3::new(-0.5, 0.7, 0.2).normalize();
        for leaves in [ISOTROPIC_LEAVES, [0.1, 0.8, 0.1, 0.0, 0.05, 0.0]] {
            let want = response(leaves, v, l, 250_000);
            let normals = VisibleNormals::new(leaves, v);
            let (side, mut mean, mut spread_one, mut spread_lattice) = (100, 0.0, 0.0, 0.0);
            for i in 0..side {
                for j in 0..side {
                    let u = [
                        (i as f32 + 0.5) / side as f32,
                        (j as f32 + 0.5) / side as f32,
                    ];
                    let lit = |n: Vec3| f64::from(n.dot(l).max(0.0));
                    let lattice = normals.lattice(u);
                    let m = lattice.iter().map(|&n| lit(n)).sum::<f64>() / DRAWS as f64;
                    mean += m;
                    spread_lattice += (m - want).powi(2);
                    spread_one += (lit(normals.draw(u)) - want).powi(2);
                }
            }
            let n = f64::from(side * side);
            mean /= n;
            assert!((mean - want).abs() < 1e-3, "{leaves:?}: {mean} vs {want}");
            let ratio = spread_lattice / spread_one;
            assert!(ratio < 0.1, "{leaves:?}: variance {ratio} of one draw's");
        }
    }

    /// The even lattice's normals, which the bake's self-shadowing fit weights its points by,
    /// give the response the renderer's draws average to, within a hundredth, for leaves
    /// facing every way, lying flat and standing upright, lit from the eye, the side and
    /// above.
    #[test]
    fn the_even_lattice_gives_the_response() {
        let v = Vec3::new(0.3, 0.8, -0.52).normalize();
        let (e1, e2) = v.any_orthonormal_pair();
        let upright = [0.5, 0.0, 0.5, 0.0, 0.0, 0.0];
        let flat = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
        for leaves in [
            ISOTROPIC_LEAVES,
            upright,
            flat,
            [0.1, 0.8, 0.1, 0.0, 0.05, 0.0],
        ] {
            for l in [v, (v + e1).normalize(), (0.2 * v + e2).normalize(), Vec3::Y] {
                let want = response(leaves, v, l, 250_000);
                let even = VisibleNormals::new(leaves, v).even();
                let got = even
                    .iter()
                    .map(|n| f64::from(n.dot(l).max(0.0)))
                    .sum::<f64>()
                    / EVEN as f64;
                assert!((got - want).abs() < 0.01, "{leaves:?} {l}: {got} vs {want}");
            }
        }
    }

    /// Vertical leaves (normals in the horizontal plane, every azimuth) lit from straight above
    /// send nothing; lit from the side as seen from that side, the isotropic-in-azimuth mean.
    #[test]
    fn vertical_leaves_are_dark_under_a_zenith_sun() {
        let upright = [0.5, 0.0, 0.5, 0.0, 0.0, 0.0];
        let r = response(upright, Vec3::X, Vec3::Y, 10_000);
        assert!(r < 0.05, "{r}");
        let lit = response(upright, Vec3::X, Vec3::X, 40_000);
        // Normals uniform in azimuth, visible ones weighted by |cos|: E[cos^2] / E[|cos|] = pi/4.
        assert!((lit - std::f64::consts::FRAC_PI_4).abs() < 0.02, "{lit}");
    }

    /// A branch (wood, texel 1.4) is a cylinder: its normals are uniform around its axis `a`,
    /// the moment `(I - a a^T) / 2`. Seen from `v` and lit from `l`, its visible half sends
    /// `|l_p| (sin g + (pi - g) cos g) / 4`, `l_p` the part of `l` across the axis and `g` the
    /// angle between `l_p` and `v_p` (Lambert's law over the half circle the eye sees, dark
    /// past the terminator): pi / 4 lit from the eye, 1 / 4 from the side, 0 from behind.
    #[test]
    fn a_branch_shades_as_the_cylinder_it_is() {
        let a = Vec3::new(0.3, 0.9, -0.2).normalize();
        let branch = [
            (1.0 - a.x * a.x) / 2.0,
            (1.0 - a.y * a.y) / 2.0,
            (1.0 - a.z * a.z) / 2.0,
            -a.x * a.y / 2.0,
            -a.x * a.z / 2.0,
            -a.y * a.z / 2.0,
        ];
        let across = |w: Vec3| w - a * w.dot(a);
        for (v, l) in [
            (Vec3::new(0.8, -0.1, 0.6), Vec3::new(0.8, -0.1, 0.6)),
            (Vec3::new(0.8, -0.1, 0.6), Vec3::new(-0.3, 0.5, 0.8)),
            (Vec3::new(-0.1, 0.4, 0.9), Vec3::new(0.9, 0.1, -0.3)),
            (Vec3::new(-0.1, 0.4, 0.9), Vec3::new(0.2, -0.3, -0.9)),
        ] {
            let (v, l) = (v.normalize(), l.normalize());
            let (vp, lp) = (across(v), across(l));
            let g = f64::from(vp.angle_between(lp));
            let want =
                f64::from(lp.length()) * (g.sin() + (std::f64::consts::PI - g) * g.cos()) / 4.0;
            let got = response(branch, v, l, 250_000);
            assert!((got - want).abs() < 0.01, "v {v} l {l}: {got} vs {want}");
        }
    }
}
