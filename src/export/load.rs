//! What an export reads: the forest, each species' main texel (checked against the forest's
//! record), the glTF model each was baked from (checked against the texel's record, as the
//! mesh render method checks it) and, where asked for, the terrain the forest was placed on.

use std::path::{Path, PathBuf};

use crate::formats::{container, instances, texel};
use crate::import::{ImportError, RawGltf};
use crate::input::MAX_GLTF;
use crate::limits::Limits;
use crate::provenance::{self, ProvenanceError};

/// The loaded inputs of an export.
pub struct Inputs {
    pub forest: instances::Forest,
    /// The source models, each once.
    pub models: Vec<RawGltf>,
    /// Per species, its model in `models`; `None` for a species without trees (not read).
    pub species_model: Vec<Option<usize>>,
    pub terrain: Option<RawGltf>,
    /// Every file read, the forest first (for depfiles).
    pub dependencies: Vec<PathBuf>,
}

impl Inputs {
    /// Every file read so far: [`Inputs::dependencies`], and the files the models' copies
    /// read beyond what the texels recorded (images the bake does not use, such as normal
    /// maps).
    pub fn files_read(&self) -> Vec<PathBuf> {
        let mut files = self.dependencies.clone();
        for model in self.models.iter().chain(&self.terrain) {
            for s in model.sources() {
                if !files.contains(&s.path) {
                    files.push(s.path.clone());
                }
            }
        }
        files
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// A file could not be read or decoded, or changed since it was recorded.
    #[error("{}", file.display())]
    File {
        file: PathBuf,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A glTF model cannot be copied (the error names the file).
    #[error(transparent)]
    Model(#[from] ImportError),
    /// The glTF would be larger than a GLB can be.
    #[error(
        "the glTF of {0} trees would pass the 4 GiB a binary glTF can hold; export part of the \
         forest (texel place --region) or fewer trees"
    )]
    TooLarge(usize),
    /// The files are readable but do not fit together.
    #[error("{}: {message}", file.display())]
    Mismatch { file: PathBuf, message: String },
}

fn file_error(file: &Path, e: impl std::error::Error + Send + Sync + 'static) -> ExportError {
    ExportError::File {
        file: file.to_path_buf(),
        source: Box::new(e),
    }
}

/// A recorded source that changed, with what to do about it.
#[derive(Debug, thiserror::Error)]
#[error("{change}; {advice}")]
struct Stale {
    change: ProvenanceError,
    advice: &'static str,
}

fn stale(file: &Path, change: ProvenanceError, advice: &'static str) -> ExportError {
    file_error(file, Stale { change, advice })
}

/// An error about a file another file named.
#[derive(Debug, thiserror::Error)]
#[error("{}", .0.display())]
struct Named(PathBuf, #[source] Box<dyn std::error::Error + Send + Sync>);

/// When the forest recorded the files it names.
const PLACED: &str = "the forest was placed";

/// Reads the forest at `path`; with `models`, the model of every species that has trees, and
/// with `terrain`, the terrain.
pub fn load(
    path: &Path,
    models: bool,
    terrain: bool,
    limits: &Limits,
) -> Result<Inputs, ExportError> {
    let bytes = container::read_file(path).map_err(|e| file_error(path, e))?;
    let forest = instances::decode_with(&bytes, limits).map_err(|e| file_error(path, e))?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let mut inputs = Inputs {
        species_model: vec![None; forest.info.species.len()],
        forest,
        models: Vec::new(),
        terrain: None,
        dependencies: vec![path.to_path_buf()],
    };
    if models {
        let mut has_trees = vec![false; inputs.forest.info.species.len()];
        for t in &inputs.forest.instances {
            has_trees[t.species as usize] = true;
        }
        // Texel files already read (however their paths are spelt: `input::file_key`), with
        // the SHA-256 they were checked against and their model's index.
        let mut read: Vec<(PathBuf, [u8; 32], usize)> = Vec::new();
        for (s, record) in inputs.forest.info.species.iter().enumerate() {
            if !has_trees[s] {
                continue;
            }
            let file = dir.join(&record.texel);
            let key = crate::input::file_key(&file);
            if let Some((.., m)) = read
                .iter()
                .find(|(k, sha, _)| *k == key && *sha == record.texel_sha256)
            {
                inputs.species_model[s] = Some(*m);
                if !inputs.dependencies.contains(&file) {
                    inputs.dependencies.push(file);
                }
                continue;
            }
            let (model, files) = source_model(path, &file, &record.texel_sha256, limits)?;
            inputs.dependencies.push(file.clone());
            inputs.dependencies.extend(files);
            inputs.models.push(model);
            read.push((key, record.texel_sha256, inputs.models.len() - 1));
            inputs.species_model[s] = Some(inputs.models.len() - 1);
        }
    }
    if terrain {
        if inputs.forest.heightmap.is_some() {
            return Err(ExportError::Mismatch {
                file: path.to_path_buf(),
                message: "--with-terrain copies a glTF terrain's nodes, and this forest was placed on a heightmap image: export without it, or place on a glTF surface".into(),
            });
        }
        let records = &inputs.forest.info.terrain;
        let files = provenance::verify_all(records, &dir, PLACED, MAX_GLTF)
            .map_err(|e| stale(path, e, "re-run texel place"))?;
        let model = RawGltf::open(&files[0], limits)?;
        inputs.dependencies.extend(files);
        inputs.terrain = Some(model);
    }
    Ok(inputs)
}

/// The glTF the texel at `file` was baked from (its first recorded source), with every file
/// the texel recorded: the texel checked against `sha` (the forest `forest`'s record), the
/// sources against the texel's.
fn source_model(
    forest: &Path,
    file: &Path,
    sha: &[u8; 32],
    limits: &Limits,
) -> Result<(RawGltf, Vec<PathBuf>), ExportError> {
    let bytes = container::read_file(file).map_err(|e| file_error(forest, e))?;
    provenance::verify(file, &bytes, sha, PLACED)
        .map_err(|e| stale(forest, e, "re-run texel place"))?;
    // The header alone: an export copies the model the texel was baked from, never its
    // voxels, so their payload is not decompressed (the forest's digest has checked its bytes).
    let info = texel::read_info(&bytes)
        .map_err(|e| file_error(forest, Named(file.to_path_buf(), Box::new(e))))?;
    if let Some(message) = info.no_source_model("an export copies") {
        return Err(ExportError::Mismatch {
            file: file.to_path_buf(),
            message,
        });
    }
    let dir = file.parent().unwrap_or(Path::new(""));
    let files = provenance::verify_all(&info.sources, dir, "it was baked", MAX_GLTF)
        .map_err(|e| stale(file, e, "re-run texel bake"))?;
    let model = RawGltf::open(&files[0], limits)?;
    Ok((model, files))
}
