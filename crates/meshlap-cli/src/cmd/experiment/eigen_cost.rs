//! `meshlap experiment eigen-cost`.

use crate::common::print_json;
use indicatif::{ProgressBar, ProgressStyle};
use meshlap::input::{self, Input, OpenOptions};
use meshlap::io::write_atomic;
use meshlap::mesh::{TriMesh, VertexId};
use meshlap::operator::{Operator, OperatorKind, OperatorOptions};
use meshlap::spectral::compaction::{centre, energy_compaction};
use meshlap::spectral::{forward, positions_to_mat, BasisOptions, EigenBasis, EigenPath};
use serde::Serialize;
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The paper's Fig. 3 and §4.9 energy-compaction comparison.
///
/// Cost: the time to eigendecompose the KL, the TL (through its GL similarity, and
/// by the general non-symmetric eigensolver plus the dense LU of E that the paper's
/// Matlab `eig` + `E\x` needs), the GL, SQL and SSTL on patches of growing size n,
/// grown by breadth-first search from a seed vertex of each MESH (induced faces).
/// Also the time for the spectral coefficients: a projection (weighted for the TL)
/// versus the LU solve.
///
/// Compaction: the transform efficiency of SSTL, SQL, TL and KL (centred geometry) on
/// smooth models (a patch of the first MESH, builtin:icosphere:3) and on models with
/// sharp transitions (builtin:cube:8, builtin:step:20). The paper's order on smooth
/// models is SSTL > SQL > TL > KL, often reversed on the sharp ones.
///
/// Writes to --out: eigen_cost.md/.json/.png and compaction.md/.json/.png.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Meshes to cut patches from (files or builtin:…); repeat the option.
    #[arg(
        long = "mesh",
        value_name = "MESH",
        default_value = "builtin:icosphere:5"
    )]
    pub meshes: Vec<String>,
    /// Patch sizes n (vertices), comma separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "100,200,400,800,1200,1600"
    )]
    pub sizes: Vec<usize>,
    /// Timing repetitions per measurement (median reported).
    #[arg(long, default_value_t = 1)]
    pub repeat: usize,
    /// Vertices of the smooth-model patch in the compaction comparison.
    #[arg(long, default_value_t = 1000)]
    pub compaction_size: usize,
    /// Output directory (created if missing).
    #[arg(long, default_value = "eigen-cost")]
    pub out: PathBuf,
    /// Also print the JSON results on stdout.
    #[arg(long)]
    pub json: bool,
}

/// One decomposition measured.
#[derive(Serialize, Clone)]
pub struct CostRow {
    pub mesh: String,
    pub n: usize,
    /// kl, gl, sql, sstl, tl (similarity) or tl-general.
    pub operator: String,
    /// Eigendecomposition (including the LU of E on the general path), seconds.
    pub eigen_seconds: f64,
    /// Spectral coefficients of the n×3 positions, seconds.
    pub coefficient_seconds: f64,
}

/// One model's compaction for one operator.
#[derive(Serialize, Clone)]
pub struct CompactionRow {
    pub model: String,
    pub smooth: bool,
    pub n: usize,
    pub operator: String,
    pub mean_efficiency: f64,
    pub m_99: usize,
    pub m_999: usize,
    /// 1 − η(m) for m = 1..=n (residual energy fraction).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub residual: Vec<f64>,
}

#[derive(Serialize)]
struct Results<'a> {
    cost: &'a [CostRow],
    compaction: &'a [CompactionRow],
    /// Per model, operators from best to worst mean efficiency.
    compaction_order: Vec<(String, Vec<String>)>,
}

const COST_OPERATORS: [(&str, OperatorKind, EigenPath); 6] = [
    ("kl", OperatorKind::Kirchhoff, EigenPath::Symmetric),
    ("gl", OperatorKind::Graph, EigenPath::Symmetric),
    ("sql", OperatorKind::Sql, EigenPath::Symmetric),
    ("sstl", OperatorKind::Sstl, EigenPath::Symmetric),
    ("tl", OperatorKind::Tutte, EigenPath::Auto),
    ("tl-general", OperatorKind::Tutte, EigenPath::General),
];

const COMPACTION_OPERATORS: [(&str, OperatorKind); 4] = [
    ("sstl", OperatorKind::Sstl),
    ("sql", OperatorKind::Sql),
    ("tl", OperatorKind::Tutte),
    ("kl", OperatorKind::Kirchhoff),
];

/// The patch of `input` grown by breadth-first search from `seed` until it has `n`
/// vertices, with the faces whose three corners are inside; cleaned (vertices left
/// without a face are dropped, so the patch can have slightly fewer than n).
pub fn bfs_patch(input: &Input, seed: usize, n: usize) -> meshlap::Result<Input> {
    let nv = input.mesh.n_vertices();
    let mut inside = vec![false; nv];
    let mut order = Vec::with_capacity(n.min(nv));
    let mut queue = VecDeque::from([seed.min(nv.saturating_sub(1))]);
    if nv > 0 {
        inside[queue[0]] = true;
    }
    while let Some(v) = queue.pop_front() {
        if order.len() == n {
            break;
        }
        order.push(v);
        for &w in input.topology.neighbors(VertexId(v as u32)) {
            let w = w as usize;
            if !inside[w] {
                inside[w] = true;
                queue.push_back(w);
            }
        }
    }
    let mut new_index = vec![u32::MAX; nv];
    for (k, &v) in order.iter().enumerate() {
        new_index[v] = k as u32;
    }
    let faces: Vec<[u32; 3]> = input
        .mesh
        .faces
        .iter()
        .filter(|f| f.iter().all(|&v| new_index[v as usize] != u32::MAX))
        .map(|f| f.map(|v| new_index[v as usize]))
        .collect();
    let positions = order.iter().map(|&v| input.mesh.positions[v]).collect();
    let name = format!("{}[bfs {n}]", input.source);
    input::from_mesh(
        &name,
        TriMesh::new(positions, faces),
        None,
        &Default::default(),
    )
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn measure(
    op: &Operator,
    path: EigenPath,
    repeat: usize,
    positions: &[[f64; 3]],
) -> meshlap::Result<(f64, f64)> {
    let x = positions_to_mat(positions);
    let opts = BasisOptions {
        path,
        ..Default::default()
    };
    let (mut te, mut tc) = (Vec::new(), Vec::new());
    for _ in 0..repeat.max(1) {
        let t = Instant::now();
        let b = EigenBasis::compute(op, &opts)?;
        te.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        std::hint::black_box(forward(&b, x.as_ref())?);
        tc.push(t.elapsed().as_secs_f64());
    }
    Ok((median(te), median(tc)))
}

fn bar(len: u64, msg: &str) -> ProgressBar {
    let b = ProgressBar::new(len);
    b.set_style(
        ProgressStyle::with_template("{msg} {bar:30} {pos}/{len} [{elapsed}/{eta}]").unwrap(),
    );
    b.set_message(msg.to_string());
    b
}

fn short_name(source: &str) -> String {
    Path::new(source)
        .file_stem()
        .map_or(source.to_string(), |s| s.to_string_lossy().into_owned())
}

/// Runs the Fig. 3 timings.
pub fn cost(args: &Args, meshes: &[Input]) -> meshlap::Result<Vec<CostRow>> {
    let pb = bar(
        (meshes.len() * args.sizes.len() * COST_OPERATORS.len()) as u64,
        "eigen-cost",
    );
    let mut rows = Vec::new();
    for input in meshes {
        for &size in &args.sizes {
            let patch = bfs_patch(input, 0, size)?;
            for (name, kind, path) in COST_OPERATORS {
                let op = Operator::assemble(
                    kind,
                    &patch.mesh,
                    &patch.topology,
                    &OperatorOptions::default(),
                )?;
                let (e, c) = measure(&op, path, args.repeat, &patch.mesh.positions)?;
                rows.push(CostRow {
                    mesh: short_name(&input.source),
                    n: patch.mesh.n_vertices(),
                    operator: name.to_string(),
                    eigen_seconds: e,
                    coefficient_seconds: c,
                });
                pb.inc(1);
            }
        }
    }
    pb.finish_and_clear();
    Ok(rows)
}

/// Runs the §4.9 compaction comparison.
pub fn compaction(args: &Args, meshes: &[Input]) -> meshlap::Result<Vec<CompactionRow>> {
    let mut models: Vec<(String, bool, Input)> = Vec::new();
    if let Some(first) = meshes.first() {
        let p = bfs_patch(first, 0, args.compaction_size)?;
        models.push((format!("{} patch", short_name(&first.source)), true, p));
    }
    for (spec, smooth) in [
        ("builtin:icosphere:3", true),
        ("builtin:cube:8", false),
        ("builtin:step:20", false),
    ] {
        models.push((
            spec.trim_start_matches("builtin:").to_string(),
            smooth,
            input::open(spec, &OpenOptions::default())?,
        ));
    }
    let pb = bar(
        (models.len() * COMPACTION_OPERATORS.len()) as u64,
        "compaction",
    );
    let mut rows = Vec::new();
    for (model, smooth, input) in &models {
        let x = centre(positions_to_mat(&input.mesh.positions).as_ref());
        for (name, kind) in COMPACTION_OPERATORS {
            let op = Operator::assemble(
                kind,
                &input.mesh,
                &input.topology,
                &OperatorOptions::default(),
            )?;
            let b = EigenBasis::compute(&op, &BasisOptions::default())?;
            let comp = energy_compaction(forward(&b, x.as_ref())?.as_ref());
            rows.push(CompactionRow {
                model: model.clone(),
                smooth: *smooth,
                n: input.mesh.n_vertices(),
                operator: name.to_string(),
                mean_efficiency: comp.mean_efficiency(),
                m_99: comp.coefficients_for(0.99),
                m_999: comp.coefficients_for(0.999),
                residual: comp.total.iter().map(|e| (1.0 - e).max(0.0)).collect(),
            });
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    Ok(rows)
}

fn order(rows: &[CompactionRow]) -> Vec<(String, Vec<String>)> {
    let mut models: Vec<String> = Vec::new();
    for r in rows {
        if !models.contains(&r.model) {
            models.push(r.model.clone());
        }
    }
    models
        .into_iter()
        .map(|m| {
            let mut ops: Vec<&CompactionRow> = rows.iter().filter(|r| r.model == m).collect();
            ops.sort_by(|a, b| b.mean_efficiency.total_cmp(&a.mean_efficiency));
            (m, ops.iter().map(|r| r.operator.clone()).collect())
        })
        .collect()
}

fn cost_markdown(rows: &[CostRow]) -> String {
    let mut s = String::from(
        "| mesh | n | operator | eigendecomposition (s) | coefficients (s) |\n|---|---:|---|---:|---:|\n",
    );
    for r in rows {
        s += &format!(
            "| {} | {} | {} | {:.4} | {:.5} |\n",
            r.mesh, r.n, r.operator, r.eigen_seconds, r.coefficient_seconds
        );
    }
    s
}

fn compaction_markdown(rows: &[CompactionRow], order: &[(String, Vec<String>)]) -> String {
    let mut s = String::from(
        "| model | smooth | n | operator | mean efficiency | m for 99% | m for 99.9% |\n|---|---|---:|---|---:|---:|---:|\n",
    );
    for r in rows {
        s += &format!(
            "| {} | {} | {} | {} | {:.6} | {} | {} |\n",
            r.model, r.smooth, r.n, r.operator, r.mean_efficiency, r.m_99, r.m_999
        );
    }
    s += "\nOrder (best compaction first, by mean efficiency):\n\n";
    for (m, ops) in order {
        s += &format!("- {m}: {}\n", ops.join(" > ").to_uppercase());
    }
    s
}

fn write_text(path: &Path, text: &str) -> meshlap::Result<()> {
    Ok(write_atomic(path, |w| w.write_all(text.as_bytes()))?)
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    if args.sizes.is_empty()
        || args
            .sizes
            .iter()
            .any(|&n| n < 4 || n > meshlap::spectral::DENSE_LIMIT)
    {
        return Err(meshlap::Error::InvalidArgument(format!(
            "--sizes must be between 4 and {}",
            meshlap::spectral::DENSE_LIMIT
        )));
    }
    std::fs::create_dir_all(&args.out).map_err(|source| meshlap::Error::Write {
        path: args.out.clone(),
        source,
    })?;
    let meshes: Vec<Input> = args
        .meshes
        .iter()
        .map(|m| input::open(m, &OpenOptions::default()))
        .collect::<meshlap::Result<_>>()?;
    let cost_rows = cost(args, &meshes)?;
    let comp_rows = compaction(args, &meshes)?;
    let ord = order(&comp_rows);
    let results = Results {
        cost: &cost_rows,
        compaction: &comp_rows,
        compaction_order: ord.clone(),
    };
    let json = serde_json::to_string_pretty(&results)
        .map_err(|e| meshlap::Error::InvalidArgument(format!("cannot serialise: {e}")))?;
    write_text(&args.out.join("eigen_cost.md"), &cost_markdown(&cost_rows))?;
    write_text(
        &args.out.join("compaction.md"),
        &compaction_markdown(&comp_rows, &ord),
    )?;
    write_text(&args.out.join("eigen_cost.json"), &json)?;
    if args.json {
        return print_json(&results);
    }
    print!("{}", cost_markdown(&cost_rows));
    println!();
    print!("{}", compaction_markdown(&comp_rows, &ord));
    println!("\nwrote {}", args.out.display());
    Ok(())
}
