//! Volume rendering along a ray (the paper's section 3), in its continuous, normalised form:
//!
//! ```text
//! L = integral of T(t) sigma(t) S(t) dt + T(far) L_behind,   T(t) = exp(-integral of sigma)
//! ```
//!
//! sigma is the sum of the extinctions of every instance containing the point (equation 4);
//! S is the paper's equation (3) with I(t) the sun's light times the transmittance towards the
//! sun through every texture and the terrain (equation 2). At each sample one part of the mix
//! scatters, chosen by its share of the extinction (the wood's as its cells show it, so a
//! cell shows its wood no more than the mesh does within it): wood as a surface on
//! its density gradient, its shadow ray leaving the surface layer, so that an opaque volume
//! shades exactly like a surface; foliage as a cloud of two-sided leaves (`render::leaves`),
//! its shadow ray leaving the leaf and crossing the leaf's own tree with the level's
//! self-shadowing factor (`bake::seen`: clumping, and the hot spot where the sun is behind the
//! eye).
//!
//! How this relates to the paper's equation (1): there the brightness is a sum along the ray,
//! in steps, of the source times the density times the attenuation exp(-gamma x the density
//! summed so far) (the low-albedo volume rendering of Kajiya and Von Herzen). That is a
//! Riemann sum of the integral above with sigma = gamma x rho, whose per-step weight
//! gamma rho dt exceeds one in dense texels, so its brightness depends on the step and on
//! gamma. Here each segment is weighted by its exact opacity 1 - exp(-sigma dt) instead: the
//! weights along a ray then add up to exactly 1 - T, so a fully opaque texel gives the
//! surface's radiance whatever the step, and texel renders compare directly with renders of
//! the meshes. For thin media (sigma dt << 1) the two agree.
//!
//! The instances along the ray come from `render::walk` (the front-to-back walk, and how
//! finely it marches); the sun's light at a sample from `render::sunlight`.
//!
//! The hybrid method ([`hybrid`]) draws each tree as `render::lod` chooses for the sample:
//! the nearest surface of the trees drawn as meshes ends the ray as the terrain does, the
//! textures in front of it are marched and composited over it, and those behind it are never
//! reached.

use glam::Vec3;

use super::leaves::VisibleNormals;
use super::lod::Draw;
use super::matte;
use super::mesh::{self, TreeHit};
use super::scene::Scene;
use super::shading::{Radiance, shade, shade_ground, shade_leaves, sun_radiance};
use super::sunlight::{Caster, MAX_OWN, OwnTree, Strata, roulette, sun_light};
use super::walk::{Active, March, Walk, floor, segment_end};
use crate::geom::{Ray, TriangleHit};
use crate::rng::{self, purpose};
use crate::volume::{Axes, SunFromEye};

/// Radiance along the ray from the eye (the renderer frame's origin) in direction `dir`, every
/// tree drawn from its texture; `spread` is the angle the sample's share of its pixel subtends
/// (the pixel's over the square root of the samples per pixel), `key` seeds the ray's random
/// draws.
pub fn radiance(scene: &Scene, dir: Vec3, spread: f32, key: u64, march: &March) -> Radiance {
    trace(scene, dir, spread, key, march, Draw::Texel)
}

/// [`radiance`] with each tree drawn as `draw` says for this sample: from its texture or
/// from its polygon model (which needs [`Scene::with_meshes`]); every tree a texture with
/// [`Draw::Texel`], as [`radiance`] draws them.
pub fn hybrid(
    scene: &Scene,
    dir: Vec3,
    spread: f32,
    key: u64,
    march: &March,
    draw: Draw,
) -> Radiance {
    trace(scene, dir, spread, key, march, draw)
}

/// What ends a view ray behind the textures it crosses.
enum Behind<'a> {
    Sky,
    Ground(&'a super::Ground, (u32, TriangleHit)),
    /// A tree drawn from its polygon model.
    Tree(TreeHit),
    /// A texture's solid (`bake::solid`).
    Solid(SolidHit),
}

/// Where a view ray meets a texture's solid: an opaque surface, as the mesh's.
struct SolidHit {
    instance: u32,
    level: usize,
    t: f32,
    /// Outward, renderer frame.
    normal: Vec3,
    albedo: Vec3,
    species: f32,
    /// The texture's cell, renderer-frame metres: how far the shadow ray starts off it.
    step: f32,
}

/// The surface of active tree `a`'s solid that the ray `dir` enters between `start` and
/// `inside` (a point inside it): found by bisection of the solids' field along the ray.
fn solid_surface(scene: &Scene, a: &Active, dir: Vec3, start: f32, inside: f32) -> SolidHit {
    let inst = scene.instances.get(a.instance);
    let look = &scene.looks[inst.look as usize];
    let level = &scene.texels[look.texel].levels[a.level];
    let solid_at = |t: f32| level.in_solid(a.c0 + a.dc * t, look.foliage);
    // The segment's sample found the solid, but the surface may lie in a segment before,
    // whose sample happened to fall short of it: back up a cell at a time to a point outside.
    let (mut lo, mut hi) = (start, inside);
    for _ in 0..4 {
        if !solid_at(lo) || lo <= 0.0 {
            break;
        }
        hi = lo;
        lo = (lo - a.step).max(0.0);
    }
    if solid_at(lo) {
        hi = lo;
    } else {
        // A four-thousandth of a cell, well within what the cells hold.
        for _ in 0..12 {
            let mid = 0.5 * (lo + hi);
            if solid_at(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
    }
    let c = a.c0 + a.dc * hi;
    let [wood, foliage] = level.solid_parts_at(c);
    let albedo = if look.foliage * foliage > wood {
        look.foliage_albedo
    } else {
        level.albedo_at(0, c)
    };
    // Where the field is flat (a solid's single cell), the surface faces the eye.
    let normal = level
        .solid_normal(c, look.foliage)
        .map_or(-dir, |n| inst.dir_to_world(n).normalize());
    SolidHit {
        instance: a.instance,
        level: a.level,
        t: hi,
        normal,
        albedo,
        species: inst.look as f32 + 1.0,
        step: a.step,
    }
}

fn trace(scene: &Scene, dir: Vec3, spread: f32, key: u64, march: &March, draw: Draw) -> Radiance {
    let ray = Ray {
        origin: Vec3::ZERO,
        dir,
    };
    let ground_hit = scene
        .ground
        .as_ref()
        .and_then(|g| g.nearest(&ray, f32::INFINITY).map(|h| (g, h)));
    let mut t_max = ground_hit.map_or(f32::INFINITY, |(_, (_, h))| h.t);
    // The trees drawn as models: their nearest surface ends the ray, and where no texture
    // lies in front of it (most rays of a near view) there is nothing to march.
    let (tree_hit, textures) = match draw {
        Draw::Texel => (None, true),
        _ => mesh::nearest_drawn(scene, &ray, t_max, key, &draw),
    };
    if let Some(h) = &tree_hit {
        t_max = h.hit.t;
    }
    let mut walk = Walk::new(scene, ray, t_max, spread, march.lod_bias, draw);
    let mut out = Radiance {
        distance: f32::INFINITY,
        ..Radiance::default()
    };
    let mut transmittance = 1.0f32;
    let mut t = 0.0f32;
    let mut segment = 0u64;
    let mut strata = Strata::new(rng::hash3(key, 0, purpose::RAY_ROULETTE));
    let draws = RayDraws::new(key);
    // With mattes, each segment's trees and their extinctions (`render::matte`).
    let record = matte::recording();
    let mut each = Vec::new();
    SURFACES.with_borrow_mut(|s| s.clear());
    let mut solid_hit = None;
    while textures && let Some(start) = walk.advance(t) {
        t = start;
        if let Some(next) = walk.empty_until(t) {
            // Whole segments in empty space are jumped over with their draws, so the samples
            // left are exactly those of a march that skips nothing.
            let length = walk
                .active
                .iter()
                .map(|a| a.step)
                .fold(f32::INFINITY, f32::min);
            let empty = floor((next - t) / (length * march.step));
            if empty >= 1.0 {
                t += empty * length * march.step;
                segment += empty as u64;
                continue;
            }
        }
        let (end, ts) = segment_end(&walk, t, walk.t_max, march.step, draws.position(segment));
        segment += 1;
        let cell_here = walk
            .active
            .iter()
            .map(|a| a.step)
            .fold(f32::INFINITY, f32::min);
        each.clear();
        let m = mix(scene, &walk.active, ts, record.then_some(&mut each));
        out.samples += u32::from(m.read);
        if let Some(k) = m.solid {
            solid_hit = Some(solid_surface(scene, &walk.active[k], dir, t, ts));
            break;
        }
        let sigma = m.sigma();
        let length = end - t;
        t = end;
        if sigma <= 0.0 {
            continue;
        }
        let albedo = (m.albedo_wood + m.albedo_foliage) / sigma;
        let normal = (-m.gradient).try_normalize();
        let opacity = 1.0 - (-sigma * length).exp();
        let share = transmittance * opacity;
        let sample = Sample {
            mix: &m,
            dir,
            ts,
            footprint: t * spread,
            layer: cell_here.max(length),
            share,
            key: (key, segment),
            draws: &draws,
            draw: &draw,
        };
        let source = scatter(
            scene,
            &walk.active,
            &sample,
            march,
            &mut strata,
            &mut out.shadow_rays,
        );
        out.rgb += source * share;
        if record {
            matte::add_split(&each, share);
        }
        if draw.in_band(scene, walk.active[m.home].instance) {
            out.band_canopy += share;
        }
        transmittance *= 1.0 - opacity;
        SURFACES.with_borrow_mut(|s| {
            s.push(Surface {
                opacity: 1.0 - transmittance,
                distance: ts,
                normal: normal.unwrap_or(Vec3::ZERO),
                albedo,
                species: m.densest.1 as f32 + 1.0,
            })
        });
        if transmittance < march.cutoff {
            break;
        }
        let Some(left) = go_on(
            transmittance,
            march,
            rng::hash3(key, segment, purpose::SEGMENT_GO_ON),
        ) else {
            transmittance = 0.0;
            break;
        };
        transmittance = left;
    }
    out.canopy = 1.0 - transmittance;
    let behind = match (solid_hit, tree_hit, ground_hit) {
        (Some(s), ..) => Behind::Solid(s),
        (None, Some(h), _) => Behind::Tree(h),
        (None, None, Some((g, h))) => Behind::Ground(g, h),
        (None, None, None) => Behind::Sky,
    };
    let lighting = SurfaceLight {
        spread,
        key,
        march,
        draw: &draw,
    };
    finish(
        scene,
        ray,
        behind,
        transmittance,
        (&lighting, &mut strata),
        &mut out,
    );
    out
}

/// Russian roulette on what is left of a view ray with `transmittance` (`key` draws): below
/// `march.view_share` it goes on with probability transmittance / view_share, carrying
/// view_share, so every later contribution (and the terrain or sky behind) keeps its
/// expectation while most deep segments are never sampled. The transmittance to go on with,
/// or `None` where the ray stops.
fn go_on(transmittance: f32, march: &March, key: u64) -> Option<f32> {
    if transmittance >= march.view_share {
        return Some(transmittance);
    }
    let p = transmittance / march.view_share;
    ((rng::unit(key) as f32) < p).then_some(march.view_share)
}

/// A view-ray sample as [`scatter`] needs it.
struct Sample<'a> {
    mix: &'a Mix,
    dir: Vec3,
    /// Where along the ray (from the eye, unit direction `dir`).
    ts: f32,
    /// The footprint (m) shadow rays of other trees are read at.
    footprint: f32,
    /// The thickness of the layer the sample stands for: a cell, or the segment if longer.
    layer: f32,
    /// Its share of its ray (transmittance before it x its opacity), for the roulette.
    share: f32,
    /// The ray's key and the segment's index (from 1): its shadow ray's key, and which
    /// element of the ray's sequences its part and leaf normal take.
    key: (u64, u64),
    draws: &'a RayDraws,
    draw: &'a Draw,
}

/// A view ray's own draws along it: randomly shifted sequences (`rng::along`), each segment
/// taking its element, so that successive segments' draws spread evenly rather than at random.
/// The shifts are drawn once per ray.
struct RayDraws {
    position: u64,
    part: u64,
    leaf: u64,
}

impl RayDraws {
    fn new(key: u64) -> RayDraws {
        RayDraws {
            position: rng::hash3(key, 0, purpose::SEGMENT_JITTER),
            part: rng::hash3(key, 0, purpose::SEGMENT_PART),
            leaf: rng::hash3(key, 0, purpose::SEGMENT_LEAF),
        }
    }

    /// Where in segment `n` its sample lies, as a fraction of the segment.
    fn position(&self, n: u64) -> f64 {
        rng::along(self.position, n, rng::GOLDEN)
    }

    /// Which part of sample `n`'s mixture scatters, as a fraction of what shows.
    fn part(&self, n: u64) -> f64 {
        rng::along(self.part, n, rng::SILVER)
    }

    /// The shift of sample `n`'s lattice of leaf normals (`render::leaves`).
    fn leaf(&self, n: u64) -> [f32; 2] {
        rng::along2(self.leaf, n).map(|x| x as f32)
    }
}

/// The light a sample sends towards the eye. One part of the mixture scatters it, chosen by
/// its share of the extinction, the wood's as its cells show it (`Level::wood_shown`: a cell
/// shows its wood first as often as the mesh does within it, not wherever it mixes it with
/// foliage; the level's wood weight in files before texel 1.7): the
/// wood as a surface on the wood's density gradient, the foliage as a cloud of leaves
/// (`render::leaves`); each with its own shadow ray, counted in `shadow_rays`.
fn scatter(
    scene: &Scene,
    active: &[Active],
    s: &Sample,
    march: &March,
    strata: &mut Strata,
    shadow_rays: &mut u32,
) -> Vec3 {
    let (m, dir, sun) = (s.mix, s.dir, scene.sun);
    let (key, segment) = s.key;
    let shown = m.wood_shown + m.foliage_shown;
    let part = s.draws.part(segment);
    // Never foliage where there is none (a draw that rounds to 1 in f32 would pick it).
    let foliage_scatters = m.foliage > 0.0 && part as f32 * shown >= m.wood_shown;
    // A leaf's shadow ray leaves the leaf itself, through its own tree as the level's
    // self-shadowing says (clumping, and the hot spot where the sun is behind the eye). Wood
    // is a solid: its shadow ray leaves the layer of surfaces the sample stands for, so that
    // the layer does not shadow itself (an opaque volume would otherwise shade as
    // Lommel-Seeliger's law, half as bright as a surface lit head-on). Where the textures hold
    // the wood's normal distribution (texel 1.4), which way its surfaces face is in the
    // shading, and the ray leaves one layer towards the sun. Without it, the wood is a surface
    // on its density gradient, and from a point up to one layer deep a ray towards a sun at
    // angle theta to that normal leaves after the layer over cos theta (capped at four
    // layers, where grazing light is faint anyway). The distribution is used where at least
    // half the wood at the sample carries one (a 1.3 tree beside a 1.4 one keeps its
    // gradient), and read before the shadow ray, whose start it decides.
    // Read once, and only for a wood sample that casts its shadow ray or is lit.
    let wood_moment = std::cell::OnceCell::new();
    let wood_moment = || {
        *wood_moment.get_or_init(|| {
            let (moment, covered) = wood_moment_at(scene, active, s.ts);
            (covered > 0.0 && covered >= 0.5 * m.wood).then(|| moment.map(|v| v / covered))
        })
    };
    let wood_normal = || (-m.gradient_wood).try_normalize();
    let lit = if !scene.shadows {
        sun_radiance(scene)
    } else {
        roulette(s.share, march, strata, shadow_rays, || {
            // Only for a shadow ray actually cast: the roulette skips most.
            let p = if foliage_scatters {
                dir * s.ts
            } else if wood_moment().is_some() {
                dir * s.ts + sun.direction * s.layer
            } else {
                let rise = wood_normal().map_or(1.0, |n| n.dot(sun.direction).max(0.25));
                dir * s.ts + sun.direction * (s.layer / rise)
            };
            let mut own = [OwnTree::default(); MAX_OWN];
            let mut n = 0;
            let sun_from_eye = SunFromEye::new(-dir, sun.direction);
            for a in active.iter().take(MAX_OWN) {
                let level = &scene.texel_of(a.instance).levels[a.level];
                // A tree with solids: what of them its level set leaves out (a rim thinner
                // than a cell) is density on the solid's surface, lit as the surface is, not
                // shadowed by the solid it lies on; so its own tree is marched, the solid
                // left out for the first cell, as a solid's surface's own shadow ray is.
                let solid = level.has_solid();
                if !(foliage_scatters || solid) {
                    continue;
                }
                own[n] = OwnTree {
                    instance: a.instance,
                    level: a.level,
                    factor: if foliage_scatters {
                        level.self_shadow.at(&sun_from_eye)
                    } else {
                        1.0
                    },
                    exact: solid,
                };
                n += 1;
            }
            let caster = Caster {
                footprint: s.footprint,
                key: rng::hash3(key, segment, purpose::SEGMENT_LIGHT),
                own: &own[..n],
                draw: s.draw,
            };
            sun_light(scene, p, march, &caster)
        })
    };
    let albedo = if foliage_scatters {
        m.albedo_foliage / m.foliage
    } else {
        m.albedo_wood / m.wood
    };
    if lit == 0.0 {
        // Unlit (shadowed, or its shadow ray skipped by the roulette): only the ambient term
        // is left, which no normal changes, so none is drawn.
        return shade(scene, albedo, None, lit, -dir);
    }
    if foliage_scatters {
        let u = s.draws.leaf(segment);
        let leaves = leaf_moment(scene, active, s.ts);
        let normals = VisibleNormals::new(leaves.map(|v| v / m.foliage), -dir).lattice(u);
        return shade_leaves(scene, albedo, &normals, lit, -dir);
    }
    // Wood thinner than a cell has no surface its gradient can say: it is shaded as the
    // surfaces its cell holds, from their normals' distribution, as leaves are (a branch's
    // visible half, lit where it faces the sun).
    match wood_moment() {
        Some(moment) => {
            let u = s.draws.leaf(segment);
            let normals = VisibleNormals::new(moment, -dir).lattice(u);
            shade_leaves(scene, albedo, &normals, lit, -dir)
        }
        None => shade(scene, albedo, wood_normal(), lit, -dir),
    }
}

/// What the instances containing a sample say: their extinction by part, each part's albedo
/// weighted by its extinction, the gradients (the whole's, for the surface it reports, and the
/// wood's, which shades the wood) and the densest instance's look. The foliage's leaf-normal
/// moment is read apart ([`leaf_moment`]), only where a leaf is lit.
struct Mix {
    wood: f32,
    foliage: f32,
    /// Each part's extinction as it counts in choosing which part scatters (`Fetch::shown`):
    /// the cells' chances of showing wood, weighed by their extinction.
    wood_shown: f32,
    foliage_shown: f32,
    albedo_wood: Vec3,
    albedo_foliage: Vec3,
    gradient: Vec3,
    gradient_wood: Vec3,
    densest: (f32, u16),
    /// Which of the active instances is the densest there.
    home: usize,
    /// Whether any texture was read: a step where every stencil is empty reads none.
    read: bool,
    /// The first active instance whose solid holds the point: it ends the ray there.
    solid: Option<usize>,
}

impl Mix {
    fn sigma(&self) -> f32 {
        self.wood + self.foliage
    }
}

/// `each`, where given, gets every instance's extinction there.
fn mix(scene: &Scene, active: &[Active], ts: f32, mut each: Option<&mut Vec<(u32, f32)>>) -> Mix {
    let mut m = Mix {
        wood: 0.0,
        foliage: 0.0,
        wood_shown: 0.0,
        foliage_shown: 0.0,
        albedo_wood: Vec3::ZERO,
        albedo_foliage: Vec3::ZERO,
        gradient: Vec3::ZERO,
        gradient_wood: Vec3::ZERO,
        densest: (0.0, 0),
        home: 0,
        read: false,
        solid: None,
    };
    for (k, a) in active.iter().enumerate() {
        if a.found_empty_at(ts) {
            continue;
        }
        // Most steps through a crown are in air: one bit says so without reading a cell. The
        // point's place in the grid is worked out once, for the bit and the cells' reads.
        let occupancy = &scene.occupancy[a.model as usize][a.level];
        let stencils = &occupancy.stencils;
        let Some(axes) = Axes::at(a.c0 + a.dc * ts, stencils.dims()) else {
            continue;
        };
        if !stencils.holds_at(&axes) {
            continue;
        }
        m.read = true;
        let inst = scene.instances.get(a.instance);
        let look = &scene.looks[inst.look as usize];
        let level = &scene.texels[look.texel].levels[a.level];
        if level.has_solid() && level.in_solid(a.c0 + a.dc * ts, look.foliage) {
            m.solid.get_or_insert(k);
            continue;
        }
        let f = level.fetch_at(&axes, &occupancy.wood_chances);
        // Each part as much as faces the view (`Active::facing`).
        let [to_wood, to_foliage] = a.facing;
        let (wood, foliage) = (
            a.extinction(f.density[0]) * to_wood,
            a.extinction(look.foliage * f.density[1]) * to_foliage,
        );
        let s = wood + foliage;
        if s <= 0.0 {
            continue;
        }
        if let Some(e) = each.as_deref_mut() {
            e.push((a.instance, s));
        }
        m.wood += wood;
        m.wood_shown += a.extinction(f.shown[0]) * to_wood;
        m.foliage_shown += a.extinction(look.foliage * f.shown[1]) * to_foliage;
        m.foliage += foliage;
        m.albedo_wood += f.wood_albedo * wood;
        m.albedo_foliage += look.foliage_albedo * foliage;
        // Gradients are linear in density; per metre of the frame they shrink with scale.
        let per_metre = a.sigma_scale / inst.scale;
        m.gradient += inst.dir_to_world(f.gradient[0] + f.gradient[1] * look.foliage) * per_metre;
        m.gradient_wood += inst.dir_to_world(f.gradient[0]) * per_metre;
        if s > m.densest.0 {
            m.densest = (s, inst.look);
            m.home = k;
        }
    }
    m
}

/// The foliage's leaf-normal moment at `ts` along the ray, in the renderer's frame, summed
/// over the instances there, each weighted by its foliage extinction (divide by the total for
/// the mixture's moment). Read only for a leaf that is lit: most samples are not.
fn leaf_moment(scene: &Scene, active: &[Active], ts: f32) -> [f32; 6] {
    moment_sum(scene, active, ts, 1).0
}

/// The wood's normal moment at `ts`, as [`leaf_moment`] the foliage's, and the wood
/// extinction it covers: instances whose textures have no wood moments (before texel 1.4)
/// add none.
fn wood_moment_at(scene: &Scene, active: &[Active], ts: f32) -> ([f32; 6], f32) {
    moment_sum(scene, active, ts, 0)
}

/// A part's (`[wood, foliage]`) normal moment at `ts`, summed over the instances there
/// weighted by their extinction of it, and that extinction.
fn moment_sum(scene: &Scene, active: &[Active], ts: f32, part: usize) -> ([f32; 6], f32) {
    let mut covered = 0.0;
    let mut sum = [0.0f32; 6];
    for a in active {
        // The instances `mix` reads: not those whose bricks the walk found empty here, nor
        // one whose solid holds the point (the sample's extinction leaves them out too).
        if a.found_empty_at(ts) {
            continue;
        }
        let inst = scene.instances.get(a.instance);
        let look = &scene.looks[inst.look as usize];
        let level = &scene.texels[look.texel].levels[a.level];
        let c = a.c0 + a.dc * ts;
        if level.has_solid() && level.in_solid(c, look.foliage) {
            continue;
        }
        let found = if part == 1 {
            level.foliage_leaves(c)
        } else {
            level.wood_normals_at(c)
        };
        let Some((density, moment)) = found else {
            continue;
        };
        let sigma = a.extinction(if part == 1 {
            look.foliage * density
        } else {
            density
        });
        covered += sigma;
        // The moment turns with the instance: M' = R M R^T, R a turn about +Y.
        for (s, v) in sum.iter_mut().zip(turn_moment(moment, inst.cos, inst.sin)) {
            *s += v * sigma;
        }
    }
    (sum, covered)
}

/// The leaf-normal moment `[xx, yy, zz, xy, xz, yz]` of model space in the renderer's frame,
/// for an instance turned about +Y (`dir_to_world`: x' = c x + s z, z' = -s x + c z).
pub(super) fn turn_moment(m: [f32; 6], c: f32, s: f32) -> [f32; 6] {
    let [xx, yy, zz, xy, xz, yz] = m;
    [
        c * c * xx + 2.0 * c * s * xz + s * s * zz,
        yy,
        s * s * xx - 2.0 * c * s * xz + c * c * zz,
        c * xy + s * yz,
        (c * c - s * s) * xz + c * s * (zz - xx),
        -s * xy + c * yz,
    ]
}

/// The end of a view ray: its surface (where the trees' opacity reaches half of what the ray
/// ends with, all of it when the terrain or a tree's model stops the ray, else that surface),
/// and what lies behind the textures: the terrain, a tree's model, the sky's radiance, or the
/// transparent sky.
fn finish(
    scene: &Scene,
    ray: Ray,
    behind: Behind,
    transmittance: f32,
    (l, strata): (&SurfaceLight, &mut Strata),
    out: &mut Radiance,
) {
    let half = if matches!(behind, Behind::Sky) {
        0.5 * out.canopy
    } else {
        0.5
    };
    SURFACES.with_borrow(|s| {
        if let Some(surface) = s.iter().find(|s| s.opacity >= half && s.opacity > 0.0) {
            out.distance = surface.distance;
            out.normal = surface.normal;
            out.albedo = surface.albedo;
            out.species = surface.species;
        }
    });
    match &behind {
        Behind::Tree(h) => matte::add(h.instance, transmittance),
        Behind::Solid(h) => matte::add(h.instance, transmittance),
        Behind::Ground(..) => matte::add(matte::TERRAIN, transmittance),
        Behind::Sky if scene.sky.is_some() => matte::add(matte::SKY, transmittance),
        Behind::Sky => {}
    }
    if let Behind::Tree(h) = &behind {
        // A model is opaque where it is hit: the canopy is whole, that much of it the model's.
        out.canopy = 1.0;
        out.mesh_canopy = transmittance;
        if l.draw.in_band(scene, h.instance) {
            out.band_canopy += transmittance;
        }
    }
    if let Behind::Solid(h) = &behind {
        // A solid is opaque: the canopy is whole, that much of it the texture's.
        out.canopy = 1.0;
        if l.draw.in_band(scene, h.instance) {
            out.band_canopy += transmittance;
        }
    }
    match behind {
        Behind::Ground(g, hit) if transmittance >= l.march.cutoff => {
            light_ground(scene, g, ray, hit, transmittance, (l, strata), out);
        }
        Behind::Tree(h) if transmittance >= l.march.cutoff => {
            light_tree(scene, ray, &h, transmittance, (l, strata), out);
        }
        Behind::Solid(h) if transmittance >= l.march.cutoff => {
            light_solid(scene, ray, &h, transmittance, (l, strata), out);
        }
        Behind::Ground(..) | Behind::Tree(_) | Behind::Solid(_) => out.transmittance = 0.0,
        Behind::Sky => {
            if let Some(sky) = scene.sky {
                out.rgb += sky * transmittance;
                out.transmittance = 0.0;
            } else {
                out.transmittance = transmittance;
            }
        }
    }
}

/// What the shadow ray of the surface ending a view ray needs of the view ray.
struct SurfaceLight<'a> {
    spread: f32,
    key: u64,
    march: &'a March,
    draw: &'a Draw,
}

/// The terrain where the view `ray` hits it, seen through `transmittance` of trees: lit by
/// the sun through the trees (by roulette, as a tree sample is), and the surface where no tree
/// was one.
fn light_ground(
    scene: &Scene,
    g: &super::Ground,
    ray: Ray,
    (tri, hit): (u32, crate::geom::TriangleHit),
    transmittance: f32,
    (l, strata): (&SurfaceLight, &mut Strata),
    out: &mut Radiance,
) {
    let normal = g.normal(tri, ray.dir);
    let triangle = &g.mesh.triangles[tri as usize];
    let albedo = g.mesh.base_color(triangle, hit.w).truncate();
    let surface = Opaque {
        t: hit.t,
        normal,
        albedo,
        species: 0.0,
        leave: g.leave(tri, &hit, normal, scene.sun.direction),
        light_key: rng::hash3(l.key, 0, purpose::GROUND_LIGHT),
        own: None,
    };
    light_opaque(scene, &surface, transmittance, (l, strata), out, |lit| {
        shade_ground(scene, albedo, normal, lit)
    });
}

/// A tree drawn from its polygon model where the view `ray` hits it, seen through
/// `transmittance` of textures: lit as the mesh method lights it (its shadow ray through every
/// tree as the sample draws it, by roulette as the terrain's), and the surface where no
/// texture was one.
fn light_tree(
    scene: &Scene,
    ray: Ray,
    h: &TreeHit,
    transmittance: f32,
    (l, strata): (&SurfaceLight, &mut Strata),
    out: &mut Radiance,
) {
    let s = mesh::tree_surface(scene, h, ray.dir);
    let surface = Opaque {
        t: h.hit.t,
        normal: s.normal,
        albedo: s.albedo,
        species: s.species,
        leave: s.leave,
        // The ray's own key: its mesh stream is the one the mesh method's shadow ray draws
        // alpha-blended triangles from.
        light_key: l.key,
        own: None,
    };
    light_opaque(scene, &surface, transmittance, (l, strata), out, |lit| {
        shade(scene, s.albedo, Some(s.normal), lit, -ray.dir)
    });
}

/// A texture's solid where the view `ray` meets it, seen through `transmittance` of textures
/// in front: lit as a tree's model is, its shadow ray leaving a tenth of a cell off the
/// surface and marching its own tree whatever the shadows (a cached grid of the tree's depths
/// would blur the surface the ray starts on). Its own tree's density shadows it as it
/// shadows the level's leaves, scaled by the level's self-shadowing: in a tree with solids
/// that density is mostly the solids' rims, parts of the same closed surfaces, which the
/// self-shadowing fit finds cast next to no shadow on the leaves (the Kenney trees' levels
/// with solids: 0); at full extinction they left the forests of such trees 4-10 % dark.
fn light_solid(
    scene: &Scene,
    ray: Ray,
    h: &SolidHit,
    transmittance: f32,
    (l, strata): (&SurfaceLight, &mut Strata),
    out: &mut Radiance,
) {
    let surface = Opaque {
        t: h.t,
        normal: h.normal,
        albedo: h.albedo,
        species: h.species,
        leave: ray.dir * h.t + h.normal * (0.1 * h.step),
        light_key: rng::hash3(l.key, 0, purpose::SOLID_LIGHT),
        own: Some(OwnTree {
            instance: h.instance,
            level: h.level,
            factor: scene.texel_of(h.instance).levels[h.level]
                .self_shadow
                .at(&SunFromEye::new(-ray.dir, scene.sun.direction)),
            exact: true,
        }),
    };
    light_opaque(scene, &surface, transmittance, (l, strata), out, |lit| {
        shade(scene, h.albedo, Some(h.normal), lit, -ray.dir)
    });
}

/// An opaque surface ending a view ray (the terrain, a tree's model, a texture's solid):
/// where, what the AOVs report of it, where its shadow ray leaves, that ray's key, and the
/// tree it leaves (a solid's).
struct Opaque {
    t: f32,
    normal: Vec3,
    albedo: Vec3,
    species: f32,
    leave: Vec3,
    light_key: u64,
    own: Option<OwnTree>,
}

/// `surface` seen through `transmittance`: lit by the sun through everything (by roulette, as
/// a tree sample is), shaded by `shade(light)`, and the ray's surface where no texture was one.
fn light_opaque(
    scene: &Scene,
    surface: &Opaque,
    transmittance: f32,
    (l, strata): (&SurfaceLight, &mut Strata),
    out: &mut Radiance,
    shade: impl FnOnce(f32) -> Vec3,
) {
    let lit = if surface.normal.dot(scene.sun.direction) <= 0.0 {
        0.0
    } else if !scene.shadows {
        sun_radiance(scene)
    } else {
        roulette(transmittance, l.march, strata, &mut out.shadow_rays, || {
            let caster = Caster {
                footprint: surface.t * l.spread,
                key: surface.light_key,
                own: surface.own.as_slice(),
                draw: l.draw,
            };
            sun_light(scene, surface.leave, l.march, &caster)
        })
    };
    out.rgb += shade(lit) * transmittance;
    if out.distance.is_infinite() {
        out.distance = surface.t;
        out.normal = surface.normal;
        out.albedo = surface.albedo;
        out.species = surface.species;
    }
    out.transmittance = 0.0;
}

/// A point a ray's surface may be at: the opacity reached after a segment, and what the
/// AOVs report there.
struct Surface {
    opacity: f32,
    distance: f32,
    normal: Vec3,
    albedo: Vec3,
    species: f32,
}

thread_local! {
    /// The current ray's candidate surfaces, kept per thread so rays allocate nothing.
    static SURFACES: std::cell::RefCell<Vec<Surface>> = const { std::cell::RefCell::new(Vec::new()) };
}
