"""meshlap: discrete mesh Laplacians for digital geometry processing.

Python bindings of the meshlap Rust library, after H. Zhang, *Discrete combinatorial
Laplacian operators for digital geometry processing* (2004): the combinatorial and
geometric operators, their property reports, partial spectra (a drop-in for scipy's
shift-invert ``eigsh``), spectral projection and compaction, fairing filters,
SQL repair, METIS partitions, compression, distortion metrics, rendering, and the
heat / wave kernel signatures.

Conventions
-----------
- **Sign.** Every operator is positive semi-definite, ``F = D - W`` as in the paper
  (libigl's ``cotmatrix`` and pmp use the negative). Eigenvalues are ascending from 0.
- **Meshes** are ``V`` float64 ``(n, 3)`` and ``F`` int64 ``(m, 3)`` (0-based).
  Inputs may be any array-like: float32 (or integer) coordinates and int32 / uint32 /
  int64 face indices are accepted; float64 coordinates and int64 or uint32 indices
  in C order are passed without a copy, others converted (one copy) to float64 and
  int64. The library checks the values (finite coordinates, indices in range, at
  least one face) and names the argument in its message. Functions that take
  ``(V, F)`` use the mesh as given (validated, not cleaned: use :func:`clean` or
  :func:`read_mesh`, which cleans as the CLI does).
- **Errors** are :class:`meshlap.Error` (a ``ValueError``) subclasses naming the
  argument and the expected shape; nothing crashes the interpreter.
- **Threads.** Every call releases the GIL while it computes, on all cores unless
  :func:`set_threads` says otherwise.
"""

from __future__ import annotations

import json as _json
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from . import _meshlap, errors
from .errors import (
    CodecError,
    Error,
    MeshError,
    MeshIOError,
    MetricError,
    OperatorError,
    PartitionError,
    RenderError,
    RepairError,
    SolveError,
    SpectralError,
    WatermarkError,
)

__version__ = "0.1.0"

#: Operator kinds accepted by ``kind=`` (aliases: kl, tl, gl, t2, mv, cot).
OPERATOR_KINDS = (
    "kirchhoff",
    "tutte",
    "graph",
    "sql",
    "sstl",
    "tutte2",
    "sdl",
    "cotan",
    "mean-value",
)

# ----------------------------------------------------------------------------------
# Argument conversion (shapes and dtypes checked here, naming the argument)


def _vertices(V: Any, name: str = "V") -> np.ndarray:
    # dtype and shape only: finiteness is checked by the library (TriMesh::validate),
    # which names the argument in its message.
    a = np.asarray(V)
    if a.dtype != np.float64:
        if a.dtype.kind not in "fiu":
            raise MeshError(f"{name} must be a real (n, 3) array, got dtype {a.dtype}")
        a = a.astype(np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise MeshError(f"{name} must have shape (n, 3), got {a.shape}")
    return a if a.flags.c_contiguous else np.ascontiguousarray(a)


def _faces(F: Any, name: str = "F") -> np.ndarray:
    # dtype and shape only: the extension takes int64 (numpy's default) or uint32 and
    # the library checks the indices (negative, out of range, no faces).
    a = np.asarray(F)
    if a.dtype.kind not in "iu":
        raise MeshError(f"{name} must be an integer (m, 3) array, got dtype {a.dtype}")
    if a.ndim != 2 or a.shape[1] != 3:
        raise MeshError(f"{name} must have shape (m, 3), got {a.shape}")
    if a.dtype != np.int64 and a.dtype != np.uint32:
        a = a.astype(np.int64)
    return a if a.flags.c_contiguous else np.ascontiguousarray(a)


def _mesh(V: Any, F: Any, vname: str = "V", fname: str = "F") -> Tuple[np.ndarray, np.ndarray]:
    return _vertices(V, vname), _faces(F, fname)


def _vector(x: Any, name: str, n: Optional[int] = None) -> np.ndarray:
    a = np.asarray(x)
    if a.dtype.kind not in "fiu":
        raise Error(f"{name} must be a real array, got dtype {a.dtype}")
    if a.ndim == 2 and 1 in a.shape:
        a = a.reshape(-1)
    if a.ndim != 1 or (n is not None and a.shape[0] != n):
        want = f"({n},)" if n is not None else "(k,)"
        raise Error(f"{name} must have shape {want}, got {a.shape}")
    return np.ascontiguousarray(a, dtype=np.float64)


def _csr_checked(parts: Tuple[np.ndarray, np.ndarray, np.ndarray, Tuple[int, int]]):
    import scipy.sparse as sp

    indptr, indices, data, shape = parts
    return sp.csr_array((data, indices, indptr), shape=shape)


def _csr_direct(parts: Tuple[np.ndarray, np.ndarray, np.ndarray, Tuple[int, int]]):
    # The extension's arrays are a canonical CSR (rows sorted, no duplicates, int64
    # indices): set them on the array without scipy's argument checks, which cost
    # about 30 microseconds per call (as much as a 1k-vertex operator's assembly).
    import scipy.sparse as sp

    indptr, indices, data, shape = parts
    m = sp.csr_array.__new__(sp.csr_array)
    m.indptr, m.indices, m.data = indptr, indices, data
    m._shape = (int(shape[0]), int(shape[1]))
    m.maxprint = 50
    return m


def _csr_direct_works() -> bool:
    # The direct path sets scipy internals: use it only if it gives, on a small
    # matrix, exactly what the public constructor gives (else the checked path).
    try:
        parts = (
            np.array([0, 2, 3, 4], dtype=np.int64),
            np.array([0, 2, 1, 2], dtype=np.int64),
            np.array([1.0, -2.0, 3.0, 4.0]),
            (3, 3),
        )
        a, b = _csr_checked(parts), _csr_direct(parts)
        x = np.array([1.0, 2.0, 3.0])
        return bool(
            type(a) is type(b)
            and a.shape == b.shape
            and a.nnz == b.nnz
            and b.format == "csr"
            and b.has_canonical_format
            and np.array_equal(a.toarray(), b.toarray())
            and np.array_equal(a @ x, b @ x)
            and np.array_equal(b.T @ x, a.T @ x)
            and np.array_equal(b.tocsc().toarray(), a.toarray())
            and repr(a) == repr(b)
        )
    except Exception:
        return False


_CSR_DIRECT: Optional[bool] = None


def _csr(parts: Tuple[np.ndarray, np.ndarray, np.ndarray, Tuple[int, int]]):
    global _CSR_DIRECT
    if _CSR_DIRECT is None:
        _CSR_DIRECT = _csr_direct_works()
    return _csr_direct(parts) if _CSR_DIRECT else _csr_checked(parts)


# ----------------------------------------------------------------------------------
# Meshes


def read_mesh(path_or_builtin: Union[str, "os.PathLike[str]"], format: Optional[str] = None):
    """Read a mesh file (OBJ, OFF, PLY, STL; format from the extension or ``format``)
    or generate ``builtin:NAME[:ARGS]`` (``icosphere:3``, ``torus:16:8``, ``grid:8``,
    ``cube:4``, ...), cleaned as the CLI cleans (faces with a repeated vertex,
    duplicate faces and unreferenced vertices dropped).

    Returns ``(V, F)``: float64 ``(n, 3)`` and int64 ``(m, 3)``.
    """
    return _meshlap.read_mesh(str(path_or_builtin), format)


def write_mesh(
    path: Union[str, "os.PathLike[str]"],
    V: Any,
    F: Any,
    scalars: Any = None,
    colors: Any = None,
    *,
    scalar_name: str = "scalar",
    format: Optional[str] = None,
    ascii: bool = False,
) -> None:
    """Write ``(V, F)`` to ``path`` atomically (a temporary file renamed; never a
    partial file). ``scalars`` (n,) float and ``colors`` (n, 3) uint8 are PLY vertex
    properties (PLY only)."""
    v, f = _mesh(V, F)
    s = None if scalars is None else _vector(scalars, "scalars", v.shape[0])
    c = None
    if colors is not None:
        c = np.asarray(colors)
        if c.ndim != 2 or c.shape != (v.shape[0], 3):
            raise MeshError(f"colors must have shape ({v.shape[0]}, 3), got {c.shape}")
        c = np.ascontiguousarray(c, dtype=np.uint8)
    _meshlap.write_mesh(str(path), v, f, s, scalar_name, c, format, ascii)


def info(V: Any, F: Any) -> Dict[str, Any]:
    """The report of ``meshlap info --json`` (one library function, ``Input::info``;
    after cleaning, with the dropped counts): source (``"array"``),
    polygons_triangulated, read, vertices, faces, edges, boundary_edges, boundary_loops, components,
    euler_characteristic, genus, non_manifold_edges, non_manifold_vertices,
    inconsistently_oriented_edges, zero_area_faces, degree, bbox_min, bbox_max,
    bbox_diagonal, dropped_* counts."""
    v, f = _mesh(V, F)
    return _json.loads(_meshlap.info(v, f))


def clean(V: Any, F: Any, split_nonmanifold: bool = False):
    """Clean a mesh as the CLI does; ``split_nonmanifold`` also duplicates vertices
    along non-manifold edges and at non-manifold vertices. The report has the keys of
    ``meshlap clean --json`` (one library function, ``Input::cleaned``).

    Returns ``(V, F, report)``: float64 ``(n', 3)``, int64 ``(m', 3)`` and a dict
    (dropped_unreferenced_vertices, dropped_degenerate_faces, dropped_duplicate_faces,
    split, vertices, faces, non_manifold_edges, non_manifold_vertices).
    """
    v, f = _mesh(V, F)
    v2, f2, rep = _meshlap.clean(v, f, bool(split_nonmanifold))
    return v2, f2, _json.loads(rep)


# ----------------------------------------------------------------------------------
# Operators and spectra


def operator(
    V: Any,
    F: Any,
    kind: str = "sql",
    *,
    sql_diagonal: str = "zero-row-sum",
    mass: str = "voronoi",
):
    """The n×n operator ``kind`` as a ``scipy.sparse.csr_array`` of float64, sign
    ``F = D - W`` (positive semi-definite; libigl's cotmatrix is ``-operator(V, F,
    "cotan")``). Kinds: kirchhoff (kl), tutte (tl), graph (gl), sql, sstl, tutte2
    (t2), sdl, cotan, mean-value (mv). ``sql_diagonal="printed"`` reproduces the
    paper's printed (erroneous) SQL boundary diagonal (Zhang 2004 §3.7)."""
    v, f = _mesh(V, F)
    return _csr(_meshlap.operator(v, f, kind, sql_diagonal, mass))


def mass_matrix(V: Any, F: Any, kind: str = "voronoi"):
    """The lumped mass matrix M of the cotangent operator as a diagonal n×n
    ``scipy.sparse.csr_array``: ``voronoi`` (mixed Voronoi areas, Meyer et al. 2003)
    or ``barycentric`` (a third of the incident triangle areas), for ``L v = λ M v``
    with ``L = operator(V, F, "cotan")`` (sign ``F = D − W``, positive semi-definite).
    Computed face by face, without the stiffness matrix or the connectivity; a
    degenerate face raises ``OperatorError`` as ``operator`` does."""
    import scipy.sparse as sp

    v, f = _mesh(V, F)
    m = _meshlap.mass_matrix(v, f, kind)
    return sp.diags_array(m, format="csr") if hasattr(sp, "diags_array") else sp.csr_array(sp.diags(m))


def properties(
    V: Any,
    F: Any,
    kind: str,
    *,
    dense_limit: Optional[int] = None,
    sql_diagonal: str = "zero-row-sum",
    mass: str = "voronoi",
) -> Dict[str, Any]:
    """The matrix-theoretic property report of ``meshlap operator --json`` (every
    property measured on the matrix: symmetry, negative weights, row sums, the
    smoothing matrix, spectrum bounds, GSML status)."""
    v, f = _mesh(V, F)
    return _json.loads(_meshlap.properties(v, f, kind, dense_limit, sql_diagonal, mass))


def spectrum(
    V: Any,
    F: Any,
    kind: str = "sql",
    count: Optional[int] = None,
    *,
    path: str = "auto",
    normalization: str = "unit",
    dense_solver: str = "blocked",
    sql_diagonal: str = "zero-row-sum",
    mass: str = "voronoi",
    tol: Optional[float] = None,
    refine: bool = True,
    band_size: Optional[int] = None,
    block_size: Optional[int] = None,
    return_info: bool = False,
):
    """The eigenbasis of ``meshlap spectrum``: eigenvalues ascending ``evals`` (k,) and
    eigenvectors ``evecs`` (n, k) float64, column j for ``evals[j]``; all n pairs by a
    dense eigendecomposition (the paper's ED transform, x = E X), or only the ``count``
    smallest (by shift-invert above 5,000 vertices, where ``count`` is required).
    Operators are positive semi-definite, F = D − W (libigl and pmp use the negative).

    ``path``: "auto" (symmetric operators directly, the TL and others with a positive
    diagonal symmetrizer through their symmetric similar matrix), "symmetric",
    "symmetrized" or "general" (non-symmetric solver, Matlab's ``eig``).
    ``normalization``: "unit" (unit-length columns, as Matlab's ``eig``) or "weighted"
    (orthonormal in the symmetrizer's / mass inner product). ``dense_solver``:
    "blocked", "faer" or "reproducible" (the same bits on every CPU). ``tol``,
    ``refine``, ``band_size`` and ``block_size`` tune the shift-invert path, as in
    :func:`eigs`. Signs and the bases of repeated eigenvalues are canonical. With
    ``return_info`` also a dict: the path taken, the cluster multiplicities,
    ``max_residual`` and ``orthonormality_error``.
    """
    v, f = _mesh(V, F)
    evals, evecs, info = _meshlap.spectrum(
        v,
        f,
        kind,
        None if count is None else int(count),
        path,
        normalization,
        dense_solver,
        sql_diagonal,
        mass,
        tol,
        bool(refine),
        band_size,
        block_size,
    )
    return (evals, evecs, _json.loads(info)) if return_info else (evals, evecs)


def eigs(
    V: Any,
    F: Any,
    k: int,
    kind: str = "sql",
    *,
    tol: Optional[float] = None,
    sql_diagonal: str = "zero-row-sum",
    mass: str = "voronoi",
    refine: bool = True,
    band_size: Optional[int] = None,
    block_size: Optional[int] = None,
    return_residuals: bool = False,
):
    """The k smallest eigenpairs of a mesh operator, ascending: ``evals`` (k,) and
    ``evecs`` (n, k) float64. The cotangent operator is solved with its lumped mass,
    ``L v = λ M v`` (``evecs`` M-orthonormal); the TL (and T², SDL) through its
    positive diagonal symmetrizer S (S-orthonormal); the others are orthonormal.
    Shift-invert block Krylov–Schur with a Sylvester-inertia completeness check (dense
    below 600 vertices). Signs (and the bases of repeated eigenvalues) are canonical:
    the crate's one rule, v · r0 >= 0 for a fixed probe vector r0, as on the dense path.
    ``band_size`` (eigenpairs per shift, default 200) and ``block_size`` (vectors per
    Krylov block, default 8, at most ``band_size``) tune the shift-invert solver, as
    ``meshlap spectrum --band-size --block-size``. Sign convention: ``F = D − W``
    (positive semi-definite), so the smoothest eigenvectors come first."""
    v, f = _mesh(V, F)
    evals, evecs, res = _meshlap.eigs(
        v,
        f,
        _count(k),
        kind,
        tol,
        sql_diagonal,
        mass,
        bool(refine),
        _size("band_size", band_size),
        _size("block_size", block_size),
    )
    return (evals, evecs, res) if return_residuals else (evals, evecs)


def _count(k: Any) -> int:
    return _positive("k", k)


def _positive(name: str, x: Any) -> int:
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)) or x < 1:
        raise SpectralError(f"{name} must be a positive integer, got {x!r}")
    return int(x)


def _size(name: str, x: Any) -> Optional[int]:
    return None if x is None else _positive(name, x)


def _mass(M: Any, n: int):
    """``(diagonal, csc)`` for ``_meshlap.eigsh``: an (n,) diagonal, or the CSC arrays
    of a sparse or dense (n, n) matrix (the library checks symmetry and positive
    definiteness, and takes a diagonal one the cheap way)."""
    import scipy.sparse as sp

    if sp.issparse(M):
        if M.shape != (n, n):
            raise SpectralError(f"M must have shape ({n}, {n}), got {M.shape}")
        m = sp.csc_array(M, dtype=np.float64)
    else:
        a = np.asarray(M)
        if a.dtype.kind not in "fiu":
            raise SpectralError(f"M must be a real matrix or diagonal, got dtype {a.dtype}")
        if a.ndim == 1 and a.shape[0] == n:
            return np.ascontiguousarray(a, dtype=np.float64), None
        if a.ndim != 2 or a.shape != (n, n):
            raise SpectralError(f"M must have shape ({n},) or ({n}, {n}), got {a.shape}")
        m = sp.csc_array(a.astype(np.float64))
    m.sum_duplicates()
    m.sort_indices()
    return None, (
        np.ascontiguousarray(m.indptr, dtype=np.int64),
        np.ascontiguousarray(m.indices, dtype=np.int64),
        np.ascontiguousarray(m.data, dtype=np.float64),
    )


def eigsh(
    A: Any,
    k: int,
    M: Any = None,
    tol: float = 1e-10,
    *,
    refine: bool = True,
    band_size: Optional[int] = None,
    block_size: Optional[int] = None,
    return_residuals: bool = False,
):
    """The k smallest eigenpairs of ANY symmetric positive semi-definite matrix ``A``
    (scipy sparse, or dense), optionally of ``A v = λ M v`` with a symmetric positive
    definite ``M``: a lumped mass (the (n,) diagonal, or a diagonal matrix) or any
    sparse or dense SPD (n, n) matrix such as a consistent finite-element mass matrix
    (reduced through its sparse Cholesky factor ``M = C Cᵀ``).

    Returns ``evals`` (k,) ascending and ``evecs`` (n, k) float64, M-orthonormal
    (``evecs.T @ M @ evecs = I``). Complete: Sylvester's law of inertia on the LDLᵀ
    factors of ``A − σM`` proves no eigenvalue inside the returned range is skipped.
    Robust on singular A (the shifts never sit on an eigenvalue, unlike scipy's
    ``sigma=0``); dense below 600 rows. ``tol`` is the relative Ritz residual of the
    shift-inverted operator; ``tol=1e-12`` brings the residuals ``‖Av − λMv‖`` to the
    level of scipy's (ARPACK's) shift-invert ``eigsh``. ``refine`` (default on) adds one step of subspace
    iteration with each band's factorization and a Rayleigh–Ritz step with ``A``
    itself: residuals about 20x lower for a few more solves. ``band_size`` (eigenpairs
    per shift, default 200) and ``block_size`` (vectors per Krylov block, default 8, at
    most ``band_size``) tune the solver. A non-symmetric A or M, or an M that is not positive
    definite, raises :class:`SpectralError` (a ``ValueError``). Sign convention: the
    paper's operators are ``F = D − W`` (positive semi-definite); pass ``-L`` for
    libigl's or pmp's negative semi-definite cotangent matrix.

    A drop-in for ``scipy.sparse.linalg.eigsh(A, k, M, sigma=-small, which="LM")``.
    """
    import scipy.sparse as sp

    if sp.issparse(A):
        a = sp.csc_array(A, dtype=np.float64)
    else:
        d = np.asarray(A)
        if d.dtype.kind not in "fiu":
            raise SpectralError(f"A must be a real matrix, got dtype {d.dtype}")
        if d.ndim != 2:
            raise SpectralError(f"A must be a square 2-D matrix, got shape {d.shape}")
        a = sp.csc_array(d.astype(np.float64))
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise SpectralError(f"A must be square (n, n), got shape {a.shape}")
    n = a.shape[0]
    k = _count(k)
    if k > n:
        raise SpectralError(f"k must be at most n = {n}, got {k}")
    a.sum_duplicates()
    a.sort_indices()
    mass, mass_csc = (None, None) if M is None else _mass(M, n)
    evals, evecs, res = _meshlap.eigsh(
        np.ascontiguousarray(a.indptr, dtype=np.int64),
        np.ascontiguousarray(a.indices, dtype=np.int64),
        np.ascontiguousarray(a.data, dtype=np.float64),
        n,
        k,
        mass,
        mass_csc,
        float(tol),
        bool(refine),
        _size("band_size", band_size),
        _size("block_size", block_size),
    )
    return (evals, evecs, res) if return_residuals else (evals, evecs)


def project(V: Any, F: Any, kind: str, keep: Union[int, str], patch_size: Optional[int] = None) -> np.ndarray:
    """Spectral projection (Zhang 2004 Fig. 1; Karni & Gotsman 2000): the positions
    rebuilt from the ``keep`` lowest-frequency coefficients of the operator's
    ED-transform, ``x⁽ᵐ⁾ = e₁X₁ + … + e_mX_m``. ``keep`` is a count m (1 ≤ m ≤ n) or a
    percentage string like ``"10%"`` (of n, rounded half away from zero, at least 1).
    With ``patch_size`` the mesh is split into METIS
    patches of about that many vertices and each keeps the fraction m/n. Dense basis
    (n ≤ 5000 without patches). Returns V′ float64 (n, 3)."""
    v, f = _mesh(V, F)
    if isinstance(keep, str):
        text = keep
    else:
        text = str(_count(keep))
    return _meshlap.project(v, f, kind, text, patch_size)


def compaction(V: Any, F: Any, kind: str, *, centre: bool = False) -> np.ndarray:
    """Energy compaction (transform efficiency, Zhang 2004 §4.9) of the geometry in
    the operator's ED-transform: an (n, 4) float64 array whose row m−1 holds the
    fraction of the coefficient energy of x, y, z and in total in the first m
    (lowest-frequency) coefficients."""
    v, f = _mesh(V, F)
    return _meshlap.compaction(v, f, kind, bool(centre))


def smooth(
    V: Any,
    F: Any,
    filter: str = "implicit",
    operator: str = "sql",
    lam: Optional[float] = None,
    steps: Optional[int] = None,
    solver: Optional[str] = None,
    *,
    stop: Optional[str] = None,
    tol: Optional[float] = None,
    max_iterations: Optional[int] = None,
    kpb: Optional[float] = None,
    order: Optional[int] = None,
    passband: Optional[float] = None,
    preserve: str = "none",
    dense_limit: Optional[int] = None,
):
    """Low-pass filter the positions with operator F (``F = D − W``; default the
    SQL, the library's ``FilterSettings::DEFAULT_OPERATOR``, as ``meshlap smooth``):
    ``implicit``
    ((I + λF)x′ = x, Desbrun 1999; Zhang 2004 §4.10; λ = 30, 1 step by default),
    ``explicit``, ``taubin``, ``butterworth``, ``ideal`` (see ``meshlap smooth``).
    ``None`` takes the library's default; the solver ``auto`` is CG for a symmetric F
    and BiCG otherwise (on an F with a diagonal symmetrizer S, as the TL, BiCG uses
    ``(I + λF)ᵀ = S(I + λF)S⁻¹``: both products in one pass, no transpose stored).

    Returns ``(V′, info)``: float64 (n, 3) and a dict with ``iterations`` per
    coordinate column, ``residuals``, ``solves`` (each with ``history``: the relative
    residual per iteration and column), ``solver``, timings and volumes.
    """
    v, f = _mesh(V, F)
    out, rep = _meshlap.smooth(
        v, f, filter, operator, lam, steps, solver, stop, tol, max_iterations, kpb, order,
        passband, preserve, dense_limit,
    )
    return out, _json.loads(rep)


def repair_sql(V: Any, F: Any, method: str = "swap", *, max_dihedral: Optional[float] = None):
    """Remove the SQL's negative weights (Zhang 2004 §3.7) by greedy edge swapping
    (``swap``), vertex splits (``split``) or both (``swap-split``).

    Returns ``(V, F, report)`` (new vertices are appended; report keys as
    ``meshlap repair-sql --json``)."""
    v, f = _mesh(V, F)
    v2, f2, rep = _meshlap.repair_sql(v, f, method, max_dihedral)
    return v2, f2, _json.loads(rep)


def partition(
    V: Any,
    F: Any,
    patch_size: int,
    *,
    seed: int = 0,
    method: str = "metis",
    lloyd_iterations: Optional[int] = None,
    return_stats: bool = False,
):
    """Connected patches of about ``patch_size`` vertices: int32 labels (n,) (with
    ``return_stats``, also the dict of ``meshlap partition --json``).

    ``method``: ``"metis"`` (METIS k-way, ``seed`` its random seed: the lowest edge
    cut, sizes within a few vertices) or ``"lloyd"`` (Lloyd-relaxed graph Voronoi
    cells: an edge cut close to METIS's in a fraction of the time, more spread in the
    sizes; the compressor's partition since ``.mlz`` format 7). ``lloyd_iterations``:
    the Lloyd relaxation steps (``None``: the library's default, 5; at most 100; the
    compressor takes 2 from ``.mlz`` format 9); ``meshlap.PartitionError`` (a
    ``ValueError``) above the limit."""
    v, f = _mesh(V, F)
    steps = None if lloyd_iterations is None else int(lloyd_iterations)
    labels, stats = _meshlap.partition(v, f, int(patch_size), int(seed), str(method), steps)
    return (labels, _json.loads(stats)) if return_stats else labels


# ----------------------------------------------------------------------------------
# Compression, metrics, pictures


def compress(
    V: Any,
    F: Any,
    bits: Optional[float] = None,
    target_bpv: Optional[float] = None,
    mode: Optional[str] = None,
    *,
    operator: Optional[str] = None,
    patch_size: Optional[int] = None,
    keep_ratio: Optional[float] = None,
    coefficients: Optional[int] = None,
    band_slope: Optional[float] = None,
    dead_zone: Optional[float] = None,
    prediction: bool = True,
    border_residuals: bool = False,
    rdo_lambda: Optional[float] = None,
    select: bool = True,
    preserve_order: bool = False,
    return_report: bool = False,
):
    """Compress a manifold, consistently oriented mesh to ``.mlz`` bytes (options and
    defaults of ``meshlap compress``: 10 bits, ``mode="auto"``). With
    ``return_report`` also the dict of ``meshlap compress --json``. The vertex order
    of :func:`decompress` is the coder's unless ``preserve_order``."""
    v, f = _mesh(V, F)
    data, rep = _meshlap.compress(
        v, f, bits, target_bpv, mode, operator, patch_size, keep_ratio, coefficients,
        band_slope, dead_zone, prediction, border_residuals, rdo_lambda, select, preserve_order,
    )
    return (data, _json.loads(rep)) if return_report else data


def decompress(data: Union[bytes, bytearray, memoryview]):
    """Decode ``.mlz`` bytes: ``(V, F)`` float64 (n, 3) and int64 (m, 3)."""
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise CodecError(f"data must be bytes, got {type(data).__name__}")
    return _meshlap.decompress(bytes(data))


def compare(Va: Any, Fa: Any, Vb: Any, Fb: Any, *, map: Any = None, samples: int = 200_000) -> Dict[str, Any]:
    """Distortion of mesh B against A (÷ A's bounding-box diagonal): vertex RMS/max
    (same vertex count, or through ``map``: per vertex of B its vertex of A), Metro
    surface distances both ways and Hausdorff, Zhang's SDL measure and
    Karni–Gotsman's error when the connectivity is identical. Keys of
    ``meshlap compare --json``."""
    va, fa = _mesh(Va, Fa, "Va", "Fa")
    vb, fb = _mesh(Vb, Fb, "Vb", "Fb")
    m = None
    if map is not None:
        m = np.asarray(map)
        if m.ndim != 1 or m.shape[0] != vb.shape[0] or m.dtype.kind not in "iu":
            raise MetricError(f"map must be an integer array of shape ({vb.shape[0]},), got {m.dtype} {m.shape}")
        if (m < 0).any() or (m >= va.shape[0]).any():
            raise MetricError(f"map entries must be vertices of A (0..{va.shape[0] - 1})")
        m = np.ascontiguousarray(m, dtype=np.uint32)
    return _json.loads(_meshlap.compare(va, fa, vb, fb, m, int(samples)))


def render(
    V: Any,
    F: Any,
    scalars: Any = None,
    colormap: str = "viridis",
    azimuth: float = 0.0,
    elevation: float = 0.0,
    size: Optional[Tuple[int, int]] = None,
    *,
    smooth: bool = False,
    wireframe: bool = False,
    legend: bool = True,
) -> np.ndarray:
    """A picture of the mesh by meshlap's software rasterizer (orthographic, framed
    to fill the picture, two-sided Lambert shading). ``scalars``: one value per
    vertex (e.g. an eigenvector) through ``colormap`` (``viridis`` or ``coolwarm``),
    with a color bar unless ``legend=False``. ``size`` is (width, height), by default
    the library's (800, 800).

    Returns an (H, W, 3) uint8 RGB array."""
    v, f = _mesh(V, F)
    s = None if scalars is None else _vector(scalars, "scalars", v.shape[0])
    w, h = (None, None) if size is None else (int(size[0]), int(size[1]))
    return _meshlap.render(v, f, s, colormap, float(azimuth), float(elevation), w, h, smooth, wireframe, legend)


# ----------------------------------------------------------------------------------
# Descriptors


def _eigenpairs(evals: Any, evecs: Any) -> Tuple[np.ndarray, np.ndarray]:
    lam = _vector(evals, "evals")
    phi = np.asarray(evecs)
    if phi.ndim != 2 or phi.shape[1] != lam.shape[0] or phi.dtype.kind not in "fiu":
        raise SpectralError(
            f"evecs must be a real (n, {lam.shape[0]}) array (one column per eigenvalue), got {phi.shape}"
        )
    return lam, np.ascontiguousarray(phi, dtype=np.float64)


def hks(evals: Any, evecs: Any, times: Any = None, *, count: int = 100, return_times: bool = False):
    """Heat kernel signature (Sun, Ovsjanikov & Guibas 2009):
    ``HKS(x, t) = Σ_i exp(−λ_i t) φ_i(x)²``, an (n, T) float64 array, from
    eigenpairs of a PSD operator (``F = D − W``; e.g. :func:`eigs` with the cotangent
    kind). Default ``times``: ``count`` values log-spaced over
    ``[4 ln10/λ_max, 4 ln10/λ_1]`` (λ_1 the smallest non-zero eigenvalue), as the
    paper samples them."""
    lam, phi = _eigenpairs(evals, evecs)
    t = None if times is None else _vector(times, "times")
    out, used = _meshlap.hks(lam, phi, t, int(count))
    return (out, used) if return_times else out


def wks(
    evals: Any,
    evecs: Any,
    energies: Any = None,
    *,
    sigma: Optional[float] = None,
    count: int = 100,
    return_energies: bool = False,
):
    """Wave kernel signature (Aubry, Schlickewei & Cremers 2011):
    ``WKS(x, e) = Σ_i φ_i(x)² exp(−(e − log λ_i)²/2σ²) / Σ_i exp(−(e − log λ_i)²/2σ²)``
    over the non-zero eigenvalues, an (n, E) float64 array. Default: ``count``
    log-energies from ``log λ_1 + 2σ`` to ``log λ_max − 2σ`` with ``σ = 7δ`` (δ the
    increment), the paper's choice; for given ``energies`` σ defaults to 7 × their
    mean increment. With ``return_energies``: ``(WKS, energies, sigma)``."""
    lam, phi = _eigenpairs(evals, evecs)
    e = None if energies is None else _vector(energies, "energies")
    out, used, s = _meshlap.wks(lam, phi, e, None if sigma is None else float(sigma), int(count))
    return (out, used, s) if return_energies else out


# ----------------------------------------------------------------------------------
# Threads


def set_threads(n: int) -> None:
    """Run every later call on ``n`` threads (``0``: all cores, the default). A
    process forked after meshlap calls runs its calls on a pool of its own, of the
    parent's size."""
    if not isinstance(n, (int, np.integer)) or n < 0:
        raise Error(f"n must be a non-negative integer, got {n!r}")
    _meshlap.set_threads(int(n))


def get_threads() -> int:
    """The number of threads calls run on."""
    return _meshlap.get_threads()


def keep_freed_memory() -> bool:
    """Reuse freed memory instead of returning it to the kernel at once, for the
    whole process: glibc keeps up to 64 MiB of free memory per heap and serves every
    block below 32 MiB from its heaps (``mallopt(M_TOP_PAD)`` and
    ``mallopt(M_MMAP_THRESHOLD)``).

    meshlap's own buffers (everything the extension allocates, the arrays of its
    results included) do not need this: they come from the extension's allocator,
    mimalloc, which keeps freed memory for reuse for about a second
    (``MIMALLOC_PURGE_DELAY``, in milliseconds, changes that). This setting does the
    same for glibc's allocations: numpy's arrays (the converted copies of float32 or
    non-contiguous arguments among them) and other extensions. The ``meshlap``
    command does it at start; the package does not on import, since the setting
    applies to every other allocation of the interpreter. Returns whether the
    allocator took the setting (``False`` without glibc, where nothing changes).
    """
    return bool(_meshlap.keep_freed_memory())


def watermark_embed(
    V: Any,
    F: Any,
    key: int,
    message: str,
    *,
    operator: Optional[str] = None,
    strength: Optional[float] = None,
    chip_rate: Optional[int] = None,
    patch_size: Optional[int] = None,
    band: Optional[int] = None,
    msdm2: bool = True,
) -> Tuple[np.ndarray, Dict[str, Any]]:
    """Embed a watermark (Ohbuchi, Takahashi, Miyazawa, Mukaiyama 2001; Ohbuchi,
    Mukaiyama, Takahashi 2002; Zhang 2004 §4.9): the hex ``message`` (16 digits = 64
    bits) spread with the 64-bit ``key``'s ±1 chips over the low-frequency spectral
    coefficients of METIS patches, in the ED basis of a combinatorial operator
    (``operator``: kirchhoff (default), sql, sstl, tutte; PSD, F = D − W).

    V: float (n, 3), F: int (m, 3). Returns ``(V′, report)``: V′ float64 (n, 3) with the
    input's connectivity and vertex order; the report has the keys of
    ``meshlap watermark embed --json`` (bits, patches, coefficients_per_bit, mrms,
    max_displacement, msdm2, seconds). ``strength`` is the target RMS displacement ÷
    bounding-box diagonal. Options left at None take the library's defaults; detection
    must use the same operator, patch size, band and chip rate (``patch_size=None``:
    about 36 patches of at least 1,000 vertices, computed from the mesh). ``msdm2=False`` skips
    the MSDM2 measurement (the report's msdm2 is then None)."""
    v, f = _mesh(V, F)
    if not (0 <= int(key) < 2**64):
        raise WatermarkError(f"key must be an integer in [0, 2**64), got {key}")
    out, report = _meshlap.watermark_embed(v, f, int(key), str(message), operator, strength, chip_rate, patch_size, band, bool(msdm2))
    return out, _json.loads(report)


def watermark_detect(
    Vs: Any,
    Fs: Any,
    Vo: Any,
    Fo: Any,
    key: int,
    bits: int = 64,
    *,
    expect: Optional[str] = None,
    operator: Optional[str] = None,
    patch_size: Optional[int] = None,
    band: Optional[int] = None,
    chip_rate: Optional[int] = None,
    weighting: Optional[str] = None,
) -> Dict[str, Any]:
    """Non-blind detection of a watermark in the suspect ``(Vs, Fs)`` against the
    original ``(Vo, Fo)``: similarity registration (principal axes + ICP with scale),
    resampling onto the original's connectivity when it differs, the original's patch
    bases, correlation with the key's chips. Returns the keys of
    ``meshlap watermark detect --json``: message (hex, or None when no watermark is
    found), bits, correlations, false_positive_probability, registration, resampled,
    bit_errors and ber (with ``expect``), seconds. ``weighting``: ``"auto"`` (default:
    ``"patch-axis"`` for a suspect with the original's connectivity, ``"patch"`` for a
    resampled one), ``"patch-axis"`` (one inverse-variance weight per patch and axis)
    or ``"patch"`` (one per patch)."""
    vs, fs = _mesh(Vs, Fs, "Vs", "Fs")
    vo, fo = _mesh(Vo, Fo, "Vo", "Fo")
    if not (0 <= int(key) < 2**64):
        raise WatermarkError(f"key must be an integer in [0, 2**64), got {key}")
    return _json.loads(
        _meshlap.watermark_detect(vs, fs, vo, fo, int(key), int(bits), expect, operator, patch_size, band, chip_rate, weighting)
    )


__all__ = [
    "read_mesh",
    "write_mesh",
    "info",
    "clean",
    "operator",
    "mass_matrix",
    "properties",
    "spectrum",
    "eigs",
    "eigsh",
    "project",
    "compaction",
    "smooth",
    "repair_sql",
    "partition",
    "compress",
    "decompress",
    "compare",
    "render",
    "hks",
    "wks",
    "set_threads",
    "get_threads",
    "keep_freed_memory",
    "watermark_embed",
    "watermark_detect",
    "OPERATOR_KINDS",
    *errors.__all__,
]
