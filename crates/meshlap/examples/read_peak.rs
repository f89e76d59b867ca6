//! Peak resident memory of reading one mesh file (RELIABILITY.md, "Memory, whole
//! process"): reads `PATH` with `io::read_mesh` and prints the vertex and face counts,
//! the in-memory mesh size (24 bytes per vertex, 12 per face), the process's peak
//! resident set (`VmHWM` from `/proc/self/status`, Linux) and their ratio.
//!
//! ```sh
//! cargo run --release -p meshlap --example read_peak -- /tmp/big.ply
//! ```

fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

fn main() {
    let Some(path) = std::env::args_os().nth(1) else {
        eprintln!("usage: read_peak MESH_FILE");
        std::process::exit(2);
    };
    let before = peak_rss_bytes();
    let loaded = match meshlap::io::read_mesh(std::path::Path::new(&path), None) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let m = &loaded.mesh;
    let mesh_bytes = 24 * m.n_vertices() as u64 + 12 * m.n_faces() as u64;
    println!("vertices        {}", m.n_vertices());
    println!("faces           {}", m.n_faces());
    println!("mesh bytes      {mesh_bytes}");
    if let (Some(b), Some(p)) = (before, peak_rss_bytes()) {
        println!("peak RSS before {b}");
        println!("peak RSS        {p}");
        println!("ratio           {:.3}", p as f64 / mesh_bytes as f64);
    }
}
