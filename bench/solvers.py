"""Implicit-fairing solvers: meshlap vs scipy (cg, bicg) and CHOLMOD (scikit-sparse).

Run: bench/.venv/bin/python bench/solvers.py [MESH] [LAMBDA] [ROUNDS]
     (defaults: igea.ply, 30, 5)

The same matrices on both sides: meshlap-bench exports (I + λS) (SQL), (I + λT) (TL)
and the symmetrised TL (D + λK) as Matrix Market, which this script reads; they are
also rebuilt here with scipy (bench/operators.py) and checked equal. Three coordinate
columns, x0 = 0, relative residual ‖Ax − b‖/‖b‖ < 1e-5 on both sides (scipy solves one
column at a time, meshlap all three in one blocked iteration). Both sides use
BENCH_THREADS threads (default 2).

Timing alternates the sides over ROUNDS rounds (A B A B …): in each round one
meshlap-bench process times REPEAT solves of each system (warm: its median, the
buffers of each solve fresh, the process' first solves included), then this process
times REPEAT scipy solves of each. Each round also measures the streaming-copy
bandwidth (meshlap-bench) and with it meshlap's time per iteration against the
memory-traffic bound (the bytes an iteration must move ÷ that bandwidth). Prints the
medians over the rounds of each side's time, of the per-round speed-ups (with their
range) and of the per-round ratios to the bound.
"""
import os
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from common import THREADS, limit_threads, load_vf, meshlap_bench, table, timeit, mesh_path
from operators import kirchhoff, sql, tutte

REPEAT = 5


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
    path = str(mesh_path(sys.argv[1] if len(sys.argv) > 1 else "igea.ply"))
    lam = float(sys.argv[2]) if len(sys.argv) > 2 else 30.0
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 5
    bench_args = ("solvers", path, "--repeat", REPEAT, "--lambda", lam)
    with tempfile.TemporaryDirectory() as d:
        # The export's own run is not timed: it only writes the matrices.
        meshlap_bench(*bench_args[:3], 1, *bench_args[4:], "--export", d)
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
    systems = [
        ("cg_sql", "CG, (I + λS)x = b", spla.cg, A_sql, B),
        ("bicg_tl", "BiCG, (I + λT)x = b", spla.bicg, A_tl, B),
        ("cg_tl_sym", "CG, (D + λK)x = Db", spla.cg, A_sym, DB),
    ]
    try:
        from sksparse.cholmod import cholesky
    except ImportError as e:
        cholesky = None
        print(f"CHOLMOD unavailable ({e}); see bench/setup_venv.sh", file=sys.stderr)
    A_csc = A_sql.tocsc()

    def cholmod():
        f = cholesky(A_csc)
        return f(B)

    peer_its = {}
    with limit_threads():
        for key, _, method, A, rhs in systems:
            X, peer_its[key] = solve_cols(method, A, rhs)
            res = rel_residual(A, X, rhs)
            assert max(res) < 1e-5, res
        if cholesky:
            assert max(rel_residual(A_sql, cholmod(), B)) < 1e-10
        ours_r, peer_r, copy_r = [], [], []
        for r in range(rounds):
            ours_r.append(meshlap_bench(*bench_args))
            copy_r.append(ours_r[-1]["copy_bandwidth_gb_s"])
            peer = {key: timeit(lambda: solve_cols(method, A, rhs), repeat=REPEAT)
                    for key, _, method, A, rhs in systems}
            if cholesky:
                peer["cholesky_sql"] = timeit(cholmod, repeat=REPEAT)
            peer_r.append(peer)
            print(f"round {r + 1}/{rounds}: load {os.getloadavg()[0]:.2f}", file=sys.stderr, flush=True)
    med = statistics.median
    rows = []
    for key, label, *_ in systems + ([("cholesky_sql", "Cholesky factor+solve, I + λS")] if cholesky else []):
        t_ours = [o[key]["median"] for o in ours_r]
        t_peer = [p[key] for p in peer_r]
        ratios = [p / o for p, o in zip(t_peer, t_ours)]
        row = [label, f"{med(t_peer) * 1e3:.1f}", "/".join(map(str, peer_its.get(key, ["-"]))),
               f"{med(t_ours) * 1e3:.1f}", "/".join(map(str, ours_r[0][key].get("iterations", ["-"]))),
               f"{med(ratios):.2f}x", f"{min(ratios):.2f}–{max(ratios):.2f}"]
        if key == "cholesky_sql":
            row += ["-", "-", "-"]
        else:
            row += [f"{med(o[key]['seconds_per_iteration'] for o in ours_r) * 1e3:.2f}",
                    f"{med(o[key]['bandwidth_bound_per_iteration'] for o in ours_r) * 1e3:.2f}",
                    f"{med(o[key]['ratio_to_bound'] for o in ours_r):.2f}"]
        rows.append(row)
    print(f"mesh {path}: n = {n}, λ = {lam}, threads = {THREADS}, {rounds} rounds (A B alternated) "
          f"of {REPEAT} solves per side, copy bandwidth {med(copy_r):.2f} GB/s (read + write; "
          f"{min(copy_r):.2f}–{max(copy_r):.2f} over the rounds), load {os.getloadavg()}")
    table(rows, ["solve", "peer ms", "peer its", "meshlap ms", "meshlap its", "speed-up (median of rounds)",
                 "per-round range", "meshlap ms/it", "bound ms/it", "ratio to bound"])


if __name__ == "__main__":
    main()
