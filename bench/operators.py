"""Operator assembly: meshlap vs a vectorised numpy/scipy build and igl.cotmatrix.

Run: bench/.venv/bin/python bench/operators.py [MESH]   (default: igea.ply)
Both sides use BENCH_THREADS threads (default 2). Prints medians and ratios.
"""
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse as sp

from common import MESHES, THREADS, build, limit_threads, load_vf, meshlap_bench, table, timeit


def adjacency(F, n):
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    E = np.sort(E, axis=1)
    E = np.unique(E, axis=0)
    A = sp.coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n, n))
    return (A + A.T).tocsr()


def kirchhoff(F, n):
    A = adjacency(F, n)
    d = np.asarray(A.sum(axis=1)).ravel()
    return (sp.diags(d) - A).tocsr()


def tutte(F, n):
    A = adjacency(F, n)
    d = np.asarray(A.sum(axis=1)).ravel()
    return (sp.eye(n) - sp.diags(1.0 / d) @ A).tocsr()


def sql(F, n):
    A = adjacency(F, n)
    d = np.asarray(A.sum(axis=1)).ravel()
    inv = 1.0 / d
    # half-edges (i, j) with opposite vertex k
    I = np.concatenate([F[:, 0], F[:, 1], F[:, 2]])
    J = np.concatenate([F[:, 1], F[:, 2], F[:, 0]])
    K = np.concatenate([F[:, 2], F[:, 0], F[:, 1]])
    lo, hi = np.minimum(I, J), np.maximum(I, J)
    key = lo.astype(np.int64) * n + hi
    ukey, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    opp = np.bincount(inverse, weights=inv[K])
    a, b = ukey // n, ukey % n
    w = inv[a] + inv[b] - np.where(counts == 1, opp, 0.5 * opp)
    # boundary diagonal: 1 + 1/2 sum over boundary edges (1/d_j - 1/d_k)
    bmask = counts[inverse] == 1
    diag = np.ones(n)
    np.add.at(diag, I[bmask], 0.5 * (inv[J[bmask]] - inv[K[bmask]]))
    np.add.at(diag, J[bmask], 0.5 * (inv[I[bmask]] - inv[K[bmask]]))
    W = sp.coo_matrix((w, (a, b)), shape=(n, n))
    return (sp.diags(diag) - (W + W.T)).tocsr()


def sstl(F, n):
    T = tutte(F, n)
    return (T.T @ T).tocsr()


def check_same_matrices(path, V, F, n):
    """Every peer builds the same matrix as meshlap: max |entry difference| per
    operator (igl.cotmatrix is -L: libigl's sign convention is the negative of ours)."""
    import igl
    peers = {
        "kirchhoff": kirchhoff(F, n),
        "tutte": tutte(F, n),
        "sql": sql(F, n),
        "sstl": sstl(F, n),
        "cotan": -igl.cotmatrix(V, F),
    }
    diffs = {}
    with tempfile.TemporaryDirectory() as d:
        meshlap_bench("dump", path, d)
        for name, peer in peers.items():
            ours = sp.csr_matrix(scipy.io.mmread(str(Path(d) / f"{name}.mtx")))
            diff = abs(ours - peer.tocsr())
            scale = abs(peer).max()
            diffs[name] = (diff.max() if diff.nnz else 0.0, scale, ours.nnz, peer.nnz)
    return diffs


def main():
    import igl
    path = sys.argv[1] if len(sys.argv) > 1 else str(MESHES / "igea.ply")
    V, F = load_vf(path)
    n = len(V)
    build()
    diffs = check_same_matrices(path, V, F, n)
    print(f"same matrices? max |meshlap - peer| per operator on {Path(path).name}:")
    for name, (d, scale, nnz_ours, nnz_peer) in diffs.items():
        print(f"  {name:10s} {d:.2e} (max |entry| {scale:.3g}; nnz {nnz_ours} vs {nnz_peer})")
        assert d <= 1e-12 * max(scale, 1.0), f"{name}: meshlap and the peer differ by {d}"
    rows = []
    with limit_threads():
        peers = {
            "kirchhoff": lambda: kirchhoff(F, n),
            "tutte": lambda: tutte(F, n),
            "sql": lambda: sql(F, n),
            "sstl": lambda: sstl(F, n),
            "cotan": lambda: igl.cotmatrix(V, F),
        }
        # The machine may be shared: time our side and the peer back to back per
        # operator, so that both see the same load.
        for name, fn in peers.items():
            t_ours = meshlap_bench("operators", path, "--repeat", 7, "--kind", name)[name]["median"]
            t_peer = timeit(fn, repeat=5)
            peer = "igl.cotmatrix" if name == "cotan" else "scipy (vectorised)"
            rows.append([name, peer, f"{t_peer * 1e3:.1f}", f"{t_ours * 1e3:.2f}", f"{t_peer / t_ours:.1f}x"])
    ours = meshlap_bench("operators", path, "--repeat", 7)
    for name in ["graph", "tutte2", "sdl", "mean-value", "topology"]:
        rows.append([name, "-", "-", f"{ours[name]['median'] * 1e3:.2f}", "-"])
    print(f"mesh {path}: n = {n}, threads = {THREADS}")
    table(rows, ["operator", "peer", "peer ms", "meshlap ms", "speed-up"])


if __name__ == "__main__":
    main()
