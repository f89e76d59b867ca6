//! `meshlap-bench TASK MESH [--repeat N]`: times library calls for the side-by-side
//! scripts in `bench/` and prints JSON with the median and all timings (seconds).
//! Tasks: `load` (read + clean + connectivity), `operators` (assemble each operator),
//! `io` (write and re-read as PLY and OBJ), `spectrum` (dense eigenbases: KL and SQL
//! by the symmetric solver, the TL through its GL similarity and by the general
//! eigensolver plus LU), `codec` (compress and decompress, default settings,
//! non-manifold vertices split first).

use meshlap::input::{open, OpenOptions};
use meshlap::operator::{Operator, OperatorKind, OperatorOptions};
use std::collections::BTreeMap;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn time<T>(repeat: usize, mut f: impl FnMut() -> T) -> (f64, Vec<f64>) {
    let mut times = Vec::with_capacity(repeat);
    for _ in 0..repeat {
        let t = Instant::now();
        std::hint::black_box(f());
        times.push(t.elapsed().as_secs_f64());
    }
    (median(times.clone()), times)
}

fn main() {
    if let Err(e) = run() {
        eprintln!("meshlap-bench: error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage =
        "usage: meshlap-bench load|operators|io|spectrum|codec MESH [--repeat N] [--general]";
    let task = args.first().ok_or(usage)?.clone();
    let mesh = args.get(1).ok_or(usage)?.clone();
    let repeat = match args.iter().position(|a| a == "--repeat") {
        Some(p) => args.get(p + 1).ok_or(usage)?.parse()?,
        None => 7,
    };
    let mut out: BTreeMap<String, serde_json::Value> = BTreeMap::new();
    out.insert("threads".into(), rayon::current_num_threads().into());
    match task.as_str() {
        "load" => {
            let (m, t) = time(repeat, || {
                open(&mesh, &OpenOptions::default()).map(|i| i.mesh.n_faces())
            });
            out.insert("load".into(), serde_json::json!({"median": m, "times": t}));
        }
        "operators" => {
            let input = open(&mesh, &OpenOptions::default())?;
            out.insert("vertices".into(), input.mesh.n_vertices().into());
            for kind in OperatorKind::ALL {
                let (m, t) = time(repeat, || {
                    Operator::assemble(
                        kind,
                        &input.mesh,
                        &input.topology,
                        &OperatorOptions::default(),
                    )
                    .map(|o| o.matrix.compute_nnz())
                });
                out.insert(
                    kind.name().into(),
                    serde_json::json!({"median": m, "times": t}),
                );
            }
            // Connectivity is shared by all operators; time it separately.
            let (m, t) = time(repeat, || {
                meshlap::mesh::topology::Topology::new(&input.mesh).map(|t| t.n_edges())
            });
            out.insert(
                "topology".into(),
                serde_json::json!({"median": m, "times": t}),
            );
        }
        "io" => {
            // Write and re-read the (cleaned) mesh as binary PLY and as OBJ.
            let input = open(&mesh, &OpenOptions::default())?;
            out.insert("vertices".into(), input.mesh.n_vertices().into());
            let dir = tempfile::tempdir()?;
            for ext in ["ply", "obj"] {
                let path = dir.path().join(format!("mesh.{ext}"));
                let (w, _) = time(repeat, || {
                    meshlap::io::write_mesh(&path, &input.mesh, &Default::default()).map(|_| ())
                });
                let bytes = std::fs::metadata(&path)?.len() as f64;
                let (r, _) = time(repeat, || {
                    meshlap::io::read_mesh(&path, None).map(|l| l.mesh.n_faces())
                });
                out.insert(
                    ext.into(),
                    serde_json::json!({"write": w, "read": r, "bytes": bytes,
                        "write_mb_s": bytes / w / 1e6, "read_mb_s": bytes / r / 1e6}),
                );
            }
        }
        "codec" => {
            // Compress (SSTL, 10 bits, default patches) and decompress in memory.
            let input = open(&mesh, &OpenOptions::default())?;
            let (mesh_c, _) = meshlap::mesh::clean::split_non_manifold(&input.mesh)?;
            let topo = meshlap::mesh::topology::Topology::new(&mesh_c)?;
            out.insert("vertices".into(), mesh_c.n_vertices().into());
            let opts = meshlap::codec::CompressOptions::default();
            let c = meshlap::codec::compress(&mesh_c, &topo, &opts)?;
            let (e, te) = time(repeat, || {
                meshlap::codec::compress(&mesh_c, &topo, &opts).map(|c| c.bytes.len())
            });
            let (d, td) = time(repeat, || {
                meshlap::codec::decompress(&c.bytes).map(|m| m.n_faces())
            });
            out.insert("bits_per_vertex".into(), c.report.bits_per_vertex.into());
            out.insert(
                "encode".into(),
                serde_json::json!({"median": e, "times": te}),
            );
            out.insert(
                "decode".into(),
                serde_json::json!({"median": d, "times": td}),
            );
        }
        "spectrum" => {
            use meshlap::spectral::{BasisOptions, EigenBasis, EigenPath};
            let input = open(&mesh, &OpenOptions::default())?;
            out.insert("vertices".into(), input.mesh.n_vertices().into());
            let general = args.iter().any(|a| a == "--general");
            let mut cases = vec![
                ("kirchhoff", OperatorKind::Kirchhoff, EigenPath::Auto),
                ("sql", OperatorKind::Sql, EigenPath::Auto),
                ("tutte", OperatorKind::Tutte, EigenPath::Auto),
            ];
            if general {
                cases.push(("tutte-general", OperatorKind::Tutte, EigenPath::General));
            }
            for (name, kind, path) in cases {
                let op = Operator::assemble(
                    kind,
                    &input.mesh,
                    &input.topology,
                    &OperatorOptions::default(),
                )?;
                let opts = BasisOptions {
                    path,
                    ..Default::default()
                };
                let (m, t) = time(repeat, || EigenBasis::compute(&op, &opts).map(|b| b.len()));
                out.insert(name.into(), serde_json::json!({"median": m, "times": t}));
            }
        }
        _ => return Err(usage.into()),
    }
    println!("{}", serde_json::to_string(&out)?);
    Ok(())
}
