"""Every bad input is a ValueError subclass naming the argument: never a crash,
never a silent result."""

import numpy as np
import pytest
import scipy.sparse as sp

import meshlap


@pytest.fixture
def tet():
    return meshlap.read_mesh("builtin:tetrahedron")


def test_error_classes_are_value_errors():
    for cls in [meshlap.MeshError, meshlap.MeshIOError, meshlap.OperatorError, meshlap.SpectralError,
                meshlap.SolveError, meshlap.CodecError, meshlap.RenderError, meshlap.MetricError]:
        assert issubclass(cls, meshlap.Error) and issubclass(cls, ValueError)
    assert issubclass(meshlap.MeshIOError, OSError)


@pytest.mark.parametrize(
    "V, F, match",
    [
        (np.zeros((4, 2)), [[0, 1, 2]], r"V must have shape \(n, 3\), got \(4, 2\)"),
        (np.zeros(12), [[0, 1, 2]], r"V must have shape \(n, 3\)"),
        (np.zeros((4, 3)), [[0, 1]], r"F must have shape \(m, 3\), got \(1, 2\)"),
        (np.zeros((4, 3)), [[0, 1, 4]], r"F\[0\] = \[0, 1, 4\] refers to a vertex >= 4, but V has 4 vertices"),
        (np.zeros((4, 3)), [[0, -1, 2]], r"negative vertex index"),
        (np.zeros((4, 3)), np.zeros((0, 3), int), r"F is empty"),
        (np.zeros((4, 3)), [[0.0, 1.0, 2.0]], r"F must be an integer"),
        (np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0], [0, 0, 1]]), [[0, 1, 2]], r"V has a NaN or infinite coordinate at vertex 2"),
        (np.array([[0, 0, 0], [1, 0, 0], [0, np.inf, 0], [0, 0, 1]]), [[0, 1, 2]], r"vertex 2"),
        ([["a", "b", "c"]], [[0, 0, 0]], r"V must be a real"),
    ],
)
def test_bad_meshes(V, F, match):
    for fn in [lambda: meshlap.operator(V, F, "kirchhoff"), lambda: meshlap.info(V, F),
               lambda: meshlap.compress(V, F), lambda: meshlap.render(V, F)]:
        with pytest.raises(meshlap.MeshError, match=match):
            fn()


def test_library_checks_reach_python(tet):
    V, F = tet
    # A face with a repeated corner, or with the vertices of an earlier face, is
    # refused by the library (not cleaned silently), naming both faces.
    n = len(F)
    for dtype in [np.int64, np.uint32]:
        bad = np.vstack([F, [[0, 0, 1]]]).astype(dtype)
        with pytest.raises(meshlap.MeshError, match=rf"F\[{n}\] = \[0, 0, 1\] repeats a vertex"):
            meshlap.operator(V, bad, "kirchhoff")
        dup = np.vstack([F, F[1][::-1]]).astype(dtype)
        msg = rf"F\[{n}\] = \[{F[1][2]}, {F[1][1]}, {F[1][0]}\] repeats face F\[1\]; clean the mesh first"
        for fn in [lambda: meshlap.operator(V, dup, "kirchhoff"),
                   lambda: meshlap.mass_matrix(V, dup),
                   lambda: meshlap.write_mesh("never-written.ply", V, dup)]:
            with pytest.raises(meshlap.MeshError, match=msg):
                fn()
    # Cleaning drops the copy instead.
    V2, F2, rep = meshlap.clean(V, np.vstack([F, F[1][::-1]]))
    assert rep["dropped_duplicate_faces"] == 1 and len(F2) == n
    with pytest.raises(meshlap.OperatorError, match="unknown operator `nope`"):
        meshlap.operator(V, F, "nope")
    with pytest.raises(meshlap.OperatorError, match="unknown SQL boundary diagonal"):
        meshlap.operator(V, F, "sql", sql_diagonal="upside-down")
    with pytest.raises(meshlap.OperatorError, match="unknown mass matrix"):
        meshlap.mass_matrix(V, F, "lumpy")
    # Degenerate geometry for the cotangent operator.
    flat = V.copy()
    flat[:] = 0
    with pytest.raises(meshlap.OperatorError, match="degenerate"):
        meshlap.operator(flat, F, "cotan")
    with pytest.raises(meshlap.OperatorError, match="face 0 .* is degenerate"):
        meshlap.mass_matrix(flat, F)


def test_eigsh_bad_input():
    n = 30
    A = sp.random_array((n, n), density=0.2, random_state=1) if hasattr(sp, "random_array") else sp.random(n, n, 0.2, random_state=1)
    with pytest.raises(ValueError, match="must be symmetric"):
        meshlap.eigsh(A + sp.eye_array(n), 3)
    S = sp.csr_array(A @ A.T + sp.eye_array(n))
    with pytest.raises(meshlap.SpectralError, match="square"):
        meshlap.eigsh(sp.csr_array(np.ones((3, 4))), 1)
    with pytest.raises(meshlap.SpectralError, match="k must be at most n = 30"):
        meshlap.eigsh(S, 31)
    with pytest.raises(meshlap.SpectralError, match="positive integer"):
        meshlap.eigsh(S, 0)
    with pytest.raises(meshlap.SpectralError, match=r"M must have shape \(30,\)"):
        meshlap.eigsh(S, 2, np.ones(29))
    with pytest.raises(meshlap.SpectralError, match="not positive definite"):
        meshlap.eigsh(S, 2, -S)
    with pytest.raises(meshlap.SpectralError, match="M must be symmetric"):
        meshlap.eigsh(S, 2, sp.csr_array(S + sp.triu(S, 1)))
    with pytest.raises(meshlap.SpectralError, match=r"M must have shape \(30, 30\)"):
        meshlap.eigsh(S, 2, sp.eye_array(29))
    with pytest.raises(meshlap.SpectralError, match="mass of vertex 3"):
        m = np.ones(n)
        m[3] = -1
        meshlap.eigsh(S, 2, m)
    bad = S.copy()
    bad.data[0] = np.nan
    with pytest.raises(meshlap.SpectralError, match="non-finite"):
        meshlap.eigsh(bad, 2)


def test_descriptor_bad_input():
    lam = np.array([0.0, 1.0, 2.0])
    phi = np.eye(3)
    with pytest.raises(meshlap.SpectralError, match=r"evecs must be a real \(n, 3\)"):
        meshlap.hks(lam, phi[:, :2])
    with pytest.raises(meshlap.SpectralError, match="time 0 is -1"):
        meshlap.hks(lam, phi, [-1.0])
    with pytest.raises(meshlap.SpectralError, match="non-negative"):
        meshlap.wks(-lam - 1, phi, [0.0])
    with pytest.raises(meshlap.SpectralError, match="two distinct non-zero"):
        meshlap.hks(np.zeros(3), phi)


def test_io_codec_render_errors(tmp_path, tet):
    V, F = tet
    with pytest.raises(meshlap.MeshIOError) as e:
        meshlap.read_mesh(tmp_path / "missing.obj")
    assert isinstance(e.value, OSError)
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nf 1 2 3\n")
    with pytest.raises(meshlap.Error):
        meshlap.read_mesh(bad)
    with pytest.raises(meshlap.MeshIOError):
        meshlap.write_mesh(tmp_path / "x.unknown", V, F)
    with pytest.raises(meshlap.CodecError):
        meshlap.decompress(b"MLZ\x1a garbage")
    data = meshlap.compress(V, F)
    with pytest.raises(meshlap.CodecError):
        meshlap.decompress(data[: len(data) // 2])
    with pytest.raises(meshlap.CodecError):
        meshlap.compress(V, F, bits=99)
    with pytest.raises(meshlap.CodecError):
        meshlap.decompress("not bytes")
    with pytest.raises(meshlap.Error, match=r"scalars must have shape \(4,\)"):
        meshlap.render(V, F, scalars=np.ones(5))
    with pytest.raises(meshlap.RenderError, match="colormap"):
        meshlap.render(V, F, colormap="rainbow")
    with pytest.raises(meshlap.RenderError):
        meshlap.render(V, F, size=(2, 2))
    with pytest.raises(meshlap.MetricError, match="map must be"):
        meshlap.compare(V, F, V, F, map=[0, 1])


def test_filter_errors(tet):
    V, F = tet
    with pytest.raises(meshlap.SolveError, match="pass-band|passband"):
        meshlap.smooth(V, F, "butterworth")
    with pytest.raises(meshlap.SolveError):
        meshlap.smooth(V, F, lam=-1.0)
    with pytest.raises(meshlap.SolveError):
        meshlap.smooth(V, F, steps=0)
    with pytest.raises(meshlap.SolveError, match="needs a symmetric operator"):
        meshlap.smooth(*meshlap.read_mesh("builtin:grid:4"), "implicit", "tutte", solver="cg")
    with pytest.raises(meshlap.SolveError):
        meshlap.smooth(V, F, solver="magic")
    with pytest.raises(meshlap.Error):
        meshlap.project(V, F, "kirchhoff", 5)
    with pytest.raises(meshlap.PartitionError):
        meshlap.partition(V, F, 0)
    with pytest.raises(meshlap.PartitionError, match="unknown partition method"):
        meshlap.partition(V, F, 10, method="kway")


def test_index_dtypes_and_layouts_give_the_same_operator(tet):
    V, F = tet
    ref = meshlap.operator(V, F, "cotan").toarray()
    for f in [F.astype(np.uint32), F.astype(np.int32), F.astype(np.uint64), np.asfortranarray(F), F[:, :]]:
        assert np.array_equal(meshlap.operator(V, f, "cotan").toarray(), ref)
    for v in [V.astype(np.float32).astype(np.float64), np.asfortranarray(V), V.astype(np.float32)]:
        got = meshlap.operator(v, F, "kirchhoff").toarray()
        assert np.array_equal(got, meshlap.operator(V, F, "kirchhoff").toarray())
    # An index beyond the uint32 range is out of range, not wrapped.
    big = F.copy()
    big[1, 2] = 2**33
    with pytest.raises(meshlap.MeshError, match=r"F\[1\] = \[.*8589934592\] refers to a vertex >= 4"):
        meshlap.operator(V, big, "kirchhoff")


def test_two_mesh_functions_name_their_arguments(tet):
    V, F = tet
    bad = V.copy()
    bad[3, 0] = np.nan
    with pytest.raises(meshlap.MeshError, match="Vb has a NaN or infinite coordinate at vertex 3"):
        meshlap.compare(V, F, bad, F)
    with pytest.raises(meshlap.MeshError, match=r"Fa\[0\] = \[0, 1, 9\] refers to a vertex >= 4, but Va has 4"):
        meshlap.compare(V, np.array([[0, 1, 9]]), V, F)


def test_operators_are_the_csr_arrays_scipy_builds(tet):
    # meshlap builds its csr_array without scipy's argument checks when, on this
    # scipy, that gives the same object; either way the result is a canonical CSR.
    from meshlap import _csr_checked, _csr_direct_works, _meshlap

    V, F = meshlap.read_mesh("builtin:icosphere:2")
    L = meshlap.operator(V, F, "cotan")
    parts = _meshlap.operator(V, F, "cotan", "zero-row-sum", "voronoi")
    ref = _csr_checked(parts)
    assert _csr_direct_works()
    assert type(L) is type(ref) and L.shape == ref.shape and L.nnz == ref.nnz
    assert L.has_canonical_format and L.has_sorted_indices
    assert (L != ref).nnz == 0
    x = np.arange(V.shape[0], dtype=float)
    assert np.array_equal(L @ x, ref @ x)
    assert abs(L - L.T).max() < 1e-12
    assert np.allclose((L + sp.eye_array(V.shape[0])).toarray(), ref.toarray() + np.eye(V.shape[0]))
