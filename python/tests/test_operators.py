"""Operators against their scipy construction in the test, sign F = D − W."""

import numpy as np
import pytest
import scipy.sparse as sp

import meshlap
from conftest import adjacency


def dense(a):
    return a.toarray() if sp.issparse(a) else np.asarray(a)


@pytest.mark.parametrize("mesh", ["sphere", "grid"])
def test_combinatorial_operators_equal_scipy_construction(mesh, request):
    V, F = request.getfixturevalue(mesh)
    n = len(V)
    A = adjacency(F, n)
    d = np.asarray(A.sum(axis=1)).ravel()
    K = sp.diags_array(d) - A
    T = sp.eye_array(n) - sp.diags_array(1.0 / d) @ A
    G = sp.eye_array(n) - sp.diags_array(d ** -0.5) @ A @ sp.diags_array(d ** -0.5)
    for kind, ref in [("kirchhoff", K), ("tutte", T), ("graph", G), ("kl", K)]:
        L = meshlap.operator(V, F, kind)
        assert isinstance(L, sp.csr_array)
        assert L.dtype == np.float64 and L.shape == (n, n)
        np.testing.assert_allclose(dense(L), dense(ref), atol=1e-14, err_msg=kind)
    # The second-order ones: T² is not symmetric (its rows must not come out as its
    # columns), TᵀT is (its compressed columns are returned as the rows).
    for kind, ref in [("tutte2", T @ T), ("sstl", T.T @ T)]:
        L = meshlap.operator(V, F, kind)
        np.testing.assert_allclose(dense(L), dense(ref), atol=1e-13, err_msg=kind)


@pytest.mark.parametrize("kind", meshlap.OPERATOR_KINDS)
def test_every_operator_is_a_canonical_csr_array(sphere, kind):
    V, F = sphere
    L = meshlap.operator(V, F, kind)
    assert isinstance(L, sp.csr_array) and L.has_canonical_format
    assert L.indptr.dtype == np.int64 and L.indices.dtype == np.int64
    checked = sp.csr_array((L.data, L.indices, L.indptr), shape=L.shape)
    checked.check_format(full_check=True)
    assert checked.has_sorted_indices


def test_sql_closed_mesh_weights_and_unit_diagonal(sphere):
    V, F = sphere
    n = len(V)
    A = adjacency(F, n)
    d = np.asarray(A.sum(axis=1)).ravel()
    # W_ij = 1/d_i + 1/d_j − (1/d_k + 1/d_l)/2 with k, l the vertices opposite edge ij.
    W = np.zeros((n, n))
    for a, b, c in np.asarray(F):
        for i, j, k in [(a, b, c), (b, c, a), (c, a, b)]:
            W[i, j] += 0.5 * (1 / d[i] + 1 / d[j]) - 0.5 / d[k]
            W[j, i] += 0.5 * (1 / d[i] + 1 / d[j]) - 0.5 / d[k]
    S = dense(meshlap.operator(V, F, "sql"))
    np.testing.assert_allclose(S - np.diag(np.diag(S)), -W, atol=1e-14)
    np.testing.assert_allclose(np.diag(S), 1.0, atol=1e-14)
    np.testing.assert_allclose(S.sum(axis=1), 0.0, atol=1e-13)


def cotan_reference(V, F):
    """Cotangent stiffness (Pinkall–Polthier) assembled in numpy: positive
    semi-definite, L_ij = −(cot α + cot β)/2."""
    n = len(V)
    rows, cols, vals = [], [], []
    for tri in np.asarray(F):
        for c in range(3):
            o, i, j = tri[c], tri[(c + 1) % 3], tri[(c + 2) % 3]
            u, w = V[i] - V[o], V[j] - V[o]
            cot = np.dot(u, w) / np.linalg.norm(np.cross(u, w))
            rows += [i, j, i, j]
            cols += [j, i, i, j]
            vals += [-0.5 * cot, -0.5 * cot, 0.5 * cot, 0.5 * cot]
    return sp.coo_array((vals, (rows, cols)), shape=(n, n)).toarray()


@pytest.mark.parametrize("mesh", ["sphere", "grid"])
def test_cotan_equals_numpy_construction_and_is_minus_libigl(mesh, request):
    V, F = request.getfixturevalue(mesh)
    L = dense(meshlap.operator(V, F, "cotan"))
    np.testing.assert_allclose(L, cotan_reference(V, F), atol=1e-12)
    assert np.linalg.eigvalsh(L).min() > -1e-10  # PSD: F = D − W


def test_barycentric_mass_is_a_third_of_the_incident_areas(sphere):
    V, F = sphere
    F = np.asarray(F)
    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    ref = np.zeros(len(V))
    for c in range(3):
        np.add.at(ref, F[:, c], area / 3)
    M = meshlap.mass_matrix(V, F, "barycentric")
    assert sp.issparse(M) and M.shape == (len(V), len(V))
    np.testing.assert_allclose(M.diagonal(), ref, rtol=1e-13)
    # Voronoi areas tile the surface too.
    np.testing.assert_allclose(meshlap.mass_matrix(V, F).diagonal().sum(), area.sum(), rtol=1e-12)


@pytest.mark.parametrize("mesh", ["sphere", "grid", "jittered"])
def test_voronoi_mass_equals_a_numpy_construction(mesh, request, grid):
    """Mixed Voronoi areas (Meyer et al. 2003), computed face by face in numpy: the
    circumcentric share 1/8 (|e_ij|² cot γ + |e_ik|² cot β) at a corner of a
    non-obtuse triangle, else half the area at the obtuse corner, a quarter at the
    others. `mass_matrix` builds neither the stiffness nor the connectivity."""
    V, F = grid if mesh == "jittered" else request.getfixturevalue(mesh)
    V, F = np.array(V, dtype=float), np.asarray(F)
    if mesh == "jittered":
        # Up to 0.3 of the spacing in the plane: many obtuse triangles.
        V[:, :2] += np.random.default_rng(3).uniform(-0.3, 0.3, (len(V), 2)) / 8
    P = V[F]  # (f, 3 corners, 3)
    e = np.roll(P, -1, axis=1) - P  # edge k from corner k to corner k + 1
    area = 0.5 * np.linalg.norm(np.cross(e[:, 0], P[:, 2] - P[:, 0]), axis=1)
    # cot at corner k: the edges leaving it, e_k and −e_{k+2}.
    dots = -np.einsum("fkx,fkx->fk", e, np.roll(e, 1, axis=1))
    cot = dots / (2 * area)[:, None]
    len2 = np.einsum("fkx,fkx->fk", e, e)
    obtuse = cot < 0
    share = np.empty_like(cot)
    for k in range(3):
        j, l = (k + 1) % 3, (k + 2) % 3
        share[:, k] = (len2[:, k] * cot[:, l] + len2[:, l] * cot[:, j]) / 8
    any_obtuse = obtuse.any(axis=1)
    share[any_obtuse] = np.where(obtuse[any_obtuse], 0.5, 0.25) * area[any_obtuse, None]
    ref = np.zeros(len(V))
    for k in range(3):
        np.add.at(ref, F[:, k], share[:, k])
    M = meshlap.mass_matrix(V, F)
    np.testing.assert_allclose(M.diagonal(), ref, rtol=1e-12)
    assert any_obtuse.any() == (mesh == "jittered")


def test_float32_and_int32_inputs_give_the_same_operator(sphere):
    V, F = sphere
    a = meshlap.operator(V.astype(np.float32).astype(np.float64), F, "cotan")
    b = meshlap.operator(V.astype(np.float32), F.astype(np.int32), "cotan")
    c = meshlap.operator(V.astype(np.float32).tolist(), F.astype(np.uint32), "cotan")
    assert abs(a - b).max() == 0 and abs(a - c).max() == 0


def test_properties_report_measured_on_the_matrix(sphere, grid):
    V, F = sphere
    r = meshlap.properties(V, F, "sql")
    assert r["symmetric"] is True and r["gsml"]["is_gsml"] is True
    assert r["n"] == len(V)
    ev = np.linalg.eigvalsh(dense(meshlap.operator(V, F, "sql")))
    assert abs(r["lambda_max"] - ev.max()) < 1e-9
    r = meshlap.properties(*grid, "sql", sql_diagonal="printed")
    assert r["max_abs_row_sum"] > 1e-3  # the paper's printed boundary diagonal


def test_info_and_clean(sphere):
    V, F = sphere
    r = meshlap.info(V, F)
    for key in ["vertices", "faces", "edges", "boundary_edges", "boundary_loops", "components",
                "euler_characteristic", "non_manifold_edges", "non_manifold_vertices",
                "dropped_unreferenced_vertices", "dropped_degenerate_faces", "dropped_duplicate_faces",
                "source", "polygons_triangulated", "read"]:
        assert key in r
    assert r["euler_characteristic"] == 2 and r["genus"] == 0
    # An unreferenced vertex, a duplicate face and a degenerate one are dropped.
    V2 = np.vstack([V, [[9.0, 9.0, 9.0]]])
    F2 = np.vstack([F, F[:1], [[0, 0, 1]]])
    Vc, Fc, rep = meshlap.clean(V2, F2)
    assert (rep["dropped_unreferenced_vertices"], rep["dropped_duplicate_faces"], rep["dropped_degenerate_faces"]) == (1, 1, 1)
    # the keys of `meshlap clean --json` (the same library function)
    assert set(rep) == {"dropped_unreferenced_vertices", "dropped_degenerate_faces",
                        "dropped_duplicate_faces", "split", "vertices", "faces",
                        "non_manifold_edges", "non_manifold_vertices"}
    np.testing.assert_array_equal(Vc, V)
    np.testing.assert_array_equal(Fc, F)
    assert Fc.dtype == np.int64
    assert meshlap.info(V2, F2)["dropped_unreferenced_vertices"] == 1
