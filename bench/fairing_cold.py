"""Implicit fairing, cold and warm: one `meshlap smooth` call against one fresh scipy solve.

Run: bench/.venv/bin/python bench/fairing_cold.py [MESH] [LAMBDA] [ROUNDS]
     (defaults: igea.ply, 30, 7)

The paper's three systems (Table 1), each with its solver:

    cg_sql     CG,   (I + λS)x = b    meshlap smooth --operator sql   --solver cg
    bicg_tl    BiCG, (I + λT)x = b    meshlap smooth --operator tutte --solver bicg
    cg_tl_sym  CG,   (D + λK)x = Db   meshlap smooth --operator tutte --solver cg-sym

Cold (the figure a user of one command sees), alternated A B A B … over ROUNDS rounds:
  A  one fresh `meshlap smooth … --stop strong --tol 1e-5 --json` process; the figure
     is its `solve_seconds`: the solver's own timer, from after the argument checks to
     the final residuals recomputed from scratch — work buffers (allocation and first
     touch), the initial residual, every iteration, the final residual (for cg-sym
     also forming Sb and the residuals of the original system). Not included:
     reading the mesh, assembling the operator and the system matrix, writing the
     output (the same things are outside the scipy figure).
  B  one fresh Python process that loads the same system matrix (exported by
     meshlap-bench, CSR) and right-hand side, then times its first solve of the three
     columns with scipy.sparse.linalg.cg / bicg, one column after another, from the
     same initial guess as the CLI (the positions), rtol 1e-5, atol 0 (the same
     criterion: recurrence residual ‖r‖ < 1e-5‖b‖): everything scipy does inside the
     call (its argument checks, work vectors, every iteration).
Warm, in the same rounds: meshlap-bench `solvers` (median of 5 solves in one process,
x0 = 0, a fresh workspace per solve) against the median of 5 further scipy solves in
the worker process (x0 = 0). Both sides use BENCH_THREADS threads (default 2: our rayon
pool; scipy's BLAS through threadpoolctl; its sparse products are single-threaded).
Prints medians over the rounds, iterations, and speed-ups (scipy / meshlap).
Everything written goes to a temporary directory.
"""
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from common import THREADS, build, meshlap_bench, table, mesh_path

CASES = [
    # key, label, CLI arguments, scipy method, matrix file, rhs scaled by the degrees
    ("cg_sql", "CG, (I + λS)x = b", ["--operator", "sql", "--solver", "cg"], "cg", "sql", False),
    ("bicg_tl", "BiCG, (I + λT)x = b", ["--operator", "tutte", "--solver", "bicg"], "bicg", "tl", False),
    ("cg_tl_sym", "CG, (D + λK)x = Db", ["--operator", "tutte", "--solver", "cg-sym"], "cg", "tl_sym", True),
]
WARM_REPEAT = 5


def worker(method_name, matrix, rhs, x0_path):
    """One fresh scipy solve of the 3 columns, then WARM_REPEAT warm ones from x0 = 0."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla
    from threadpoolctl import threadpool_limits

    A = sp.load_npz(matrix).tocsr()
    B = np.load(rhs)
    X0 = np.load(x0_path)
    method = getattr(spla, method_name)

    def solve(x0):
        its = []
        for c in range(B.shape[1]):
            count = [0]

            def cb(_xk):
                count[0] += 1

            x, info = method(A, B[:, c], x0=None if x0 is None else x0[:, c].copy(),
                             rtol=1e-5, atol=0.0, callback=cb)
            assert info == 0, f"{method_name} did not converge on column {c}"
            its.append(count[0])
        return its

    with threadpool_limits(limits=THREADS):
        t = time.perf_counter()
        its = solve(X0)
        fresh = time.perf_counter() - t
        warm, warm_its = [], None
        for _ in range(WARM_REPEAT):
            t = time.perf_counter()
            warm_its = solve(None)
            warm.append(time.perf_counter() - t)
    print(json.dumps({"fresh": fresh, "iterations": its,
                      "warm": statistics.median(warm), "warm_iterations": warm_its}))


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        worker(*sys.argv[2:6])
        return
    path = str(mesh_path(sys.argv[1] if len(sys.argv) > 1 else "igea.ply"))
    lam = float(sys.argv[2]) if len(sys.argv) > 2 else 30.0
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 7
    import scipy.io
    import scipy.sparse as sp

    exe = build() / "meshlap"
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        meshlap_bench("solvers", path, "--repeat", 1, "--lambda", lam, "--export", d)
        B = np.load(d / "b.npy")
        deg = np.load(d / "d.npy").ravel()
        np.save(d / "db.npy", deg[:, None] * B)
        for _, _, _, _, name, _ in CASES:
            sp.save_npz(d / f"{name}.npz", scipy.io.mmread(d / f"{name}.mtx").tocsr())
        cold = {key: ([], []) for key, *_ in CASES}
        warm = {key: ([], []) for key, *_ in CASES}
        its = {}
        for r in range(rounds):
            for key, _, cli, method, name, scaled in CASES:
                out = subprocess.run(
                    [str(exe), "smooth", path, "-o", str(d / "out.ply"), *cli, "--lambda", str(lam),
                     "--stop", "strong", "--tol", "1e-5", "--json"],
                    check=True, capture_output=True, text=True).stdout
                ours = json.loads(out)
                peer = json.loads(subprocess.run(
                    [sys.executable, __file__, "--worker", method, str(d / f"{name}.npz"),
                     str(d / ("db.npy" if scaled else "b.npy")), str(d / "b.npy")],
                    check=True, capture_output=True, text=True, cwd=Path(__file__).parent).stdout)
                cold[key][0].append(ours["solve_seconds"])
                cold[key][1].append(peer["fresh"])
                warm[key][1].append(peer["warm"])
                its[key] = (ours["iterations"], peer["iterations"], peer["warm_iterations"])
            wb = meshlap_bench("solvers", path, "--repeat", WARM_REPEAT, "--lambda", lam)
            for key, *_ in CASES:
                warm[key][0].append(wb[key]["median"])
                its[key] = its[key] + (wb[key]["iterations"],)
            print(f"round {r + 1}/{rounds}: load {os.getloadavg()[0]:.2f}", file=sys.stderr)
    rows = []
    for key, label, *_ in CASES:
        (oc, pc), (ow, pw) = cold[key], warm[key]
        mo, mp = statistics.median(oc), statistics.median(pc)
        wo, wp = statistics.median(ow), statistics.median(pw)
        per_round = statistics.median(p / o for o, p in zip(oc, pc))
        ci, pi, pwi, wi = its[key]
        rows.append([label,
                     f"{mo * 1e3:.1f}", f"{mp * 1e3:.1f}", f"{mp / mo:.2f}x", f"{per_round:.2f}x",
                     "/".join(map(str, ci)), "/".join(map(str, pi)),
                     f"{wo * 1e3:.1f}", f"{wp * 1e3:.1f}", f"{wp / wo:.2f}x",
                     "/".join(map(str, wi)), "/".join(map(str, pwi))])
    print(f"mesh {path}: λ = {lam}, threads = {THREADS}, {rounds} rounds (A B alternated), "
          f"load {os.getloadavg()}")
    table(rows, ["solve", "cold meshlap ms", "cold scipy ms", "cold speed-up", "per-round median",
                 "its (CLI)", "its (scipy)", "warm meshlap ms", "warm scipy ms", "warm speed-up",
                 "warm its (meshlap)", "warm its (scipy)"])


if __name__ == "__main__":
    main()
