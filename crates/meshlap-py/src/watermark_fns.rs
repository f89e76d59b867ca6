//! Spectral watermarking (Ohbuchi et al. 2001/2002; `meshlap::watermark`): embed and
//! detect. Operators are PSD, `F = D − W` (libigl and pmp use the negative).

use crate::{compute, json, mesh_arrays, mesh_named, mesh_of, FaceArray, OrRaise};
use meshlap::operator::OperatorKind;
use meshlap::watermark::layout::LayoutParams;
use meshlap::watermark::message::Message;
use meshlap::watermark::{detect, embed, DetectParams, EmbedParams, WatermarkError, Weighting};
use numpy::{PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;

/// The patch layout from the keyword options (library defaults where `None`).
fn layout(
    py: Python<'_>,
    operator: Option<&str>,
    patch_size: Option<usize>,
    band: Option<usize>,
    chip_rate: Option<usize>,
) -> PyResult<LayoutParams> {
    let d = LayoutParams::default();
    Ok(LayoutParams {
        operator: match operator {
            Some(k) => k.parse::<OperatorKind>().or_raise(py)?,
            None => d.operator,
        },
        patch_size: patch_size.or(d.patch_size),
        band: band.unwrap_or(d.band),
        chip_rate: chip_rate.or(d.chip_rate),
    })
}

/// `watermark_embed(V, F, key, message, operator, strength, chip_rate, patch_size,
/// band, msdm2)` → `(V′ (n, 3) float64, report JSON)`; connectivity and vertex order
/// are the input's; `msdm2 = false` skips the metric.
#[pyfunction]
#[pyo3(signature = (v, f, key, message, operator=None, strength=None, chip_rate=None,
    patch_size=None, band=None, msdm2=true))]
#[allow(clippy::too_many_arguments)]
fn watermark_embed<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    key: u64,
    message: &str,
    operator: Option<&str>,
    strength: Option<f64>,
    chip_rate: Option<usize>,
    patch_size: Option<usize>,
    band: Option<usize>,
    msdm2: bool,
) -> PyResult<(Bound<'py, PyArray2<f64>>, String)> {
    let message = Message::from_hex(message)
        .map_err(WatermarkError::from)
        .or_raise(py)?;
    let input = mesh_of(py, &v, &f)?;
    let layout = layout(py, operator, patch_size, band, chip_rate)?;
    let (marked, report) = compute(py, || {
        let mut params = EmbedParams::new(key, message);
        params.layout = layout;
        params.measure_msdm2 = msdm2;
        if let Some(s) = strength {
            params.strength = s;
        }
        embed(&input.mesh, &params)
    })
    .or_raise(py)?;
    let (positions, _) = mesh_arrays(py, marked)?;
    Ok((positions, json(py, &report)?))
}

/// `watermark_detect(Vs, Fs, Vo, Fo, key, bits, expect, operator, patch_size, band,
/// chip_rate, weighting)` → report JSON (the keys of `meshlap watermark detect --json`).
#[pyfunction]
#[pyo3(signature = (vs, fs, vo, fo, key, bits=64, expect=None, operator=None,
    patch_size=None, band=None, chip_rate=None, weighting=None))]
#[allow(clippy::too_many_arguments)]
fn watermark_detect(
    py: Python<'_>,
    vs: PyReadonlyArray2<'_, f64>,
    fs: FaceArray<'_>,
    vo: PyReadonlyArray2<'_, f64>,
    fo: FaceArray<'_>,
    key: u64,
    bits: usize,
    expect: Option<&str>,
    operator: Option<&str>,
    patch_size: Option<usize>,
    band: Option<usize>,
    chip_rate: Option<usize>,
    weighting: Option<&str>,
) -> PyResult<String> {
    let weighting = match weighting {
        Some(w) => w.parse::<Weighting>().or_raise(py)?,
        None => Weighting::default(),
    };
    let expect = expect
        .map(Message::from_hex)
        .transpose()
        .map_err(WatermarkError::from)
        .or_raise(py)?;
    let suspect = mesh_named(py, &vs, &fs, ("Vs", "Fs"))?;
    let original = mesh_named(py, &vo, &fo, ("Vo", "Fo"))?;
    let layout = layout(py, operator, patch_size, band, chip_rate)?;
    let report = compute(py, || {
        let params = DetectParams {
            layout,
            expect,
            weighting,
            ..DetectParams::new(key, bits)
        };
        detect(&suspect.mesh, &original.mesh, &params)
    })
    .or_raise(py)?;
    json(py, &report)
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::add_functions!(m; watermark_embed, watermark_detect)
}
