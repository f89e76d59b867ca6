"""Dense spectra: meshlap's eigenbases vs numpy (LAPACK via OpenBLAS), side by side.

Run: bench/.venv/bin/python bench/spectral.py
Meshes: a 2,000-vertex breadth-first patch of the Stanford bunny and the cow
(n = 2,903). Symmetric operators (KL, SQL): meshlap's full eigenbasis (faer
self-adjoint solver + canonicalisation) vs numpy.linalg.eigh on the same dense matrix.
TL: meshlap's default path (the GL similarity, symmetric solver) vs
numpy.linalg.eig on the dense TL (what the paper's Matlab eig does); meshlap's own
general path (non-symmetric EVD + LU of E) is reported alongside.
Both sides use BENCH_THREADS threads (default 2). Prints medians and ratios.
"""
import sys
import tempfile
from collections import deque
from pathlib import Path

import numpy as np

from common import MESHES, THREADS, limit_threads, load_vf, meshlap_bench, table, timeit
from operators import kirchhoff, sql, tutte


def bfs_patch(V, F, n, seed=0):
    """The first n vertices reached by BFS from `seed`, with their induced faces."""
    nv = len(V)
    nbrs = [[] for _ in range(nv)]
    for a, b, c in F:
        nbrs[a] += [b, c]
        nbrs[b] += [c, a]
        nbrs[c] += [a, b]
    seen = np.zeros(nv, bool)
    seen[seed] = True
    order, q = [], deque([seed])
    while q and len(order) < n:
        v = q.popleft()
        order.append(v)
        for w in sorted(set(nbrs[v])):
            if not seen[w]:
                seen[w] = True
                q.append(w)
    idx = -np.ones(nv, np.int64)
    idx[order] = np.arange(len(order))
    keep = (idx[F] >= 0).all(axis=1)
    return V[order], idx[F[keep]]


def write_off(path, V, F):
    with open(path, "w") as f:
        f.write(f"OFF\n{len(V)} {len(F)} 0\n")
        for v in V:
            f.write(f"{float(v[0])!r} {float(v[1])!r} {float(v[2])!r}\n")
        for t in F:
            f.write(f"3 {t[0]} {t[1]} {t[2]}\n")


def main():
    repeat = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    rows = []
    with tempfile.TemporaryDirectory() as d:
        V, F = load_vf(MESHES / "stanford-bunny.obj")
        Vp, Fp = bfs_patch(V, F, 2000)
        patch = Path(d) / "bunny-2000.off"
        write_off(patch, Vp, Fp)
        for label, path in [("bunny patch", patch), ("cow", MESHES / "cow.obj")]:
            V, F = load_vf(path)  # exactly as meshlap cleans it
            n = len(V)
            ours = meshlap_bench("spectrum", path, "--repeat", repeat, "--general")
            assert ours["vertices"] == n, (ours["vertices"], n)
            with limit_threads():
                for name, build in [("kirchhoff", kirchhoff), ("sql", sql)]:
                    A = build(F, n).toarray()
                    t_np = timeit(lambda: np.linalg.eigh(A), repeat=repeat)
                    t_us = ours[name]["median"]
                    rows.append([label, n, name, "numpy.linalg.eigh", f"{t_np:.3f}", f"{t_us:.3f}", f"{t_np / t_us:.2f}x"])
                T = tutte(F, n).toarray()
                t_np = timeit(lambda: np.linalg.eig(T), repeat=repeat)
                for ours_name in ["tutte", "tutte-general"]:
                    t_us = ours[ours_name]["median"]
                    path_name = "tl (GL similarity)" if ours_name == "tutte" else "tl (general EVD + LU)"
                    rows.append([label, n, path_name, "numpy.linalg.eig", f"{t_np:.3f}", f"{t_us:.3f}", f"{t_np / t_us:.2f}x"])
    print(f"threads = {THREADS}, repeat = {repeat} (medians, seconds)")
    table(rows, ["mesh", "n", "operator", "peer", "peer s", "meshlap s", "speed-up"])


if __name__ == "__main__":
    main()
