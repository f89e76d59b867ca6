//! `meshlap compare`.

use crate::common::{print_json, MeshArgs};
use meshlap::io::Format;
use std::path::PathBuf;

/// Measure how far mesh B is from mesh A: RMS and maximum vertex error (when the
/// vertex counts match; `--map` gives B's vertex order), Metro-style symmetric surface
/// distance by area-uniform sampling and a BVH (works for any vertex order), Zhang's
/// scale-dependent-Laplacian measure (§4.9) and Karni–Gotsman's geometric-Laplacian
/// error, and the MSDM2 perceptual distance (Lavoué 2011; any connectivity).
/// Distances are divided by A's bounding-box diagonal. Reports whether the
/// connectivity is identical.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub a: MeshArgs,
    /// The approximation B (a file or builtin:…).
    pub b: String,
    /// B's format, overriding its extension.
    #[arg(long, value_name = "FORMAT")]
    pub format_b: Option<Format>,
    /// Vertex map: a text file with one integer per line, the vertex of A that each
    /// vertex of B corresponds to.
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Sample points per surface for the surface distance (besides the vertices).
    #[arg(long, default_value_t = 200_000)]
    pub samples: usize,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let a = args.a.open()?;
    let b = MeshArgs {
        mesh: args.b.clone(),
        format: args.format_b,
    }
    .open()?;
    let map = match &args.map {
        None => None,
        Some(p) => {
            let text = std::fs::read_to_string(p).map_err(|e| {
                meshlap::Error::InvalidArgument(format!("cannot read {}: {e}", p.display()))
            })?;
            let v: Result<Vec<u32>, _> = text.split_whitespace().map(str::parse).collect();
            Some(v.map_err(|e| {
                meshlap::Error::InvalidArgument(format!("bad vertex map {}: {e}", p.display()))
            })?)
        }
    };
    let c = meshlap::metric::compare(&a.mesh, &b.mesh, map.as_deref(), args.samples)?;
    if args.json {
        return print_json(&c);
    }
    let o = crate::common::opt;
    println!("diagonal of A        {:.6e}", c.diagonal);
    println!("same connectivity    {}", c.same_connectivity);
    println!(
        "vertex error         RMS {}  max {}",
        o(c.vertex_rms),
        o(c.vertex_max)
    );
    println!(
        "surface A→B          RMS {:.6e}  max {:.6e}",
        c.a_to_b_rms, c.a_to_b_max
    );
    println!(
        "surface B→A          RMS {:.6e}  max {:.6e}",
        c.b_to_a_rms, c.b_to_a_max
    );
    println!("Hausdorff            {:.6e}", c.hausdorff);
    println!("Zhang SDL measure    {}", o(c.zhang_sdl));
    println!("Karni–Gotsman error  {}", o(c.karni_gotsman));
    println!("MSDM2                {:.6e}", c.msdm2);
    Ok(())
}
