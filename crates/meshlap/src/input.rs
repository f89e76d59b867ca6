//! Opening a mesh from a path or a `builtin:` spec, cleaned and with connectivity.
//!
//! Every command of the CLI goes through [`open`]: the mesh is read (format from the
//! extension unless overridden), validated, cleaned ([`crate::mesh::clean`]) and its
//! [`Topology`] built once.

use crate::io::{self, Format, ReadInfo};
use crate::mesh::clean::{clean, CleanOptions, CleanReport, MeshReport};
use crate::mesh::{builtin, topology::Topology, TriMesh};
use crate::Result;
use std::path::Path;

/// Options of [`open`].
#[derive(Clone, Copy, Debug, Default)]
pub struct OpenOptions {
    /// Input format; `None` infers it from the extension.
    pub format: Option<Format>,
    /// What cleaning removes.
    pub clean: CleanOptions,
}

/// A cleaned mesh with its connectivity and the reports of reading and cleaning.
#[derive(Clone, Debug)]
pub struct Input {
    /// Where it came from (path or `builtin:` spec).
    pub source: String,
    /// The cleaned mesh.
    pub mesh: TriMesh,
    /// Its connectivity.
    pub topology: Topology,
    /// What the reader reported (`None` for built-in meshes).
    pub read_info: Option<ReadInfo>,
    /// What cleaning removed.
    pub clean: CleanReport,
}

impl Input {
    /// The full validation report of the cleaned mesh.
    pub fn report(&self) -> MeshReport {
        MeshReport::new(&self.mesh, &self.topology, &self.clean)
    }
}

/// True when `spec` names a generated mesh (`builtin:NAME[:ARGS]`).
pub fn is_builtin(spec: &str) -> bool {
    spec.starts_with("builtin:")
}

/// Reads (or generates) the raw mesh named by `spec`, without cleaning.
pub fn read_raw(spec: &str, format: Option<Format>) -> Result<(TriMesh, Option<ReadInfo>)> {
    if is_builtin(spec) {
        Ok((builtin::from_spec(spec)?, None))
    } else {
        let loaded = io::read_mesh(Path::new(spec), format)?;
        Ok((loaded.mesh, Some(loaded.info)))
    }
}

/// Opens `spec` (a file path or `builtin:NAME[:ARGS]`), cleans it and builds its
/// connectivity.
pub fn open(spec: &str, opts: &OpenOptions) -> Result<Input> {
    let (raw, read_info) = read_raw(spec, opts.format)?;
    from_mesh(spec, raw, read_info, &opts.clean)
}

/// Cleans an in-memory mesh and builds its connectivity.
pub fn from_mesh(
    source: &str,
    raw: TriMesh,
    read_info: Option<ReadInfo>,
    clean_opts: &CleanOptions,
) -> Result<Input> {
    raw.validate().or_else(|e| match e {
        crate::mesh::MeshError::Empty => Ok(()),
        e => Err(e),
    })?;
    let (mesh, clean_report) = clean(&raw, clean_opts)?;
    let topology = Topology::new(&mesh)?;
    Ok(Input {
        source: source.to_string(),
        mesh,
        topology,
        read_info,
        clean: clean_report,
    })
}
