//! Loading what a render needs from disk: the forest, every texture its species name (the
//! leafless one in winter), the terrain, and for the mesh and hybrid methods the tree models
//! the textures were baked from. Every file is read within limits and checked against the hash
//! its referrer recorded, so a stale input is refused before rendering starts; the paths read
//! are returned for depfiles. The models, checked with the rest, are read only when a frame
//! first draws a tree from one ([`Models`]).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::scene::TreeMesh;
use super::{Look, Placed};
use crate::bake;
use crate::formats::instances::SpeciesRecord;
use crate::formats::{container, instances, texel};
use crate::import::{self, Model};
use crate::input::MAX_GLTF;
use crate::limits::Limits;
use crate::number::shortest;
use crate::provenance::{self, ProvenanceError};
use crate::terrain::{self, HeightmapOptions};
use crate::volume::Texel;

/// What to load.
pub struct SceneRequest<'a> {
    /// The `.instances` file; the files it names are found relative to it.
    pub forest: &'a Path,
    /// A terrain to use instead of the recorded one (not checked against the record).
    pub terrain: Option<&'a Path>,
    /// How to convert `terrain` if it is a heightmap (the recorded conversion is used for
    /// the recorded terrain).
    pub heightmap: HeightmapOptions,
    /// Day of the year: picks each species' foliage colour, leaf fraction and texture.
    pub day: f64,
    /// Whether to load the tree models too (for `Method::Mesh` and `Method::Hybrid`).
    pub meshes: Meshes,
    pub limits: Limits,
}

/// Whether a render checks (and, where a frame draws one, reads) the polygon models the
/// textures were baked from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Meshes {
    /// Textures only (`--method texel`).
    Skip,
    /// The models or an error (`--method mesh`, `--method hybrid`).
    Require,
    /// The models where every one can be loaded, else none, and why not
    /// ([`LoadedScene::without_meshes`]): the default method draws what there is.
    Prefer,
}

/// Everything a render reads, loaded and checked.
pub struct LoadedScene {
    pub forest: instances::Forest,
    pub texels: Vec<Texel>,
    /// One per species, in the forest's species order.
    pub looks: Vec<Look>,
    pub placed: Vec<Placed>,
    pub terrain: Model,
    /// Where asked for, the texels' models: checked now, read when a frame draws one.
    pub models: Option<Models>,
    /// With [`Meshes::Prefer`], why the models were not loaded (one missing or changed).
    pub without_meshes: Option<LoadError>,
    /// Every file read, the forest first.
    pub dependencies: Vec<PathBuf>,
}

#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// A file could not be read or decoded, or changed since it was recorded.
    #[error("{file}")]
    File {
        file: PathBuf,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The files are readable but do not fit together, or ask for more than the renderer holds.
    #[error("{file}: {message}")]
    Mismatch { file: PathBuf, message: String },
    /// The terrain could not be read (its errors name the file themselves).
    #[error(transparent)]
    Terrain(#[from] crate::terrain::TerrainError),
}

fn file_error(file: &Path, e: impl std::error::Error + Send + Sync + 'static) -> LoadError {
    LoadError::File {
        file: file.to_path_buf(),
        source: Box::new(e),
    }
}

/// When the forest recorded the files it names.
const PLACED: &str = "the forest was placed";

/// An error about a file another file named.
#[derive(Debug, thiserror::Error)]
#[error("{}", .0.display())]
struct Named(PathBuf, #[source] Box<dyn std::error::Error + Send + Sync>);

/// A recorded source that changed or is gone, with what to do about it.
#[derive(Debug, thiserror::Error)]
#[error("{change}; {}{advice}", restore_first(.change))]
struct Stale {
    change: ProvenanceError,
    advice: &'static str,
}

/// A file that is gone may only have been left behind: bringing it back is the first remedy.
fn restore_first(change: &ProvenanceError) -> &'static str {
    match change {
        ProvenanceError::Unreadable(_) => "put it back where it was recorded, or ",
        ProvenanceError::Changed { .. } => "",
    }
}

fn stale(file: &Path, change: ProvenanceError, advice: &'static str) -> LoadError {
    file_error(file, Stale { change, advice })
}

pub fn load(request: &SceneRequest) -> Result<LoadedScene, LoadError> {
    let path = request.forest;
    let bytes = container::read_file(path).map_err(|e| file_error(path, e))?;
    let forest =
        instances::decode_with(&bytes, &request.limits).map_err(|e| file_error(path, e))?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let mut dependencies = vec![path.to_path_buf()];

    let terrain = load_terrain(request, &forest, &dir)?;
    dependencies.extend(terrain.sources.iter().map(|s| s.path.clone()));

    let mut textures = Textures::new(path, &dir, &request.limits);
    let looks = forest
        .info
        .species
        .iter()
        .map(|s| textures.look(s, request.day))
        .collect::<Result<Vec<_>, _>>()?;
    check_heights(path, &forest, &looks, &textures.texels)?;
    check_crowding(path, &forest, &looks, &textures.texels, &request.limits)?;
    dependencies.extend(textures.paths.iter().cloned());
    dependencies.extend(textures.other_spellings.iter().cloned());
    let models = |dependencies: &mut Vec<PathBuf>| {
        Models::check(
            &textures.texels,
            &textures.paths,
            &request.limits,
            dependencies,
        )
    };
    let (models, without_meshes) = match request.meshes {
        Meshes::Skip => (None, None),
        Meshes::Require => (Some(models(&mut dependencies)?), None),
        // All or none: the files of a model that loaded before one that failed are no
        // dependency of a render that draws no model.
        Meshes::Prefer => {
            let mut files = Vec::new();
            match models(&mut files) {
                Ok(m) => {
                    dependencies.extend(files);
                    (Some(m), None)
                }
                Err(e) => (None, Some(e)),
            }
        }
    };
    let placed = forest.instances.iter().map(Placed::of).collect();
    Ok(LoadedScene {
        forest,
        texels: textures.texels,
        looks,
        placed,
        terrain,
        models,
        without_meshes,
        dependencies,
    })
}

/// The terrain: the one asked for, or the one the forest recorded, every file of it (the glTF,
/// its buffers and images, or the heightmap) unchanged since, a heightmap converted as
/// recorded.
fn load_terrain(
    request: &SceneRequest,
    forest: &instances::Forest,
    dir: &Path,
) -> Result<Model, LoadError> {
    let (terrain_path, options) = match request.terrain {
        Some(t) => (t.to_path_buf(), request.heightmap),
        None => {
            let files = provenance::verify_all(&forest.info.terrain, dir, PLACED, MAX_GLTF)
                .map_err(|e| stale(request.forest, e, "re-run texel place"))?;
            (files[0].clone(), forest.heightmap.unwrap_or_default())
        }
    };
    terrain::load_model(
        &terrain_path,
        &options,
        "to render as a terrain",
        &request.limits,
    )
    .map(|(model, _)| model)
    .map_err(LoadError::from)
}

/// The textures a forest names, each read once, checked against the forest's record and
/// refused if older than the renderer's foliage model.
struct Textures<'a> {
    forest: &'a Path,
    dir: &'a Path,
    limits: &'a Limits,
    texels: Vec<Texel>,
    /// Where each texel was read, in `texels` order.
    paths: Vec<PathBuf>,
    /// Each file read ([`crate::input::file_key`]): its texel, and the SHA-256 it was
    /// checked against.
    index: HashMap<PathBuf, (usize, [u8; 32])>,
    /// Other paths the forest names a file read by (a depfile lists them too: a link among
    /// them may be moved to another file).
    other_spellings: Vec<PathBuf>,
}

impl<'a> Textures<'a> {
    fn new(forest: &'a Path, dir: &'a Path, limits: &'a Limits) -> Self {
        Textures {
            forest,
            dir,
            limits,
            texels: Vec::new(),
            paths: Vec::new(),
            index: HashMap::new(),
            other_spellings: Vec::new(),
        }
    }

    /// How species `s` looks on `day`: its foliage colour and leaf fraction, and its texture
    /// (the leafless one when it is bare and has one).
    fn look(&mut self, s: &SpeciesRecord, day: f64) -> Result<Look, LoadError> {
        let leaf_fraction = s.seasons.leaf_fraction(day) as f32;
        let albedo = s.seasons.albedo(day).map(|c| c as f32);
        let (texel, foliage) = match (&s.leafless_texel, &s.leafless_sha256) {
            (Some(rel), Some(sha)) if leaf_fraction <= 0.0 => (self.texel(rel, sha)?, 0.0),
            _ => (self.texel(&s.texel, &s.texel_sha256)?, leaf_fraction),
        };
        Ok(Look {
            texel,
            foliage,
            foliage_albedo: Vec3::from(albedo),
        })
    }

    /// The index of the texture at `rel` (relative to the forest) whose SHA-256 the forest
    /// recorded as `sha`. Errors name the forest that refers to the texture, then the texture.
    fn texel(&mut self, rel: &str, sha: &[u8; 32]) -> Result<usize, LoadError> {
        let file = self.dir.join(rel);
        // A file named again (however its path is spelt) is decoded once; a record that
        // disagrees with what it held is checked as if it were new, and refused.
        let key = crate::input::file_key(&file);
        if let Some(&(i, known)) = self.index.get(&key)
            && known == *sha
        {
            if self.paths[i] != file && !self.other_spellings.contains(&file) {
                self.other_spellings.push(file);
            }
            return Ok(i);
        }
        let forest = self.forest;
        let bytes = container::read_file(&file).map_err(|e| file_error(forest, e))?;
        provenance::verify(&file, &bytes, sha, PLACED)
            .map_err(|e| stale(forest, e, "re-run texel place"))?;
        let t = texel::decode_with(&bytes, self.limits)
            .map_err(|e| file_error(forest, Named(file.clone(), Box::new(e))))?;
        let minor = container::preamble(&bytes).map_or(0, |p| p.minor);
        if minor < texel::RENDER_MINOR {
            return Err(LoadError::Mismatch {
                file,
                message: format!(
                    "texel 1.{minor} was baked before the renderer's foliage model (texel 1.{}: \
                     leaf normals, self-shadowing); re-bake it with texel bake",
                    texel::RENDER_MINOR
                ),
            });
        }
        // The renderer holds a box in f32 of its model's units: one reaching beyond 1e30
        // (valid, its numbers being f64) would be infinite there and draw nothing.
        let l = &t.levels[0];
        let reach = (0..3)
            .map(|k| t.info.origin[k].abs() + l.cell * l.dims[k] as f64)
            .fold(0.0, f64::max);
        if reach > 1e30 {
            return Err(LoadError::Mismatch {
                file,
                message: format!(
                    "the texture's box reaches {reach:e} of its model's units from the model's \
                     origin, beyond the 1e30 the renderer's f32 arithmetic holds; re-bake its \
                     model in smaller units"
                ),
            });
        }
        self.texels.push(t);
        self.paths.push(file.clone());
        self.index.insert(key, (self.texels.len() - 1, *sha));
        Ok(self.texels.len() - 1)
    }
}

/// Heights were scaled for each texel's model when the forest was placed: a rebaked texel
/// must still match.
fn check_heights(
    path: &Path,
    forest: &instances::Forest,
    looks: &[Look],
    texels: &[Texel],
) -> Result<(), LoadError> {
    for (s, look) in forest.info.species.iter().zip(looks) {
        let info = &texels[look.texel].info;
        let height = info.model_max[1] - info.model_min[1];
        if look.foliage > 0.0 && (height - s.model_height).abs() > 1e-6 * s.model_height.max(1.0) {
            return Err(LoadError::Mismatch {
                file: path.to_path_buf(),
                message: format!(
                    "species {:?}: the texel's model is {} m tall, the forest was placed for one \
                     {} m tall; re-run texel place with this texel",
                    s.name,
                    shortest(height),
                    shortest(s.model_height)
                ),
            });
        }
    }
    Ok(())
}

/// Refuses a forest with more trees over one tree's base than the limit (`render::crowding`),
/// naming the tree and where it stands.
fn check_crowding(
    path: &Path,
    forest: &instances::Forest,
    looks: &[Look],
    texels: &[Texel],
    limits: &Limits,
) -> Result<(), LoadError> {
    let reaches: Vec<f64> = looks.iter().map(|l| reach(&texels[l.texel])).collect();
    let origin = forest.info.origin;
    let trees: Vec<([f64; 2], f64)> = forest
        .instances
        .iter()
        .map(|t| {
            let at = [t.position[0] - origin[0], t.position[2] - origin[2]];
            (at, reaches[usize::from(t.species)] * f64::from(t.scale))
        })
        .collect();
    if let Some((i, n)) = super::crowding::most_crowded(&trees, limits.overlap) {
        let [x, _, z] = forest.instances[i].position;
        let what = format!(
            "the number of trees standing over the base of tree {i} (x {}, z {} m)",
            crate::number::number(x, 2),
            crate::number::number(z, 2)
        );
        limits
            .check_overlap(n, &what)
            .map_err(|e| file_error(path, e))?;
    }
    Ok(())
}

/// How far a tree of `texel` reaches from its base across the ground, in model units: to the
/// farthest corner of the box the renderer draws it in ([`Texel::grid_box`]).
fn reach(texel: &Texel) -> f64 {
    let (lo, hi) = texel.grid_box();
    [lo.x, hi.x]
        .into_iter()
        .flat_map(|x| [lo.z, hi.z].map(|z| x.hypot(z)))
        .fold(0.0, f64::max)
}

/// The polygon models the texels were baked from (each texel's first recorded source,
/// relative to it), for the frames that draw trees as models. Their files are checked against
/// the texels' records when the scene is loaded ([`Models::check`]), so a stale model is
/// refused before any frame renders, whether or not a frame needs it; they are read, and their
/// hierarchies built, only when a frame first draws one ([`Models::get`]): a hybrid frame whose
/// every tree is far enough to be a texture (`render::draws_models`) costs no more than the
/// texel method's.
pub struct Models {
    sources: Vec<ModelSource>,
    limits: Limits,
    meshes: Option<Vec<TreeMesh>>,
}

/// Where a texel's model is and how it was baked: what reading it needs.
struct ModelSource {
    /// The texel's file (its recorded sources are relative to it).
    texel: PathBuf,
    sources: Vec<provenance::SourceFile>,
    /// Its foliage pattern decides which triangles are leaves, as the bake decided.
    parameters: crate::volume::BakeParameters,
}

impl Models {
    /// The models of `texels` (read from `paths`), every file of each unchanged since its
    /// bake; the files checked go into `dependencies`.
    fn check(
        texels: &[Texel],
        paths: &[PathBuf],
        limits: &Limits,
        dependencies: &mut Vec<PathBuf>,
    ) -> Result<Models, LoadError> {
        let mut sources = Vec::with_capacity(texels.len());
        for (t, path) in texels.iter().zip(paths) {
            if let Some(message) = t.info.no_source_model("drawing its trees as meshes needs") {
                return Err(LoadError::Mismatch {
                    file: path.clone(),
                    message,
                });
            }
            let source = ModelSource {
                texel: path.clone(),
                sources: t.info.sources.clone(),
                parameters: t.info.parameters.clone(),
            };
            dependencies.extend(source.verified()?);
            sources.push(source);
        }
        Ok(Models {
            sources,
            limits: *limits,
            meshes: None,
        })
    }

    /// The models, read and made ready for tracing on the first call. Their files are checked
    /// again as they are read: a model changed since the scene was loaded is refused.
    pub fn get(&mut self) -> Result<&[TreeMesh], LoadError> {
        if self.meshes.is_none() {
            let mut models = Vec::new();
            for source in &self.sources {
                let files = source.verified()?;
                let m = import::load_surface(&files[0], "to draw as a tree", &self.limits)
                    .map_err(|e| file_error(&files[0], e))?;
                let foliage = bake::foliage_triangles(&m.mesh, &source.parameters)
                    .map_err(|e| file_error(&source.texel, e))?;
                models.push((m.mesh, foliage));
            }
            // Their hierarchies are built side by side, each the same whichever thread builds
            // it.
            self.meshes = Some(
                models
                    .into_par_iter()
                    .map(|(mesh, foliage)| TreeMesh::new(mesh, foliage))
                    .collect(),
            );
        }
        Ok(self.meshes.as_deref().unwrap_or_default())
    }

    /// [`Models::get`], handing the models over: for the last frame that needs them.
    pub fn into_meshes(mut self) -> Result<Vec<TreeMesh>, LoadError> {
        self.get()?;
        Ok(self.meshes.take().unwrap_or_default())
    }
}

impl ModelSource {
    /// The model's files, each unchanged since the bake recorded it; the glTF first.
    fn verified(&self) -> Result<Vec<PathBuf>, LoadError> {
        let dir = self.texel.parent().unwrap_or(Path::new(""));
        provenance::verify_all(&self.sources, dir, "it was baked", MAX_GLTF)
            .map_err(|e| stale(&self.texel, e, "re-run texel bake"))
    }
}

impl LoadedScene {
    /// The scene the renderer draws, in the frame of a camera at `eye`.
    pub fn into_scene(self, eye: glam::DVec3, lighting: super::Lighting) -> super::Scene {
        super::Scene::new(
            eye,
            self.texels,
            self.looks,
            &self.placed,
            Some(self.terrain.mesh),
            lighting,
        )
    }

    /// [`LoadedScene::into_scene`] keeping what was loaded, for the next frame of a sequence
    /// (each frame's scene is in the frame of its own eye).
    pub fn scene(&self, eye: glam::DVec3, lighting: super::Lighting) -> super::Scene {
        super::Scene::new(
            eye,
            self.texels.clone(),
            self.looks.clone(),
            &self.placed,
            Some(self.terrain.mesh.clone()),
            lighting,
        )
    }

    /// Why the terrain looks like another than the one the forest was placed on, if it does
    /// (for a `--terrain` given in place of the recorded one): it does not reach over the
    /// forest's region, or the trees' bases lie above its highest point or below its lowest.
    /// A finer or larger terrain of the same ground passes.
    pub fn terrain_mismatch(&self) -> Option<String> {
        let r = self.forest.info.region;
        // A metre of slack, and a thousandth of the region, for rounding and re-meshing.
        let slack = 1.0 + 1e-3 * (r[2] - r[0]).max(r[3] - r[1]);
        let Some((lo, hi)) = self.terrain.mesh.bounds() else {
            return Some("it has no triangles to stand the trees on".into());
        };
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        if lo.x > r[0] + slack || lo.z > r[1] + slack || hi.x < r[2] - slack || hi.z < r[3] - slack
        {
            return Some(format!(
                "it spans x {:.1} to {:.1}, z {:.1} to {:.1} m, which does not cover the \
                 forest's region, x {:.1} to {:.1}, z {:.1} to {:.1} m",
                lo.x, hi.x, lo.z, hi.z, r[0], r[2], r[1], r[3]
            ));
        }
        let (y0, y1) = self
            .forest
            .instances
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.position[1]), b.max(p.position[1]))
            });
        (y0 < lo.y - slack || y1 > hi.y + slack).then(|| {
            format!(
                "its heights run from {:.1} to {:.1} m, but the trees stand from {y0:.1} to \
                 {y1:.1} m",
                lo.y, hi.y
            )
        })
    }

    /// Height of the terrain's surface above (x, z), if any.
    pub fn ground_height(&self, x: f64, z: f64) -> Option<f64> {
        crate::terrain::Terrain::surface_height(&self.terrain.mesh, x, z)
    }

    /// The box to frame by default: the forest's region, from the lowest tree base (or the
    /// terrain) to the highest crown; the whole terrain when the forest is empty.
    pub fn forest_bounds(&self) -> (DVec3, DVec3) {
        let info = &self.forest.info;
        let (t_lo, t_hi) = (DVec3::from(info.terrain_min), DVec3::from(info.terrain_max));
        if self.forest.instances.is_empty() {
            return (t_lo, t_hi);
        }
        let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in &self.forest.instances {
            let top = p.scale as f64 * info.species[p.species as usize].model_height;
            y0 = y0.min(p.position[1]);
            y1 = y1.max(p.position[1] + top);
        }
        let r = info.region;
        (DVec3::new(r[0], y0, r[1]), DVec3::new(r[2], y1, r[3]))
    }
}
