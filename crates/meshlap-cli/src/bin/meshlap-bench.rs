//! `meshlap-bench TASK MESH [--repeat N]`: times library calls for the side-by-side
//! scripts in `bench/` and prints JSON with the median and all timings (seconds).
//! Tasks: `load` (read + clean + connectivity), `operators` (assemble each operator),
//! `topology` (connectivity only), `io` (write and re-read as PLY and OBJ),
//! `read` (parse a file only), `write MESH OUT` (write one file), `dump MESH DIR` (every
//! operator as `DIR/KIND.mtx`, for entry-by-entry comparison with the peers),
//! `spectrum` (dense eigenbases: KL and SQL by the symmetric solver, the TL through its
//! GL similarity and by the general eigensolver plus LU; `--kind K` keeps one of
//! kirchhoff, sql, tutte, tutte-general, or tutte-coefficients (adds the basis plus
//! the coefficients of the positions); each symmetric case also times faer alone,
//! `K-faer-only`: dense copy + `self_adjoint_evd`, `K-blocked-only`: dense copy +
//! `blocked_evd::symmetric_evd`, `--owned` adds `K-blocked-owned` (the same solver
//! reducing the dense copy in place, as the basis does), and `--phases` splits faer's
//! time into its phases), `solvers` (implicit-fairing
//! solves of `(I + λS)`, `(I + λT)`, `(D + λK)` with CG/BiCG/Cholesky, a streaming-copy
//! bandwidth measurement and the memory-traffic bound per iteration; `--lambda L`, and
//! `--export DIR` writes the matrices and right-hand side for the scipy side), `codec`
//! (compress and decompress in memory, default settings or `--patch-size P`, `--mode M`,
//! `--bits Q`, `--target-bpv B`; non-manifold vertices split first),
//! `partial` (the `--count` smallest eigenpairs by banded shift-invert block
//! Krylov–Schur; `--tol`, `--band`, `--block`, `--no-refine` override `PartialParams`), `partition`
//! (patches of `--patch-size`, METIS or `--method lloyd`), `project-patches` (partition + patch-wise
//! truncated ED reconstruction, end to end, with the peak RSS).

use meshlap::input::{open, OpenOptions};
use meshlap::operator::{Operator, OperatorKind};
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

type BoxError = Box<dyn std::error::Error>;

/// [`time`] for a fallible run: the first error ends the timing and is returned (a
/// bad mesh or option is an error message, never a panic).
fn try_time<T>(
    repeat: usize,
    mut f: impl FnMut() -> Result<T, BoxError>,
) -> Result<(f64, Vec<f64>), BoxError> {
    let mut err = None;
    let r = time(repeat, || {
        if err.is_none() {
            if let Err(e) = f() {
                err = Some(e);
            }
        }
    });
    match err {
        Some(e) => Err(e),
        None => Ok(r),
    }
}

/// `{"median": …, "times": […]}` of `repeat` runs of the fallible `f`; the first
/// error ends the timing and is returned (see [`try_time`]).
fn timing<T, E: Into<BoxError>>(
    repeat: usize,
    mut f: impl FnMut() -> Result<T, E>,
) -> Result<serde_json::Value, BoxError> {
    let (m, t) = try_time(repeat, || f().map_err(Into::into))?;
    Ok(serde_json::json!({"median": m, "times": t}))
}

/// Connectivity alone (read and cleaning excluded), shared by all operators.
fn topology_timing(
    input: &meshlap::input::Input,
    repeat: usize,
) -> Result<serde_json::Value, BoxError> {
    timing(repeat, || {
        meshlap::mesh::topology::Topology::new(&input.mesh).map(|t| t.n_edges())
    })
}

/// The value after `name` in the arguments.
fn flag<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    let p = args.iter().position(|a| a == name)?;
    args.get(p + 1).map(String::as_str)
}

/// Peak resident set size of this process (VmHWM, Linux), in KiB.
fn peak_rss_kb() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Resets the peak resident set size (VmHWM) to the current one (`echo 5 >
/// /proc/self/clear_refs`, Linux ≥ 4.0), so a later [`peak_rss_kb`] is the peak of
/// what ran in between. Returns false where that is not available.
fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// User and system CPU seconds of this process so far, all threads (`/proc/self/stat`
/// fields 14 and 15, in Linux's fixed `USER_HZ` = 100 ticks a second): the load-
/// independent measure of a phase's work on a shared machine.
fn cpu_seconds() -> Option<(f64, f64)> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The command name (field 2) is in parentheses and may hold spaces.
    let rest = &s[s.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i)?.parse::<f64>().ok();
    // `rest` starts at field 3, so field k is f[k − 3].
    Some((ticks(11)? / 100.0, ticks(12)? / 100.0))
}

fn main() {
    // As the `meshlap` binary does.
    meshlap::keep_freed_memory();
    if let Err(e) = run() {
        eprintln!("meshlap-bench: error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: meshlap-bench load|operators|topology|io|read|spectrum|solvers|codec|partial|partition|project-patches MESH \
                 [--repeat N] [--kind K] [--general] [--phases] [--lambda L] [--export DIR] [--count K] [--tol T] [--band B] [--block P] [--no-refine] [--patch-size P] [--method metis|lloyd] [--lloyd-iterations N] [--mode M] [--bits Q] [--target-bpv B] \
                 | dump MESH DIR | write MESH OUT [--repeat N]";
    let task = args.first().ok_or(usage)?.clone();
    let mesh = args.get(1).ok_or(usage)?.clone();
    let repeat = match args.iter().position(|a| a == "--repeat") {
        Some(p) => args.get(p + 1).ok_or(usage)?.parse()?,
        None => 7,
    };
    let mut out: BTreeMap<String, serde_json::Value> = BTreeMap::new();
    out.insert("threads".into(), rayon::current_num_threads().into());
    out.insert("simd".into(), meshlap::cpu::build_name().into());
    match task.as_str() {
        "load" => {
            let t = timing(repeat, || {
                open(&mesh, &OpenOptions::default()).map(|i| i.mesh.n_faces())
            })?;
            out.insert("load".into(), t);
            // The same work split into its phases: read (or generate), validate +
            // clean, connectivity.
            let (mut read, mut cleaning, mut topo) = (Vec::new(), Vec::new(), Vec::new());
            for _ in 0..repeat {
                let t0 = Instant::now();
                let (raw, _) = meshlap::input::read_raw(&mesh, None)?;
                let t1 = Instant::now();
                raw.validate()?;
                let (m, _) = meshlap::mesh::clean::clean(&raw, &Default::default())?;
                drop(raw);
                let t2 = Instant::now();
                let tp = meshlap::mesh::topology::Topology::new(&m)?;
                let t3 = Instant::now();
                std::hint::black_box(tp.n_edges());
                read.push((t1 - t0).as_secs_f64());
                cleaning.push((t2 - t1).as_secs_f64());
                topo.push((t3 - t2).as_secs_f64());
            }
            out.insert(
                "phases".into(),
                serde_json::json!({"read": median(read), "clean": median(cleaning),
                    "topology": median(topo)}),
            );
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
                let t = timing(repeat, || {
                    Operator::on_input(kind, &input).map(|o| o.matrix.compute_nnz())
                })?;
                out.insert(kind.name().into(), t);
            }
            if only.is_some() {
                println!("{}", serde_json::to_string(&out)?);
                return Ok(());
            }
            // Connectivity is shared by all operators; time it separately.
            out.insert("topology".into(), topology_timing(&input, repeat)?);
        }
        "topology" => {
            // Connectivity alone (read and cleaning excluded).
            let input = open(&mesh, &OpenOptions::default())?;
            out.insert("vertices".into(), input.mesh.n_vertices().into());
            out.insert("topology".into(), topology_timing(&input, repeat)?);
            // The faces and adjacency alone, what the `.mlz` decoder builds.
            let m = &input.mesh;
            let t = timing(repeat, || {
                meshlap::mesh::graph::VertexGraph::from_faces(m.n_vertices(), &m.faces)
                    .map(|g| g.n_edges())
            })?;
            out.insert("vertex_graph".into(), t);
        }
        "dump" => {
            // Every operator as Matrix Market, for the scripts to compare entries.
            let dir = args.get(2).ok_or(usage)?;
            let input = open(&mesh, &OpenOptions::default())?;
            for kind in OperatorKind::ALL {
                let op = Operator::on_input(kind, &input)?;
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
            let (w, _) = try_time(repeat, || {
                meshlap::io::write_mesh(&dest, &input.mesh, &Default::default())
                    .map(|_| ())
                    .map_err(BoxError::from)
            })?;
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
            let (r, _) = try_time(repeat, || {
                meshlap::io::read_mesh(&path, None)
                    .map(|l| l.mesh.n_faces())
                    .map_err(BoxError::from)
            })?;
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
                let (w, _) = try_time(repeat, || {
                    meshlap::io::write_mesh(&path, &input.mesh, &Default::default())
                        .map(|_| ())
                        .map_err(BoxError::from)
                })?;
                let bytes = std::fs::metadata(&path)?.len() as f64;
                let (r, _) = try_time(repeat, || {
                    meshlap::io::read_mesh(&path, None)
                        .map(|l| l.mesh.n_faces())
                        .map_err(BoxError::from)
                })?;
                out.insert(
                    ext.into(),
                    serde_json::json!({"write": w, "read": r, "bytes": bytes,
                        "write_mb_s": bytes / w / 1e6, "read_mb_s": bytes / r / 1e6}),
                );
            }
        }
        "solvers" => {
            let lambda: f64 = match args.iter().position(|a| a == "--lambda") {
                Some(p) => args.get(p + 1).ok_or(usage)?.parse()?,
                None => 30.0,
            };
            let export = args
                .iter()
                .position(|a| a == "--export")
                .map(|p| args.get(p + 1).map(std::path::PathBuf::from).ok_or(usage))
                .transpose()?;
            solvers(&mesh, lambda, repeat, export.as_deref(), &mut out)?;
        }
        "codec" => {
            // Compress (default settings unless overridden) and decompress in memory.
            let input = open(&mesh, &OpenOptions::default())?;
            let (mesh_c, _) = meshlap::mesh::clean::split_non_manifold(&input.mesh)?;
            let topo = meshlap::mesh::topology::Topology::new(&mesh_c)?;
            out.insert("vertices".into(), mesh_c.n_vertices().into());
            let mut opts = meshlap::codec::CompressOptions::default();
            if let Some(p) = flag(&args, "--patch-size") {
                opts.spectral.patch_size = p.parse()?;
            }
            if let Some(m) = flag(&args, "--mode") {
                opts.mode = m.parse()?;
            }
            opts.quantization = meshlap::codec::Quantization::from_options(
                flag(&args, "--bits").map(str::parse).transpose()?,
                flag(&args, "--target-bpv").map(str::parse).transpose()?,
            );
            out.insert("patch_size".into(), opts.spectral.patch_size.into());
            let c = meshlap::codec::compress(&mesh_c, &topo, &opts)?;
            let (e, te) = try_time(repeat, || {
                meshlap::codec::compress(&mesh_c, &topo, &opts)
                    .map(|c| c.bytes.len())
                    .map_err(BoxError::from)
            })?;
            let (d, td) = try_time(repeat, || {
                meshlap::codec::decompress(&c.bytes)
                    .map(|m| m.n_faces())
                    .map_err(BoxError::from)
            })?;
            out.insert("bits_per_vertex".into(), c.report.bits_per_vertex.into());
            out.insert(
                "geometry_mode".into(),
                c.report.geometry_mode.to_string().into(),
            );
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
            // `--kind NAME` keeps one case (kirchhoff, sql, tutte, tutte-general), so
            // that a script can alternate our timings with a peer's.
            let only = flag(&args, "--kind");
            let mut cases = vec![
                ("kirchhoff", OperatorKind::Kirchhoff, EigenPath::Auto),
                ("sql", OperatorKind::Sql, EigenPath::Auto),
                ("tutte", OperatorKind::Tutte, EigenPath::Auto),
            ];
            if general || only == Some("tutte-general") {
                cases.push(("tutte-general", OperatorKind::Tutte, EigenPath::General));
            }
            for (name, kind, path) in cases {
                if only.is_some_and(|k| k != name && k != format!("{name}-coefficients")) {
                    continue;
                }
                let op = Operator::on_input(kind, &input)?;
                let opts = BasisOptions {
                    path,
                    ..Default::default()
                };
                let t = timing(repeat, || EigenBasis::compute(&op, &opts).map(|b| b.len()))?;
                out.insert(name.into(), t);
                if only.is_some_and(|k| k.ends_with("-coefficients")) {
                    // The basis and the coefficients X of the positions (n×3): what
                    // `numpy.linalg.eig` + `numpy.linalg.solve(E, x)` computes.
                    let x = meshlap::spectral::positions_to_mat(&input.mesh.positions);
                    let t = timing(repeat, || -> Result<usize, BoxError> {
                        let b = EigenBasis::compute(&op, &opts)?;
                        Ok(meshlap::spectral::forward(&b, x.as_ref())?.nrows())
                    })?;
                    out.insert(format!("{name}-coefficients"), t);
                }
                if path == EigenPath::General {
                    continue;
                }
                // faer alone on the same symmetric matrix: the dense copy (for the TL
                // the GL similarity `D^{1/2} T D^{-1/2}`) and `self_adjoint_evd`
                // with default parameters and the basis' parallelism, no checks, no
                // canonicalisation.
                let t = timing(repeat, || faer_only(&op))?;
                out.insert(format!("{name}-faer-only"), t);
                // meshlap's blocked solver alone on the same matrix (the default of
                // the basis): dense copy + `blocked_evd::symmetric_evd`.
                let t = timing(repeat, || blocked_only(&op))?;
                out.insert(format!("{name}-blocked-only"), t);
                if args.iter().any(|a| a == "--owned") {
                    // The same, reducing the dense copy in place as the basis does
                    // (`blocked_evd::symmetric_evd_owned`: no second n×n copy).
                    let t = timing(repeat, || blocked_owned(&op))?;
                    out.insert(format!("{name}-blocked-owned"), t);
                }
                if args.iter().any(|a| a == "--phases") {
                    out.insert(format!("{name}-phases"), faer_phases(&op, repeat)?);
                }
            }
        }
        "partial" => {
            // The `--count` smallest eigenpairs of `--kind` (default sql) by banded
            // shift-invert; the time includes assembly.
            let count: usize = flag(&args, "--count").unwrap_or("50").parse()?;
            let kind: OperatorKind = flag(&args, "--kind").unwrap_or("sql").parse()?;
            let input = open(&mesh, &OpenOptions::default())?;
            out.insert("vertices".into(), input.mesh.n_vertices().into());
            let mut last = None;
            let mut opts = meshlap::spectral::partial::PartialParams::new(count);
            if let Some(t) = flag(&args, "--tol") {
                opts.tolerance = t.parse()?;
            }
            if let Some(b) = flag(&args, "--band") {
                opts.band_size = b.parse()?;
            }
            if let Some(b) = flag(&args, "--block") {
                opts.block_size = b.parse()?;
            }
            if args.iter().any(|a| a == "--no-refine") {
                opts.refine = false;
            }
            let (m, t) = try_time(repeat, || {
                let op = Operator::on_input(kind, &input)?;
                last = Some(meshlap::spectral::partial::operator_partial_spectrum(
                    &op,
                    true,
                    &opts,
                    &mut |_, _| {},
                )?);
                Ok(())
            })?;
            let ps = last.ok_or("no run")?;
            let max_res = ps.residuals.iter().fold(0.0f64, |a, &b| a.max(b));
            // Orthonormality of the eigenvectors (untimed): max |VᵀV − I|.
            let v = ps.eigenvectors.as_ref();
            let g = v.transpose() * v;
            let mut ortho = 0.0f64;
            for j in 0..g.ncols() {
                for i in 0..g.nrows() {
                    let e = g[(i, j)] - if i == j { 1.0 } else { 0.0 };
                    ortho = ortho.max(e.abs());
                }
            }
            out.insert(
                "partial".into(),
                serde_json::json!({"median": m, "times": t, "count": count,
                    "bands": ps.info.bands.len(), "band_info": ps.info.bands, "max_residual": max_res,
                    "orthogonality": ortho,
                    "eigenvalues": ps.eigenvalues}),
            );
        }
        "partition" => {
            let p: usize = flag(&args, "--patch-size").unwrap_or("300").parse()?;
            let input = open(&mesh, &OpenOptions::default())?;
            out.insert("vertices".into(), input.mesh.n_vertices().into());
            let mut opts = meshlap::partition::PartitionOptions::new(p);
            if let Some(m) = flag(&args, "--method") {
                opts.method = m.parse()?;
            }
            if let Some(k) = flag(&args, "--lloyd-iterations") {
                opts.lloyd_iterations = k.parse()?;
            }
            let mut stats = None;
            let (m, t) = try_time(repeat, || {
                let part = meshlap::partition::partition(input.topology.graph(), &opts)?;
                stats = Some(part.stats().clone());
                Ok(())
            })?;
            out.insert(
                "partition".into(),
                serde_json::json!({"median": m, "times": t, "stats": stats}),
            );
        }
        "project-patches" => {
            // End to end: generate/read, clean, partition, per-patch operator and
            // dense ED, truncated reconstruction (all patches in parallel).
            let p: usize = flag(&args, "--patch-size").unwrap_or("300").parse()?;
            let keep: f64 = flag(&args, "--keep").unwrap_or("0.1").parse()?;
            let kind: OperatorKind = flag(&args, "--kind").unwrap_or("sql").parse()?;
            let mut info = serde_json::Value::Null;
            // Per phase: user and system CPU seconds and the peak RSS of the phase
            // (with what earlier phases still hold), both independent of the load.
            // The whole run's peak is the largest phase peak.
            let peak = std::cell::Cell::new(None::<u64>);
            let phase = |start: Option<(f64, f64)>| {
                let (u0, s0) = start.unwrap_or_default();
                let (u1, s1) = cpu_seconds().unwrap_or_default();
                let rss = peak_rss_kb();
                peak.set(peak.get().max(rss));
                let out = serde_json::json!({"user_s": u1 - u0, "sys_s": s1 - s0,
                    "peak_rss_kb": rss});
                reset_peak_rss();
                out
            };
            let (m, t) = try_time(repeat, || {
                reset_peak_rss();
                let mut c = cpu_seconds();
                let t0 = Instant::now();
                let input = open(&mesh, &OpenOptions::default())?;
                let t_open = t0.elapsed().as_secs_f64();
                let cpu_open = phase(c);
                c = cpu_seconds();
                let opts = meshlap::partition::PartitionOptions::new(p);
                let part = meshlap::partition::partition(input.topology.graph(), &opts)?;
                let t_part = t0.elapsed().as_secs_f64() - t_open;
                let cpu_part = phase(c);
                c = cpu_seconds();
                let rec = meshlap::spectral::patchwise::patchwise_positions(
                    &input.mesh,
                    &part,
                    kind,
                    keep,
                    &|_, _| {},
                )?;
                let t_all = t0.elapsed().as_secs_f64();
                let cpu_transform = phase(c);
                let err = rec
                    .iter()
                    .zip(&input.mesh.positions)
                    .map(|(a, b)| {
                        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2))
                            .sqrt()
                    })
                    .fold(0.0f64, f64::max);
                info = serde_json::json!({"vertices": input.mesh.n_vertices(),
                    "patches": part.n_patches(), "open_s": t_open, "partition_s": t_part,
                    "transform_s": t_all - t_open - t_part, "max_displacement": err,
                    "bbox_diagonal": input.mesh.bbox_diagonal(),
                    "cpu": {"open": cpu_open, "partition": cpu_part,
                        "transform": cpu_transform}});
                Ok(())
            })?;
            out.insert(
                "project_patches".into(),
                serde_json::json!({"median": m, "times": t, "info": info,
                    "peak_rss_kb": peak.get().max(peak_rss_kb())}),
            );
        }
        _ => return Err(usage.into()),
    }
    println!("{}", serde_json::to_string(&out)?);
    Ok(())
}

/// The dense symmetric matrix of `op`'s symmetric path (`F`, or `S^{1/2} F S^{-1/2}`
/// for the TL) decomposed by faer's `self_adjoint_evd` alone (eigenvalues and vectors,
/// default parameters, [`meshlap::spectral::basis::PARALLELISM_DEGREE`] tasks).
fn faer_only(op: &Operator) -> Result<f64, BoxError> {
    faer_only_on(&faer_dense(op)?)
}

/// The matrix of [`faer_only`] decomposed by meshlap's blocked solver
/// (`spectral::blocked_evd`) with the basis' parallelism.
fn blocked_only(op: &Operator) -> Result<f64, BoxError> {
    let a = faer_dense(op)?;
    let par = faer::Par::rayon(meshlap::spectral::basis::PARALLELISM_DEGREE);
    let (lam, u) = meshlap::spectral::blocked_evd::symmetric_evd(a.as_ref(), par)
        .ok_or("blocked_evd: no convergence")?;
    Ok(lam[0] + u[(0, 0)])
}

/// [`blocked_only`] with the dense copy given to the solver and reduced in place, as
/// [`meshlap::spectral::EigenBasis::compute`] does.
fn blocked_owned(op: &Operator) -> Result<f64, BoxError> {
    let a = faer_dense(op)?;
    let par = faer::Par::rayon(meshlap::spectral::basis::PARALLELISM_DEGREE);
    let (lam, u) = meshlap::spectral::blocked_evd::symmetric_evd_owned(a, par)
        .ok_or("blocked_evd: no convergence")?;
    Ok(lam[0] + u[(0, 0)])
}

/// The dense symmetric matrix of [`faer_only`]: the operator, or for a diagonally
/// symmetrizable one (the TL) its similarity `S^{1/2} F S^{-1/2}`.
fn faer_dense(op: &Operator) -> Result<faer::Mat<f64>, BoxError> {
    use meshlap::operator::symmetrize::{diagonal_symmetrizer, symmetrized_dense, Scaling};
    Ok(if meshlap::operator::symmetrize::is_symmetric(&op.matrix) {
        op.matrix.to_dense()
    } else {
        let s = diagonal_symmetrizer(&op.matrix).ok_or("operator is not symmetrizable")?;
        symmetrized_dense(&op.matrix, Scaling::Similarity(&s))
    })
}

/// `self_adjoint_evd` of `a` (values and vectors), as in [`faer_only`].
fn faer_only_on(a: &faer::Mat<f64>) -> Result<f64, BoxError> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::evd::{self, ComputeEigenvectors};
    let n = a.nrows();
    let par = faer::Par::rayon(meshlap::spectral::basis::PARALLELISM_DEGREE);
    let mut u = faer::Mat::<f64>::zeros(n, n);
    let mut s = faer::diag::Diag::<f64>::zeros(n);
    let mut mem = MemBuffer::new(evd::self_adjoint_evd_scratch::<f64>(
        n,
        ComputeEigenvectors::Yes,
        par,
        Default::default(),
    ));
    evd::self_adjoint_evd(
        a.as_ref(),
        s.as_mut(),
        Some(u.as_mut()),
        par,
        MemStack::new(&mut mem),
        Default::default(),
    )
    .map_err(|e| format!("faer self_adjoint_evd: {e:?}"))?;
    Ok(s[0] + u[(0, 0)])
}

/// Medians of faer's phases on the matrix of [`faer_only`]: the dense copy, the
/// Householder tridiagonalisation `A = Q T Qᵀ` (`tridiag_in_place`), the
/// back-transformation `U = Q Z` (the blocked Householder sequence applied to an n×n
/// matrix) and the whole `self_adjoint_evd`; the tridiagonal divide and conquer is
/// not public, so its time is inferred as evd − tridiagonalisation −
/// back-transformation.
fn faer_phases(op: &Operator, repeat: usize) -> Result<serde_json::Value, BoxError> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::evd::tridiag;
    use faer::linalg::householder;
    let (t_dense, _) = try_time(repeat, || faer_dense(op))?;
    let a = faer_dense(op)?;
    let n = a.nrows();
    let par = faer::Par::rayon(meshlap::spectral::basis::PARALLELISM_DEGREE);
    let bs = faer::linalg::qr::no_pivoting::factor::recommended_block_size::<f64>(n, n);
    let mut trid = a.clone();
    let mut h = faer::Mat::<f64>::zeros(bs, n - 1);
    let (t_tridiag, _) = time(repeat, || {
        trid.copy_from(&a);
        let mut mem = MemBuffer::new(tridiag::tridiag_in_place_scratch::<f64>(
            n,
            par,
            Default::default(),
        ));
        tridiag::tridiag_in_place(
            trid.as_mut(),
            h.as_mut(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        );
    });
    let mut u = faer::Mat::<f64>::identity(n, n);
    let (t_back, _) = time(repeat, || {
        let mut mem = MemBuffer::new(
            householder::apply_block_householder_sequence_on_the_left_in_place_scratch::<f64>(
                n - 1,
                bs,
                n,
            ),
        );
        householder::apply_block_householder_sequence_on_the_left_in_place_with_conj(
            trid.as_ref().submatrix(1, 0, n - 1, n - 1),
            h.as_ref(),
            faer::Conj::No,
            u.as_mut().subrows_mut(1, n - 1),
            par,
            MemStack::new(&mut mem),
        );
    });
    let (t_evd, _) = try_time(repeat, || faer_only_on(&a))?;
    Ok(
        serde_json::json!({"dense": t_dense, "tridiagonalisation": t_tridiag,
        "back_transformation": t_back, "self_adjoint_evd": t_evd,
        "divide_and_conquer_inferred": t_evd - t_tridiag - t_back}),
    )
}

/// Streaming-copy bandwidth (bytes read + written per second) of `threads` rayon
/// workers over two 128 MiB arrays, far beyond the last-level cache.
fn copy_bandwidth(repeat: usize) -> f64 {
    use rayon::prelude::*;
    let n = 16 << 20; // 16 Mi f64 = 128 MiB per array
    let src: Vec<f64> = (0..n).into_par_iter().map(|i| i as f64).collect();
    let mut dst = vec![0.0f64; n];
    let (t, _) = time(repeat.max(5), || {
        dst.par_chunks_mut(1 << 16)
            .zip(src.par_chunks(1 << 16))
            .for_each(|(d, s)| d.copy_from_slice(s));
        dst[n / 2]
    });
    2.0 * 8.0 * n as f64 / t
}

fn solvers(
    mesh: &str,
    lambda: f64,
    repeat: usize,
    export: Option<&std::path::Path>,
    out: &mut BTreeMap<String, serde_json::Value>,
) -> Result<(), Box<dyn std::error::Error>> {
    use meshlap::filter::{ImplicitSolver, SolverKind};
    use meshlap::solve::{
        direct::CholeskySolver, CsrWithSymmetrizer, Info, Params, Stopping, Workspace,
    };
    let input = open(mesh, &OpenOptions::default())?;
    let n = input.mesh.n_vertices();
    let topo = &input.topology;
    let s = meshlap::operator::sql::sql(topo, Default::default())?;
    let t = meshlap::operator::tutte::tutte(topo)?;
    let b: Vec<f64> = input.mesh.positions.iter().flat_map(|p| *p).collect();
    // The three systems, as the solvers see them.
    let cg_sql = ImplicitSolver::new(&s, lambda, SolverKind::Cg)?;
    let bicg_tl = ImplicitSolver::new(&t, lambda, SolverKind::Bicg)?;
    let cg_tl = ImplicitSolver::new(&t, lambda, SolverKind::CgSym)?;
    let d: Vec<f64> = topo.degrees().iter().map(|&v| v as f64).collect();
    let db: Vec<f64> = b.iter().enumerate().map(|(j, v)| v * d[j / 3]).collect();
    if let Some(dir) = export {
        std::fs::create_dir_all(dir)?;
        for (name, m) in [
            ("sql", cg_sql.system_matrix()),
            ("tl", bicg_tl.system_matrix()),
            ("tl_sym", cg_tl.system_matrix()),
        ] {
            meshlap::io::write_matrix_market(
                &dir.join(format!("{name}.mtx")),
                m.to_csc().as_ref(),
            )?;
        }
        let bm = faer::Mat::from_fn(n, 3, |i, c| b[3 * i + c]);
        meshlap::io::write_npy(&dir.join("b.npy"), bm.as_ref())?;
        let dm = faer::Mat::from_fn(n, 1, |i, _| d[i]);
        meshlap::io::write_npy(&dir.join("d.npy"), dm.as_ref())?;
    }
    let params = Params {
        stopping: Stopping::Strong,
        tolerance: 1e-5,
        record_history: false,
        ..Default::default()
    };
    out.insert("vertices".into(), n.into());
    out.insert("lambda".into(), lambda.into());
    let bw = copy_bandwidth(repeat);
    out.insert("copy_bandwidth_gb_s".into(), (bw / 1e9).into());
    for (name, solver, rhs, kind_bicg) in [
        ("cg_sql", &cg_sql, &b, false),
        ("bicg_tl", &bicg_tl, &b, true),
        ("cg_tl_sym", &cg_tl, &db, false),
    ] {
        let mut last: Option<Info> = None;
        // x0 = 0, as scipy's default; cg_tl_sym solves (D + λK)x = Db directly, so
        // time the cg-sym system through the plain CG on its matrix.
        let a = solver.system_matrix();
        // BiCG as ImplicitSolver runs it on the Tutte system: with the symmetrizer D
        // (Aᵀ = D A D⁻¹), both products in one pass over A, no transpose.
        let with_s = if kind_bicg {
            let sym = meshlap::operator::symmetrize::symmetrizer(&t).ok_or("TL: no symmetrizer")?;
            Some(CsrWithSymmetrizer::new(a.clone(), sym)?)
        } else {
            None
        };
        // A fresh workspace per solve: the buffers are allocated inside the timing.
        let (med, times) = try_time(repeat, || {
            let mut x = vec![0.0; rhs.len()];
            let ws = &mut Workspace::new();
            let info = if let Some(with_s) = &with_s {
                meshlap::solve::bicg(with_s, rhs, &mut x, 3, &params.into(), None, ws)
                    .map(|i| i.info)?
            } else {
                meshlap::solve::cg(a, rhs, &mut x, 3, &params, None, ws)?
            };
            last = Some(info);
            Ok(())
        })?;
        let info = last.ok_or("no solve ran (--repeat 0)")?;
        let its = *info.iterations.iter().max().unwrap_or(&1);
        // Memory traffic per iteration (bytes read + written) in n×3 f64 blocks of 24n
        // bytes, for the passes the solvers make with the residual criterion. CG (x
        // moves in the p pass): q = Ap fused with pᵀq (matrix, read p, write q: 2) + r
        // update (read r, q; write r: 3) + x, p update (read x, r, p; write x, p: 5) =
        // matrix + 10 blocks. BiCG with the symmetrizer s: p, p̂ update (read r, r̂, p,
        // p̂, s; write p, p̂: 6 blocks + s) + q = Ap and q̂ = Ap̂ in one pass with p̃ᵀq
        // (matrix once; read p, p̂, s; write q, q̂: 4 blocks + s) + x, r, r̂ update
        // (read x, p, r, q, r̂, q̂, s; write x, r, r̂: 9 blocks + s) = 1 matrix + 19
        // blocks + 3 reads of s (8n bytes each).
        let block = 24.0 * n as f64;
        let traffic = if kind_bicg {
            a.bytes() as f64 + 19.0 * block + 3.0 * 8.0 * n as f64
        } else {
            a.bytes() as f64 + 10.0 * block
        };
        let per_it = med / its as f64;
        let bound = traffic / bw;
        out.insert(
            name.into(),
            serde_json::json!({
                "median": med, "times": times, "iterations": info.iterations,
                "residuals": info.residuals, "nnz": a.nnz(),
                "seconds_per_iteration": per_it, "bytes_per_iteration": traffic,
                "bandwidth_bound_per_iteration": bound, "ratio_to_bound": per_it / bound,
            }),
        );
    }
    // Sparse Cholesky of I + λS: symbolic + numeric factorisation + solve of 3 columns.
    let a = cg_sql.system_matrix().to_csc();
    let (med, times) = try_time(repeat, || {
        let c = CholeskySolver::new(&a)?;
        let mut x = b.clone();
        c.solve_in_place(&mut x, 3)?;
        Ok(x[0])
    })?;
    let chol = CholeskySolver::new(&a)?;
    let (solve_med, _) = try_time(repeat, || {
        let mut x = b.clone();
        chol.solve_in_place(&mut x, 3)?;
        Ok(x[0])
    })?;
    out.insert(
        "cholesky_sql".into(),
        serde_json::json!({"median": med, "times": times, "solve_only": solve_med}),
    );
    Ok(())
}
