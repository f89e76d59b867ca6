//! `meshlap clean`.

use crate::common::{print_json, MeshArgs};
use meshlap::io::{write_mesh, WriteOptions};
use meshlap::mesh::clean::{split_non_manifold, SplitReport};
use serde::Serialize;
use std::path::PathBuf;

/// Clean a mesh and write it: drop unreferenced vertices, faces with a repeated vertex
/// and duplicate faces (each counted). With --split-nonmanifold, also make it manifold
/// by duplicating vertices along non-manifold edges (more than two faces) and at
/// non-manifold vertices (several fans), so that every other command can run on it.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Output file (format from the extension).
    pub output: PathBuf,
    /// Duplicate vertices to remove non-manifold edges and vertices.
    #[arg(long)]
    pub split_nonmanifold: bool,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct CleanJson {
    dropped_unreferenced_vertices: usize,
    dropped_degenerate_faces: usize,
    dropped_duplicate_faces: usize,
    split: Option<SplitReport>,
    vertices: usize,
    faces: usize,
    non_manifold_edges: usize,
    non_manifold_vertices: usize,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.mesh.open()?;
    let (mesh, split) = if args.split_nonmanifold {
        let (m, r) = split_non_manifold(&input.mesh)?;
        (m, Some(r))
    } else {
        (input.mesh.clone(), None)
    };
    let topo = meshlap::mesh::topology::Topology::new(&mesh)?;
    write_mesh(&args.output, &mesh, &WriteOptions::default())?;
    let out = CleanJson {
        dropped_unreferenced_vertices: input.clean.dropped_unreferenced_vertices,
        dropped_degenerate_faces: input.clean.dropped_degenerate_faces,
        dropped_duplicate_faces: input.clean.dropped_duplicate_faces,
        split,
        vertices: mesh.n_vertices(),
        faces: mesh.n_faces(),
        non_manifold_edges: topo.non_manifold_edges().count(),
        non_manifold_vertices: topo.non_manifold_vertices().count(),
    };
    if args.json {
        return print_json(&out);
    }
    println!(
        "dropped {} unreferenced vertices, {} degenerate faces, {} duplicate faces",
        out.dropped_unreferenced_vertices,
        out.dropped_degenerate_faces,
        out.dropped_duplicate_faces
    );
    if let Some(s) = &out.split {
        println!(
            "split {} non-manifold edges and {} non-manifold vertices: {} vertices added",
            s.non_manifold_edges_before, s.non_manifold_vertices_before, s.vertices_added
        );
    }
    println!(
        "wrote {} ({} vertices, {} faces; {} non-manifold edges, {} non-manifold vertices)",
        args.output.display(),
        out.vertices,
        out.faces,
        out.non_manifold_edges,
        out.non_manifold_vertices
    );
    Ok(())
}
