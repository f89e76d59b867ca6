//! `meshlap clean`.

use crate::common::{print_json, MeshArgs};
use meshlap::io::{write_mesh, WriteOptions};
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

pub fn run(args: &Args) -> meshlap::Result<()> {
    let (mesh, out) = args.mesh.open()?.cleaned(args.split_nonmanifold)?;
    write_mesh(&args.output, &mesh, &WriteOptions::default())?;
    if args.json {
        return print_json(&out);
    }
    println!(
        "dropped {} unreferenced vertices, {} degenerate faces, {} duplicate faces",
        out.clean.dropped_unreferenced_vertices,
        out.clean.dropped_degenerate_faces,
        out.clean.dropped_duplicate_faces
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
