//! `meshlap convert`.

use crate::common::MeshArgs;
use meshlap::io::{write_mesh, Format, WriteOptions};
use std::path::PathBuf;

/// Convert a mesh between OBJ, OFF, PLY and STL. The mesh is cleaned on the way
/// (see `meshlap info`); the output keeps the cleaned vertex order. The file is
/// written to a temporary name and renamed, so a failure leaves no partial output.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Output file; its extension picks the format unless --output-format is given.
    pub output: PathBuf,
    /// Output format (obj, off, ply, stl).
    #[arg(long, value_name = "FORMAT")]
    pub output_format: Option<Format>,
    /// Write PLY as ASCII instead of binary little-endian.
    #[arg(long)]
    pub ascii: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.mesh.open()?;
    let opts = WriteOptions {
        format: args.output_format,
        ply_ascii: args.ascii,
        ..Default::default()
    };
    write_mesh(&args.output, &input.mesh, &opts)?;
    eprintln!(
        "wrote {} ({} vertices, {} faces)",
        args.output.display(),
        input.mesh.n_vertices(),
        input.mesh.n_faces()
    );
    Ok(())
}
