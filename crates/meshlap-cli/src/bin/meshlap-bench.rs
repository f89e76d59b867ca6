//! `meshlap-bench TASK MESH [--repeat N]`: times library calls for the side-by-side
//! scripts in `bench/` and prints JSON with the median and all timings (seconds).
//! Tasks: `load` (read + clean + connectivity), `operators` (assemble each operator),
//! `topology` (connectivity only), `io` (write and re-read as PLY and OBJ),
//! `read` (parse a file only), `write MESH OUT` (write one file), `dump MESH DIR` (every
//! operator as `DIR/KIND.mtx`, for entry-by-entry comparison with the peers),
//! `spectrum` (dense eigenbases: KL and SQL by the symmetric solver, the TL through its
//! GL similarity and by the general eigensolver plus LU).

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
    let usage = "usage: meshlap-bench load|operators|topology|io|read|spectrum MESH \
                 [--repeat N] [--kind K] [--general] | dump MESH DIR | write MESH OUT [--repeat N]";
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
            // `--kind NAME` restricts the task to one operator (and skips topology),
            // so that a script can interleave our timings with a peer's.
            let only: Option<OperatorKind> = match args.iter().position(|a| a == "--kind") {
                Some(p) => Some(args.get(p + 1).ok_or(usage)?.parse()?),
                None => None,
            };
            for kind in OperatorKind::ALL {
                if only.is_some_and(|k| k != kind) {
                    continue;
                }
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
            if only.is_some() {
                println!("{}", serde_json::to_string(&out)?);
                return Ok(());
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
        "topology" => {
            // Connectivity alone (read and cleaning excluded).
            let input = open(&mesh, &OpenOptions::default())?;
            out.insert("vertices".into(), input.mesh.n_vertices().into());
            let (m, t) = time(repeat, || {
                meshlap::mesh::topology::Topology::new(&input.mesh).map(|t| t.n_edges())
            });
            out.insert(
                "topology".into(),
                serde_json::json!({"median": m, "times": t}),
            );
        }
        "dump" => {
            // Every operator as Matrix Market, for the scripts to compare entries.
            let dir = args.get(2).ok_or(usage)?;
            let input = open(&mesh, &OpenOptions::default())?;
            for kind in OperatorKind::ALL {
                let op = Operator::assemble(
                    kind,
                    &input.mesh,
                    &input.topology,
                    &OperatorOptions::default(),
                )?;
                let path = std::path::Path::new(dir).join(format!("{}.mtx", kind.name()));
                meshlap::io::write_matrix_market(&path, op.matrix.as_ref())?;
            }
            out.insert("vertices".into(), input.mesh.n_vertices().into());
        }
        "write" => {
            // Write MESH (cleaned) to OUT (format from the extension); one process per
            // format, so the peak memory measured outside is this step's alone.
            let dest = std::path::PathBuf::from(args.get(2).ok_or(usage)?);
            let input = open(&mesh, &OpenOptions::default())?;
            let (w, _) = time(repeat, || {
                meshlap::io::write_mesh(&dest, &input.mesh, &Default::default()).map(|_| ())
            });
            let bytes = std::fs::metadata(&dest)?.len() as f64;
            out.insert("vertices".into(), input.mesh.n_vertices().into());
            out.insert(
                "write".into(),
                serde_json::json!({"median": w, "bytes": bytes, "mb_s": bytes / w / 1e6}),
            );
        }
        "read" => {
            // Parse MESH (a file) into a mesh, without cleaning or connectivity.
            let path = std::path::PathBuf::from(&mesh);
            let bytes = std::fs::metadata(&path)?.len() as f64;
            let (r, _) = time(repeat, || {
                meshlap::io::read_mesh(&path, None).map(|l| l.mesh.n_faces())
            });
            out.insert(
                "read".into(),
                serde_json::json!({"median": r, "bytes": bytes, "mb_s": bytes / r / 1e6}),
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
