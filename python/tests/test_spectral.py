"""eigsh / eigs against scipy and numpy, HKS / WKS against their closed forms,
projection and compaction against a dense numpy construction."""

import sys

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

import meshlap


def check_pairs(A, M, evals, evecs, tol=1e-8):
    """Residuals ‖Av − λMv‖ small, VᵀMV = I, ascending."""
    Md = sp.eye_array(A.shape[0]) if M is None else M
    R = A @ evecs - (Md @ evecs) * evals
    scale = max(1.0, abs(evals).max())
    assert np.abs(R).max() < tol * scale
    np.testing.assert_allclose(evecs.T @ (Md @ evecs), np.eye(len(evals)), atol=1e-9)
    assert np.all(np.diff(evals) >= -1e-12)


def compare_to_scipy(evals, ref):
    scale = max(abs(ref).max(), 1.0)
    for a, b in zip(evals, ref):
        assert abs(a - b) <= 1e-9 * max(abs(b), 1e-3 * scale), (a, b)


def test_eigsh_matches_lapack_on_the_sql(big_sphere):
    V, F = big_sphere
    S = meshlap.operator(V, F, "sql")
    k = 30
    evals, evecs, res = meshlap.eigsh(S, k, return_residuals=True)
    # Dense LAPACK, not ARPACK: the sphere's eigenvalues are multiple and ARPACK's
    # shift-invert from a random start vector may miss a copy (it did in CI).
    ref = sla.eigh(S.toarray(), eigvals_only=True, subset_by_index=[0, k - 1])
    compare_to_scipy(evals, ref)
    check_pairs(S, None, evals, evecs)
    assert res.shape == (k,) and res.max() < 1e-8
    assert evecs.shape == (len(V), k) and evecs.dtype == np.float64


def test_eigsh_generalized_cotan_with_lumped_mass(big_sphere):
    V, F = big_sphere
    L = meshlap.operator(V, F, "cotan")
    M = meshlap.mass_matrix(V, F)
    k = 25
    evals, evecs = meshlap.eigsh(L, k, M)
    ref = sla.eigh(L.toarray(), M.toarray(), eigvals_only=True, subset_by_index=[0, k - 1])
    compare_to_scipy(evals, ref)
    check_pairs(L, M, evals, evecs)
    # The mass may also be given as its diagonal, dense or sparse.
    e2, _ = meshlap.eigsh(L, k, M.diagonal())
    e3, _ = meshlap.eigsh(L.toarray(), k, M.toarray())
    np.testing.assert_allclose(e2, evals, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(e3, evals, rtol=1e-10, atol=1e-10)
    # eigs on the mesh uses the same mass automatically.
    e4, v4 = meshlap.eigs(V, F, k, "cotan")
    np.testing.assert_allclose(e4, evals, rtol=1e-10, atol=1e-10)


def consistent_mass(V, F):
    """The linear finite-element mass matrix: A/6 on the diagonal, A/12 off it."""
    e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
    rows = np.repeat(F, 3, axis=1).ravel()
    cols = np.tile(F, (1, 3)).ravel()
    w = np.where(np.tile(np.eye(3).ravel(), len(F)) == 1, 1 / 6, 1 / 12) * np.repeat(area, 9)
    return sp.csr_array(sp.coo_array((w, (rows, cols)), shape=(len(V), len(V))))


@pytest.mark.parametrize("mesh", ["sphere", "big_sphere"])
def test_eigsh_with_a_consistent_mass_matrix(mesh, request):
    """A non-diagonal SPD M (dense path for the small sphere, shift-invert bands for the
    big one) against scipy's dense generalized eigh."""
    V, F = request.getfixturevalue(mesh)
    L = meshlap.operator(V, F, "cotan")
    M = consistent_mass(V, F)
    assert abs(M - M.T).max() == 0 and (M - sp.diags_array(M.diagonal())).nnz > 0
    k = 20
    evals, evecs, res = meshlap.eigsh(L, k, M, return_residuals=True)
    check_pairs(L, M, evals, evecs)
    assert res.max() < 1e-8 * max(1.0, evals.max())
    # scipy's dense generalized eigh as the reference: its shift-invert eigsh (ARPACK,
    # random start) sometimes skips a copy of the sphere's nearly 9-fold eigenvalue
    # that k = 20 cuts through.
    ref = sla.eigh(L.toarray(), M.toarray(), eigvals_only=True)[:k]
    compare_to_scipy(evals, ref)
    # A dense M is the same problem.
    e2, _ = meshlap.eigsh(L, k, M.toarray())
    np.testing.assert_allclose(e2, evals, rtol=1e-10, atol=1e-10)


def test_eigsh_singular_matrix_at_sigma_zero_works(big_sphere):
    """The Kirchhoff operator is singular (constant null vector): shift-invert at
    σ = 0 factors a singular matrix; meshlap's shifts never sit on an eigenvalue."""
    V, F = big_sphere
    K = meshlap.operator(V, F, "kirchhoff")
    evals, evecs = meshlap.eigsh(K, 12)
    assert abs(evals[0]) < 1e-9
    # The constant null vector, unit length; its sign is the crate's canonical one
    # (v · r0 >= 0 for the fixed probe vector r0), not necessarily positive.
    c = evecs[:, 0] * np.sign(evecs[0, 0])
    np.testing.assert_allclose(c, np.full(len(V), 1 / np.sqrt(len(V))), atol=1e-9)
    ref = np.linalg.eigvalsh(K.toarray())[:12]
    compare_to_scipy(evals, ref)
    check_pairs(K, None, evals, evecs)


def test_eigsh_dense_path_and_multiplicities(sphere):
    """Below 600 rows the dense solver runs; the icosphere's multiple eigenvalues
    come with all their copies (completeness)."""
    V, F = sphere
    K = meshlap.operator(V, F, "kirchhoff")
    k = 16  # 1 + 3 + 5 + 7: the first four clusters exactly
    evals, evecs = meshlap.eigsh(K, k)
    ref = np.linalg.eigvalsh(K.toarray())[:k]
    compare_to_scipy(evals, ref)
    check_pairs(K, None, evals, evecs)


def test_eigsh_random_spd_matrix_not_from_a_mesh():
    rng = np.random.default_rng(7)
    n = 700
    B = sp.random_array((n, n), density=0.01, random_state=rng) if hasattr(sp, "random_array") else sp.random(n, n, 0.01, random_state=7)
    A = sp.csr_array(B @ B.T + sp.eye_array(n) * 1e-3)
    evals, evecs = meshlap.eigsh(A, 10)
    ref = np.linalg.eigvalsh(A.toarray())[:10]
    compare_to_scipy(evals, ref)
    check_pairs(A, None, evals, evecs)


def test_eigs_tutte_through_its_symmetrizer(sphere):
    V, F = sphere
    T = meshlap.operator(V, F, "tutte").toarray()
    evals, evecs = meshlap.eigs(V, F, 10, "tutte")
    ref = np.sort(np.linalg.eigvals(T).real)[:10]
    np.testing.assert_allclose(evals, ref, atol=1e-10)
    np.testing.assert_allclose(T @ evecs, evecs * evals, atol=1e-9)


def heat_diag(K, t):
    return np.diag(sla.expm(-t * K))


def test_hks_equals_heat_kernel_diagonal_from_dense_spectrum(sphere):
    V, F = sphere
    K = meshlap.operator(V, F, "kirchhoff").toarray()
    lam, phi = np.linalg.eigh(K)
    times = np.array([0.01, 0.1, 1.0])
    H = meshlap.hks(lam, phi, times)
    assert H.shape == (len(V), 3)
    for j, t in enumerate(times):
        np.testing.assert_allclose(H[:, j], heat_diag(K, t), rtol=1e-10, atol=1e-12)
    # Default times: Sun et al.'s log-spaced [4 ln10/λ_max, 4 ln10/λ_1].
    H2, t2 = meshlap.hks(lam, phi, count=7, return_times=True)
    c = 4 * np.log(10)
    np.testing.assert_allclose([t2[0], t2[-1]], [c / lam[-1], c / lam[1]], rtol=1e-12)
    np.testing.assert_allclose(np.diff(np.log(t2)), np.log(t2[1] / t2[0]), rtol=1e-9)
    np.testing.assert_allclose(H2[:, 0], (phi**2) @ np.exp(-lam * t2[0]), rtol=1e-12)


def test_wks_closed_form_and_default_energies(sphere):
    V, F = sphere
    lam, phi = meshlap.eigs(V, F, 40, "cotan")
    e = np.linspace(np.log(lam[1]) + 0.5, np.log(lam[-1]) - 0.5, 5)
    s = 0.3
    W = meshlap.wks(lam, phi, e, sigma=s)
    pos = lam > 1e-9 * lam[-1]
    g = np.exp(-((e[None, :] - np.log(lam[pos])[:, None]) ** 2) / (2 * s * s))
    ref = (phi[:, pos] ** 2) @ g / g.sum(axis=0)
    np.testing.assert_allclose(W, ref, rtol=1e-12)
    W2, e2, s2 = meshlap.wks(lam, phi, count=10, return_energies=True)
    delta = e2[1] - e2[0]
    np.testing.assert_allclose(s2, 7 * delta, rtol=1e-12)
    np.testing.assert_allclose(e2[0], np.log(lam[1]) + 2 * s2, rtol=1e-12)
    np.testing.assert_allclose(e2[-1], np.log(lam[-1]) - 2 * s2, rtol=1e-9)
    # M-weighted columns of the WKS sum to 1 (convex combinations of M-normalised φ²).
    m = meshlap.mass_matrix(V, F).diagonal()
    np.testing.assert_allclose(m @ W2, 1.0, rtol=1e-9)


def test_project_equals_dense_truncated_projection(sphere):
    V, F = sphere
    K = meshlap.operator(V, F, "kirchhoff").toarray()
    lam, E = np.linalg.eigh(K)
    keep = 16  # at a gap between clusters (1 + 3 + 5 + 7)
    assert lam[keep] - lam[keep - 1] > 1e-3
    ref = E[:, :keep] @ (E[:, :keep].T @ V)
    np.testing.assert_allclose(meshlap.project(V, F, "kirchhoff", keep), ref, atol=1e-10)
    np.testing.assert_allclose(meshlap.project(V, F, "sql", len(V)), V, atol=1e-10)
    Vp = meshlap.project(V, F, "kirchhoff", "10%", patch_size=40)
    assert Vp.shape == V.shape and np.isfinite(Vp).all()


def test_compaction_is_the_cumulative_coefficient_energy(sphere):
    V, F = sphere
    K = meshlap.operator(V, F, "kirchhoff").toarray()
    _, E = np.linalg.eigh(K)
    X = E.T @ V
    ref = np.cumsum(X**2, axis=0) / (X**2).sum(axis=0)
    c = meshlap.compaction(V, F, "kirchhoff")
    assert c.shape == (len(V), 4)
    # Per coordinate: equal where the eigenbasis is unique (cluster boundaries).
    np.testing.assert_allclose(c[15, :3], ref[15], atol=1e-10)
    np.testing.assert_allclose(c[-1], 1.0, atol=1e-12)
    assert np.all(np.diff(c[:, 3]) >= -1e-15)


def test_eigsh_refinement_lowers_the_residuals(big_sphere):
    V, F = big_sphere
    S = meshlap.operator(V, F, "sql")
    L, M = meshlap.operator(V, F, "cotan"), meshlap.mass_matrix(V, F)
    for A, B in [(S, None), (L, M)]:
        w1, v1 = meshlap.eigsh(A, 40, B)
        w0, v0 = meshlap.eigsh(A, 40, B, refine=False)
        Bd = sp.eye_array(A.shape[0]) if B is None else B
        worst = lambda w, v: np.linalg.norm(A @ v - (Bd @ v) * w, axis=0).max()
        assert worst(w1, v1) < worst(w0, v0)
        np.testing.assert_allclose(w1, w0, rtol=1e-9, atol=1e-12)
        check_pairs(A, B, w1, v1)
    with pytest.raises(meshlap.SpectralError, match="tolerance must be in"):
        meshlap.eigsh(S, 5, tol=0.0)


def test_band_and_block_sizes_change_the_path_not_the_spectrum(big_sphere):
    # Several small bands with small blocks against the default single band: the same
    # eigenvalues (the sphere's multiple ones included), both complete and accurate.
    V, F = big_sphere
    S = meshlap.operator(V, F, "sql")
    k = 40
    w_default, v_default = meshlap.eigsh(S, k)
    w_bands, v_bands = meshlap.eigsh(S, k, band_size=12, block_size=4)
    np.testing.assert_allclose(w_bands, w_default, rtol=1e-9, atol=1e-12)
    check_pairs(S, None, w_bands, v_bands)
    w_eigs, _ = meshlap.eigs(V, F, k, "sql", band_size=12, block_size=4)
    np.testing.assert_allclose(w_eigs, w_default, rtol=1e-9, atol=1e-12)
    with pytest.raises(meshlap.SpectralError, match="block size"):
        meshlap.eigsh(S, 5, band_size=4, block_size=8)
    for bad in [0, -3, 2.5, True]:
        with pytest.raises(meshlap.SpectralError, match="positive integer"):
            meshlap.eigs(V, F, 5, "sql", band_size=bad)


def test_spectrum_is_the_dense_ed_transform():
    """`meshlap.spectrum` (the CLI's `spectrum`) against numpy's dense solvers: all n
    eigenpairs of the KL and SQL (symmetric), of the TL (symmetrized and general paths,
    unit columns as Matlab's eig), the k smallest with `count`, and the info dict."""
    V, F = meshlap.read_mesh("builtin:torus:24:12")
    n = len(V)
    for kind in ["kl", "sql"]:
        A = meshlap.operator(V, F, kind).toarray()
        evals, evecs = meshlap.spectrum(V, F, kind)
        assert evals.shape == (n,) and evecs.shape == (n, n)
        np.testing.assert_allclose(evals, np.linalg.eigvalsh(A), atol=1e-12)
        check_pairs(sp.csr_array(A), None, evals, evecs, tol=1e-12)
    # The TL on a mesh of unequal degrees (on the torus it is KL/6, symmetric).
    V, F = meshlap.read_mesh("builtin:icosphere:2")
    n = len(V)
    T = meshlap.operator(V, F, "tl").toarray()
    ref = np.sort(np.linalg.eigvals(T).real)
    for path in ["auto", "general"]:
        evals, evecs, info = meshlap.spectrum(V, F, "tl", path=path, return_info=True)
        np.testing.assert_allclose(evals, ref, atol=1e-10)
        assert np.abs(T @ evecs - evecs * evals).max() < 1e-10
        np.testing.assert_allclose(np.linalg.norm(evecs, axis=0), 1.0, atol=1e-12)
        assert info["path"] == ("symmetrized" if path == "auto" else "general")
        assert sum(info["multiplicities"]) == n and info["max_residual"] < 1e-10
    # Weighted: orthonormal in the symmetrizer's inner product. The TL's symmetrizer
    # is the degree matrix D up to one free scale per connected component, so on a
    # connected mesh EᵀDE is a multiple of the identity.
    evals, evecs, info = meshlap.spectrum(
        V, F, "tl", normalization="weighted", return_info=True
    )
    D = np.diag(meshlap.operator(V, F, "kl").diagonal())
    G = evecs.T @ D @ evecs
    np.testing.assert_allclose(G, G[0, 0] * np.eye(n), atol=1e-9 * G[0, 0])
    assert info["orthonormality_error"] < 1e-10
    # The k smallest, with another dense solver: the same values.
    small, vecs = meshlap.spectrum(V, F, "sql", 7, dense_solver="reproducible")
    assert small.shape == (7,) and vecs.shape == (n, 7)
    np.testing.assert_allclose(small, np.linalg.eigvalsh(meshlap.operator(V, F, "sql").toarray())[:7], atol=1e-12)


def test_spectrum_bad_options():
    V, F = meshlap.read_mesh("builtin:grid:4")
    with pytest.raises(meshlap.SpectralError, match="normalization"):
        meshlap.spectrum(V, F, "kl", normalization="euclid")
    with pytest.raises(meshlap.SpectralError, match="dense solver"):
        meshlap.spectrum(V, F, "kl", dense_solver="lapack")
    with pytest.raises(ValueError):
        meshlap.spectrum(V, F, "kl", path="sideways")
    with pytest.raises(ValueError):
        meshlap.spectrum(V, F, "kl", 0)
    with pytest.raises(ValueError):
        meshlap.spectrum(V, F, "tl", path="symmetric")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/status")
def test_memory_freed_by_a_large_call_is_returned_while_idle():
    """The extension allocates with mimalloc, which keeps freed memory for reuse for
    about a second; its purge thread then has the pool's threads return it, without
    another meshlap call (without that thread it stayed resident until the next call)."""
    import time

    def rss_mb():
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmRSS"):
                    return int(line.split()[1]) / 1024

    V, F = meshlap.read_mesh("builtin:icosphere:6")  # 40,962 vertices
    time.sleep(2.5)  # what earlier tests freed is returned first
    before = rss_mb()
    ev, vec = meshlap.eigs(V, F, 60, "kirchhoff")
    del ev, vec
    after = rss_mb()
    assert after - before > 60, "the call should leave freed memory behind at first"
    deadline = time.monotonic() + 8
    while rss_mb() > before + 0.5 * (after - before) and time.monotonic() < deadline:
        time.sleep(0.25)
    assert rss_mb() <= before + 0.5 * (after - before), (before, after, rss_mb())


def _in_forked_child():
    """Run in a child forked after the parent's calls: the same operator as the parent,
    the pool's size, and (Linux) the resident MB before a large call, after it, and
    once the child's own purge thread has returned what the call freed (or 8 s later)."""
    import time

    V, F = meshlap.read_mesh("builtin:icosphere:3")
    A = meshlap.operator(V, F, "cotan")
    purge = None
    if sys.platform.startswith("linux"):

        def rss_mb():
            with open("/proc/self/status") as f:
                for line in f:
                    if line.startswith("VmRSS"):
                        return int(line.split()[1]) / 1024

        V6, F6 = meshlap.read_mesh("builtin:icosphere:6")
        # What the parent had freed but not yet returned when it forked is the child's
        # too, resident and reusable: let the child's purge thread return it first, or
        # it shrinks the call's growth (as in the parent's test above).
        time.sleep(2.5)
        before = rss_mb()
        ev, vec = meshlap.eigs(V6, F6, 60, "kirchhoff")
        del ev, vec
        after = rss_mb()
        deadline = time.monotonic() + 8
        while rss_mb() > before + 0.5 * (after - before) and time.monotonic() < deadline:
            time.sleep(0.25)
        purge = (before, after, rss_mb())
    return A.indptr.tolist(), A.indices.tolist(), A.data.tolist(), meshlap.get_threads(), purge


@pytest.mark.skipif(not hasattr(__import__("os"), "fork"), reason="no fork on this platform")
@pytest.mark.parametrize("threads", [0, 1])
def test_a_forked_child_computes_on_threads_of_its_own(threads):
    """A process forked after meshlap calls (multiprocessing's `fork` start method)
    inherits the pools without their threads; its calls must run on pools of its own,
    of the parent's size, instead of waiting forever."""
    import multiprocessing

    meshlap.set_threads(threads)
    try:
        V, F = meshlap.read_mesh("builtin:icosphere:3")
        A = meshlap.operator(V, F, "cotan")  # the parent's pool has run
        expected_threads = meshlap.get_threads()
        with multiprocessing.get_context("fork").Pool(1) as pool:
            indptr, indices, data, child_threads, purge = pool.apply_async(_in_forked_child).get(timeout=120)
        assert (indptr, indices, data) == (A.indptr.tolist(), A.indices.tolist(), A.data.tolist())
        assert child_threads == expected_threads
        if purge is not None:
            before, after, final = purge
            assert after - before > 60, f"the child's call should leave freed memory behind at first: {purge}"
            assert final <= before + 0.5 * (after - before), f"the child's purge thread should return freed memory: {purge}"
        # The parent's own pool still works.
        assert meshlap.operator(V, F, "cotan").nnz == A.nnz
    finally:
        meshlap.set_threads(0)
