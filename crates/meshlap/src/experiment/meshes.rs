//! Where the experiments' meshes come from: the shared test models (a directory, by
//! default [`DEFAULT_MESH_DIR`] relative to the repository root) or generated ones
//! (`builtin:` specs), opened and cleaned by [`crate::input::open`].

use super::{ExperimentError, Progress, ProgressFn};
use crate::input::{self, Input, OpenOptions};
use std::path::Path;

/// The directory of the shared test meshes, relative to the repository root.
pub const DEFAULT_MESH_DIR: &str = "../shared/data/meshes";

/// The spec of the shared model `name` (e.g. `cow.obj`) in `dir`.
pub fn shared(dir: &Path, name: &str) -> String {
    dir.join(name).to_string_lossy().into_owned()
}

/// Short name of a mesh source for tables (file name without directories).
pub fn short_name(source: &str) -> String {
    Path::new(source)
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| source.to_string())
}

/// Opens (and cleans) one mesh; the error names the mesh and keeps the cause.
pub fn open(spec: &str) -> Result<Input, ExperimentError> {
    input::open(spec, &OpenOptions::default()).map_err(|e| ExperimentError::input(spec, e))
}

/// Opens every mesh of `specs`, reporting a [`Progress::Note`] for each.
pub fn open_all(
    specs: &[String],
    progress: &mut ProgressFn,
) -> Result<Vec<Input>, ExperimentError> {
    specs
        .iter()
        .map(|s| {
            progress(Progress::note(format!("loading {}", short_name(s))));
            open(s)
        })
        .collect()
}
