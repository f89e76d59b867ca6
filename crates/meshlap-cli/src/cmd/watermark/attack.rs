//! `meshlap watermark attack`.

use crate::common::{print_json, MeshInOut};
use meshlap::io::{write_mesh, WriteOptions};
use meshlap::watermark::attack::{attack, AttackKind, AttackOptions, SubdivisionScheme};
use serde::Serialize;

/// Apply one attack of the 3D mesh watermarking benchmark (Wang, Lavoué, Denis,
/// Baskurt, SMI 2010) and write the attacked mesh.
///
/// --amount by kind:
///   noise       X % of the mean vertex distance to the centroid (uniform, per coordinate)
///   smooth      X iterations of x ← x + λ(Cx − x), C the neighbour average (--lambda)
///   quantize    X bits per coordinate over the bounding box
///   similarity  scale factor X; rotation and translation random from --seed
///   simplify    remove X % of the vertices by quadric edge collapse
///   subdivide   X steps of midpoint, loop or sqrt3 subdivision (--scheme)
///   crop        remove X % of the vertices from one side (principal axis; --seed odd:
///               the other side)
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub io: MeshInOut,
    /// The attack.
    #[arg(long)]
    pub kind: AttackKind,
    /// Its strength (see above).
    #[arg(long, allow_negative_numbers = true)]
    pub amount: f64,
    /// Subdivision scheme (subdivide).
    #[arg(long, value_enum, default_value_t = SubdivisionScheme::default())]
    pub scheme: SubdivisionScheme,
    /// Smoothing step λ in (0, 1] (smooth).
    #[arg(long, default_value_t = AttackOptions::DEFAULT_LAMBDA)]
    pub lambda: f64,
    /// Seed of the noise, the similarity and the cropping side.
    #[arg(long, default_value_t = AttackOptions::DEFAULT_SEED)]
    pub seed: u64,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct AttackJson {
    #[serde(flatten)]
    options: AttackOptions,
    vertices_before: usize,
    faces_before: usize,
    vertices_after: usize,
    faces_after: usize,
    seconds: f64,
    output: String,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.io.mesh.open()?;
    let options = AttackOptions {
        scheme: args.scheme,
        lambda: args.lambda,
        seed: args.seed,
        ..AttackOptions::new(args.kind, args.amount)
    };
    let t = std::time::Instant::now();
    let out = attack(&input.mesh, &options)?;
    let seconds = t.elapsed().as_secs_f64();
    write_mesh(&args.io.output, &out, &WriteOptions::default())?;
    let report = AttackJson {
        options,
        vertices_before: input.mesh.n_vertices(),
        faces_before: input.mesh.n_faces(),
        vertices_after: out.n_vertices(),
        faces_after: out.n_faces(),
        seconds,
        output: args.io.output.display().to_string(),
    };
    if args.json {
        return print_json(&report);
    }
    println!("attack     {}", options.label());
    println!(
        "vertices   {} → {}",
        report.vertices_before, report.vertices_after
    );
    println!(
        "faces      {} → {}",
        report.faces_before, report.faces_after
    );
    println!("written    {}", report.output);
    Ok(())
}
