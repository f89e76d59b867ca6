//! Mesh-level functions: reading, writing, info, cleaning, SQL repair, partitioning,
//! compression, comparison and rendering. Each mirrors one CLI command and calls the
//! same library function with the same defaults.

use crate::{
    checked_named, compute, json, mesh_arrays, mesh_named, mesh_of, raise_as, raw_mesh, slice2,
    FaceArray, OrRaise, VF,
};
use meshlap::codec::{CompressOptions, GeometryMode, Keep, Quantization};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use crate::MeshOut as Mesh;

/// A mesh and a JSON report.
type MeshReport<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>, String);

/// Parses a library option name, raising the library's error as `class`.
fn parse<T: std::str::FromStr>(py: Python<'_>, s: &str, what: &str, class: &str) -> PyResult<T>
where
    T::Err: std::fmt::Display,
{
    s.parse::<T>()
        .map_err(|e| raise_as(py, class, format!("{what}: {e}")))
}

/// A contiguous view of an optional 1-D array, the argument named in the error.
fn slice1<'a, T: numpy::Element>(
    py: Python<'_>,
    a: Option<&'a PyReadonlyArray1<'_, T>>,
    name: &str,
) -> PyResult<Option<&'a [T]>> {
    a.map(|a| {
        a.as_slice()
            .map_err(|_| raise_as(py, "Error", format!("{name} must be contiguous")))
    })
    .transpose()
}

/// `read_mesh(path, format=None)` → `(V, F)`: read (or generate `builtin:…`) and clean
/// exactly as the CLI does (`meshlap::input::open`).
#[pyfunction]
#[pyo3(signature = (path, format=None))]
fn read_mesh<'py>(py: Python<'py>, path: &str, format: Option<&str>) -> PyResult<Mesh<'py>> {
    let format = format
        .map(|f| parse::<meshlap::io::Format>(py, f, "format", "MeshIOError"))
        .transpose()?;
    let opts = meshlap::input::OpenOptions {
        format,
        ..Default::default()
    };
    let (mesh, _) = compute(py, || meshlap::input::open_mesh(path, &opts)).or_raise(py)?;
    mesh_arrays(py, mesh)
}

/// `write_mesh(path, V, F, scalars, scalar_name, colors, format, ascii)`: atomic.
#[pyfunction]
#[pyo3(signature = (path, v, f, scalars=None, scalar_name="scalar", colors=None, format=None, ascii=false))]
#[allow(clippy::too_many_arguments)]
fn write_mesh(
    py: Python<'_>,
    path: &str,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    scalars: Option<PyReadonlyArray1<'_, f64>>,
    scalar_name: &str,
    colors: Option<PyReadonlyArray2<'_, u8>>,
    format: Option<&str>,
    ascii: bool,
) -> PyResult<()> {
    let mesh = checked_named(py, &v, &f, VF)?;
    let format = format
        .map(|s| parse::<meshlap::io::Format>(py, s, "format", "MeshIOError"))
        .transpose()?;
    let scalars = slice1(py, scalars.as_ref(), "scalars")?;
    let colors: Option<Vec<[u8; 3]>> = match &colors {
        Some(c) => {
            let (s, _, _) = slice2(py, c, "colors", Some(3))?;
            Some(s.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        }
        None => None,
    };
    let opts = meshlap::io::WriteOptions {
        format,
        vertex_scalar: scalars.map(|s| (scalar_name, s)),
        vertex_colors: colors.as_deref(),
        ply_ascii: ascii,
    };
    let p = std::path::Path::new(path);
    compute(py, || meshlap::io::write_mesh(p, &mesh, &opts)).or_raise(py)
}

/// `info(V, F)` → JSON of `meshlap info --json` (`Input::info`; the mesh is cleaned
/// first, as the CLI does, and the dropped counts reported; source `array`).
#[pyfunction]
fn info(py: Python<'_>, v: PyReadonlyArray2<'_, f64>, f: FaceArray<'_>) -> PyResult<String> {
    let raw = raw_mesh(py, &v, &f)?;
    let input = compute(py, || {
        meshlap::input::from_mesh("array", raw, None, &Default::default())
    })
    .or_raise(py)?;
    json(py, &input.info())
}

/// `clean(V, F, split_nonmanifold=False)` → `(V, F, report JSON)`: the JSON of
/// `meshlap clean --json` (`Input::cleaned`).
#[pyfunction]
#[pyo3(signature = (v, f, split_nonmanifold=false))]
fn clean<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    split_nonmanifold: bool,
) -> PyResult<MeshReport<'py>> {
    let raw = raw_mesh(py, &v, &f)?;
    let (mesh, out) = compute(py, || -> meshlap::Result<_> {
        let input = meshlap::input::from_mesh("array", raw, None, &Default::default())?;
        Ok(input.cleaned(split_nonmanifold)?)
    })
    .or_raise(py)?;
    let (va, fa) = mesh_arrays(py, mesh)?;
    Ok((va, fa, json(py, &out)?))
}

/// `repair_sql(V, F, method, max_dihedral)` → `(V, F, report JSON)`.
#[pyfunction]
#[pyo3(signature = (v, f, method="swap", max_dihedral=None))]
fn repair_sql<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    method: &str,
    max_dihedral: Option<f64>,
) -> PyResult<MeshReport<'py>> {
    use meshlap::analysis::repair::{repair_sql, RepairMethod, RepairOptions};
    let input = mesh_of(py, &v, &f)?;
    let opts = RepairOptions {
        method: parse::<RepairMethod>(py, method, "method", "RepairError")?,
        max_dihedral_degrees: max_dihedral,
        ..Default::default()
    };
    let (mesh, report) = compute(py, || repair_sql(&input.mesh, &opts)).or_raise(py)?;
    let (va, fa) = mesh_arrays(py, mesh)?;
    Ok((va, fa, json(py, &report)?))
}

/// `partition(V, F, patch_size, seed=0, method="metis", lloyd_iterations=None)` →
/// `(labels int32 (n,), stats JSON)`; `None`: the library's default Lloyd steps.
#[pyfunction]
#[pyo3(signature = (v, f, patch_size, seed=0, method="metis", lloyd_iterations=None))]
fn partition<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    patch_size: usize,
    seed: i32,
    method: &str,
    lloyd_iterations: Option<usize>,
) -> PyResult<(Bound<'py, PyArray1<i32>>, String)> {
    use meshlap::partition::{partition_mesh, PartitionMethod, PartitionOptions};
    let method: PartitionMethod = method.parse().or_raise(py)?;
    let input = mesh_of(py, &v, &f)?;
    let defaults = PartitionOptions::new(patch_size);
    let opts = PartitionOptions {
        method,
        seed,
        lloyd_iterations: lloyd_iterations.unwrap_or(defaults.lloyd_iterations),
        ..defaults
    };
    let part = compute(py, || partition_mesh(&input.mesh, &input.topology, &opts)).or_raise(py)?;
    let labels: Vec<i32> = part.patch_of().iter().map(|&p| p as i32).collect();
    Ok((PyArray1::from_vec(py, labels), json(py, part.stats())?))
}

/// `compress(V, F, …)` → `(bytes, report JSON)`; every option `None` takes the
/// codec's default (`CompressOptions::default()`).
#[pyfunction]
#[pyo3(signature = (v, f, bits=None, target_bpv=None, mode=None, operator=None, patch_size=None,
    keep_ratio=None, coefficients=None, band_slope=None, dead_zone=None, prediction=true,
    border_residuals=false, rdo_lambda=None, select=true, preserve_order=false))]
#[allow(clippy::too_many_arguments)]
fn compress<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    bits: Option<f64>,
    target_bpv: Option<f64>,
    mode: Option<&str>,
    operator: Option<&str>,
    patch_size: Option<usize>,
    keep_ratio: Option<f64>,
    coefficients: Option<u32>,
    band_slope: Option<f64>,
    dead_zone: Option<f64>,
    prediction: bool,
    border_residuals: bool,
    rdo_lambda: Option<f64>,
    select: bool,
    preserve_order: bool,
) -> PyResult<(Bound<'py, PyBytes>, String)> {
    let input = mesh_of(py, &v, &f)?;
    let d = CompressOptions::default();
    let mut opts = d;
    if let Some(m) = mode {
        opts.mode = parse::<GeometryMode>(py, m, "mode", "CodecError")?;
    }
    if let Some(o) = operator {
        opts.spectral.operator = parse(py, o, "operator", "OperatorError")?;
    }
    opts.spectral.patch_size = patch_size.unwrap_or(d.spectral.patch_size);
    if keep_ratio.is_some() || coefficients.is_some() {
        opts.spectral.keep = Keep::from_options(keep_ratio, coefficients);
    }
    opts.spectral.band_slope = band_slope.unwrap_or(d.spectral.band_slope);
    opts.spectral.dead_zone = dead_zone.unwrap_or(d.spectral.dead_zone);
    opts.spectral.predicted = prediction;
    opts.spectral.border_residuals = border_residuals;
    opts.spatial.lambda = rdo_lambda.unwrap_or(d.spatial.lambda);
    opts.spatial.select = select;
    if bits.is_some() || target_bpv.is_some() {
        opts.quantization = Quantization::from_options(bits, target_bpv);
    }
    opts.preserve_order = preserve_order;
    let c = compute(py, || {
        meshlap::codec::compress_owned(&input.mesh, input.topology, &opts)
    })
    .or_raise(py)?;
    Ok((PyBytes::new(py, &c.bytes), json(py, &c.report)?))
}

/// `decompress(data)` → `(V, F)`.
#[pyfunction]
fn decompress<'py>(py: Python<'py>, data: &[u8]) -> PyResult<Mesh<'py>> {
    let mesh = compute(py, || meshlap::codec::decompress(data)).or_raise(py)?;
    mesh_arrays(py, mesh)
}

/// `compare(Va, Fa, Vb, Fb, map=None, samples=200000)` → JSON of `meshlap compare`.
#[pyfunction]
#[pyo3(signature = (va, fa, vb, fb, map=None, samples=200_000))]
fn compare(
    py: Python<'_>,
    va: PyReadonlyArray2<'_, f64>,
    fa: FaceArray<'_>,
    vb: PyReadonlyArray2<'_, f64>,
    fb: FaceArray<'_>,
    map: Option<PyReadonlyArray1<'_, u32>>,
    samples: usize,
) -> PyResult<String> {
    let a = mesh_named(py, &va, &fa, ("Va", "Fa"))?;
    let b = mesh_named(py, &vb, &fb, ("Vb", "Fb"))?;
    let map = slice1(py, map.as_ref(), "map")?;
    let c = compute(py, || {
        let opts = meshlap::metric::CompareOptions {
            samples,
            ..Default::default()
        };
        meshlap::metric::compare(&a.mesh, &b.mesh, map, &opts)
    })
    .or_raise(py)?;
    json(py, &c)
}

/// `render(V, F, scalars, colormap, azimuth, elevation, width, height, smooth,
/// wireframe, legend)` → `(H, W, 3)` uint8.
#[pyfunction]
#[pyo3(signature = (v, f, scalars=None, colormap=None, azimuth=0.0, elevation=0.0,
    width=None, height=None, smooth=false, wireframe=false, legend=true))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    scalars: Option<PyReadonlyArray1<'_, f64>>,
    colormap: Option<&str>,
    azimuth: f64,
    elevation: f64,
    width: Option<u32>,
    height: Option<u32>,
    smooth: bool,
    wireframe: bool,
    legend: bool,
) -> PyResult<Bound<'py, numpy::PyArray3<u8>>> {
    use meshlap::render::{render, Coloring, Colormap, RenderOptions, Scalars};
    let input = mesh_of(py, &v, &f)?;
    let cmap = colormap
        .map(|c| parse::<Colormap>(py, c, "colormap", "RenderError"))
        .transpose()?;
    let coloring = match slice1(py, scalars.as_ref(), "scalars")? {
        Some(values) => {
            if values.len() != input.mesh.n_vertices() {
                return Err(raise_as(
                    py,
                    "RenderError",
                    format!(
                        "scalars must have shape (n,) = ({},), got ({},)",
                        input.mesh.n_vertices(),
                        values.len()
                    ),
                ));
            }
            Coloring::Scalar(Scalars::new(
                values.to_vec(),
                cmap.unwrap_or(Colormap::Viridis),
            ))
        }
        None => Coloring::Clay,
    };
    let opts = RenderOptions {
        width: width.unwrap_or(RenderOptions::DEFAULT_SIZE),
        height: height.unwrap_or(RenderOptions::DEFAULT_SIZE),
        azimuth,
        elevation,
        smooth,
        wireframe,
        coloring,
        legend,
        ..Default::default()
    };
    let img = compute(py, || render(&input.mesh, &opts)).or_raise(py)?;
    let (w, h) = (img.width as usize, img.height as usize);
    PyArray1::from_vec(py, img.rgb).reshape([h, w, 3])
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::add_functions!(m; read_mesh, write_mesh, info, clean, repair_sql, partition, compress, decompress, compare, render)
}
