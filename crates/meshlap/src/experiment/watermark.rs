//! Spectral watermarking (Ohbuchi et al. 2001/2002; Zhang 2004 §4.9) under the attacks
//! of the 3D mesh watermarking benchmark (Wang, Lavoué, Denis, Baskurt, SMI 2010).
//!
//! For every mesh and operator (`F = D − W`, PSD): a 64-bit message is embedded
//! ([`crate::watermark::embed()`]), its distortion measured (MRMS, MSDM2), every attack
//! of [`crate::watermark::attack::benchmark_levels`] applied to the marked mesh and the
//! message detected ([`crate::watermark::Detector`], non-blind) with its bit error rate
//! and false-positive probability. False-positive checks: the unmarked mesh after
//! noise and smoothing (no mark at all) and the marked mesh tested with wrong keys.
//! Writes `watermark.md/.csv/.json` (BER per attack and level), `watermark_summary`
//! (distortion, timings, false-positive checks), one chart of BER against strength per
//! attack kind, and per mesh a picture: original, marked, heat map of the displacement.

use super::meshes::{open_all, shared, short_name};
use super::{sig, ExperimentError, Outputs, Progress, ProgressFn, Table};
use crate::mesh::TriMesh;
use crate::operator::OperatorKind;
use crate::plot::{Chart, Scale, Series};
use crate::watermark::attack::{attack, benchmark_levels, AttackKind, AttackOptions};
use crate::watermark::{embed, DetectParams, Detector, EmbedParams, LayoutParams, Message};
use serde::Serialize;
use std::path::Path;

/// Options of [`run`].
#[derive(Clone, Debug, PartialEq)]
pub struct WatermarkOptions {
    /// Meshes (files or `builtin:` specs).
    pub meshes: Vec<String>,
    /// Operators compared (each gets the whole attack table).
    pub operators: Vec<OperatorKind>,
    /// The key.
    pub key: u64,
    /// The message (hex).
    pub message: String,
    /// Embedding strength (MRMS).
    pub strength: f64,
    /// Patches, band and chip rate (the operator is taken from `operators`).
    pub layout: LayoutParams,
    /// The attacks and their strengths.
    pub attacks: Vec<AttackOptions>,
    /// Wrong keys tried on each marked mesh.
    pub wrong_keys: usize,
    /// Render the pictures.
    pub pictures: bool,
}

default_is_paper!(WatermarkOptions);

impl WatermarkOptions {
    /// stanford-bunny, horse and igea from `dir`, the Kirchhoff operator (the papers')
    /// and the SQL, SSTL and TL, every benchmark attack, 20 wrong keys.
    pub fn paper(dir: &Path) -> Self {
        WatermarkOptions {
            meshes: ["stanford-bunny.obj", "horse.ply", "igea.ply"]
                .iter()
                .map(|m| shared(dir, m))
                .collect(),
            operators: vec![
                OperatorKind::Kirchhoff,
                OperatorKind::Sql,
                OperatorKind::Sstl,
                OperatorKind::Tutte,
            ],
            key: 0x6d65_7368_6c61_7021,
            message: "c0ffee15deadbeef".into(),
            strength: crate::watermark::embed::DEFAULT_STRENGTH,
            layout: LayoutParams::default(),
            attacks: benchmark_levels(),
            wrong_keys: 20,
            pictures: true,
        }
    }

    /// A generated sphere (2,562 vertices), Kirchhoff only, patches of 400 and a band
    /// of 16, the attack levels the goals name, 3 wrong keys (for `experiment all` and
    /// the tests).
    pub fn quick() -> Self {
        // The levels the goals name (the strongest with zero errors required).
        let keep = |a: &AttackOptions| match a.kind {
            AttackKind::Noise => a.amount == 0.3,
            AttackKind::Smooth => a.amount == 30.0,
            AttackKind::Quantize => a.amount == 8.0,
            AttackKind::Simplify => a.amount == 50.0,
            AttackKind::Crop => a.amount == 10.0,
            AttackKind::Similarity | AttackKind::Subdivide => true,
        };
        WatermarkOptions {
            meshes: vec!["builtin:icosphere:4".into()],
            operators: vec![OperatorKind::Kirchhoff],
            layout: LayoutParams {
                patch_size: Some(400),
                band: 16,
                ..LayoutParams::default()
            },
            attacks: benchmark_levels().into_iter().filter(keep).collect(),
            wrong_keys: 3,
            ..Self::default()
        }
    }
}

/// BER of one attack on one marked mesh.
#[derive(Clone, Debug, Serialize)]
pub struct AttackResult {
    /// Mesh (short name).
    pub mesh: String,
    /// Operator.
    pub operator: OperatorKind,
    /// Attack kind name.
    pub attack: String,
    /// Its strength (`amount`), or the scheme of a subdivision.
    pub level: String,
    /// Numeric strength (for the charts).
    pub amount: f64,
    /// Bit error rate of the sign decisions.
    pub ber: f64,
    /// The mark was found (false-positive probability ≤ 10⁻⁶).
    pub found: bool,
    /// log₁₀ of the false-positive probability.
    pub false_positive_log10: f64,
    /// The suspect was resampled.
    pub resampled: bool,
    /// Detection seconds (taken under load).
    pub seconds: f64,
}

/// Distortion, timing and false-positive checks of one marked mesh.
#[derive(Clone, Debug, Serialize)]
pub struct MeshSummary {
    /// Mesh (short name).
    pub mesh: String,
    /// Vertices.
    pub vertices: usize,
    /// Operator.
    pub operator: OperatorKind,
    /// Patches.
    pub patches: usize,
    /// Chips per bit.
    pub coefficients_per_bit: usize,
    /// RMS displacement ÷ diagonal.
    pub mrms: f64,
    /// MSDM2 (original vs marked).
    pub msdm2: Option<f64>,
    /// Embedding seconds (under load).
    pub embed_seconds: f64,
    /// Detection seconds of the unattacked marked mesh (under load).
    pub detect_seconds: f64,
    /// Smallest log₁₀ false-positive probability over the unmarked checks (the most
    /// alarming one).
    pub unmarked_min_log10_p: f64,
    /// Smallest over the wrong keys.
    pub wrong_key_min_log10_p: f64,
    /// Unmarked meshes or wrong keys reported as marked (must be 0).
    pub false_detections: usize,
    /// Attacks with zero bit errors.
    pub attacks_without_errors: usize,
    /// Attacks run.
    pub attacks: usize,
}

/// What [`run`] measured.
#[derive(Clone, Debug)]
pub struct WatermarkResults {
    /// Every attack on every marked mesh.
    pub attacks: Vec<AttackResult>,
    /// One row per mesh and operator.
    pub summaries: Vec<MeshSummary>,
}

fn label(a: &AttackOptions) -> (String, f64) {
    if a.kind == AttackKind::Subdivide {
        (a.scheme.name().to_string(), 0.0)
    } else {
        (sig(Some(a.amount), 3), a.amount)
    }
}

/// Runs the experiment of `opts` and writes its tables, charts and pictures to `out`.
pub fn run(
    opts: &WatermarkOptions,
    out: &mut Outputs,
    progress: &mut ProgressFn,
) -> Result<WatermarkResults, ExperimentError> {
    let message = Message::from_hex(&opts.message).map_err(ExperimentError::Message)?;
    if opts.operators.is_empty() {
        return Err(ExperimentError::invalid(
            "operators",
            "must not be empty".into(),
        ));
    }
    progress(Progress::Experiment {
        title: "Spectral watermarking under the benchmark attacks".into(),
    });
    let inputs = open_all(&opts.meshes, progress)?;
    let per = opts.attacks.len() + 3 + opts.wrong_keys;
    progress(Progress::start(
        "watermark",
        inputs.len() * opts.operators.len() * per,
    ));
    let mut attacks = Vec::new();
    let mut summaries = Vec::new();
    for input in &inputs {
        let name = short_name(&input.source);
        let err = |e: crate::Error| ExperimentError::input(&input.source, e);
        let mesh = &input.mesh;
        for (oi, &op) in opts.operators.iter().enumerate() {
            let layout = LayoutParams {
                operator: op,
                ..opts.layout
            };
            progress(Progress::step(format!("{name} {op}: embed")));
            let ep = EmbedParams {
                key: opts.key,
                message: message.clone(),
                strength: opts.strength,
                layout,
                measure_msdm2: true,
            };
            let (marked, rep) = embed(mesh, &ep).map_err(|e| err(e.into()))?;
            let dp = DetectParams {
                layout,
                expect: Some(message.clone()),
                ..DetectParams::new(opts.key, message.len())
            };
            let det = Detector::new(mesh, &dp).map_err(|e| err(e.into()))?;
            progress(Progress::step(format!("{name} {op}: detect")));
            let clean = det.detect(&marked).map_err(|e| err(e.into()))?;
            let mut false_detections = 0;
            let mut unmarked_min = 0.0f64;
            for a in [
                AttackOptions::new(AttackKind::Noise, 0.3),
                AttackOptions::new(AttackKind::Smooth, 10.0),
            ] {
                progress(Progress::step(format!(
                    "{name} {op}: unmarked {}",
                    a.label()
                )));
                let s = attack(mesh, &a).map_err(|e| err(e.into()))?;
                let r = det.detect(&s).map_err(|e| err(e.into()))?;
                false_detections += usize::from(r.found);
                unmarked_min = unmarked_min.min(r.false_positive_log10);
            }
            let mut wrong_min = 0.0f64;
            for k in 0..opts.wrong_keys {
                progress(Progress::step(format!("{name} {op}: wrong key {k}")));
                let wrong = det.with_key(
                    opts.key
                        .wrapping_add(1 + k as u64)
                        .wrapping_mul(0x9E37_79B9),
                );
                let r = wrong.detect(&marked).map_err(|e| err(e.into()))?;
                false_detections += usize::from(r.found);
                wrong_min = wrong_min.min(r.false_positive_log10);
            }
            let mut clean_errors = 0;
            for a in &opts.attacks {
                progress(Progress::step(format!("{name} {op}: {}", a.label())));
                let s = attack(&marked, a).map_err(|e| err(e.into()))?;
                let r = det.detect(&s).map_err(|e| err(e.into()))?;
                let (level, amount) = label(a);
                let ber = r.ber.unwrap_or(1.0);
                clean_errors += usize::from(ber == 0.0);
                attacks.push(AttackResult {
                    mesh: name.clone(),
                    operator: op,
                    attack: a.kind.name().to_string(),
                    level,
                    amount,
                    ber,
                    found: r.found,
                    false_positive_log10: r.false_positive_log10,
                    resampled: r.resampled,
                    seconds: r.seconds,
                });
            }
            summaries.push(MeshSummary {
                mesh: name.clone(),
                vertices: mesh.n_vertices(),
                operator: op,
                patches: rep.patches,
                coefficients_per_bit: rep.coefficients_per_bit,
                mrms: rep.mrms,
                msdm2: rep.msdm2,
                embed_seconds: rep.seconds,
                detect_seconds: clean.seconds,
                unmarked_min_log10_p: unmarked_min,
                wrong_key_min_log10_p: wrong_min,
                false_detections,
                attacks_without_errors: clean_errors,
                attacks: opts.attacks.len(),
            });
            if opts.pictures && oi == 0 {
                picture(out, &name, mesh, &marked)?;
            }
        }
    }
    write(out, &attacks, &summaries)?;
    Ok(WatermarkResults { attacks, summaries })
}

/// Original, marked, and the marked mesh colored by displacement length.
fn picture(
    out: &mut Outputs,
    name: &str,
    mesh: &TriMesh,
    marked: &TriMesh,
) -> Result<(), ExperimentError> {
    use crate::render::{
        render, Coloring, Colormap, Framing, Panel, RenderOptions, Scalars, Window,
    };
    let base = RenderOptions {
        width: 480,
        height: 480,
        smooth: true,
        framing: Window::fit(mesh, 0.0, 0.0).map_or(Framing::Fit, Framing::Window),
        ..Default::default()
    };
    let d: Vec<f64> = mesh
        .positions
        .iter()
        .zip(&marked.positions)
        .map(|(a, b)| {
            (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt() / mesh.bbox_diagonal()
        })
        .collect();
    let mut s = Scalars::new(d, Colormap::Viridis);
    s.label = "displacement / diagonal".into();
    let heat = RenderOptions {
        coloring: Coloring::Scalar(s),
        ..base.clone()
    };
    let panel = Panel {
        cells: vec![
            (render(mesh, &base)?, "original".into()),
            (render(marked, &base)?, "marked".into()),
            (render(marked, &heat)?, "displacement".into()),
        ],
        title: Some(format!("{name}: spectral watermark")),
    };
    let stem = name.replace(['.', ':'], "_");
    out.image(&format!("watermark_{stem}.png"), &panel.compose()?)?;
    Ok(())
}

/// The BER table of the attacks.
pub fn table(attacks: &[AttackResult]) -> Table {
    let mut t = Table::new(
        "Bit error rate per attack (64 bits; found: false-positive probability ≤ 1e-6)",
        &[
            "mesh", "operator", "attack", "level", "BER", "found", "log10 p",
        ],
    );
    for a in attacks {
        t.push(vec![
            a.mesh.clone(),
            a.operator.name().into(),
            a.attack.clone(),
            a.level.clone(),
            sig(Some(a.ber), 3),
            if a.found { "yes" } else { "no" }.into(),
            format!("{:.1}", a.false_positive_log10),
        ]);
    }
    t
}

/// The distortion and false-positive table.
pub fn summary_table(s: &[MeshSummary]) -> Table {
    Table::from_columns(
        "Distortion and false-positive checks (timings taken under load)",
        s,
        &[
            ("mesh", &|r: &&MeshSummary| r.mesh.clone()),
            ("n", &|r| r.vertices.to_string()),
            ("operator", &|r| r.operator.name().into()),
            ("patches", &|r| r.patches.to_string()),
            ("chips/bit", &|r| r.coefficients_per_bit.to_string()),
            ("MRMS", &|r| sig(Some(r.mrms), 3)),
            ("MSDM2", &|r| sig(r.msdm2, 3)),
            ("embed s", &|r| format!("{:.2}", r.embed_seconds)),
            ("detect s", &|r| format!("{:.2}", r.detect_seconds)),
            ("unmarked min log10 p", &|r| {
                format!("{:.1}", r.unmarked_min_log10_p)
            }),
            ("wrong key min log10 p", &|r| {
                format!("{:.1}", r.wrong_key_min_log10_p)
            }),
            ("false detections", &|r| r.false_detections.to_string()),
            ("attacks without errors", &|r| {
                format!("{}/{}", r.attacks_without_errors, r.attacks)
            }),
        ],
    )
}

fn write(
    out: &mut Outputs,
    attacks: &[AttackResult],
    s: &[MeshSummary],
) -> Result<(), ExperimentError> {
    out.table("watermark", &table(attacks))?;
    out.json("watermark.json", &attacks)?;
    out.table("watermark_summary", &summary_table(s))?;
    out.json("watermark_summary.json", &s)?;
    for kind in ["noise", "smooth", "quantize", "simplify", "crop"] {
        let mut series: Vec<Series> = Vec::new();
        for r in s {
            let pts: Vec<(f64, f64)> = attacks
                .iter()
                .filter(|a| a.attack == kind && a.mesh == r.mesh && a.operator == r.operator)
                .map(|a| (a.amount, a.ber))
                .collect();
            if !pts.is_empty() {
                series.push(
                    Series::new(format!("{} {}", r.mesh, r.operator.name()), pts).with_markers(),
                );
            }
        }
        if series.is_empty() {
            continue;
        }
        let chart = Chart::new(format!("BER under {kind}"), kind, "bit error rate")
            .with_scales(Scale::Linear, Scale::Linear)
            .with_series(series);
        out.chart(&format!("watermark_ber_{kind}.png"), &chart)?;
    }
    Ok(())
}
