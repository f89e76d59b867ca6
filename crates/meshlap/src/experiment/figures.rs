//! The paper's pictures, re-made: JPEG-like truncated ED reconstructions (Zhang 2004
//! §2.6, §3 and §4.9; Karni–Gotsman 2000), rendered with [`crate::render`].
//!
//! - Fig. 1: with the normalized graph Laplacian (GL) the truncated reconstructions
//!   `x⁽ᵐ⁾` are not smooth versions of the mesh, because the GL's lowest eigenvector is
//!   `D^{1/2}·1`, not constant; with a GSML (here the SQL and the TL) they are. The
//!   figure shows each model, its GL reconstruction and a GSML one at the same `m`.
//! - Fig. 4: KL reconstructions show artifacts at low-degree vertices (the expected
//!   local variance is inversely proportional to the degree), SSTL and SQL do not.
//!   The model is the paper's, a sphere with 4-8 connectivity
//!   ([`crate::mesh::builtin::sphere48`]).
//!
//! Every panel is computed with the dense ED basis ([`crate::spectral::basis`]); the
//! reconstruction error `‖x − x⁽ᵐ⁾‖ / ‖x − x̄‖` of each is returned and printed under
//! it. All pictures of one model share the original's framing. [`run`] makes both
//! figures with [`FiguresOptions`]. Sign convention of the operators: `F = D − W`.

use super::meshes::{open, shared, short_name};
use super::{sig, ExperimentError, Outputs, Progress, ProgressFn, Table};
use crate::input::Input;
use crate::mesh::TriMesh;
use crate::operator::{Operator, OperatorKind};
use crate::render::{render, Framing, Panel, RenderOptions, Window};
use crate::spectral::basis::{BasisOptions, EigenBasis};
use crate::spectral::transform::{mat_to_positions, positions_to_mat, truncated};
use serde::Serialize;
use std::path::Path;

/// Options of [`run`].
#[derive(Clone, Debug, PartialEq)]
pub struct FiguresOptions {
    /// The model of Fig. 1 beside `builtin:icosphere:3` (dense ED: at most 5,000
    /// vertices).
    pub mesh: String,
    /// Fraction of the coefficients kept in Fig. 1, in (0, 1].
    pub keep_fraction: f64,
    /// Coefficients kept in Fig. 4.
    pub fig4_keep: usize,
    /// Picture size of each cell, pixels.
    pub size: u32,
}

default_is_paper!(FiguresOptions);

impl FiguresOptions {
    /// The paper's settings with the cow read from `dir`.
    pub fn paper(dir: &Path) -> Self {
        FiguresOptions {
            mesh: shared(dir, "cow.obj"),
            keep_fraction: 0.05,
            fig4_keep: 24,
            size: 420,
        }
    }

    /// A small generated model instead of the cow.
    pub fn quick() -> Self {
        FiguresOptions {
            mesh: "builtin:icosphere:2".into(),
            ..Self::default()
        }
    }

    fn validate(&self) -> Result<(), ExperimentError> {
        if !(self.keep_fraction > 0.0 && self.keep_fraction <= 1.0) {
            return Err(ExperimentError::invalid(
                "keep_fraction",
                format!("must be in (0, 1], got {}", self.keep_fraction),
            ));
        }
        Ok(())
    }
}

/// The reconstructions of both figures (serialized as `figures.json`).
#[derive(Clone, Debug, Serialize)]
pub struct FiguresResults {
    /// Fig. 1: each model, its GL, SQL and TL reconstructions.
    pub fig1: Vec<Reconstruction>,
    /// Fig. 4: the 4-8 sphere and its KL, SQL and SSTL reconstructions.
    pub fig4: Vec<Reconstruction>,
    /// Their errors.
    #[serde(skip)]
    pub table: Table,
}

/// Figs. 1 and 4 with `opts`: writes `fig1_<model>.png`, `fig4_4_8_sphere.png`,
/// `figures.md/.csv` and `figures.json` to `out`.
pub fn run(
    opts: &FiguresOptions,
    out: &mut Outputs,
    progress: &mut ProgressFn,
) -> Result<FiguresResults, ExperimentError> {
    opts.validate()?;
    progress(Progress::start("Fig. 1", 0));
    let mut models = Vec::new();
    for (spec, name, view) in [
        (opts.mesh.as_str(), None, (-60.0, 15.0)),
        ("builtin:icosphere:3", Some("Sphere"), (20.0, 20.0)),
    ] {
        let input = open(spec)?;
        let n = input.mesh.n_vertices();
        models.push(FigureModel {
            name: name.map_or_else(|| short_name(spec), str::to_string),
            input,
            keep: ((n as f64 * opts.keep_fraction).round() as usize).max(1),
            view,
        });
    }
    let fig1 = figure(
        out,
        "fig1",
        "Fig. 1 — GL versus GSML truncated reconstructions",
        &models,
        &[OperatorKind::Graph, OperatorKind::Sql, OperatorKind::Tutte],
        opts.size,
    )?;
    progress(Progress::start("Fig. 4", 0));
    let sphere = FigureModel {
        name: "4-8 sphere".into(),
        input: open("builtin:sphere48:12")?,
        keep: opts.fig4_keep,
        view: (35.0, 30.0),
    };
    let fig4 = figure(
        out,
        "fig4",
        "Fig. 4 — KL artifacts at low-degree vertices",
        &[sphere],
        &[
            OperatorKind::Kirchhoff,
            OperatorKind::Sql,
            OperatorKind::Sstl,
        ],
        opts.size,
    )?;
    let rows: Vec<Reconstruction> = fig1.iter().chain(&fig4).cloned().collect();
    let table = error_table("Truncated ED reconstructions (Figs. 1 and 4)", &rows);
    out.table("figures", &table)?;
    let results = FiguresResults { fig1, fig4, table };
    out.json("figures.json", &results)?;
    Ok(results)
}

/// One reconstruction shown in a figure.
#[derive(Clone, Debug, Serialize)]
pub struct Reconstruction {
    /// Model name.
    pub model: String,
    /// Operator, or `None` for the original.
    pub kind: Option<OperatorKind>,
    /// Coefficients kept.
    pub keep: usize,
    /// Vertices.
    pub n: usize,
    /// `‖x − x⁽ᵐ⁾‖_F / ‖x − x̄‖_F`.
    pub relative_error: f64,
}

/// The truncated reconstruction of `input` with the first `keep` ED coefficients of
/// `kind`'s dense basis.
pub fn reconstruct(
    input: &Input,
    kind: OperatorKind,
    keep: usize,
) -> Result<(TriMesh, f64), ExperimentError> {
    let err = |e: crate::Error| ExperimentError::input(&input.source, e);
    let op = Operator::on_input(kind, input).map_err(|e| err(e.into()))?;
    let basis = EigenBasis::compute(&op, &BasisOptions::default()).map_err(|e| err(e.into()))?;
    let x = positions_to_mat(&input.mesh.positions);
    let y = truncated(&basis, x.as_ref(), keep.clamp(1, basis.len())).map_err(|e| err(e.into()))?;
    let positions = mat_to_positions(y.as_ref()).map_err(|e| err(e.into()))?;
    let n = positions.len();
    let mean: [f64; 3] =
        std::array::from_fn(|k| input.mesh.positions.iter().map(|p| p[k]).sum::<f64>() / n as f64);
    let (mut num, mut den) = (0.0, 0.0);
    for (a, b) in input.mesh.positions.iter().zip(&positions) {
        for k in 0..3 {
            num += (a[k] - b[k]).powi(2);
            den += (a[k] - mean[k]).powi(2);
        }
    }
    let rel = if den > 0.0 {
        (num / den).sqrt()
    } else {
        num.sqrt()
    };
    Ok((TriMesh::new(positions, input.mesh.faces.clone()), rel))
}

/// A model of a figure: its name, the mesh and the view.
#[derive(Clone, Debug)]
pub struct FigureModel {
    /// Caption name.
    pub name: String,
    /// The mesh.
    pub input: Input,
    /// Coefficients kept.
    pub keep: usize,
    /// View azimuth and elevation, degrees.
    pub view: (f64, f64),
}

/// Renders one row per model: the original, then one reconstruction per operator of
/// `kinds`, all framed like the original. Writes `stem_<model>.png` for each row and
/// returns the reconstructions.
pub fn figure(
    out: &mut Outputs,
    stem: &str,
    title: &str,
    models: &[FigureModel],
    kinds: &[OperatorKind],
    size: u32,
) -> Result<Vec<Reconstruction>, ExperimentError> {
    let mut rows = Vec::new();
    for m in models {
        let opts = RenderOptions {
            width: size,
            height: size,
            azimuth: m.view.0,
            elevation: m.view.1,
            framing: Window::fit(&m.input.mesh, m.view.0, m.view.1)
                .map_or(Framing::Fit, Framing::Window),
            ..Default::default()
        };
        let n = m.input.mesh.n_vertices();
        let mut cells = vec![(
            render(&m.input.mesh, &opts)?,
            format!("{} (n = {n})", m.name),
        )];
        rows.push(Reconstruction {
            model: m.name.clone(),
            kind: None,
            keep: n,
            n,
            relative_error: 0.0,
        });
        for &kind in kinds {
            let (mesh, rel) = reconstruct(&m.input, kind, m.keep)?;
            cells.push((
                render(&mesh, &opts)?,
                format!(
                    "{}, m = {} (error {})",
                    kind.name().to_uppercase(),
                    m.keep,
                    sig(Some(rel), 2)
                ),
            ));
            rows.push(Reconstruction {
                model: m.name.clone(),
                kind: Some(kind),
                keep: m.keep,
                n,
                relative_error: rel,
            });
        }
        let panel = Panel {
            cells,
            title: Some(format!("{title}: {}", m.name)),
        };
        let slug: String = m
            .name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() {
                    c.to_ascii_lowercase()
                } else {
                    '_'
                }
            })
            .collect();
        out.image(&format!("{stem}_{slug}.png"), &panel.compose()?)?;
    }
    Ok(rows)
}

/// Table of the reconstructions' errors.
pub fn error_table(title: &str, rows: &[Reconstruction]) -> Table {
    let mut t = Table::new(
        title,
        &["model", "n", "operator", "m", "‖x − x⁽ᵐ⁾‖ / ‖x − x̄‖"],
    );
    for r in rows.iter().filter(|r| r.kind.is_some()) {
        t.push(vec![
            r.model.clone(),
            r.n.to_string(),
            r.kind.map_or("original".into(), |k| k.name().to_string()),
            r.keep.to_string(),
            sig(Some(r.relative_error), 3),
        ]);
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::{from_mesh, open, OpenOptions};

    #[test]
    fn gl_reconstruction_is_not_smooth_and_gsml_is() {
        // With one coefficient a GSML collapses the mesh to its centroid (constant
        // lowest eigenvector); the GL does not (its lowest eigenvector is D^{1/2}·1).
        let input = open("builtin:grid:6", &OpenOptions::default()).unwrap();
        let (sql, _) = reconstruct(&input, OperatorKind::Sql, 1).unwrap();
        let (gl, _) = reconstruct(&input, OperatorKind::Graph, 1).unwrap();
        let spread = |m: &TriMesh| {
            let p0 = m.positions[0];
            m.positions
                .iter()
                .map(|p| (0..3).map(|k| (p[k] - p0[k]).abs()).fold(0.0, f64::max))
                .fold(0.0, f64::max)
        };
        assert!(spread(&sql) < 1e-12, "{}", spread(&sql));
        assert!(spread(&gl) > 1e-2, "{}", spread(&gl));
        // keeping everything reproduces the mesh
        let n = input.mesh.n_vertices();
        let (all, rel) = reconstruct(&input, OperatorKind::Graph, n).unwrap();
        assert!(rel < 1e-10);
        assert_eq!(all.faces, input.mesh.faces);
    }

    #[test]
    fn figure_writes_one_panel_per_model() {
        let dir = tempfile::tempdir().unwrap();
        let mut out = Outputs::new(dir.path()).unwrap();
        let mesh = crate::mesh::builtin::sphere48(4).unwrap();
        let input = from_mesh("4-8 sphere", mesh, None, &Default::default()).unwrap();
        let models = [FigureModel {
            name: "4-8 sphere".into(),
            input,
            keep: 10,
            view: (30.0, 20.0),
        }];
        let rows = figure(
            &mut out,
            "fig",
            "Test",
            &models,
            &[OperatorKind::Kirchhoff, OperatorKind::Sstl],
            64,
        )
        .unwrap();
        assert_eq!(rows.len(), 3);
        assert!(dir.path().join("fig_4_8_sphere.png").is_file());
        assert_eq!(error_table("t", &rows).rows.len(), 2);
    }
}
