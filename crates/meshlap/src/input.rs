//! Opening a mesh from a path or a `builtin:` spec, cleaned and with connectivity.
//!
//! Every command of the CLI goes through [`open`]: the mesh is read (format from the
//! extension unless overridden), validated, cleaned ([`crate::mesh::clean`]) and its
//! [`Topology`] built once.
//!
//! [`open`], [`open_mesh`], [`from_mesh`] and [`from_mesh_as_given`] run on a worker
//! of rayon's current pool (on the caller's thread when it is one): their parallel
//! passes are then shared out by work stealing instead of being handed to the pool
//! one by one from outside (see BENCHMARKS.md, "Connectivity").

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
    crate::par::on_worker(|| {
        let (raw, read_info) = read_raw(spec, opts.format)?;
        from_mesh(spec, raw, read_info, &opts.clean)
    })
}

/// An in-memory mesh used as given, not cleaned: its connectivity, and a clean report
/// that removes nothing (identity vertex map). A mesh that would need cleaning is
/// refused with [`crate::mesh::clean::check_clean`]'s errors (an index out of range,
/// a repeated corner, a duplicate face: the Python package names its `(V, F)`
/// arguments in their messages); the duplicates are found from the connectivity
/// ([`crate::mesh::clean::check_clean_given`]).
pub fn from_mesh_as_given(source: &str, mesh: TriMesh) -> Result<Input> {
    crate::par::on_worker(|| as_given(source, mesh))
}

fn as_given(source: &str, mesh: TriMesh) -> Result<Input> {
    let topology = Topology::new(&mesh)?;
    crate::mesh::clean::check_clean_given(&topology)?;
    let clean = CleanReport {
        vertex_map: crate::mesh::clean::identity_vertex_map(mesh.n_vertices()),
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
    crate::par::on_worker(|| {
        let (raw, _) = read_raw(spec, opts.format)?;
        Ok(clean_owned(raw, &opts.clean)?)
    })
}

/// Cleans an in-memory mesh and builds its connectivity.
///
/// In two steps, which give what one cleaning gives (tested): everything but the
/// duplicate faces first, then the connectivity, from which
/// [`crate::mesh::clean::check_clean_given`] finds duplicates without cleaning's
/// counting sort of the faces (a face's copy holds its three twins). Only a mesh that
/// has duplicates (rare) is then cleaned of them and its connectivity built again.
/// (Dropping duplicates last is the same as dropping them second: no vertex is used
/// by a copy alone, and renumbering the vertices keeps which faces repeat.)
pub fn from_mesh(
    source: &str,
    raw: TriMesh,
    read_info: Option<ReadInfo>,
    clean_opts: &CleanOptions,
) -> Result<Input> {
    crate::par::on_worker(|| clean_and_connect(source, raw, read_info, clean_opts))
}

fn clean_and_connect(
    source: &str,
    raw: TriMesh,
    read_info: Option<ReadInfo>,
    clean_opts: &CleanOptions,
) -> Result<Input> {
    let first = CleanOptions {
        drop_duplicate_faces: false,
        ..*clean_opts
    };
    let (mut mesh, mut clean_report) = clean_owned(raw, &first)?;
    if clean_opts.drop_duplicate_faces {
        if let Ok(topology) = Topology::new(&mesh) {
            if crate::mesh::clean::check_clean_given(&topology).is_ok() {
                return Ok(Input {
                    source: source.to_string(),
                    mesh,
                    topology,
                    read_info,
                    clean: clean_report,
                });
            }
        }
        let duplicates = CleanOptions {
            drop_degenerate_faces: false,
            drop_duplicate_faces: true,
            drop_unreferenced_vertices: false,
        };
        let (m, r) = clean_owned(mesh, &duplicates)?;
        clean_report.dropped_duplicate_faces = r.dropped_duplicate_faces;
        mesh = m;
    }
    let topology = Topology::new(&mesh)?;
    Ok(Input {
        source: source.to_string(),
        mesh,
        topology,
        read_info,
        clean: clean_report,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Opening runs on a pool worker ([`crate::par::on_worker`]) whichever thread
    /// calls: from a thread outside any pool (this test's), from a worker of a
    /// 1-thread pool and from one of a 3-thread pool, the same mesh, report and
    /// connectivity, and no deadlock when the caller is already a worker.
    #[test]
    fn opening_gives_the_same_input_from_any_thread() {
        let spec = "builtin:icosphere:4";
        let open_all = || {
            let i = open(spec, &OpenOptions::default()).unwrap();
            let (m, _) = open_mesh(spec, &OpenOptions::default()).unwrap();
            let g = from_mesh_as_given("t", m.clone()).unwrap();
            assert_eq!(g.mesh, i.mesh);
            (i, m)
        };
        assert!(rayon::current_thread_index().is_none());
        let (want, want_mesh) = open_all();
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (got, got_mesh) = pool.install(open_all);
            assert_eq!(got.mesh, want.mesh, "{threads} threads");
            assert_eq!(got_mesh, want_mesh);
            assert_eq!(got.clean.vertex_map, want.clean.vertex_map);
            assert_eq!(got.topology.twins(), want.topology.twins());
            assert_eq!(got.topology.adjacency(), want.topology.adjacency());
            assert_eq!(
                got.topology.half_edge_edges(),
                want.topology.half_edge_edges()
            );
        }
    }

    /// `from_mesh` gives what cleaning and then building the connectivity gives: the
    /// same mesh, report and connectivity (or the same error), on meshes with nothing
    /// to clean and with a repeated corner, a duplicate face, a face with two copies,
    /// an unused vertex, and with each cleaning option on and off.
    #[test]
    fn from_mesh_equals_cleaning_then_the_connectivity() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
        let mut meshes: Vec<TriMesh> = ["cow.obj", "teapot.obj", "woody.obj", "fandisk.obj"]
            .iter()
            .map(|f| io::read_mesh(&dir.join(f), None).unwrap().mesh)
            .collect();
        meshes.push(builtin::icosphere(2).unwrap());
        meshes.push(builtin::grid(6).unwrap());
        let base = meshes.clone();
        for m in &base {
            let mut degenerate = m.clone();
            degenerate.faces.insert(3, [1, 1, 2]);
            let mut duplicate = m.clone();
            let f = duplicate.faces[5];
            duplicate.faces.push([f[1], f[0], f[2]]);
            let mut twice = duplicate.clone();
            twice.faces.insert(2, [f[2], f[0], f[1]]);
            let mut unused = m.clone();
            unused.positions.push([9.0, 9.0, 9.0]);
            let mut all = twice.clone();
            all.faces.insert(7, [4, 3, 4]);
            all.positions.insert(0, [7.0, 7.0, 7.0]);
            all.faces.iter_mut().flatten().for_each(|v| *v += 1);
            meshes.extend([degenerate, duplicate, twice, unused, all]);
        }
        for (i, m) in meshes.iter().enumerate() {
            for bits in 0..8u8 {
                let opts = CleanOptions {
                    drop_degenerate_faces: bits & 1 != 0,
                    drop_duplicate_faces: bits & 2 != 0,
                    drop_unreferenced_vertices: bits & 4 != 0,
                };
                let got = from_mesh("t", m.clone(), None, &opts);
                let want = clean_owned(m.clone(), &opts)
                    .map_err(crate::Error::from)
                    .and_then(|(c, r)| Ok((Topology::new(&c)?, c, r)));
                let (got, (topology, mesh, report)) = match (got, want) {
                    (Ok(g), Ok(w)) => (g, w),
                    (Err(g), Err(w)) => {
                        assert_eq!(g.to_string(), w.to_string(), "mesh {i}, options {bits}");
                        continue;
                    }
                    (g, w) => panic!(
                        "mesh {i}, options {bits}: {:?} against {:?}",
                        g.err(),
                        w.err()
                    ),
                };
                assert_eq!(got.mesh, mesh, "mesh {i}, options {bits}");
                assert_eq!(got.clean.vertex_map, report.vertex_map);
                assert_eq!(
                    [
                        got.clean.dropped_degenerate_faces,
                        got.clean.dropped_duplicate_faces,
                        got.clean.dropped_unreferenced_vertices
                    ],
                    [
                        report.dropped_degenerate_faces,
                        report.dropped_duplicate_faces,
                        report.dropped_unreferenced_vertices
                    ]
                );
                let t = &got.topology;
                assert_eq!(t.twins(), topology.twins());
                assert_eq!(t.edges(), topology.edges());
                assert_eq!(t.adjacency_offsets(), topology.adjacency_offsets());
                assert_eq!(t.adjacency(), topology.adjacency());
                assert_eq!(t.half_edge_edges(), topology.half_edge_edges());
                assert_eq!(
                    t.inconsistently_oriented_edges(),
                    topology.inconsistently_oriented_edges()
                );
            }
        }
    }
}
