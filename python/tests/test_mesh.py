"""Round trips (files, compression), smoothing against scipy, repair, partition,
compare and render."""

import platform
import sys

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import meshlap
from conftest import shared_mesh


@pytest.mark.parametrize("ext", ["obj", "ply", "off"])
def test_write_read_round_trip_is_exact(tmp_path, sphere, ext):
    V, F = sphere
    V = V * np.pi  # full-precision coordinates
    p = tmp_path / f"m.{ext}"
    meshlap.write_mesh(p, V, F)
    V2, F2 = meshlap.read_mesh(p)
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(F2, F)
    assert V2.dtype == np.float64 and F2.dtype == np.int64


def test_write_ply_with_scalars_and_colors(tmp_path, sphere):
    V, F = sphere
    p = tmp_path / "c.ply"
    meshlap.write_mesh(p, V, F, scalars=V[:, 0], colors=np.zeros((len(V), 3), np.uint8), scalar_name="x")
    text = p.read_bytes()[:400]
    assert b"property double x" in text and b"property uchar red" in text
    V2, F2 = meshlap.read_mesh(p)
    np.testing.assert_array_equal(V2, V)


def test_read_builtin_and_shared_file():
    V, F = meshlap.read_mesh("builtin:torus:12:8")
    assert V.shape == (96, 3) and F.shape == (192, 3)
    V, F = meshlap.read_mesh(shared_mesh("cow.obj"))
    assert meshlap.info(V, F)["vertices"] == len(V)


def test_compress_decompress_round_trip(sphere):
    V, F = sphere
    data, rep = meshlap.compress(V, F, bits=12, preserve_order=True, return_report=True)
    assert isinstance(data, bytes) and rep["bytes"] == len(data)
    V2, F2 = meshlap.decompress(data)
    # Connectivity exactly (same vertex order), geometry within the quantization: the
    # RMS within the step (below); the largest error within two steps, since the
    # spectral coder (which auto keeps here since format 7) spreads a coefficient's
    # rounding over its patch, so one vertex can exceed a step (1.17 steps here).
    assert sorted(map(tuple, np.sort(F2, axis=1))) == sorted(map(tuple, np.sort(F, axis=1)))
    diag = np.linalg.norm(V.max(0) - V.min(0))
    assert rep["geometry_mode"] in ("spectral", "spatial")
    assert np.abs(V2 - V).max() <= diag * 2.0**-11
    c = meshlap.compare(V, F, V2, F2, samples=2000)
    assert c["vertex_rms"] < 2.0**-12 and c["hausdorff"] < 2.0**-11
    # Spatial and spectral coders both round-trip; a lower rate is smaller.
    for mode in ["spatial", "spectral"]:
        d = meshlap.compress(V, F, bits=8, mode=mode)
        assert len(meshlap.decompress(d)[0]) == len(V)
    assert len(meshlap.compress(V, F, bits=6)) < len(meshlap.compress(V, F, bits=14))


def test_compare_identical_meshes_is_zero(sphere):
    V, F = sphere
    c = meshlap.compare(V, F, V, F, samples=1000)
    assert c["same_connectivity"] is True
    assert c["vertex_rms"] == 0 and c["hausdorff"] < 1e-12


def test_implicit_smoothing_equals_scipy_solve(sphere):
    rng = np.random.default_rng(3)
    V, F = sphere
    V = V + 0.01 * rng.standard_normal(V.shape)
    S = meshlap.operator(V, F, "sql")
    lam = 5.0
    Vs, info = meshlap.smooth(V, F, "implicit", "sql", lam=lam, steps=2, solver="cholesky")
    ref = V
    for _ in range(2):
        ref = spla.spsolve((sp.eye_array(len(V)) + lam * S).tocsc(), ref)
    np.testing.assert_allclose(Vs, ref, atol=1e-10)
    assert info["solver"] == "cholesky" and len(info["solves"]) == 2
    # CG: iterations per column and the residual history per iteration.
    Vc, info = meshlap.smooth(V, F, operator="sql", lam=lam, stop="strong", tol=1e-12)
    np.testing.assert_allclose(Vc, spla.spsolve((sp.eye_array(len(V)) + lam * S).tocsc(), V), atol=1e-9)
    assert info["solver"] == "cg" and len(info["iterations"]) == 3
    hist = info["solves"][0]["history"]  # per column: relative residual per iteration
    assert len(hist) == 3 and [len(h) for h in hist] >= info["iterations"]
    assert hist[0][-1] < 1e-12 < hist[0][0] and max(info["residuals"]) < 1e-11


def test_bicg_on_the_tutte_system_equals_scipy_solve(sphere):
    # The TL is not symmetric; BiCG solves (I + λT)x = b through its symmetrizer D
    # ((I + λT)ᵀ = D(I + λT)D⁻¹), and must agree with a direct solve and with LU.
    rng = np.random.default_rng(5)
    V, F = sphere
    V = V + 0.01 * rng.standard_normal(V.shape)
    T = meshlap.operator(V, F, "tutte")
    assert abs(T - T.T).max() > 1e-3
    lam = 30.0
    ref = spla.spsolve((sp.eye_array(len(V)) + lam * T).tocsc(), V)
    Vb, info = meshlap.smooth(V, F, "implicit", "tutte", lam=lam, solver="bicg", stop="strong", tol=1e-12)
    assert info["solver"] == "bicg" and max(info["residuals"]) < 1e-11
    np.testing.assert_allclose(Vb, ref, atol=1e-9)
    Vl, _ = meshlap.smooth(V, F, "implicit", "tutte", lam=lam, solver="lu")
    np.testing.assert_allclose(Vl, ref, atol=1e-10)


def test_smooth_default_operator_is_the_librarys():
    import inspect

    from meshlap import _meshlap

    default = inspect.signature(meshlap.smooth).parameters["operator"].default
    assert default == _meshlap.DEFAULT_SMOOTH_OPERATOR == "sql"


def test_taubin_and_explicit_filters_take_library_defaults(sphere):
    V, F = sphere
    for name in ["explicit", "taubin"]:
        Vs, info = meshlap.smooth(V, F, name, "kirchhoff", lam=0.1)
        assert Vs.shape == V.shape and info["filter"]["filter"] == name


def test_repair_sql_removes_negative_weights():
    V, F = meshlap.read_mesh(shared_mesh("cow.obj"))
    S = meshlap.operator(V, F, "sql")
    off = S - sp.diags_array(S.diagonal())
    negative_before = int((off.data > 1e-15).sum() // 2)  # W = −offdiag < 0
    V2, F2, rep = meshlap.repair_sql(V, F)
    assert rep["negative_before"] == negative_before > 0
    assert rep["negative_after"] == 0 and rep["flips"] > 0
    np.testing.assert_array_equal(V2, V)  # swaps keep the vertices
    S2 = meshlap.operator(V2, F2, "sql")
    off2 = S2 - sp.diags_array(S2.diagonal())
    assert (off2.data > 1e-15).sum() == 0


def test_partition_labels(big_sphere):
    V, F = big_sphere
    labels, stats = meshlap.partition(V, F, 100, return_stats=True)
    assert labels.dtype == np.int32 and labels.shape == (len(V),)
    assert labels.min() == 0 and labels.max() + 1 == stats["patches"]
    assert np.bincount(labels).min() == stats["min_size"]
    assert stats["method"] == "metis"


def test_partition_lloyd_cells(big_sphere):
    V, F = big_sphere
    labels, stats = meshlap.partition(V, F, 100, method="lloyd", return_stats=True)
    assert stats["method"] == "lloyd" and labels.max() + 1 == stats["patches"]
    metis = meshlap.partition(V, F, 100, return_stats=True)[1]
    assert stats["edge_cut"] <= 1.1 * metis["edge_cut"]
    again = meshlap.partition(V, F, 100, method="lloyd")
    np.testing.assert_array_equal(again, labels)


def test_partition_lloyd_iterations(big_sphere):
    V, F = big_sphere
    default = meshlap.partition(V, F, 100, method="lloyd")
    five = meshlap.partition(V, F, 100, method="lloyd", lloyd_iterations=5)
    np.testing.assert_array_equal(default, five)
    two, stats = meshlap.partition(V, F, 100, method="lloyd", lloyd_iterations=2,
                                   return_stats=True)
    assert two.shape == (len(V),) and two.max() + 1 == stats["patches"]
    assert np.bincount(two).min() == stats["min_size"]
    with pytest.raises(meshlap.PartitionError, match="at most 100"):
        meshlap.partition(V, F, 100, method="lloyd", lloyd_iterations=101)


def test_render_returns_an_rgb_picture(sphere):
    V, F = sphere
    img = meshlap.render(V, F, size=(120, 90))
    assert img.shape == (90, 120, 3) and img.dtype == np.uint8
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 5
    _, evecs = meshlap.eigs(V, F, 4, "kirchhoff")
    img2 = meshlap.render(V, F, scalars=evecs[:, 3], colormap="coolwarm", size=(200, 160))
    assert img2.shape == (160, 200, 3)


def test_threads_and_results_do_not_depend_on_them(big_sphere):
    V, F = big_sphere
    meshlap.set_threads(1)
    assert meshlap.get_threads() == 1
    a = meshlap.eigs(V, F, 10, "sql")[0]
    meshlap.set_threads(0)
    b = meshlap.eigs(V, F, 10, "sql")[0]
    # atol for λ₀ = 0, which each thread count computes as a different ~1e-17.
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-14)


def test_calls_release_the_gil():
    """A Python thread keeps running while meshlap computes: the largest gap between
    its time stamps stays far below the length of the call (holding the GIL, the gap
    would be the whole call)."""
    import threading
    import time

    V, F = meshlap.read_mesh("builtin:icosphere:4")
    stamps = []
    done = threading.Event()

    def spin():
        while not done.is_set():
            stamps.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=spin)
    t.start()
    try:
        t0 = time.perf_counter()
        meshlap.eigs(V, F, 150, "cotan")
        elapsed = time.perf_counter() - t0
    finally:
        done.set()
        t.join()
    calls = [s for s in stamps if t0 <= s <= t0 + elapsed]
    gap = np.diff(calls).max()
    assert len(calls) > 2 and gap < 0.5 * elapsed, (elapsed, gap)


def test_keep_freed_memory_changes_no_result():
    # The allocator setting is a speed option only: a dense basis computed before
    # and after it is the same to the bit.
    V, F = meshlap.read_mesh("builtin:icosphere:2")
    a = meshlap.eigs(V, F, 20, "sql")
    took = meshlap.keep_freed_memory()
    assert isinstance(took, bool)
    if sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc":
        assert took
    b = meshlap.eigs(V, F, 20, "sql")
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
