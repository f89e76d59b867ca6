//! `meshlap decompress`.

use meshlap::io::{write_mesh, IoError, WriteOptions};
use std::path::PathBuf;

/// Decompress a `.mlz` file written by `meshlap compress` into a mesh file (format
/// from the extension). Connectivity is exact; geometry within the coded precision;
/// vertex order is the input's if it was stored (`--preserve-order`), otherwise the
/// coder's traversal order. A truncated or corrupt file is an error, never a partial
/// output.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Compressed file (.mlz).
    pub input: PathBuf,
    /// Output mesh (.obj .off .ply .stl).
    #[arg(short, long)]
    pub output: PathBuf,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let bytes = std::fs::read(&args.input).map_err(|source| IoError::Open {
        path: args.input.clone(),
        source,
    })?;
    let mesh = meshlap::codec::decompress(&bytes)?;
    write_mesh(&args.output, &mesh, &WriteOptions::default())?;
    eprintln!(
        "wrote {} ({} vertices, {} faces)",
        args.output.display(),
        mesh.n_vertices(),
        mesh.n_faces()
    );
    Ok(())
}
