//! `meshlap info`.

use crate::common::{print_json, MeshArgs};

/// Describe a mesh: counts, boundary loops, components, Euler characteristic and
/// genus, degree statistics, bounding box, and everything cleaning dropped or
/// validation detected (non-manifold edges and vertices, inconsistent orientation,
/// zero-area faces).
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Print machine-readable JSON instead of text (keys include vertices, faces,
    /// edges, boundary_edges, boundary_loops, components, euler_characteristic,
    /// non_manifold_edges, non_manifold_vertices, dropped_unreferenced_vertices,
    /// dropped_degenerate_faces, dropped_duplicate_faces).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let info = args.mesh.open()?.info();
    if args.json {
        return print_json(&info);
    }
    let r = &info.report;
    let polys = info.polygons_triangulated;
    println!("mesh            {}", info.source);
    println!("vertices        {}", r.vertices);
    println!("faces           {}", r.faces);
    println!("edges           {}", r.edges);
    println!(
        "boundary        {} edges in {} loops",
        r.boundary_edges, r.boundary_loops
    );
    println!("components      {}", r.components);
    println!("euler char.     {}", r.euler_characteristic);
    match r.genus {
        Some(g) => println!("genus           {g}"),
        None => println!("genus           n/a (not closed, manifold and oriented)"),
    }
    println!(
        "degree          min {}  mean {:.3}  max {}",
        r.degree.min, r.degree.mean, r.degree.max
    );
    let hist: Vec<String> = r
        .degree
        .histogram
        .iter()
        .enumerate()
        .filter(|(_, &c)| c > 0)
        .map(|(d, c)| format!("{d}:{c}"))
        .collect();
    println!("degree hist.    {}", hist.join(" "));
    println!(
        "bounding box    [{:.6}, {:.6}, {:.6}] – [{:.6}, {:.6}, {:.6}]  (diagonal {:.6})",
        r.bbox_min[0],
        r.bbox_min[1],
        r.bbox_min[2],
        r.bbox_max[0],
        r.bbox_max[1],
        r.bbox_max[2],
        r.bbox_diagonal
    );
    println!(
        "non-manifold    {} edges, {} vertices",
        r.non_manifold_edges, r.non_manifold_vertices
    );
    println!(
        "orientation     {} inconsistently oriented edges",
        r.inconsistently_oriented_edges
    );
    println!("zero-area faces {}", r.zero_area_faces);
    println!(
        "dropped         {} unreferenced vertices, {} degenerate faces, {} duplicate faces",
        r.dropped_unreferenced_vertices, r.dropped_degenerate_faces, r.dropped_duplicate_faces
    );
    if polys > 0 {
        println!("triangulated    {polys} polygons (fan)");
    }
    Ok(())
}
