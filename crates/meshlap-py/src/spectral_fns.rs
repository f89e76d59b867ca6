//! Operators and everything spectral: assembly, mass matrices, property reports,
//! partial eigensolves (of a mesh operator or of any symmetric sparse matrix),
//! spectral projection and compaction, filtering, and HKS/WKS. Operators are
//! positive semi-definite, `F = D − W` (Zhang 2004).

use crate::{
    checked_named, compute, csr_out, json, mat_out, mesh_of, raise_as, CsrParts, FaceArray,
    OrRaise, VF,
};
use faer::MatRef;
use meshlap::operator::cotan::{self, MassKind};
use meshlap::operator::{Operator, OperatorKind, OperatorOptions};
use meshlap::spectral::descriptors;
use meshlap::spectral::partial::{
    operator_partial_spectrum, partial_spectrum_with_mass, Mass, PartialParams,
};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

type Eigen<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<f64>>,
);

/// Eigenvalues (k,), eigenvectors (n, k) and the JSON of how they were computed.
type Basis<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray2<f64>>, String);

/// A descriptor (n, T) and its samples (T,).
type Samples<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<f64>>);

/// The WKS (n, E), its energies (E,) and σ.
type WksOut<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<f64>>, f64);

fn kind_of(py: Python<'_>, kind: &str) -> PyResult<OperatorKind> {
    kind.parse::<OperatorKind>().or_raise(py)
}

fn options_of(py: Python<'_>, sql_diagonal: &str, mass: &str) -> PyResult<OperatorOptions> {
    Ok(OperatorOptions {
        sql_boundary: sql_diagonal.parse().or_raise(py)?,
        mass: mass.parse().or_raise(py)?,
    })
}

fn assemble(
    py: Python<'_>,
    input: &meshlap::input::Input,
    kind: &str,
    sql_diagonal: &str,
    mass: &str,
) -> PyResult<Operator> {
    let kind = kind_of(py, kind)?;
    let opts = options_of(py, sql_diagonal, mass)?;
    compute(py, || {
        Operator::assemble(kind, &input.mesh, &input.topology, &opts)
    })
    .or_raise(py)
}

/// `operator(V, F, kind, sql_diagonal, mass)` → the n×n operator as CSC parts.
#[pyfunction]
#[pyo3(signature = (v, f, kind="sql", sql_diagonal="zero-row-sum", mass="voronoi"))]
fn operator<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    kind: &str,
    sql_diagonal: &str,
    mass: &str,
) -> PyResult<CsrParts<'py>> {
    let input = mesh_of(py, &v, &f)?;
    let op = assemble(py, &input, kind, sql_diagonal, mass)?;
    Ok(csr_out(py, op))
}

/// `mass_matrix(V, F, kind)` → the lumped mass diagonal (n,) of the cotangent
/// operator (`voronoi`: mixed Voronoi areas, Meyer et al. 2003; `barycentric`), by
/// [`meshlap::operator::cotan::mass`]: neither the stiffness matrix nor the
/// connectivity is built.
#[pyfunction]
#[pyo3(signature = (v, f, kind="voronoi"))]
fn mass_matrix<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    kind: &str,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let kind: MassKind = kind.parse().or_raise(py)?;
    let mesh = checked_named(py, &v, &f, VF)?;
    let m = compute(py, || cotan::mass(&mesh, kind)).or_raise(py)?;
    Ok(PyArray1::from_vec(py, m))
}

/// `properties(V, F, kind, dense_limit, sql_diagonal, mass)` → JSON of the property
/// report (`meshlap operator --json`).
#[pyfunction]
#[pyo3(signature = (v, f, kind, dense_limit=None, sql_diagonal="zero-row-sum", mass="voronoi"))]
fn properties(
    py: Python<'_>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    kind: &str,
    dense_limit: Option<usize>,
    sql_diagonal: &str,
    mass: &str,
) -> PyResult<String> {
    use meshlap::analysis::properties::{analyze, PropertyOptions};
    let input = mesh_of(py, &v, &f)?;
    let op = assemble(py, &input, kind, sql_diagonal, mass)?;
    let d = PropertyOptions::default();
    let opts = PropertyOptions {
        dense_limit: dense_limit.unwrap_or(d.dense_limit),
        ..d
    };
    let report = compute(py, || analyze(&op.matrix, &opts));
    json(py, &report)
}

fn partial_out<'py>(
    py: Python<'py>,
    ps: meshlap::spectral::partial::PartialSpectrum,
) -> PyResult<Eigen<'py>> {
    Ok((
        PyArray1::from_vec(py, ps.eigenvalues),
        mat_out(py, ps.eigenvectors.as_ref())?,
        PyArray1::from_vec(py, ps.residuals),
    ))
}

/// `eigs(V, F, k, kind, tol, sql_diagonal, mass, refine, band_size, block_size)` → the
/// k smallest eigenpairs
/// `(evals, evecs, residuals)` of a mesh operator (the cotangent one with its lumped
/// mass, the TL through its diagonal symmetrizer).
#[pyfunction]
#[pyo3(signature = (v, f, k, kind="sql", tol=None, sql_diagonal="zero-row-sum", mass="voronoi", refine=true, band_size=None, block_size=None))]
#[allow(clippy::too_many_arguments)]
fn eigs<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    k: usize,
    kind: &str,
    tol: Option<f64>,
    sql_diagonal: &str,
    mass: &str,
    refine: bool,
    band_size: Option<usize>,
    block_size: Option<usize>,
) -> PyResult<Eigen<'py>> {
    let input = mesh_of(py, &v, &f)?;
    let op = assemble(py, &input, kind, sql_diagonal, mass)?;
    let opts = partial_params(k, tol, refine, band_size, block_size);
    let ps = compute(py, || {
        operator_partial_spectrum(&op, true, &opts, &mut |_, _| {})
    })
    .or_raise(py)?;
    partial_out(py, ps)
}

/// `spectrum(V, F, kind, count, path, normalization, dense_solver, sql_diagonal, mass,
/// tol, refine, band_size, block_size)` → `(evals, evecs, info JSON)`: the eigenbasis
/// of `meshlap spectrum` — all n eigenpairs by a dense eigendecomposition (n ≤
/// `DENSE_LIMIT`), or the `count` smallest (shift-invert above the limit), canonical
/// signs, through [`meshlap::spectral::smallest`].
#[pyfunction]
#[pyo3(signature = (v, f, kind="sql", count=None, path="auto", normalization="unit", dense_solver="blocked", sql_diagonal="zero-row-sum", mass="voronoi", tol=None, refine=true, band_size=None, block_size=None))]
#[allow(clippy::too_many_arguments)]
fn spectrum<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    kind: &str,
    count: Option<usize>,
    path: &str,
    normalization: &str,
    dense_solver: &str,
    sql_diagonal: &str,
    mass: &str,
    tol: Option<f64>,
    refine: bool,
    band_size: Option<usize>,
    block_size: Option<usize>,
) -> PyResult<Basis<'py>> {
    use meshlap::spectral::{smallest, BasisOptions, SmallestParams};
    let basis = BasisOptions {
        path: path.parse().or_raise(py)?,
        normalization: normalization.parse().or_raise(py)?,
        dense_solver: dense_solver.parse().or_raise(py)?,
        ..Default::default()
    };
    let input = mesh_of(py, &v, &f)?;
    let op = assemble(py, &input, kind, sql_diagonal, mass)?;
    let params = SmallestParams {
        basis,
        partial: partial_params(0, tol, refine, band_size, block_size),
        ..Default::default()
    };
    let sp = compute(py, || smallest(&op, count, &params, &mut |_, _| {})).or_raise(py)?;
    // The CLI's JSON keys and path names (`meshlap spectrum --json`).
    let i = &sp.info;
    let info = json(
        py,
        &serde_json::json!({
            "path": i.path.to_string(),
            "multiplicities": i.multiplicities,
            "max_residual": i.max_residual,
            "orthonormality_error": i.orthonormality_error,
            "bands": i.bands.len(),
        }),
    )?;
    Ok((
        PyArray1::from_vec(py, sp.eigenvalues),
        mat_out(py, sp.eigenvectors.as_ref())?,
        info,
    ))
}

/// `eigsh(indptr, indices, data, n, k, mass, mass_csc, tol, refine, band_size,
/// block_size)`: the k smallest
/// eigenpairs of `A v = λ M v` for a symmetric sparse A given by its compressed
/// columns; M is the identity, a positive diagonal (`mass`, (n,)) or a sparse
/// symmetric positive definite matrix (`mass_csc`: its indptr, indices, data). The
/// library checks symmetry and positivity.
#[pyfunction]
#[pyo3(signature = (indptr, indices, data, n, k, mass=None, mass_csc=None, tol=None, refine=true, band_size=None, block_size=None))]
#[allow(clippy::too_many_arguments)]
fn eigsh<'py>(
    py: Python<'py>,
    indptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
    data: PyReadonlyArray1<'_, f64>,
    n: usize,
    k: usize,
    mass: Option<PyReadonlyArray1<'_, f64>>,
    mass_csc: Option<CscIn<'_>>,
    tol: Option<f64>,
    refine: bool,
    band_size: Option<usize>,
    block_size: Option<usize>,
) -> PyResult<Eigen<'py>> {
    let a = csc_in(py, "A", &indptr, &indices, &data, n)?;
    let contiguous = |name: &str| raise_as(py, "Error", format!("{name} must be contiguous"));
    let diag = mass
        .as_ref()
        .map(|m| m.as_slice().map_err(|_| contiguous("M")))
        .transpose()?;
    let sparse = match &mass_csc {
        Some((p, i, v)) => Some(csc_in(py, "M", p, i, v, n)?),
        None => None,
    };
    let mass = match (&sparse, diag) {
        (Some(m), _) => Mass::Sparse(m),
        (None, Some(d)) => Mass::Lumped(d),
        (None, None) => Mass::Identity,
    };
    let opts = partial_params(k, tol, refine, band_size, block_size);
    let ps = compute(py, || {
        partial_spectrum_with_mass(&a, mass, &opts, &mut |_, _| {}).map_err(meshlap::Error::from)
    })
    .map_err(|e| crate::raise(py, e))?;
    partial_out(py, ps)
}

/// The library's defaults for `k` pairs with the arguments given (the library checks
/// them).
fn partial_params(
    k: usize,
    tol: Option<f64>,
    refine: bool,
    band_size: Option<usize>,
    block_size: Option<usize>,
) -> PartialParams {
    let d = PartialParams::new(k);
    PartialParams {
        tolerance: tol.unwrap_or(d.tolerance),
        band_size: band_size.unwrap_or(d.band_size),
        block_size: block_size.unwrap_or(d.block_size),
        refine,
        ..d
    }
}

/// A matrix in compressed sparse columns from Python: indptr, indices, data.
type CscIn<'a> = (
    PyReadonlyArray1<'a, i64>,
    PyReadonlyArray1<'a, i64>,
    PyReadonlyArray1<'a, f64>,
);

/// The faer matrix of CSC arrays (checked: lengths, monotone pointers, indices in
/// range).
fn csc_in(
    py: Python<'_>,
    name: &str,
    indptr: &PyReadonlyArray1<'_, i64>,
    indices: &PyReadonlyArray1<'_, i64>,
    data: &PyReadonlyArray1<'_, f64>,
    n: usize,
) -> PyResult<meshlap::SparseMatrix> {
    let contiguous =
        |what: &str| raise_as(py, "Error", format!("{name}'s {what} must be contiguous"));
    let ptr = indptr.as_slice().map_err(|_| contiguous("indptr"))?;
    let idx = indices.as_slice().map_err(|_| contiguous("indices"))?;
    let val = data.as_slice().map_err(|_| contiguous("data"))?;
    let bad = |m: String| raise_as(py, "SpectralError", m);
    if ptr.len() != n + 1 || idx.len() != val.len() || ptr.last().copied() != Some(idx.len() as i64)
    {
        return Err(bad(format!(
            "{name} is not a valid {n}×{n} compressed sparse matrix (indptr {}, indices {}, data {})",
            ptr.len(),
            idx.len(),
            val.len()
        )));
    }
    let mut trip = Vec::with_capacity(val.len());
    for j in 0..n {
        let (s, e) = (ptr[j], ptr[j + 1]);
        if s < 0 || e < s {
            return Err(bad(format!("{name}'s indptr must be non-decreasing")));
        }
        for p in s as usize..e as usize {
            let i = idx[p];
            if i < 0 || i as usize >= n {
                return Err(bad(format!("{name} has a row index {i} outside 0..{n}")));
            }
            if !val[p].is_finite() {
                return Err(bad(format!("{name} has a non-finite entry at ({i}, {j})")));
            }
            trip.push(faer::sparse::Triplet::new(i as usize, j, val[p]));
        }
    }
    meshlap::SparseMatrix::try_new_from_triplets(n, n, &trip)
        .map_err(|e| bad(format!("{name} could not be assembled: {e}")))
}

/// `project(V, F, kind, keep, patch_size)` → V′ (n, 3): the library's
/// [`meshlap::spectral::project::project`] (the truncated ED-transform reconstruction
/// from the `keep` lowest-frequency coefficients, dense basis, or patch by patch
/// keeping the fraction m/n of each patch's); `keep` is parsed by the library's
/// [`Keep`](meshlap::spectral::project::Keep) (`"m"` or `"P%"`).
#[pyfunction]
#[pyo3(signature = (v, f, kind, keep, patch_size=None))]
fn project<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    kind: &str,
    keep: &str,
    patch_size: Option<usize>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    use meshlap::spectral::project::{project, Keep, ProjectParams};
    let input = mesh_of(py, &v, &f)?;
    let n = input.mesh.n_vertices();
    let kind = kind_of(py, kind)?;
    let keep: Keep = keep
        .parse()
        .map_err(|e: meshlap::spectral::project::KeepError| {
            crate::raise(py, meshlap::spectral::SpectralError::from(e))
        })?;
    let params = ProjectParams {
        patch_size,
        ..ProjectParams::default()
    };
    let positions = compute(py, || {
        project(
            &input.mesh,
            &input.topology,
            kind,
            keep,
            &params,
            &|_, _| {},
        )
    })
    .or_raise(py)?
    .positions;
    let flat: Vec<f64> = positions.iter().flatten().copied().collect();
    PyArray1::from_vec(py, flat).reshape([n, 3])
}

/// `compaction(V, F, kind, centre=False)` → (n, 4): η_x(m), η_y(m), η_z(m), η(m)
/// for m = 1..n (Zhang 2004 §4.9).
#[pyfunction]
#[pyo3(signature = (v, f, kind, centre=false))]
fn compaction<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    kind: &str,
    centre: bool,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    use meshlap::spectral::{
        compaction, energy_compaction, forward, positions_to_mat, BasisOptions, EigenBasis,
    };
    let input = mesh_of(py, &v, &f)?;
    let op = assemble(py, &input, kind, "zero-row-sum", "voronoi")?;
    let comp = compute(py, || -> meshlap::Result<_> {
        let basis = EigenBasis::compute(&op, &BasisOptions::default())?;
        let mut x = positions_to_mat(&input.mesh.positions);
        if centre {
            x = compaction::centre(x.as_ref());
        }
        let coeffs = forward(&basis, x.as_ref())?;
        Ok(energy_compaction(coeffs.as_ref()))
    })
    .or_raise(py)?;
    let m = comp.len();
    let mut flat = Vec::with_capacity(4 * m);
    for i in 0..m {
        flat.extend([
            comp.per_coordinate[0][i],
            comp.per_coordinate[1][i],
            comp.per_coordinate[2][i],
            comp.total[i],
        ]);
    }
    PyArray1::from_vec(py, flat).reshape([m, 4])
}

/// `smooth(V, F, filter, operator, lam, steps, solver, stop, tol, max_iterations,
/// kpb, order, passband, preserve, dense_limit)` → `(V′, report JSON)`; `None` takes
/// the library's default (`Filter::new`).
#[pyfunction]
#[pyo3(signature = (v, f, filter="implicit", operator="sql", lam=None, steps=None, solver=None,
    stop=None, tol=None, max_iterations=None, kpb=None, order=None, passband=None,
    preserve="none", dense_limit=None))]
#[allow(clippy::too_many_arguments)]
fn smooth<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: FaceArray<'_>,
    filter: &str,
    operator: &str,
    lam: Option<f64>,
    steps: Option<usize>,
    solver: Option<&str>,
    stop: Option<&str>,
    tol: Option<f64>,
    max_iterations: Option<usize>,
    kpb: Option<f64>,
    order: Option<usize>,
    passband: Option<f64>,
    preserve: &str,
    dense_limit: Option<usize>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, String)> {
    use meshlap::filter::{apply, Filter, FilterKind, FilterSettings, Preserve, SolverKind};
    use meshlap::solve::{Params, Stopping};
    let input = mesh_of(py, &v, &f)?;
    let kind: FilterKind = filter.parse().or_raise(py)?;
    let preserve: Preserve = preserve.parse().or_raise(py)?;
    let solver: Option<SolverKind> = solver.map(str::parse).transpose().or_raise(py)?;
    let stopping: Option<Stopping> = stop
        .map(str::parse)
        .transpose()
        .map_err(|e: meshlap::solve::InputError| raise_as(py, "SolveError", e.to_string()))?;
    let params = (stopping.is_some() || tol.is_some() || max_iterations.is_some()).then(|| {
        let d = Params::default();
        Params {
            tolerance: tol.unwrap_or(d.tolerance),
            stopping: stopping.unwrap_or(d.stopping),
            max_iterations: max_iterations.unwrap_or(d.max_iterations),
            ..d
        }
    });
    let settings = FilterSettings {
        lambda: lam,
        steps,
        solver,
        params,
        k_pb: kpb,
        order,
        passband,
        dense_limit,
    };
    let filter = Filter::new(kind, &settings).or_raise(py)?;
    let op = assemble(py, &input, operator, "zero-row-sum", "voronoi")?;
    let (positions, report) =
        compute(py, || apply(&input.mesh, &op.matrix, &filter, preserve)).or_raise(py)?;
    #[derive(serde::Serialize)]
    struct Out<'a> {
        filter: &'a Filter,
        operator: OperatorKind,
        #[serde(flatten)]
        report: &'a meshlap::filter::FilterReport,
    }
    let text = json(
        py,
        &Out {
            filter: &filter,
            operator: op.kind,
            report: &report,
        },
    )?;
    let flat: Vec<f64> = positions.iter().flatten().copied().collect();
    Ok((
        PyArray1::from_vec(py, flat).reshape([positions.len(), 3])?,
        text,
    ))
}

fn evecs_in<'a>(py: Python<'_>, evecs: &'a PyReadonlyArray2<'_, f64>) -> PyResult<MatRef<'a, f64>> {
    let (s, r, c) = crate::slice2(py, evecs, "evecs", None)?;
    Ok(MatRef::from_row_major_slice(s, r, c))
}

fn slice1<'a>(py: Python<'_>, a: &'a PyReadonlyArray1<'_, f64>, name: &str) -> PyResult<&'a [f64]> {
    a.as_slice()
        .map_err(|_| raise_as(py, "Error", format!("{name} must be contiguous")))
}

/// `hks(evals, evecs, times=None, count=100)` → `(HKS (n, T), times)`.
#[pyfunction]
#[pyo3(signature = (evals, evecs, times=None, count=100))]
fn hks<'py>(
    py: Python<'py>,
    evals: PyReadonlyArray1<'_, f64>,
    evecs: PyReadonlyArray2<'_, f64>,
    times: Option<PyReadonlyArray1<'_, f64>>,
    count: usize,
) -> PyResult<Samples<'py>> {
    let l = slice1(py, &evals, "evals")?;
    let phi = evecs_in(py, &evecs)?;
    let times = match &times {
        Some(t) => slice1(py, t, "times")?.to_vec(),
        None => descriptors::default_times(l, count).or_raise(py)?,
    };
    let h = compute(py, || descriptors::hks(l, phi, &times)).or_raise(py)?;
    Ok((mat_out(py, h.as_ref())?, PyArray1::from_vec(py, times)))
}

/// `wks(evals, evecs, energies=None, sigma=None, count=100)` → `(WKS (n, E),
/// energies, sigma)`.
#[pyfunction]
#[pyo3(signature = (evals, evecs, energies=None, sigma=None, count=100))]
fn wks<'py>(
    py: Python<'py>,
    evals: PyReadonlyArray1<'_, f64>,
    evecs: PyReadonlyArray2<'_, f64>,
    energies: Option<PyReadonlyArray1<'_, f64>>,
    sigma: Option<f64>,
    count: usize,
) -> PyResult<WksOut<'py>> {
    let l = slice1(py, &evals, "evals")?;
    let phi = evecs_in(py, &evecs)?;
    let (energies, default_sigma) = match &energies {
        Some(e) => {
            let e = slice1(py, e, "energies")?.to_vec();
            let s = descriptors::default_sigma(&e);
            (e, s)
        }
        None => descriptors::default_energies(l, count).or_raise(py)?,
    };
    let sigma = sigma.unwrap_or(default_sigma);
    let w = compute(py, || descriptors::wks(l, phi, &energies, sigma)).or_raise(py)?;
    Ok((
        mat_out(py, w.as_ref())?,
        PyArray1::from_vec(py, energies),
        sigma,
    ))
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::add_functions!(m; operator, mass_matrix, properties, spectrum, eigs, eigsh, project, compaction, smooth, hks, wks)
}
