//! The paper's §2–3 claims, measured (Zhang 2004):
//!
//! - [`properties`]: for every operator on every mesh, what §3 says of it — symmetry,
//!   nonnegative weights, zero row sums, a doubly stochastic and variance-diminishing
//!   `H = I − F/k`, positive semi-definiteness, one zero eigenvalue per component, the
//!   Gershgorin bound, GSML status — measured on the assembled matrix by
//!   [`crate::analysis::properties::analyze`], never assumed from the kind.
//! - [`erratum`]: the SQL's boundary diagonal as printed, `1 + ½Σ(1/d_k − 1/d_j)`, against
//!   the corrected `1 + ½Σ(1/d_j − 1/d_k)` (see [`crate::operator::sql`]): the largest
//!   |row sum| of each.
//! - [`repair`]: negative SQL weights before and after greedy edge swapping (§3.7).
//! - [`limits`]: repeated smoothing `x ← Hx` (§2.2): the TL converges to the
//!   valence-weighted centroid `Σ d_i x_i / Σ d_i`, a doubly stochastic H (KL; SQL
//!   without negative weights) to the centroid, and never increases the variance.
//!
//! [`run`] does all four with [`ClaimsOptions`] and writes their tables, the chart
//! and `claims.json`. Sign convention of every operator: `F = D − W`, positive
//! semi-definite.

use super::meshes::{open, open_all, shared, short_name, DEFAULT_MESH_DIR};
use super::{sig, yes_no, ExperimentError, Outputs, Progress, ProgressFn, Table};
use crate::analysis::properties::{analyze, PropertyOptions, PropertyReport};
use crate::analysis::repair::{repair_sql, RepairOptions, RepairReport};
use crate::analysis::smoothing::{iterate, IterateOptions, SmoothingStep};
use crate::input::Input;
use crate::operator::{sql::BoundaryDiagonal, Operator, OperatorKind, OperatorOptions};
use crate::plot::{Chart, Scale, Series};
use serde::Serialize;
use std::path::Path;

fn input_err(input: &Input, e: impl Into<crate::Error>) -> ExperimentError {
    ExperimentError::input(&input.source, e)
}

/// Options of [`run`].
#[derive(Clone, Debug, PartialEq)]
pub struct ClaimsOptions {
    /// Meshes of the property table (files or `builtin:` specs).
    pub meshes: Vec<String>,
    /// Meshes with boundary for the SQL erratum table.
    pub boundary_meshes: Vec<String>,
    /// Meshes for the SQL repair table.
    pub repair_meshes: Vec<String>,
    /// Mesh of the smoothing-limit run (irregular valences make the two centroids
    /// differ).
    pub limit_mesh: String,
    /// Smoothing steps of the limit run.
    pub steps: usize,
}

impl Default for ClaimsOptions {
    /// The settings of `meshlap experiment claims`: the shared models in
    /// [`DEFAULT_MESH_DIR`] and two generated meshes.
    fn default() -> Self {
        let dir = Path::new(DEFAULT_MESH_DIR);
        let mut o = Self::paper(dir);
        o.boundary_meshes.push("builtin:grid:12".into());
        o
    }
}

impl ClaimsOptions {
    /// The settings of `experiment all`, with the shared models read from `dir`.
    pub fn paper(dir: &Path) -> Self {
        let m = |name: &str| shared(dir, name);
        ClaimsOptions {
            meshes: vec![
                m("cow.obj"),
                m("woody.obj"),
                "builtin:grid:12".into(),
                "builtin:icosahedron".into(),
            ],
            boundary_meshes: vec![m("teapot.obj"), m("stanford-bunny.obj")],
            repair_meshes: vec![m("cow.obj"), m("teapot.obj"), m("horse.ply")],
            limit_mesh: m("woody.obj"),
            steps: 20_000,
        }
    }

    /// Fewer and smaller meshes ([`DEFAULT_MESH_DIR`]).
    pub fn quick() -> Self {
        Self::quick_in(Path::new(DEFAULT_MESH_DIR))
    }

    /// Fewer and smaller meshes, the shared ones read from `dir`.
    pub fn quick_in(dir: &Path) -> Self {
        let m = |name: &str| shared(dir, name);
        ClaimsOptions {
            meshes: vec![m("woody.obj"), "builtin:grid:12".into()],
            boundary_meshes: vec![m("teapot.obj")],
            repair_meshes: vec![m("cow.obj")],
            limit_mesh: m("woody.obj"),
            steps: 20_000,
        }
    }
}

/// Everything [`run`] measured (serialized as `claims.json`).
#[derive(Clone, Debug, Serialize)]
pub struct ClaimsResults {
    /// [`properties`] rows.
    pub properties: Vec<PropertyRow>,
    /// [`erratum`] rows.
    pub erratum: Vec<ErratumRow>,
    /// [`repair`] rows.
    pub repair: Vec<RepairRow>,
    /// [`limits`] rows.
    pub limits: Vec<LimitRow>,
    /// The four tables, in that order.
    #[serde(skip)]
    pub tables: Vec<Table>,
}

/// The four measurements of the module documentation with `opts`: writes
/// `properties`, `erratum`, `repair` and `limits` (`.md` and `.csv`), `limits.png` and
/// `claims.json` to `out`.
pub fn run(
    opts: &ClaimsOptions,
    out: &mut Outputs,
    progress: &mut ProgressFn,
) -> Result<ClaimsResults, ExperimentError> {
    let meshes = open_all(&opts.meshes, progress)?;
    let (prop_rows, prop_table) = properties(
        &meshes,
        &OperatorKind::ALL,
        &PropertyOptions::default(),
        progress,
    );
    out.table("properties", &prop_table)?;

    progress(Progress::start("SQL erratum", 0));
    let (err_rows, err_table) = erratum(&open_all(&opts.boundary_meshes, progress)?)?;
    out.table("erratum", &err_table)?;

    progress(Progress::start("SQL repair", 0));
    let repair_inputs = open_all(&opts.repair_meshes, progress)?;
    let (rep_rows, rep_table) = repair(&repair_inputs, &RepairOptions::default())?;
    out.table("repair", &rep_table)?;

    progress(Progress::start("smoothing limits", 0));
    let limit_input = open(&opts.limit_mesh)?;
    let kinds = [
        OperatorKind::Tutte,
        OperatorKind::Kirchhoff,
        OperatorKind::Sql,
    ];
    let (lim_rows, lim_table, chart) =
        limits(&limit_input, &kinds, opts.steps, (opts.steps / 200).max(1))?;
    out.table("limits", &lim_table)?;
    out.chart("limits.png", &chart)?;
    let results = ClaimsResults {
        properties: prop_rows,
        erratum: err_rows,
        repair: rep_rows,
        limits: lim_rows,
        tables: vec![prop_table, err_table, rep_table, lim_table],
    };
    out.json("claims.json", &results)?;
    Ok(results)
}

/// One (mesh, operator) result of [`properties`].
#[derive(Clone, Debug, Serialize)]
pub struct PropertyRow {
    /// Mesh source.
    pub mesh: String,
    /// Connected components of the mesh.
    pub components: usize,
    /// Operator.
    pub kind: OperatorKind,
    /// The measured report, or why the operator could not be assembled.
    pub report: Result<PropertyReport, String>,
}

/// Measures every operator of `kinds` on every mesh; one [`Progress::Step`] per mesh
/// and operator.
pub fn properties(
    inputs: &[Input],
    kinds: &[OperatorKind],
    opts: &PropertyOptions,
    progress: &mut ProgressFn,
) -> (Vec<PropertyRow>, Table) {
    progress(Progress::start("properties", inputs.len() * kinds.len()));
    let mut rows = Vec::new();
    for input in inputs {
        let components = input.topology.components().1;
        for &kind in kinds {
            progress(Progress::step(format!(
                "properties: {} {}",
                short_name(&input.source),
                kind.name()
            )));
            let report = Operator::on_input(kind, input)
                .map(|op| analyze(&op.matrix, opts))
                .map_err(|e| e.to_string());
            rows.push(PropertyRow {
                mesh: input.source.clone(),
                components,
                kind,
                report,
            });
        }
    }
    let mut t = Table::new(
        "Matrix-theoretic properties, measured (Zhang 2004 §2–3)",
        &[
            "mesh",
            "operator",
            "n",
            "symmetric",
            "neg. weights",
            "max |row sum|",
            "H doubly stoch.",
            "variance dimin.",
            "PSD",
            "zero eig. mult. / comps",
            "λ_max",
            "Gershgorin max",
            "GSML",
        ],
    );
    for r in &rows {
        let name = short_name(&r.mesh);
        match &r.report {
            Err(e) => t.push(vec![name, r.kind.name().into(), format!("error: {e}")]),
            Ok(p) => t.push(vec![
                name,
                r.kind.name().into(),
                p.n.to_string(),
                yes_no(Some(p.symmetric)),
                p.negative_weights.to_string(),
                sig(Some(p.max_abs_row_sum), 2),
                yes_no(Some(p.smoothing.doubly_stochastic)),
                yes_no(Some(p.smoothing.variance_diminishing)),
                yes_no(p.positive_semidefinite),
                format!(
                    "{} / {}",
                    p.zero_eigenvalue_multiplicity
                        .map_or("n/a".into(), |m| m.to_string()),
                    r.components
                ),
                sig(p.lambda_max, 4),
                sig(Some(p.gershgorin_max), 4),
                if p.gsml.is_gsml {
                    "yes".into()
                } else {
                    format!("no ({})", p.gsml.failing.join(", "))
                },
            ]),
        }
    }
    t.notes.push(
        "Spectra are dense (n ≤ the dense limits); `n/a` where the spectrum was not computed. \
         H = I − F/k with the smallest admissible k."
            .into(),
    );
    (rows, t)
}

/// One mesh of [`erratum`].
#[derive(Clone, Debug, Serialize)]
pub struct ErratumRow {
    /// Mesh source.
    pub mesh: String,
    /// Boundary vertices.
    pub boundary_vertices: usize,
    /// `max |row sum|` with the printed diagonal.
    pub printed_max_abs_row_sum: f64,
    /// Rows whose sum exceeds 1e-12 with the printed diagonal.
    pub printed_nonzero_rows: usize,
    /// `max |row sum|` with the corrected diagonal.
    pub corrected_max_abs_row_sum: f64,
}

fn row_sums(m: &crate::SparseMatrix) -> Vec<f64> {
    let mut s = vec![0.0; m.nrows()];
    for j in 0..m.ncols() {
        for (&i, &v) in m.row_idx_of_col_raw(j).iter().zip(m.val_of_col(j)) {
            s[i] += v;
        }
    }
    s
}

/// The SQL boundary-diagonal erratum on each mesh.
pub fn erratum(inputs: &[Input]) -> Result<(Vec<ErratumRow>, Table), ExperimentError> {
    let mut rows = Vec::new();
    for input in inputs {
        let build = |d| {
            Operator::assemble(
                OperatorKind::Sql,
                &input.mesh,
                &input.topology,
                &OperatorOptions {
                    sql_boundary: d,
                    ..Default::default()
                },
            )
            .map_err(|e| input_err(input, e))
        };
        let printed = row_sums(&build(BoundaryDiagonal::AsPrinted)?.matrix);
        let corrected = row_sums(&build(BoundaryDiagonal::ZeroRowSum)?.matrix);
        let max_abs = |v: &[f64]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        rows.push(ErratumRow {
            mesh: input.source.clone(),
            boundary_vertices: (0..input.topology.n_vertices())
                .filter(|&v| input.topology.is_boundary_vertex(crate::VertexId(v as u32)))
                .count(),
            printed_max_abs_row_sum: max_abs(&printed),
            printed_nonzero_rows: printed.iter().filter(|x| x.abs() > 1e-12).count(),
            corrected_max_abs_row_sum: max_abs(&corrected),
        });
    }
    let mut t = Table::new(
        "SQL boundary diagonal: as printed vs corrected (Zhang 2004 §3.7 erratum)",
        &[
            "mesh",
            "boundary vertices",
            "printed: max |row sum|",
            "printed: rows ≠ 0",
            "corrected: max |row sum|",
        ],
    );
    for r in &rows {
        t.push(vec![
            short_name(&r.mesh),
            r.boundary_vertices.to_string(),
            sig(Some(r.printed_max_abs_row_sum), 3),
            r.printed_nonzero_rows.to_string(),
            sig(Some(r.corrected_max_abs_row_sum), 2),
        ]);
    }
    t.notes.push(
        "Printed: D_ii = 1 + ½ Σ (1/d_km − 1/d_jm); corrected: D_ii = 1 + ½ Σ (1/d_jm − 1/d_km). \
         Only the corrected one has the zero row sums the paper claims."
            .into(),
    );
    Ok((rows, t))
}

/// One mesh of [`repair`].
#[derive(Clone, Debug, Serialize)]
pub struct RepairRow {
    /// Mesh source.
    pub mesh: String,
    /// What the repair did.
    pub report: RepairReport,
}

/// Greedy edge-swap repair of negative SQL weights on each mesh.
pub fn repair(
    inputs: &[Input],
    opts: &RepairOptions,
) -> Result<(Vec<RepairRow>, Table), ExperimentError> {
    let mut rows = Vec::new();
    for input in inputs {
        let (_, report) = repair_sql(&input.mesh, opts).map_err(|e| input_err(input, e))?;
        rows.push(RepairRow {
            mesh: input.source.clone(),
            report,
        });
    }
    let mut t = Table::new(
        "SQL negative weights removed by greedy edge swapping (Zhang 2004 §3.7)",
        &[
            "mesh",
            "negative before",
            "most negative before",
            "flips",
            "negative after",
            "most negative after",
        ],
    );
    for r in &rows {
        let p = &r.report;
        t.push(vec![
            short_name(&r.mesh),
            p.negative_before.to_string(),
            sig(Some(p.min_weight_before), 3),
            p.flips.to_string(),
            p.negative_after.to_string(),
            sig(Some(p.min_weight_after), 3),
        ]);
    }
    Ok((rows, t))
}

/// One operator of [`limits`].
#[derive(Clone, Debug, Serialize)]
pub struct LimitRow {
    /// Operator.
    pub kind: OperatorKind,
    /// The k of `H = I − F/k`.
    pub k: f64,
    /// The recorded steps (every `record_every`-th and the last).
    pub steps: Vec<SmoothingStep>,
    /// Largest ratio σ²(x_{p+1}) / σ²(x_p) over the run (> 1: the variance grew).
    pub max_variance_ratio: f64,
}

/// Repeated smoothing with each operator of `kinds` for `steps` steps on one mesh;
/// every `record_every`-th step (and the last) is kept in the result.
pub fn limits(
    input: &Input,
    kinds: &[OperatorKind],
    steps: usize,
    record_every: usize,
) -> Result<(Vec<LimitRow>, Table, Chart), ExperimentError> {
    let degrees = input.topology.degrees();
    let mut rows = Vec::new();
    for &kind in kinds {
        let op = Operator::on_input(kind, input).map_err(|e| input_err(input, e))?;
        let opts = IterateOptions { k: None, steps };
        let run = iterate(&op.matrix, &input.mesh.positions, &degrees, &opts)
            .map_err(|e| input_err(input, e))?;
        let (k, st) = (run.k, run.steps);
        // Ratios are compared while the variance is well above rounding level (1e-20
        // of the input's); below that, quotients of rounding errors mean nothing.
        let floor = st[0].variance * 1e-20;
        let max_variance_ratio = st
            .windows(2)
            .filter(|w| w[0].variance > floor)
            .map(|w| w[1].variance / w[0].variance)
            .fold(0.0, f64::max);
        let every = record_every.max(1);
        let steps_kept = st
            .into_iter()
            .filter(|s| s.step % every == 0 || s.step == steps)
            .collect();
        rows.push(LimitRow {
            kind,
            k,
            steps: steps_kept,
            max_variance_ratio,
        });
    }
    let diag = input.mesh.bbox_diagonal().max(f64::MIN_POSITIVE);
    let mut t = Table::new(
        format!(
            "Smoothing limits after {steps} steps of H = I − F/k on {} (distances / bbox diagonal)",
            short_name(&input.source)
        ),
        &[
            "operator",
            "k",
            "max dist. to centroid",
            "max dist. to valence-weighted centroid",
            "variance ever grew",
            "max σ² ratio",
        ],
    );
    for r in &rows {
        let last = r.steps.last().expect("step 0 is always recorded");
        t.push(vec![
            r.kind.name().into(),
            sig(Some(r.k), 4),
            sig(Some(last.distance_to_centroid / diag), 3),
            sig(Some(last.distance_to_weighted_centroid / diag), 3),
            yes_no(Some(r.max_variance_ratio > 1.0 + 1e-12)),
            sig(Some(r.max_variance_ratio), 6),
        ]);
    }
    t.notes.push(
        "The TL (row-stochastic H) converges to the valence-weighted centroid Σdᵢxᵢ/Σdᵢ, \
         a doubly stochastic H (KL, SQL with nonnegative weights) to the centroid."
            .into(),
    );
    let mut series = Vec::new();
    for r in &rows {
        let pts = |f: fn(&SmoothingStep) -> f64| -> Vec<(f64, f64)> {
            r.steps
                .iter()
                .map(|s| (s.step as f64, f(s) / diag))
                .collect()
        };
        series.push(Series::new(
            format!("{}: to centroid", r.kind.name()),
            pts(|s| s.distance_to_centroid),
        ));
        series.push(Series::new(
            format!("{}: to weighted centroid", r.kind.name()),
            pts(|s| s.distance_to_weighted_centroid),
        ));
    }
    let chart = Chart::new(
        format!("Limits of H^p x on {}", short_name(&input.source)),
        "step p",
        "max distance / bbox diagonal",
    )
    .with_scales(Scale::Linear, Scale::Log)
    .with_series(series);
    Ok((rows, t, chart))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::{open, OpenOptions};

    fn builtin(spec: &str) -> Input {
        open(spec, &OpenOptions::default()).unwrap()
    }

    #[test]
    fn properties_of_the_paper_hold_on_a_closed_mesh() {
        let inputs = [builtin("builtin:icosphere:1")];
        let kinds = [
            OperatorKind::Kirchhoff,
            OperatorKind::Graph,
            OperatorKind::Tutte,
            OperatorKind::Sstl,
        ];
        let mut steps = 0;
        let (rows, t) = properties(&inputs, &kinds, &PropertyOptions::default(), &mut |p| {
            steps += matches!(p, Progress::Step { .. }) as usize
        });
        assert_eq!(steps, 4);
        assert_eq!(t.rows.len(), 4);
        let gsml: Vec<bool> = rows
            .iter()
            .map(|r| r.report.as_ref().unwrap().gsml.is_gsml)
            .collect();
        // KL, TL and SSTL are GSMLs; the GL is not (no zero row sum).
        assert_eq!(gsml, [true, false, true, true]);
        assert!(t.rows[1][12].contains("zero"), "{:?}", t.rows[1]);
    }

    #[test]
    fn erratum_shows_on_a_mesh_with_boundary_only() {
        let (rows, _) =
            erratum(&[builtin("builtin:grid:6"), builtin("builtin:icosahedron")]).unwrap();
        assert!(rows[0].printed_max_abs_row_sum > 0.05, "{:?}", rows[0]);
        assert!(rows[0].printed_nonzero_rows > 0);
        assert!(rows[0].corrected_max_abs_row_sum < 1e-12);
        assert_eq!(rows[1].boundary_vertices, 0);
        assert!(rows[1].printed_max_abs_row_sum < 1e-12);
    }

    #[test]
    fn tl_goes_to_the_weighted_centroid_and_kl_to_the_centroid() {
        // A grid has valences 2…6; pulling a corner (low valence) out breaks the
        // symmetry, so the centroid and the valence-weighted centroid differ.
        let mut input = builtin("builtin:grid:5");
        input.mesh.positions[0][0] -= 3.0;
        let (rows, t, chart) = limits(
            &input,
            &[OperatorKind::Tutte, OperatorKind::Kirchhoff],
            3000,
            7,
        )
        .unwrap();
        assert_eq!(rows[0].steps.len(), 3000 / 7 + 2);
        let last = |i: usize| rows[i].steps.last().unwrap().clone();
        let (tl, kl) = (last(0), last(1));
        assert!(tl.distance_to_weighted_centroid < 1e-8, "{tl:?}");
        assert!(tl.distance_to_centroid > 1e-3, "{tl:?}");
        assert!(kl.distance_to_centroid < 1e-8, "{kl:?}");
        assert!(kl.distance_to_weighted_centroid > 1e-3, "{kl:?}");
        // the doubly stochastic H never increases the variance
        assert!(rows[1].max_variance_ratio <= 1.0 + 1e-12);
        assert_eq!(t.rows.len(), 2);
        assert_eq!(chart.series.len(), 4);
    }

    #[test]
    fn repair_removes_negative_weights_of_a_step_mesh() {
        let (rows, t) = repair(&[builtin("builtin:step:8")], &RepairOptions::default()).unwrap();
        assert_eq!(
            rows[0].report.negative_after,
            rows[0].report.remaining.len()
        );
        assert!(rows[0].report.negative_after <= rows[0].report.negative_before);
        assert_eq!(t.rows.len(), 1);
    }
}
