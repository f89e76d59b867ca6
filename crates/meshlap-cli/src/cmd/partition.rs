//! `meshlap partition`.

use crate::common::{one_of, print_json, MeshArgs};
use meshlap::io::{write_mesh, WriteOptions};
use meshlap::partition::{partition_mesh, PartitionMethod, PartitionOptions, PartitionStats};
use serde::Serialize;
use std::path::PathBuf;

/// Split a mesh into connected patches of about P vertices for patch-wise spectral
/// transforms (Zhang 2004 §4.9, Karni–Gotsman 2000), with METIS's multilevel k-way
/// partitioner or (`--method lloyd`) Lloyd-relaxed graph Voronoi cells. Every vertex lands in exactly one patch; a face whose corners lie in
/// different patches is a seam and belongs to no patch; every vertex keeps at least one
/// face of its own patch, and every patch is connected. Reports the patch sizes
/// (min/mean/max) and the edge cut (edges between patches).
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Target vertices per patch (the paper: "several hundred").
    #[arg(long, short = 'p', value_name = "P")]
    pub patch_size: usize,
    /// How the vertices are first split: metis (multilevel k-way, the lowest edge
    /// cut, parts within a few vertices of P) or lloyd (Lloyd-relaxed graph Voronoi
    /// cells: an edge cut close to METIS's in a fraction of the time, more spread in
    /// the sizes; the codec's partition from .mlz format 7).
    #[arg(long, default_value_t = PartitionMethod::default(),
          value_parser = one_of::<PartitionMethod>(PartitionMethod::ALL.map(PartitionMethod::name)))]
    pub method: PartitionMethod,
    /// METIS random seed (`--method metis`).
    #[arg(long, default_value_t = PartitionOptions::DEFAULT_SEED)]
    pub seed: i32,
    /// Lloyd relaxation steps (`--method lloyd`; at most 100). Each is two
    /// breadth-first searches; the codec takes 2 from .mlz format 9 (5 before).
    #[arg(long, default_value_t = PartitionMethod::LLOYD_ITERATIONS, value_name = "N")]
    pub lloyd_iterations: usize,
    /// Write the mesh as PLY with per-vertex colours by patch and a `patch` scalar.
    #[arg(long, short, value_name = "OUT.ply")]
    pub output: Option<PathBuf>,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Report<'a> {
    vertices: usize,
    faces: usize,
    patch_size: usize,
    #[serde(flatten)]
    stats: &'a PartitionStats,
    output: Option<String>,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.mesh.open()?;
    let opts = PartitionOptions {
        method: args.method,
        seed: args.seed,
        lloyd_iterations: args.lloyd_iterations,
        ..PartitionOptions::new(args.patch_size)
    };
    let part = partition_mesh(&input.mesh, &input.topology, &opts)?;
    if let Some(out) = &args.output {
        let colours = part.vertex_colors();
        let scalar: Vec<f64> = part.patch_of().iter().map(|&p| p as f64).collect();
        write_mesh(
            out,
            &input.mesh,
            &WriteOptions {
                vertex_colors: Some(&colours),
                vertex_scalar: Some(("patch", &scalar)),
                ..Default::default()
            },
        )?;
    }
    let s = part.stats();
    if args.json {
        return print_json(&Report {
            vertices: input.mesh.n_vertices(),
            faces: input.mesh.n_faces(),
            patch_size: args.patch_size,
            stats: s,
            output: args.output.as_ref().map(|p| p.display().to_string()),
        });
    }
    let first = match s.method {
        PartitionMethod::Metis => "METIS",
        PartitionMethod::Lloyd => "Lloyd cells",
    };
    println!(
        "{} vertices, {} faces → {} patches ({first}: {} parts)",
        input.mesh.n_vertices(),
        input.mesh.n_faces(),
        s.patches,
        s.metis_parts
    );
    println!(
        "patch size: min {}, mean {:.1}, max {}",
        s.min_size, s.mean_size, s.max_size
    );
    println!(
        "edge cut: {} ({first} raw parts: {}); seam faces: {}",
        s.edge_cut, s.metis_edge_cut, s.straddling_faces
    );
    if let Some(out) = &args.output {
        println!("wrote {}", out.display());
    }
    Ok(())
}
