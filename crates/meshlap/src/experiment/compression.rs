//! §4.9 / Karni–Gotsman 2000: rate–distortion of JPEG-like spectral compression per
//! combinatorial operator, against Google Draco.
//!
//! For every mesh and operator (SSTL, SQL, TL, KL and GL, all F = D − W), the full
//! codec ([`crate::codec::compress`]) runs at a fixed quantization and a sweep of
//! keep ratios (the fraction of low-frequency coefficients kept per patch), so that
//! truncation — the basis' energy compaction — drives the distortion, as in the
//! paper's comparison. Each point records the whole file's bits per vertex and the
//! distortion of the decoded mesh ([`crate::metric::compare`]): vertex RMS and Metro
//! RMS (of the bounding-box diagonal), Zhang's SDL measure and Karni–Gotsman's error.
//! Draco points (from `bench/compression.py --json-out`) are added when given.
//!
//! Non-manifold input is made manifold first (vertex splitting, as
//! `meshlap clean --split-nonmanifold`), since the connectivity coder needs it.
//! [`run`] sweeps every mesh of [`CompressionOptions`] and writes the results.

use super::meshes::{open_all, shared, short_name};
use super::{sig, ExperimentError, Outputs, Progress, ProgressFn, Table};
use crate::codec::spectral::{Keep, SpectralParams};
use crate::codec::{compress, CompressOptions, Quantization};
use crate::input::Input;
use crate::mesh::topology::Topology;
use crate::operator::OperatorKind;
use crate::plot::{Chart, Scale, Series};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// One rate–distortion point.
#[derive(Clone, Debug, Serialize)]
pub struct RdPoint {
    /// Mesh (short name).
    pub mesh: String,
    /// Coder: an operator name, or `draco`.
    pub coder: String,
    /// Setting (keep ratio, or Draco's quantization bits).
    pub setting: String,
    /// Whole file, bits per vertex.
    pub bits_per_vertex: f64,
    /// Connectivity bits per vertex (Draco: upper bound, or NaN if unknown).
    pub connectivity_bpv: f64,
    /// Vertex RMS error / diagonal.
    pub vertex_rms: Option<f64>,
    /// Larger of the two one-sided Metro RMS distances / diagonal.
    pub metro_rms: f64,
    /// Hausdorff distance / diagonal.
    pub hausdorff: f64,
    /// Zhang §4.9 SDL measure.
    pub zhang_sdl: Option<f64>,
    /// Karni–Gotsman error.
    pub karni_gotsman: Option<f64>,
}

/// Options of [`run`] and [`rate_distortion`].
#[derive(Clone, Debug, PartialEq)]
pub struct CompressionOptions {
    /// Meshes of [`run`] (files or `builtin:` specs).
    pub meshes: Vec<String>,
    /// Operators compared.
    pub operators: Vec<OperatorKind>,
    /// Keep ratios swept.
    pub keep_ratios: Vec<f64>,
    /// Quantization bits (fixed).
    pub bits: f64,
    /// Patch size.
    pub patch_size: usize,
    /// Surface samples per mesh for the Metro distance.
    pub samples: usize,
    /// Draco's points: the JSON written by `bench/compression.py --json-out`.
    pub draco: Option<PathBuf>,
}

default_is_paper!(CompressionOptions);

impl CompressionOptions {
    /// Five operators, seven keep ratios at 12 bits, on a smooth sphere, a cube and a
    /// step (sharp), and the cow from `dir`.
    pub fn paper(dir: &Path) -> Self {
        CompressionOptions {
            meshes: vec![
                "builtin:icosphere:4".into(),
                "builtin:cube:8".into(),
                "builtin:step:20".into(),
                shared(dir, "cow.obj"),
            ],
            operators: vec![
                OperatorKind::Sstl,
                OperatorKind::Sql,
                OperatorKind::Tutte,
                OperatorKind::Kirchhoff,
                OperatorKind::Graph,
            ],
            keep_ratios: vec![0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0],
            bits: 12.0,
            patch_size: 300,
            samples: 50_000,
            draco: None,
        }
    }

    /// A smooth and a sharp generated mesh only.
    pub fn quick() -> Self {
        CompressionOptions {
            meshes: vec!["builtin:icosphere:3".into(), "builtin:step:12".into()],
            ..Self::default()
        }
    }
}

/// What [`run`] measured.
#[derive(Clone, Debug)]
pub struct CompressionResults {
    /// The points of every mesh, coder and setting (Draco's last).
    pub points: Vec<RdPoint>,
    /// [`table`] of the points.
    pub table: Table,
    /// [`operator_order`] of the points.
    pub order: Vec<(String, Vec<(String, f64)>)>,
}

/// The sweep with `opts` on every mesh, Draco's points of those meshes added: writes
/// `compression.md/.csv/.json` and the charts (see [`write()`]) to `out`.
pub fn run(
    opts: &CompressionOptions,
    out: &mut Outputs,
    progress: &mut ProgressFn,
) -> Result<CompressionResults, ExperimentError> {
    let inputs = open_all(&opts.meshes, progress)?;
    let mut points = rate_distortion(&inputs, opts, progress)?;
    if let Some(path) = &opts.draco {
        let text = std::fs::read_to_string(path).map_err(|source| crate::io::IoError::Open {
            path: path.clone(),
            source,
        })?;
        let names: Vec<String> = points.iter().map(|p| p.mesh.clone()).collect();
        let draco = draco_points(&text)?;
        points.extend(draco.into_iter().filter(|d| names.contains(&d.mesh)));
    }
    write(out, &points)?;
    Ok(CompressionResults {
        table: table(&points),
        order: operator_order(&points),
        points,
    })
}

/// Runs the sweep of `opts` (not its meshes) on every input: one [`Progress::Step`]
/// per mesh, operator and keep ratio.
pub fn rate_distortion(
    inputs: &[Input],
    opts: &CompressionOptions,
    progress: &mut ProgressFn,
) -> Result<Vec<RdPoint>, ExperimentError> {
    let total = inputs.len() * opts.operators.len() * opts.keep_ratios.len();
    progress(Progress::start("rate–distortion", total));
    let mut out = Vec::new();
    for input in inputs {
        let name = short_name(&input.source);
        let err = |e: crate::Error| ExperimentError::input(&input.source, e);
        let (mesh, _) =
            crate::mesh::clean::split_non_manifold(&input.mesh).map_err(|e| err(e.into()))?;
        let topo = Topology::new(&mesh).map_err(|e| err(e.into()))?;
        for &op in &opts.operators {
            for &r in &opts.keep_ratios {
                progress(Progress::step(format!("{name} {} keep {r}", op.name())));
                let c = compress(
                    &mesh,
                    &topo,
                    &CompressOptions {
                        spectral: SpectralParams {
                            operator: op,
                            patch_size: opts.patch_size,
                            keep: Keep::Ratio(r),
                            ..Default::default()
                        },
                        quantization: Quantization::Bits(opts.bits),
                        preserve_order: false,
                        // This experiment compares the operators' bases.
                        mode: crate::codec::GeometryMode::Spectral,
                        ..Default::default()
                    },
                )
                .map_err(|e| err(e.into()))?;
                let d = crate::metric::compare(
                    &mesh,
                    &c.decoded,
                    Some(&c.order),
                    &crate::metric::CompareOptions::without_msdm2(opts.samples),
                )
                .map_err(|e| err(e.into()))?;
                out.push(RdPoint {
                    mesh: name.clone(),
                    coder: op.name().to_string(),
                    setting: format!("keep {r}"),
                    bits_per_vertex: c.report.bits_per_vertex,
                    connectivity_bpv: c.report.connectivity_bpv,
                    vertex_rms: d.vertex_rms,
                    metro_rms: d.a_to_b_rms.max(d.b_to_a_rms),
                    hausdorff: d.hausdorff,
                    zhang_sdl: d.zhang_sdl,
                    karni_gotsman: d.karni_gotsman,
                });
            }
        }
    }
    Ok(out)
}

/// Reads Draco points written by `bench/compression.py --json-out`:
/// `{mesh: [{coder, param, bpv, connectivity_bpv_upper, distortion: {…}}]}`.
pub fn draco_points(json: &str) -> Result<Vec<RdPoint>, ExperimentError> {
    let v: serde_json::Value =
        serde_json::from_str(json).map_err(|source| ExperimentError::Draco {
            reason: "not JSON",
            source: Some(source),
        })?;
    let obj = v.as_object().ok_or(ExperimentError::Draco {
        reason: "expected an object of meshes",
        source: None,
    })?;
    let mut out = Vec::new();
    for (mesh, pts) in obj {
        for p in pts.as_array().into_iter().flatten() {
            if p["coder"].as_str() != Some("draco") {
                continue;
            }
            let d = &p["distortion"];
            let f = |x: &serde_json::Value| x.as_f64();
            out.push(RdPoint {
                mesh: short_name(mesh),
                coder: "draco".into(),
                setting: p["param"].as_str().unwrap_or("").to_string(),
                bits_per_vertex: f(&p["bpv"]).unwrap_or(f64::NAN),
                connectivity_bpv: f(&p["connectivity_bpv_upper"]).unwrap_or(f64::NAN),
                vertex_rms: f(&d["vertex_rms"]),
                metro_rms: f(&d["a_to_b_rms"])
                    .unwrap_or(f64::NAN)
                    .max(f(&d["b_to_a_rms"]).unwrap_or(f64::NAN)),
                hausdorff: f(&d["hausdorff"]).unwrap_or(f64::NAN),
                zhang_sdl: f(&d["zhang_sdl"]),
                karni_gotsman: f(&d["karni_gotsman"]),
            });
        }
    }
    Ok(out)
}

/// The result table.
pub fn table(points: &[RdPoint]) -> Table {
    let mut t = Table::from_columns(
        "Rate–distortion of spectral compression per operator (Zhang 2004 §4.9, Karni–Gotsman 2000) and Draco",
        points,
        &[
            ("mesh", &|p: &&RdPoint| p.mesh.clone()),
            ("coder", &|p| p.coder.clone()),
            ("setting", &|p| p.setting.clone()),
            ("bits/vertex", &|p| format!("{:.3}", p.bits_per_vertex)),
            ("connectivity bpv", &|p| format!("{:.3}", p.connectivity_bpv)),
            ("vertex RMS", &|p| sig(p.vertex_rms, 3)),
            ("Metro RMS", &|p| sig(Some(p.metro_rms), 3)),
            ("Hausdorff", &|p| sig(Some(p.hausdorff), 3)),
            ("Zhang SDL", &|p| sig(p.zhang_sdl, 3)),
            ("Karni–Gotsman", &|p| sig(p.karni_gotsman, 3)),
        ],
    );
    t.notes.push(
        "Distances are divided by the bounding-box diagonal. Ours: fixed quantisation, keep \
         ratio swept; Draco: compression level 10 at 8–14 bits, connectivity bpv an upper \
         bound (its size at 1 bit)."
            .into(),
    );
    t
}

/// The best operator at each rate, as the paper orders them: for each mesh the
/// operators sorted by mean log vertex RMS over the keep ratios < 1 (lower first).
pub fn operator_order(points: &[RdPoint]) -> Vec<(String, Vec<(String, f64)>)> {
    let mut meshes: Vec<String> = points.iter().map(|p| p.mesh.clone()).collect();
    meshes.dedup();
    let mut out = Vec::new();
    for m in meshes {
        let mut coders: Vec<String> = points
            .iter()
            .filter(|p| p.mesh == m && p.coder != "draco")
            .map(|p| p.coder.clone())
            .collect();
        coders.sort();
        coders.dedup();
        let mut scores: Vec<(String, f64)> = coders
            .into_iter()
            .map(|c| {
                let v: Vec<f64> = points
                    .iter()
                    .filter(|p| p.mesh == m && p.coder == c && p.setting != "keep 1")
                    .filter_map(|p| p.vertex_rms)
                    .map(f64::ln)
                    .collect();
                (c, v.iter().sum::<f64>() / v.len().max(1) as f64)
            })
            .collect();
        scores.sort_by(|a, b| a.1.total_cmp(&b.1));
        out.push((m, scores));
    }
    out
}

/// Writes `compression.md/.csv/.json` and a chart per mesh and metric.
pub fn write(out: &mut Outputs, points: &[RdPoint]) -> Result<(), ExperimentError> {
    let mut t = table(points);
    for (m, order) in operator_order(points) {
        let s: Vec<String> = order
            .iter()
            .map(|(c, v)| format!("{c} ({:.3e})", v.exp()))
            .collect();
        t.notes.push(format!(
            "{m}: operators by geometric-mean vertex RMS over keep ratios < 1: {}",
            s.join(" < ")
        ));
    }
    out.table("compression", &t)?;
    out.json("compression.json", &points)?;
    let mut meshes: Vec<String> = points.iter().map(|p| p.mesh.clone()).collect();
    meshes.sort();
    meshes.dedup();
    for m in &meshes {
        for (metric, label) in [
            ("vertex", "vertex RMS / diagonal"),
            ("metro", "Metro RMS / diagonal"),
        ] {
            let mut coders: Vec<String> = points
                .iter()
                .filter(|p| &p.mesh == m)
                .map(|p| p.coder.clone())
                .collect();
            coders.dedup();
            let mut series = Vec::new();
            for c in coders {
                if series.iter().any(|s: &Series| s.name == c) {
                    continue;
                }
                let mut pts: Vec<(f64, f64)> = points
                    .iter()
                    .filter(|p| &p.mesh == m && p.coder == c)
                    .filter_map(|p| {
                        let y = if metric == "vertex" {
                            p.vertex_rms?
                        } else {
                            p.metro_rms
                        };
                        (y > 0.0 && y.is_finite()).then_some((p.bits_per_vertex, y))
                    })
                    .collect();
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                if !pts.is_empty() {
                    series.push(Series::new(c, pts).with_markers());
                }
            }
            let chart = Chart::new(
                format!("{m}: rate–distortion"),
                "bits per vertex (whole file)",
                label,
            )
            .with_scales(Scale::Linear, Scale::Log)
            .with_series(series);
            let stem = m.replace(['.', ':'], "_");
            out.chart(&format!("compression_{stem}_{metric}.png"), &chart)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_is_monotone_and_reads_draco_json() {
        let input = crate::input::open("builtin:icosphere:3", &Default::default()).unwrap();
        let opts = CompressionOptions {
            operators: vec![OperatorKind::Sstl, OperatorKind::Kirchhoff],
            keep_ratios: vec![0.1, 0.5, 1.0],
            bits: 12.0,
            patch_size: 200,
            samples: 2000,
            ..CompressionOptions::quick()
        };
        let pts = rate_distortion(&[input], &opts, &mut |_| {}).unwrap();
        assert_eq!(pts.len(), 6);
        for w in pts.chunks(3) {
            // More coefficients: more bits, less error.
            assert!(w[0].bits_per_vertex < w[1].bits_per_vertex);
            assert!(w[1].bits_per_vertex < w[2].bits_per_vertex);
            assert!(w[0].vertex_rms.unwrap() > w[2].vertex_rms.unwrap());
        }
        let json = r#"{"bunny.obj": [{"coder": "draco", "param": "q8", "bpv": 5.5,
            "connectivity_bpv_upper": 2.1, "distortion": {"vertex_rms": 0.001,
            "a_to_b_rms": 0.0004, "b_to_a_rms": 0.0005, "hausdorff": 0.002,
            "zhang_sdl": null, "karni_gotsman": 0.01}},
            {"coder": "meshlap-sstl", "param": "4bpv", "bpv": 4.0, "distortion": {}}]}"#;
        let d = draco_points(json).unwrap();
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].metro_rms, 0.0005);
        assert_eq!(d[0].zhang_sdl, None);
        let t = table(&[pts.clone(), d].concat());
        assert_eq!(t.rows.len(), 7);
    }
}
