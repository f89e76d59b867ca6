"""Implicit-fairing solvers: meshlap vs scipy (cg, bicg) and CHOLMOD (scikit-sparse).

Run: bench/.venv/bin/python bench/solvers.py [MESH] [LAMBDA]   (default: igea.ply, 30)

The same matrices on both sides: meshlap-bench exports (I + λS) (SQL), (I + λT) (TL)
and the symmetrised TL (D + λK) as Matrix Market, which this script reads; they are
also rebuilt here with scipy (bench/operators.py) and checked equal. Three coordinate
columns, x0 = 0, relative residual ‖Ax − b‖/‖b‖ < 1e-5 on both sides (scipy solves one
column at a time, meshlap all three in one blocked iteration). Both sides use
BENCH_THREADS threads (default 2). Prints medians, iterations and ratios, and
meshlap's time per iteration against the memory-traffic bound (bytes an iteration
must move / streaming-copy bandwidth measured in the same run by meshlap-bench).
"""
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from common import MESHES, THREADS, limit_threads, load_vf, meshlap_bench, table, timeit
from operators import kirchhoff, sql, tutte

REPEAT = 11


def solve_cols(method, A, B):
    """Solve A x = B[:, c] for each column with scipy's Krylov `method`; iterations."""
    its = []
    X = np.empty_like(B)
    for c in range(B.shape[1]):
        count = [0]

        def cb(_xk):
            count[0] += 1

        x, info = method(A, B[:, c], rtol=1e-5, atol=0.0, callback=cb)
        assert info == 0, f"{method.__name__} did not converge on column {c}"
        X[:, c] = x
        its.append(count[0])
    return X, its


def rel_residual(A, X, B):
    return [float(np.linalg.norm(A @ X[:, c] - B[:, c]) / np.linalg.norm(B[:, c])) for c in range(B.shape[1])]


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else str(MESHES / "igea.ply")
    lam = float(sys.argv[2]) if len(sys.argv) > 2 else 30.0
    with tempfile.TemporaryDirectory() as d:
        ours = meshlap_bench("solvers", path, "--repeat", REPEAT, "--lambda", lam, "--export", d)
        A_sql = scipy.io.mmread(Path(d) / "sql.mtx").tocsr()
        A_tl = scipy.io.mmread(Path(d) / "tl.mtx").tocsr()
        A_sym = scipy.io.mmread(Path(d) / "tl_sym.mtx").tocsr()
        B = np.load(Path(d) / "b.npy")
        deg = np.load(Path(d) / "d.npy").ravel()
    V, F = load_vf(path)
    n = len(V)
    assert B.shape == (n, 3) and np.array_equal(B, V), "right-hand side = vertex positions"
    # The exported matrices are the ones scipy builds from the same mesh.
    I = sp.eye(n)
    for name, mine, theirs in [
        ("I + λS", A_sql, I + lam * sql(F, n)),
        ("I + λT", A_tl, I + lam * tutte(F, n)),
        ("D + λK", A_sym, sp.diags(deg) + lam * kirchhoff(F, n)),
    ]:
        diff = abs(mine - theirs).max()
        assert diff < 1e-12 * abs(theirs).max(), f"{name}: matrices differ by {diff}"
    DB = deg[:, None] * B
    rows = []
    with limit_threads():
        for key, label, method, A, rhs in [
            ("cg_sql", "CG, (I + λS)x = b", spla.cg, A_sql, B),
            ("bicg_tl", "BiCG, (I + λT)x = b", spla.bicg, A_tl, B),
            ("cg_tl_sym", "CG, (D + λK)x = Db", spla.cg, A_sym, DB),
        ]:
            X, its = solve_cols(method, A, rhs)
            res = rel_residual(A, X, rhs)
            assert max(res) < 1e-5, res
            t_peer = timeit(lambda: solve_cols(method, A, rhs), repeat=REPEAT)
            o = ours[key]
            rows.append([
                label,
                f"{t_peer * 1e3:.1f}", "/".join(map(str, its)),
                f"{o['median'] * 1e3:.1f}", "/".join(map(str, o["iterations"])),
                f"{t_peer / o['median']:.2f}x",
                f"{o['seconds_per_iteration'] * 1e3:.2f}",
                f"{o['bandwidth_bound_per_iteration'] * 1e3:.2f}",
                f"{o['ratio_to_bound']:.2f}",
            ])
        chol_row = None
        try:
            from sksparse.cholmod import cholesky

            A_csc = A_sql.tocsc()

            def cholmod():
                f = cholesky(A_csc)
                return f(B)

            X = cholmod()
            assert max(rel_residual(A_sql, X, B)) < 1e-10
            t_peer = timeit(cholmod, repeat=REPEAT)
            o = ours["cholesky_sql"]
            chol_row = ["Cholesky factor+solve, I + λS", f"{t_peer * 1e3:.1f}", "-",
                        f"{o['median'] * 1e3:.1f}", "-", f"{t_peer / o['median']:.2f}x", "-", "-", "-"]
        except ImportError as e:
            print(f"CHOLMOD unavailable ({e}); see bench/setup_venv.sh", file=sys.stderr)
        if chol_row:
            rows.append(chol_row)
    print(f"mesh {path}: n = {n}, λ = {lam}, threads = {THREADS}, "
          f"copy bandwidth {ours['copy_bandwidth_gb_s']:.2f} GB/s (read + write), repeat {REPEAT}")
    table(rows, ["solve", "peer ms", "peer its", "meshlap ms", "meshlap its", "speed-up",
                 "meshlap ms/it", "bound ms/it", "ratio to bound"])


if __name__ == "__main__":
    main()
