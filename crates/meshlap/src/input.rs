//! Opening a mesh from a path or a `builtin:` spec, cleaned and with connectivity.
//!
//! Every command of the CLI goes through [`open`]: the mesh is read (format from the
//! extension unless overridden), validated, cleaned ([`crate::mesh::clean`]) and its
//! [`Topology`] built once.

use crate::io::{self, Format, ReadInfo};
use crate::mesh::clean::{
    clean_owned, split_non_manifold, CleanOptions, CleanReport, MeshReport, SplitReport,
};
use crate::mesh::{builtin, topology::Topology, MeshError, TriMesh};
use crate::Result;
use serde::Serialize;
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

/// What `meshlap info --json` and Python's `meshlap.info` print: the source, the
/// [`MeshReport`] of the cleaned mesh (its keys flattened in) and what the reader
/// noticed.
#[derive(Clone, Debug, Serialize)]
pub struct InfoReport {
    /// Where the mesh came from (path, `builtin:` spec, or `array` for Python).
    pub source: String,
    /// Counts, connectivity, degrees, bounding box and what cleaning dropped.
    #[serde(flatten)]
    pub report: MeshReport,
    /// Polygons the reader split into triangles (fan); 0 for generated meshes.
    pub polygons_triangulated: usize,
    /// What the reader reported (`None` for generated and in-memory meshes).
    pub read: Option<ReadInfo>,
}

/// What `meshlap clean --json` and Python's `meshlap.clean` print about the mesh
/// [`Input::cleaned`] returns.
#[derive(Clone, Debug, Serialize)]
pub struct CleanSummary {
    /// What cleaning dropped (counts).
    #[serde(flatten)]
    pub clean: CleanReport,
    /// What splitting non-manifold edges and vertices did (`None` when not asked).
    pub split: Option<SplitReport>,
    /// Vertices of the result.
    pub vertices: usize,
    /// Faces of the result.
    pub faces: usize,
    /// Non-manifold edges left in the result (0 after a split).
    pub non_manifold_edges: usize,
    /// Non-manifold vertices left in the result (0 after a split).
    pub non_manifold_vertices: usize,
}

impl Input {
    /// The full validation report of the cleaned mesh.
    pub fn report(&self) -> MeshReport {
        MeshReport::new(&self.mesh, &self.topology, &self.clean)
    }

    /// The report of `meshlap info`: [`Input::report`] with the source and the
    /// reader's notes.
    pub fn info(&self) -> InfoReport {
        InfoReport {
            source: self.source.clone(),
            report: self.report(),
            polygons_triangulated: self
                .read_info
                .as_ref()
                .map_or(0, |i| i.polygons_triangulated),
            read: self.read_info.clone(),
        }
    }

    /// The cleaned mesh as `meshlap clean` writes it: with `split`, made
    /// manifold by [`split_non_manifold`]; with the summary of what was done.
    ///
    /// # Errors
    /// [`MeshError`] from [`split_non_manifold`] or from building the result's
    /// connectivity.
    pub fn cleaned(&self, split: bool) -> Result<(TriMesh, CleanSummary), MeshError> {
        let (mesh, split) = if split {
            let (m, r) = split_non_manifold(&self.mesh)?;
            (m, Some(r))
        } else {
            (self.mesh.clone(), None)
        };
        let topo = Topology::new(&mesh)?;
        let summary = CleanSummary {
            clean: self.clean.clone(),
            split,
            vertices: mesh.n_vertices(),
            faces: mesh.n_faces(),
            non_manifold_edges: topo.non_manifold_edges().count(),
            non_manifold_vertices: topo.non_manifold_vertices().count(),
        };
        Ok((mesh, summary))
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

/// An in-memory mesh used as given, not cleaned: its connectivity, and a clean report
/// that removes nothing (identity vertex map). A mesh that would need cleaning is
/// refused with [`crate::mesh::clean::check_clean`]'s errors (an index out of range,
/// a repeated corner, a duplicate face: the Python package names its `(V, F)`
/// arguments in their messages); the duplicates are found from the connectivity
/// ([`crate::mesh::clean::check_clean_given`]).
pub fn from_mesh_as_given(source: &str, mesh: TriMesh) -> Result<Input> {
    use rayon::prelude::*;
    let topology = Topology::new(&mesh)?;
    crate::mesh::clean::check_clean_given(&topology)?;
    let clean = CleanReport {
        vertex_map: (0..mesh.n_vertices() as u32)
            .into_par_iter()
            .map(Some)
            .collect(),
        ..Default::default()
    };
    Ok(Input {
        source: source.to_string(),
        mesh,
        topology,
        read_info: None,
        clean,
    })
}

/// Reads (or generates) `spec` and cleans it as [`open`] does, without building the
/// connectivity: for callers that want the arrays only (the Python package's
/// `read_mesh`). The same mesh as `open(spec, opts)?.mesh`.
pub fn open_mesh(spec: &str, opts: &OpenOptions) -> Result<(TriMesh, CleanReport)> {
    let (raw, _) = read_raw(spec, opts.format)?;
    Ok(clean_owned(raw, &opts.clean)?)
}

/// Cleans an in-memory mesh and builds its connectivity.
pub fn from_mesh(
    source: &str,
    raw: TriMesh,
    read_info: Option<ReadInfo>,
    clean_opts: &CleanOptions,
) -> Result<Input> {
    let (mesh, clean_report) = clean_owned(raw, clean_opts)?;
    let topology = Topology::new(&mesh)?;
    Ok(Input {
        source: source.to_string(),
        mesh,
        topology,
        read_info,
        clean: clean_report,
    })
}
