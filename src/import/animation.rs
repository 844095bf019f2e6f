//! A camera node of the default scene and the animation channels that move it or any node
//! above it, evaluated at any time as glTF 2.0 specifies: `LINEAR` (spherical for rotations),
//! `STEP` and `CUBICSPLINE` samplers, each holding its first and last value outside its
//! keys. This is what Blender's exporter writes for an animated camera.

use glam::{DMat4, DQuat, DVec3};
use gltf_json as json;
use json::animation::{Interpolation, Property};
use json::validation::Checked;

use super::document::Document;
use super::scene::{MAX_DEPTH, camera_of, check_transform, local_transform, scene_roots, trs};
use super::{ImportError, SceneCamera, accessor};
use crate::limits::Limits;
use std::path::Path;

/// A camera whose pose follows the animation of its node and the nodes above it.
#[derive(Clone, Debug)]
pub struct CameraAnimation {
    pub name: String,
    /// Vertical field of view, radians (glTF does not animate it without extensions).
    pub yfov: f64,
    /// From the scene's root down to the camera's node.
    chain: Vec<NodeMotion>,
    /// The first and last key time of every channel that moves the camera (seconds).
    pub start: f64,
    pub end: f64,
    /// What was ignored that a user may want to know about.
    pub warnings: Vec<String>,
}

#[derive(Clone, Debug)]
struct NodeMotion {
    rest: Rest,
    translation: Option<Track>,
    rotation: Option<Track>,
    scale: Option<Track>,
}

/// A node's own transform, where no channel moves it.
#[derive(Clone, Debug)]
enum Rest {
    Matrix(DMat4),
    Trs {
        translation: DVec3,
        rotation: DQuat,
        scale: DVec3,
    },
}

/// One sampler: key times, and per key `components` values (three elements per key for
/// `CUBICSPLINE`: in-tangent, value, out-tangent).
#[derive(Clone, Debug)]
struct Track {
    interpolation: Interpolation,
    times: Vec<f64>,
    components: usize,
    values: Vec<f64>,
}

impl Track {
    /// Element `k` of the values (for `CUBICSPLINE`, of the flattened triplets).
    fn element(&self, k: usize) -> &[f64] {
        &self.values[k * self.components..(k + 1) * self.components]
    }

    /// The key's value (the middle of a `CUBICSPLINE` triplet).
    fn value(&self, key: usize) -> &[f64] {
        match self.interpolation {
            Interpolation::CubicSpline => self.element(3 * key + 1),
            _ => self.element(key),
        }
    }

    /// The value at `time`; `rotation` interpolates `LINEAR` keys spherically and normalises.
    fn at(&self, time: f64, rotation: bool) -> Vec<f64> {
        let n = self.times.len();
        let last = n - 1;
        // Outside the keys, and at a time equal to a key, the key's value.
        if time <= self.times[0] || n == 1 {
            return self.finish(self.value(0).to_vec(), rotation);
        }
        if time >= self.times[last] {
            return self.finish(self.value(last).to_vec(), rotation);
        }
        let k = self.times.partition_point(|&t| t <= time) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let span = t1 - t0;
        let u = (time - t0) / span;
        let v = match self.interpolation {
            Interpolation::Step => self.value(k).to_vec(),
            Interpolation::Linear if rotation => {
                let q = |e: &[f64]| DQuat::from_xyzw(e[0], e[1], e[2], e[3]);
                q(self.value(k))
                    .slerp(q(self.value(k + 1)), u)
                    .to_array()
                    .to_vec()
            }
            Interpolation::Linear => {
                let (a, b) = (self.value(k), self.value(k + 1));
                (0..self.components)
                    .map(|c| a[c] + (b[c] - a[c]) * u)
                    .collect()
            }
            Interpolation::CubicSpline => {
                // glTF 2.0, appendix C: Hermite with tangents scaled by the key interval.
                let (u2, u3) = (u * u, u * u * u);
                let (h00, h10, h01, h11) = (
                    2.0 * u3 - 3.0 * u2 + 1.0,
                    u3 - 2.0 * u2 + u,
                    -2.0 * u3 + 3.0 * u2,
                    u3 - u2,
                );
                let (v0, out0) = (self.element(3 * k + 1), self.element(3 * k + 2));
                let (in1, v1) = (self.element(3 * (k + 1)), self.element(3 * (k + 1) + 1));
                (0..self.components)
                    .map(|c| h00 * v0[c] + h10 * span * out0[c] + h01 * v1[c] + h11 * span * in1[c])
                    .collect()
            }
        };
        self.finish(v, rotation)
    }

    fn finish(&self, v: Vec<f64>, rotation: bool) -> Vec<f64> {
        if !rotation {
            return v;
        }
        let q = DQuat::from_xyzw(v[0], v[1], v[2], v[3]);
        let q = if q.length_squared() > 0.0 {
            q.normalize()
        } else {
            DQuat::IDENTITY
        };
        q.to_array().to_vec()
    }
}

impl NodeMotion {
    fn transform(&self, time: f64) -> DMat4 {
        match &self.rest {
            Rest::Matrix(m) => *m,
            Rest::Trs {
                translation,
                rotation,
                scale,
            } => {
                let v3 = |t: &Option<Track>, rest: DVec3| {
                    t.as_ref()
                        .map_or(rest, |t| DVec3::from_slice(&t.at(time, false)))
                };
                let r = self
                    .rotation
                    .as_ref()
                    .map_or(*rotation, |t| DQuat::from_slice(&t.at(time, true)));
                DMat4::from_scale_rotation_translation(
                    v3(&self.scale, *scale),
                    r,
                    v3(&self.translation, *translation),
                )
            }
        }
    }
}

impl CameraAnimation {
    /// The camera at `time` (seconds): its eye, its -Z as the viewing direction and its +Y as
    /// up, placed by the product of every node's transform from the root down.
    pub fn at(&self, time: f64) -> SceneCamera {
        let world = self
            .chain
            .iter()
            .fold(DMat4::IDENTITY, |m, n| m * n.transform(time));
        let axis = |v: DVec3| crate::geom::direction(world.transform_vector3(v));
        SceneCamera {
            name: self.name.clone(),
            node: None,
            eye: world.transform_point3(DVec3::ZERO),
            forward: axis(DVec3::NEG_Z),
            up: axis(DVec3::Y),
            yfov: self.yfov,
        }
    }
}

/// The camera of glTF file `path` named `name` (the camera's name, else its node's), or
/// without a name the first camera of the default scene that an animation moves, with every
/// animation channel that moves its node or a node above it.
pub fn load_camera_animation(
    path: &Path,
    name: Option<&str>,
    limits: &Limits,
) -> Result<
    (
        CameraAnimation,
        Vec<crate::provenance::Source<std::path::PathBuf>>,
    ),
    ImportError,
> {
    let mut doc = Document::open(path, limits)?;
    let chains = camera_chains(&doc)?;
    let tracks = read_channels(&mut doc)?;
    let moved = |chain: &[usize]| chain.iter().any(|n| tracks.iter().any(|t| t.node == *n));
    let names: Vec<String> = chains.iter().map(|(n, _, _)| n.clone()).collect();
    let chosen = match name {
        // By the camera's own name first, then by its node's (as `render --camera` finds a
        // still camera).
        Some(name) => chains
            .iter()
            .find(|(n, _, _)| n == name)
            .or_else(|| {
                chains.iter().find(|(_, _, chain)| {
                    let node = chain[chain.len() - 1];
                    doc.root.nodes.get(node).and_then(|n| n.name.as_deref()) == Some(name)
                })
            })
            .ok_or_else(|| {
                let why = if orthographic(&doc, name) {
                    format!(
                        "camera {name:?} is orthographic: texel render draws perspective \
                         cameras only"
                    )
                } else {
                    format!(
                        "no perspective camera named {name:?} (the default scene has: {})",
                        list(&names)
                    )
                };
                ImportError::invalid(path, "cameras", why)
            })?,
        None => chains.iter().find(|(_, _, c)| moved(c)).ok_or_else(|| {
            ImportError::invalid(
                path,
                "animations",
                format!(
                    "no animation moves a camera of the default scene (its cameras: {})",
                    list(&names)
                ),
            )
        })?,
    };
    let (name, yfov, chain) = chosen.clone();
    let mut motions = Vec::with_capacity(chain.len());
    let (mut start, mut end) = (f64::INFINITY, f64::NEG_INFINITY);
    for &n in &chain {
        let node = doc.root.nodes[n].clone();
        let node = &node;
        let mut motion = NodeMotion {
            rest: match node.matrix {
                Some(_) => Rest::Matrix(local_transform(node)),
                None => {
                    let (translation, rotation, scale) = trs(node);
                    Rest::Trs {
                        translation,
                        rotation,
                        scale,
                    }
                }
            },
            translation: None,
            rotation: None,
            scale: None,
        };
        for t in tracks.iter().filter(|t| t.node == n) {
            if node.matrix.is_some() {
                return Err(ImportError::invalid(
                    path,
                    &t.field,
                    format!(
                        "animates nodes[{n}], which has a matrix (glTF allows animating only \
                         translation, rotation and scale)"
                    ),
                ));
            }
            let slot = match t.property {
                Property::Translation => &mut motion.translation,
                Property::Rotation => &mut motion.rotation,
                Property::Scale => &mut motion.scale,
                Property::MorphTargetWeights => continue,
            };
            if slot.is_some() {
                doc.warn(format!(
                    "{}: {} ignored: an earlier channel already animates nodes[{n}]'s {:?}",
                    path.display(),
                    t.field,
                    t.property
                ));
                continue;
            }
            start = start.min(t.track.times[0]);
            end = end.max(t.track.times[t.track.times.len() - 1]);
            *slot = Some(t.track.clone());
        }
        motions.push(motion);
    }
    if !start.is_finite() {
        (start, end) = (0.0, 0.0);
    }
    Ok((
        CameraAnimation {
            name,
            yfov,
            chain: motions,
            start,
            end,
            warnings: doc.warnings,
        },
        doc.sources,
    ))
}

/// Whether `name` is an orthographic camera's, or the name of a node that holds one.
fn orthographic(doc: &Document, name: &str) -> bool {
    doc.root.nodes.iter().any(|n| {
        n.camera
            .and_then(|c| doc.root.cameras.get(c.value()))
            .is_some_and(|c| {
                c.perspective.is_none()
                    && (c.name.as_deref() == Some(name) || n.name.as_deref() == Some(name))
            })
    })
}

fn list(names: &[String]) -> String {
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

/// Every perspective camera node of the default scene: its name, vertical field of view, and
/// the nodes from the scene's root down to it.
fn camera_chains(doc: &Document) -> Result<Vec<(String, f64, Vec<usize>)>, ImportError> {
    let root = &doc.root;
    let mut found = Vec::new();
    // Depth-first, as the flattening walks the scene, with the path kept; and refused where
    // the flattening refuses (a missing node, a cycle, a transform that is none).
    let mut stack: Vec<Vec<usize>> = scene_roots(doc)?.into_iter().map(|n| vec![n]).collect();
    stack.reverse();
    let mut count = 0;
    while let Some(chain) = stack.pop() {
        let index = chain[chain.len() - 1];
        let Some(node) = root.nodes.get(index) else {
            let field = match chain.len() {
                1 => "scene.nodes".to_string(),
                n => format!("nodes[{}].children", chain[n - 2]),
            };
            // (A root's place in scene.nodes is not kept; the flattening names it.)
            return Err(ImportError::invalid(
                &doc.path,
                field,
                format!("node {index} does not exist ({} nodes)", root.nodes.len()),
            ));
        };
        check_transform(&doc.path, index, node)?;
        let camera = camera_of(doc, index)?;
        if let Some(c) = camera
            && let Some(p) = &c.perspective
        {
            let name = c
                .name
                .clone()
                .or_else(|| node.name.clone())
                .unwrap_or_else(|| format!("camera {count}"));
            count += 1;
            found.push((name, f64::from(p.yfov), chain.clone()));
        }
        for child in node.children.iter().flatten().rev() {
            if chain.contains(&child.value()) || chain.len() > MAX_DEPTH {
                return Err(ImportError::invalid(
                    &doc.path,
                    format!("nodes[{index}].children"),
                    "the node hierarchy is cyclic or deeper than 256 levels",
                ));
            }
            let mut next = chain.clone();
            next.push(child.value());
            stack.push(next);
        }
    }
    Ok(found)
}

/// One animation channel, read and checked.
struct Channel {
    node: usize,
    property: Property,
    track: Track,
    /// Its JSON path, for messages.
    field: String,
}

/// Every channel of every animation, its sampler's keys read and checked: times finite and
/// increasing, one value per key (three for `CUBICSPLINE`), the element size the property
/// needs, every value finite.
fn read_channels(doc: &mut Document) -> Result<Vec<Channel>, ImportError> {
    let path = doc.path.clone();
    let mut channels = Vec::new();
    for a in 0..doc.root.animations.len() {
        for c in 0..doc.root.animations[a].channels.len() {
            let field = format!("animations[{a}].channels[{c}]");
            let channel = doc.root.animations[a].channels[c].clone();
            let node = channel.target.node.value();
            if node >= doc.root.nodes.len() {
                return Err(ImportError::invalid(
                    &path,
                    format!("{field}.target.node"),
                    format!("node {node} does not exist"),
                ));
            }
            let Checked::Valid(property) = channel.target.path else {
                return Err(ImportError::invalid(
                    &path,
                    format!("{field}.target.path"),
                    "invalid",
                ));
            };
            if property == Property::MorphTargetWeights {
                continue;
            }
            let s = channel.sampler.value();
            let Some(sampler) = doc.root.animations[a].samplers.get(s).cloned() else {
                return Err(ImportError::invalid(
                    &path,
                    format!("{field}.sampler"),
                    format!("sampler {s} does not exist"),
                ));
            };
            let sfield = format!("animations[{a}].samplers[{s}]");
            let Checked::Valid(interpolation) = sampler.interpolation else {
                return Err(ImportError::invalid(
                    &path,
                    format!("{sfield}.interpolation"),
                    "invalid",
                ));
            };
            check_types(
                doc,
                &sfield,
                sampler.input.value(),
                sampler.output.value(),
                property,
            )?;
            let input = accessor::read(doc, sampler.input.value(), &format!("{sfield}.input"))?;
            let output = accessor::read(doc, sampler.output.value(), &format!("{sfield}.output"))?;
            let track = check_track(&path, &sfield, interpolation, property, input, output)?;
            channels.push(Channel {
                node,
                property,
                track,
                field,
            });
        }
    }
    Ok(channels)
}

/// Refuses the component types glTF does not allow a sampler (section 3.11): key times are
/// FLOAT; translations and scales FLOAT; rotations FLOAT or normalised integers. Any other
/// would read as numbers, but not as the exporter meant them (an integer time in seconds).
fn check_types(
    doc: &Document,
    sfield: &str,
    input: usize,
    output: usize,
    property: Property,
) -> Result<(), ImportError> {
    use json::accessor::ComponentType as C;
    let type_of = |index: usize| {
        doc.root.accessors.get(index).map(|a| {
            let ct = match a.component_type {
                Checked::Valid(json::accessor::GenericComponentType(ct)) => Some(ct),
                Checked::Invalid => None,
            };
            (ct, a.normalized)
        })
    };
    if let Some((ct, _)) = type_of(input)
        && ct != Some(C::F32)
    {
        return Err(ImportError::invalid(
            &doc.path,
            format!("{sfield}.input"),
            format!("key times are {}, not FLOAT (seconds)", name(ct)),
        ));
    }
    if let Some((ct, normalized)) = type_of(output) {
        let fits = match property {
            Property::Rotation => {
                ct == Some(C::F32)
                    || (normalized && matches!(ct, Some(C::I8 | C::U8 | C::I16 | C::U16)))
            }
            _ => ct == Some(C::F32),
        };
        if !fits {
            return Err(ImportError::invalid(
                &doc.path,
                format!("{sfield}.output"),
                format!(
                    "{property:?} values are {}{}, which glTF does not allow (FLOAT{})",
                    if normalized { "normalized " } else { "" },
                    name(ct),
                    if property == Property::Rotation {
                        ", or normalized BYTE, UNSIGNED_BYTE, SHORT or UNSIGNED_SHORT"
                    } else {
                        ""
                    }
                ),
            ));
        }
    }
    Ok(())
}

/// A component type as the glTF spec names it.
fn name(ct: Option<json::accessor::ComponentType>) -> &'static str {
    use json::accessor::ComponentType as C;
    match ct {
        Some(C::I8) => "BYTE",
        Some(C::U8) => "UNSIGNED_BYTE",
        Some(C::I16) => "SHORT",
        Some(C::U16) => "UNSIGNED_SHORT",
        Some(C::U32) => "UNSIGNED_INT",
        Some(C::F32) => "FLOAT",
        None => "an invalid component type",
    }
}

fn check_track(
    path: &Path,
    field: &str,
    interpolation: Interpolation,
    property: Property,
    input: accessor::Values,
    output: accessor::Values,
) -> Result<Track, ImportError> {
    let bad = |f: &str, why: String| ImportError::invalid(path, format!("{field}.{f}"), why);
    if input.components != 1 {
        return Err(bad("input", "key times must be SCALAR".into()));
    }
    let times = input.data;
    if times.is_empty() {
        return Err(bad("input", "has no keys".into()));
    }
    if let Some(k) = times.iter().position(|t| !t.is_finite()) {
        return Err(bad("input", format!("key {k}'s time is not finite")));
    }
    if let Some(k) = (1..times.len()).find(|&k| times[k] <= times[k - 1]) {
        return Err(bad(
            "input",
            format!(
                "key {k}'s time {} is not after key {}'s {} (times must increase)",
                times[k],
                k - 1,
                times[k - 1]
            ),
        ));
    }
    let components = match property {
        Property::Rotation => 4,
        _ => 3,
    };
    if output.components != components {
        return Err(bad(
            "output",
            format!(
                "{property:?} needs {components} components per value, the accessor has {}",
                output.components
            ),
        ));
    }
    let per_key = if interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    if output.count() != times.len() * per_key {
        return Err(bad(
            "output",
            format!(
                "{} values for {} keys ({interpolation:?} needs {per_key} per key)",
                output.count(),
                times.len()
            ),
        ));
    }
    if let Some(i) = output.data.iter().position(|v| !v.is_finite()) {
        return Err(bad(
            "output",
            format!("value {} is not finite", i / components),
        ));
    }
    // A rotation key must be a quaternion that normalises (CUBICSPLINE's tangents, the first
    // and last of each three, may be zero).
    if property == Property::Rotation
        && let Some(k) = (0..output.count()).find(|&k| {
            let q = output.element(k);
            let tangent = per_key == 3 && k % 3 != 1;
            !tangent && q.iter().map(|v| v * v).sum::<f64>() <= 1e-12
        })
    {
        return Err(bad(
            "output",
            format!(
                "key {}'s rotation, {:?}, is no rotation: it does not normalise to a unit \
                 quaternion [x, y, z, w]",
                k / per_key,
                output.element(k)
            ),
        ));
    }
    Ok(Track {
        interpolation,
        times,
        components,
        values: output.data,
    })
}
