//! The paper's §4.9 experiments on ED-transforms (Zhang 2004):
//!
//! - [`cost`] (Fig. 3): the time to eigendecompose the KL, GL, SQL, SSTL, the TL
//!   through its GL similarity (symmetric solver, S-weighted projection) and the TL by
//!   the general non-symmetric eigensolver plus the dense LU of `E` that the paper's
//!   Matlab `eig` + `E\x` needs, on patches of growing size n; and the time for the
//!   spectral coefficients of the positions (projection versus LU solve).
//! - [`compaction`]: the transform efficiency of SSTL, SQL, TL and KL on centered
//!   geometry, on smooth models and on models with sharp transitions. The paper's
//!   order on smooth models is SSTL > SQL > TL > KL, "often reversed" on a tessellated
//!   step or cube; the differences are slight.
//!
//! Patches are grown by breadth-first search ([`bfs_patch`]); the real multilevel
//! partitioner lives in `partition`. [`run`] does both with [`EigenCostOptions`].
//! Sign convention: `F = D − W`, PSD.

use super::meshes::{open, open_all, shared, short_name};
use super::{sig, ExperimentError, Outputs, Progress, ProgressFn, Table};
use crate::input::{self, Input};
use crate::mesh::{TriMesh, VertexId};
use crate::operator::{Operator, OperatorKind};
use crate::plot::{Chart, Scale, Series};
use crate::spectral::compaction::{centre, energy_compaction};
use crate::spectral::{forward, positions_to_mat, BasisOptions, EigenBasis, EigenPath};
use serde::Serialize;
use std::collections::VecDeque;
use std::path::Path;
use std::time::Instant;

fn input_err(source: &str, e: impl Into<crate::Error>) -> ExperimentError {
    ExperimentError::input(source, e)
}

/// Options of [`run`].
#[derive(Clone, Debug, PartialEq)]
pub struct EigenCostOptions {
    /// Meshes to cut patches from (files or `builtin:` specs).
    pub meshes: Vec<String>,
    /// Patch sizes n (vertices), each in 4 ..= [`crate::spectral::DENSE_LIMIT`].
    pub sizes: Vec<usize>,
    /// Timing repetitions per measurement (median reported).
    pub repeat: usize,
    /// Vertices of the smooth-model patch of the compaction comparison, in
    /// 4 ..= [`crate::spectral::DENSE_LIMIT`].
    pub compaction_size: usize,
}

impl Default for EigenCostOptions {
    /// The settings of `meshlap experiment eigen-cost`: patches of
    /// `builtin:icosphere:5` of 100 to 1,600 vertices.
    fn default() -> Self {
        EigenCostOptions {
            meshes: vec!["builtin:icosphere:5".into()],
            sizes: vec![100, 200, 400, 800, 1200, 1600],
            repeat: 1,
            compaction_size: 1000,
        }
    }
}

impl EigenCostOptions {
    /// The settings of `experiment all`: patches of the bunny and the horse from `dir`.
    pub fn paper(dir: &Path) -> Self {
        EigenCostOptions {
            meshes: vec![shared(dir, "stanford-bunny.obj"), shared(dir, "horse.ply")],
            ..Self::default()
        }
    }

    /// Small patches of `builtin:icosphere:4`.
    pub fn quick() -> Self {
        EigenCostOptions {
            meshes: vec!["builtin:icosphere:4".into()],
            sizes: vec![100, 200, 400],
            repeat: 1,
            compaction_size: 400,
        }
    }

    fn validate(&self) -> Result<(), ExperimentError> {
        let limit = crate::spectral::DENSE_LIMIT;
        if self.sizes.is_empty() || self.sizes.iter().any(|&n| !(4..=limit).contains(&n)) {
            return Err(ExperimentError::invalid(
                "sizes",
                format!("must be between 4 and {limit}"),
            ));
        }
        if !(4..=limit).contains(&self.compaction_size) {
            return Err(ExperimentError::invalid(
                "compaction_size",
                format!("must be between 4 and {limit}"),
            ));
        }
        Ok(())
    }
}

/// What [`run`] measured (serialized as `eigen_cost.json`).
#[derive(Clone, Debug, Serialize)]
pub struct EigenCostResults {
    /// [`cost`] rows.
    pub cost: Vec<CostRow>,
    /// [`compaction`] rows.
    pub compaction: Vec<CompactionRow>,
    /// Per model, operators from best to worst compaction.
    pub compaction_order: CompactionOrder,
    /// The cost and compaction tables.
    #[serde(skip)]
    pub tables: Vec<Table>,
}

/// File-name-safe version of a mesh or model name.
fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect::<String>()
        .trim_matches('_')
        .to_string()
}

/// Fig. 3 and the compaction comparison with `opts`: writes `eigen_cost.md/.csv`,
/// `eigen_cost_<mesh>.png`, `compaction.md/.csv`, `compaction_<model>.png` and
/// `eigen_cost.json` to `out`.
pub fn run(
    opts: &EigenCostOptions,
    out: &mut Outputs,
    progress: &mut ProgressFn,
) -> Result<EigenCostResults, ExperimentError> {
    opts.validate()?;
    let meshes = open_all(&opts.meshes, progress)?;
    let (cost_rows, cost_table, cost_charts) = cost(&meshes, &opts.sizes, opts.repeat, progress)?;
    out.table("eigen_cost", &cost_table)?;
    for (mesh, chart) in &cost_charts {
        out.chart(&format!("eigen_cost_{}.png", slug(mesh)), chart)?;
    }
    let models = compaction_models(meshes.first(), opts.compaction_size)?;
    let (comp_rows, order, comp_table, comp_charts) = compaction(&models, progress)?;
    out.table("compaction", &comp_table)?;
    for (model, chart) in &comp_charts {
        out.chart(&format!("compaction_{}.png", slug(model)), chart)?;
    }
    let results = EigenCostResults {
        cost: cost_rows,
        compaction: comp_rows,
        compaction_order: order,
        tables: vec![cost_table, comp_table],
    };
    out.json("eigen_cost.json", &results)?;
    Ok(results)
}

/// The patch of `input` grown by breadth-first search from `seed` (neighbors in
/// index order) until it has `n` vertices, with the faces whose three corners are
/// inside; cleaned, so vertices left without a face are dropped and the patch can
/// have slightly fewer than n vertices.
pub fn bfs_patch(input: &Input, seed: usize, n: usize) -> Result<Input, ExperimentError> {
    let nv = input.mesh.n_vertices();
    if nv == 0 || seed >= nv {
        return Err(ExperimentError::invalid(
            "seed",
            format!("is vertex {seed} of a mesh with {nv} vertices"),
        ));
    }
    let mut inside = vec![false; nv];
    let mut order = Vec::with_capacity(n.min(nv));
    let mut queue = VecDeque::from([seed]);
    inside[seed] = true;
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
    let name = format!("{} [bfs {n}]", short_name(&input.source));
    input::from_mesh(
        &name,
        TriMesh::new(positions, faces),
        None,
        &Default::default(),
    )
    .map_err(|e| input_err(&name, e))
}

/// The operators timed by [`cost`]: (label, kind, path).
pub const COST_OPERATORS: [(&str, OperatorKind, EigenPath); 6] = [
    ("kl", OperatorKind::Kirchhoff, EigenPath::Symmetric),
    ("gl", OperatorKind::Graph, EigenPath::Symmetric),
    ("sql", OperatorKind::Sql, EigenPath::Symmetric),
    ("sstl", OperatorKind::Sstl, EigenPath::Symmetric),
    ("tl", OperatorKind::Tutte, EigenPath::Auto),
    ("tl-general", OperatorKind::Tutte, EigenPath::General),
];

/// One decomposition measured by [`cost`].
#[derive(Clone, Debug, Serialize)]
pub struct CostRow {
    /// Mesh the patch was cut from.
    pub mesh: String,
    /// Vertices of the patch.
    pub n: usize,
    /// Operator label (see [`COST_OPERATORS`]).
    pub operator: String,
    /// Path actually used.
    pub path: EigenPath,
    /// Eigendecomposition (with the LU of E on the general path), median seconds.
    pub eigen_seconds: f64,
    /// Spectral coefficients of the n×3 positions, median seconds.
    pub coefficient_seconds: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Fig. 3: times every operator of [`COST_OPERATORS`] on BFS patches of each mesh
/// (seed vertex 0) of every size; medians of `repeat` runs; one [`Progress::Step`]
/// per mesh, size and operator. Returns the rows, a table and one log–log chart per
/// mesh (time against n, one series per operator).
pub fn cost(
    inputs: &[Input],
    sizes: &[usize],
    repeat: usize,
    progress: &mut ProgressFn,
) -> Result<(Vec<CostRow>, Table, NamedCharts), ExperimentError> {
    let total = inputs.len() * sizes.len() * COST_OPERATORS.len();
    progress(Progress::start("eigendecomposition cost", total));
    let mut rows = Vec::new();
    for input in inputs {
        for &size in sizes {
            let patch = bfs_patch(input, 0, size)?;
            let x = positions_to_mat(&patch.mesh.positions);
            for (label, kind, path) in COST_OPERATORS {
                progress(Progress::step(format!(
                    "{} n={size} {label}",
                    short_name(&input.source)
                )));
                let op =
                    Operator::on_input(kind, &patch).map_err(|e| input_err(&patch.source, e))?;
                let opts = BasisOptions {
                    path,
                    ..Default::default()
                };
                let (mut te, mut tc) = (Vec::new(), Vec::new());
                let mut used = path;
                for _ in 0..repeat.max(1) {
                    let t = Instant::now();
                    let b =
                        EigenBasis::compute(&op, &opts).map_err(|e| input_err(&patch.source, e))?;
                    te.push(t.elapsed().as_secs_f64());
                    used = b.path();
                    let t = Instant::now();
                    std::hint::black_box(
                        forward(&b, x.as_ref()).map_err(|e| input_err(&patch.source, e))?,
                    );
                    tc.push(t.elapsed().as_secs_f64());
                }
                rows.push(CostRow {
                    mesh: short_name(&input.source),
                    n: patch.mesh.n_vertices(),
                    operator: label.to_string(),
                    path: used,
                    eigen_seconds: median(te),
                    coefficient_seconds: median(tc),
                });
            }
        }
    }
    let mut t = Table::from_columns(
        "Cost of the ED-transform (Zhang 2004 Fig. 3), seconds",
        &rows,
        &[
            ("mesh", &|r: &&CostRow| r.mesh.clone()),
            ("n", &|r| r.n.to_string()),
            ("operator", &|r| r.operator.clone()),
            ("path", &|r| r.path.name().into()),
            ("eigendecomposition", &|r| sig(Some(r.eigen_seconds), 3)),
            ("coefficients", &|r| sig(Some(r.coefficient_seconds), 3)),
        ],
    );
    t.notes.push(format!(
        "BFS patches from vertex 0; medians of {} run(s). tl = the TL through its GL \
         similarity (symmetric solver, D-weighted projection); tl-general = non-symmetric \
         eigendecomposition + LU of E (coefficients by LU solves), as Matlab's eig + E\\x.",
        repeat.max(1)
    ));
    let mut charts = Vec::new();
    let mut meshes: Vec<String> = Vec::new();
    for r in &rows {
        if !meshes.contains(&r.mesh) {
            meshes.push(r.mesh.clone());
        }
    }
    for m in meshes {
        let series = COST_OPERATORS
            .iter()
            .map(|(label, _, _)| {
                let pts = rows
                    .iter()
                    .filter(|r| r.mesh == m && r.operator == *label)
                    .map(|r| (r.n as f64, r.eigen_seconds))
                    .collect();
                Series::new(label.to_uppercase(), pts).with_markers()
            })
            .collect();
        let title = format!("Eigendecomposition cost, patches of {m}");
        let chart = Chart::new(title, "vertices n", "seconds")
            .with_scales(Scale::Log, Scale::Log)
            .with_series(series);
        charts.push((m, chart));
    }
    Ok((rows, t, charts))
}

/// The spectral coefficients of `x` in the dense eigenbasis of `kind` on `input`.
fn coefficients(
    input: &Input,
    kind: OperatorKind,
    x: faer::MatRef<'_, f64>,
) -> Result<faer::Mat<f64>, crate::Error> {
    let op = Operator::on_input(kind, input)?;
    let b = EigenBasis::compute(&op, &BasisOptions::default())?;
    Ok(forward(&b, x)?)
}

/// A model of the compaction comparison.
#[derive(Clone, Debug)]
pub struct CompactionModel {
    /// Name in tables.
    pub name: String,
    /// Smooth (true) or with sharp transitions.
    pub smooth: bool,
    /// The mesh.
    pub input: Input,
}

/// The default models: a `patch_size` BFS patch of `smooth_source` (if any) and
/// `builtin:icosphere:3` (smooth); `builtin:cube:8` and `builtin:step:20` (sharp).
pub fn compaction_models(
    smooth_source: Option<&Input>,
    patch_size: usize,
) -> Result<Vec<CompactionModel>, ExperimentError> {
    let mut models = Vec::new();
    if let Some(s) = smooth_source {
        let p = bfs_patch(s, 0, patch_size)?;
        models.push(CompactionModel {
            name: p.source.clone(),
            smooth: true,
            input: p,
        });
    }
    for (spec, smooth) in [
        ("builtin:icosphere:3", true),
        ("builtin:cube:8", false),
        ("builtin:step:20", false),
    ] {
        models.push(CompactionModel {
            name: spec.trim_start_matches("builtin:").to_string(),
            smooth,
            input: open(spec)?,
        });
    }
    Ok(models)
}

/// The operators compared by [`compaction`], in the paper's order.
pub const COMPACTION_OPERATORS: [(&str, OperatorKind); 4] = [
    ("sstl", OperatorKind::Sstl),
    ("sql", OperatorKind::Sql),
    ("tl", OperatorKind::Tutte),
    ("kl", OperatorKind::Kirchhoff),
];

/// One (model, operator) of [`compaction`].
#[derive(Clone, Debug, Serialize)]
pub struct CompactionRow {
    /// Model name.
    pub model: String,
    /// Smooth model.
    pub smooth: bool,
    /// Vertices.
    pub n: usize,
    /// Operator label.
    pub operator: String,
    /// Mean of η(m) over m = 1..=n (higher = better compaction).
    pub mean_efficiency: f64,
    /// 1 − η(m) at m = 2 %, 5 %, 10 % of n.
    pub residual_at: [f64; 3],
    /// Smallest m with η(m) ≥ 99 %.
    pub m_99: usize,
    /// Smallest m with η(m) ≥ 99.9 %.
    pub m_999: usize,
    /// 1 − η(m) for m = 1..=n.
    pub residual: Vec<f64>,
}

/// Per model, operators from best to worst mean efficiency.
pub type CompactionOrder = Vec<(String, Vec<String>)>;

/// Charts keyed by the mesh or model they show.
pub type NamedCharts = Vec<(String, Chart)>;

/// §4.9 energy compaction of the centered positions for every model and operator; one
/// [`Progress::Step`] per model and operator. Returns the rows, the order per model, a
/// table and one chart per model (residual energy 1 − η(m), log scale, against m up to
/// n/4).
pub fn compaction(
    models: &[CompactionModel],
    progress: &mut ProgressFn,
) -> Result<(Vec<CompactionRow>, CompactionOrder, Table, NamedCharts), ExperimentError> {
    progress(Progress::start(
        "energy compaction",
        models.len() * COMPACTION_OPERATORS.len(),
    ));
    let mut rows = Vec::new();
    for model in models {
        let x = centre(positions_to_mat(&model.input.mesh.positions).as_ref());
        let n = model.input.mesh.n_vertices();
        for (label, kind) in COMPACTION_OPERATORS {
            progress(Progress::step(format!("{} {label}", model.name)));
            let coeffs = coefficients(&model.input, kind, x.as_ref())
                .map_err(|e| input_err(&model.name, e))?;
            let comp = energy_compaction(coeffs.as_ref());
            let at = |p: f64| {
                let m = ((p * n as f64).round() as usize).clamp(1, n);
                (1.0 - comp.total[m - 1]).max(0.0)
            };
            rows.push(CompactionRow {
                model: model.name.clone(),
                smooth: model.smooth,
                n,
                operator: label.into(),
                mean_efficiency: comp.mean_efficiency(),
                residual_at: [at(0.02), at(0.05), at(0.10)],
                m_99: comp.coefficients_for(0.99),
                m_999: comp.coefficients_for(0.999),
                residual: comp.total.iter().map(|e| (1.0 - e).max(0.0)).collect(),
            });
        }
    }
    let order: CompactionOrder = models
        .iter()
        .map(|m| {
            let mut ops: Vec<&CompactionRow> = rows.iter().filter(|r| r.model == m.name).collect();
            ops.sort_by(|a, b| b.mean_efficiency.total_cmp(&a.mean_efficiency));
            (
                m.name.clone(),
                ops.iter().map(|r| r.operator.clone()).collect(),
            )
        })
        .collect();
    let mut t = Table::from_columns(
        "Energy compaction (transform efficiency η, Zhang 2004 §4.9), centred positions",
        &rows,
        &[
            ("model", &|r: &&CompactionRow| r.model.clone()),
            ("smooth", &|r| if r.smooth { "yes" } else { "no" }.into()),
            ("n", &|r| r.n.to_string()),
            ("operator", &|r| r.operator.clone()),
            ("mean η", &|r| format!("{:.6}", r.mean_efficiency)),
            ("1−η(2% n)", &|r| sig(Some(r.residual_at[0]), 3)),
            ("1−η(5% n)", &|r| sig(Some(r.residual_at[1]), 3)),
            ("1−η(10% n)", &|r| sig(Some(r.residual_at[2]), 3)),
            ("m for 99%", &|r| r.m_99.to_string()),
            ("m for 99.9%", &|r| r.m_999.to_string()),
        ],
    );
    for (m, ops) in &order {
        t.notes.push(format!(
            "{m}: {} (best first, by mean η)",
            ops.iter()
                .map(|s| s.to_uppercase())
                .collect::<Vec<_>>()
                .join(" > ")
        ));
    }
    let charts = models
        .iter()
        .map(|m| {
            let series = rows
                .iter()
                .filter(|r| r.model == m.name)
                .map(|r| {
                    let upto = (r.n / 4).max(2);
                    Series::new(
                        r.operator.to_uppercase(),
                        r.residual[..upto]
                            .iter()
                            .enumerate()
                            .map(|(i, &v)| ((i + 1) as f64, v))
                            .collect(),
                    )
                })
                .collect();
            let title = format!("Energy compaction, {}", m.name);
            let chart = Chart::new(title, "coefficients kept m", "residual energy 1 − η(m)")
                .with_scales(Scale::Linear, Scale::Log)
                .with_series(series);
            (m.name.clone(), chart)
        })
        .collect();
    Ok((rows, order, t, charts))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bfs_patch_is_a_connected_ball() {
        let input = open("builtin:icosphere:3").unwrap();
        let p = bfs_patch(&input, 0, 100).unwrap();
        assert!(p.mesh.n_vertices() <= 100 && p.mesh.n_vertices() >= 90);
        assert_eq!(p.topology.components().1, 1);
        assert!(p.topology.boundary_edges().count() > 0);
        // The whole mesh when n is large enough.
        let all = bfs_patch(&input, 5, 10_000).unwrap();
        assert_eq!(all.mesh.n_faces(), input.mesh.n_faces());
        assert!(bfs_patch(&input, 1_000_000, 10).is_err());
    }

    #[test]
    fn cost_and_compaction_tables() {
        let input = open("builtin:icosphere:2").unwrap();
        let mut calls = 0;
        let (rows, t, charts) = cost(std::slice::from_ref(&input), &[30, 60], 1, &mut |p| {
            calls += matches!(p, Progress::Step { .. }) as usize
        })
        .unwrap();
        assert_eq!(rows.len(), 12);
        assert_eq!(calls, 12);
        assert_eq!(t.rows.len(), 12);
        assert_eq!(charts.len(), 1);
        assert!(rows
            .iter()
            .filter(|r| r.operator == "tl")
            .all(|r| r.path == EigenPath::Symmetrized));
        let models = vec![CompactionModel {
            name: "step".into(),
            smooth: false,
            input: open("builtin:step:6").unwrap(),
        }];
        let (rows, order, t, charts) = compaction(&models, &mut |_| {}).unwrap();
        assert_eq!(rows.len(), 4);
        assert_eq!(order[0].1.len(), 4);
        assert_eq!(t.notes.len(), 1);
        assert_eq!(charts.len(), 1);
        for r in &rows {
            assert!(r.residual.last().unwrap().abs() < 1e-12);
            assert!(r.residual_at[0] >= r.residual_at[2]);
        }
    }
}
