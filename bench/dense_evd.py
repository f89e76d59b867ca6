"""Dense symmetric eigendecomposition: meshlap vs numpy (LAPACK dsyevd via OpenBLAS).

Run: bench/.venv/bin/python bench/dense_evd.py [--sizes 500,1000,2000,2903]
     [--threads 1,2] [--rounds 3] [--repeat 3] [--warmup 4] [--kinds kirchhoff,sql,tutte]
Honours CARGO_TARGET_DIR. Creates nothing outside a temporary directory.

Matrices: breadth-first patches of the Stanford bunny (n = 500, 1000, 2000, as
spectral.py builds them) and the cow (n = 2903); KL and SQL (symmetric, F = D − W,
positive semi-definite), and the TL.

What each side includes:
- numpy.linalg.eigh (LAPACK dsyevd: blocked dsytrd, dstedc divide and conquer,
  dormtr back-transformation) on the dense symmetric matrix, values and vectors;
- meshlap "basis": `EigenBasis::compute` from the assembled sparse operator: dense
  copy, symmetry/finite checks, the default dense solver (`blocked`: meshlap's
  blocked tridiagonalisation, divide and conquer and back-transformation),
  clusters and the canonical signs/rotations; "blocked only": the dense copy and
  that solver alone; "faer only": the dense copy and faer's self_adjoint_evd alone;
- TL: numpy.linalg.eig on the dense TL + numpy.linalg.solve(E, V) for the
  coefficients of the positions (the paper's Matlab `eig` + `E\\x`), against meshlap's
  default TL path (the symmetric GL similarity) + `forward` (the coefficients). Goal 1
  of issue 17 is set against that pipeline. A second peer ("GL peer") does in numpy
  what meshlap does: `numpy.linalg.eigh` of the symmetric `G = D^{-1/2} K D^{-1/2}`
  (K = D − A), `E = D^{-1/2} U` and the coefficients `Uᵀ D^{1/2} V` (E⁻¹ = Uᵀ D^{1/2}),
  the scalings and the product included (its own column and ratio).
Threads: ours RAYON_NUM_THREADS (faer's fixed 2-way split runs on that pool, so 1
thread runs both halves in turn), numpy via threadpoolctl.
Timing: ROUNDS rounds alternating the sides (ours, numpy, ours, numpy, ...), REPEAT
timed runs per side per round after WARMUP untimed ones on each side (ours runs in a
fresh process every round, numpy in this one, warm). A fresh process pays its thread
start-up and, over its first few calls, the page faults of its heaps growing to their
peak (one heap per thread that allocates): at n = 500 on 2 threads the first six basis
calls of a process took 20–30 ms and the later ones 11–16 ms, with about 2,200 page
faults per repeat over the first four repeats and 140 after (2026-12-02). Hence four
untimed calls per side by default (one before that date); the first-call cost is the
CLI's, not the dense ED's. Medians of the per-round medians.
"""
import argparse
import os
import statistics
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from common import MESHES, build, load_vf, table, timeit
from operators import kirchhoff, sql, tutte
from spectral import bfs_patch, write_off


def ours(exe, path, kind, repeat, threads, warmup):
    """meshlap-bench's timings, each case's first `warmup` runs dropped."""
    import json
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    out = subprocess.run([str(exe), "spectrum", str(path), "--kind", kind,
                          "--repeat", str(repeat + warmup)],
                         check=True, capture_output=True, text=True, env=env).stdout
    r = json.loads(out)
    for v in r.values():
        if isinstance(v, dict) and "times" in v:
            v["median"] = statistics.median(v["times"][warmup:])
    return r


def peer_time(fn, repeat, warmup):
    for _ in range(warmup):
        fn()
    return timeit(fn, repeat=repeat)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="500,1000,2000,2903")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--warmup", type=int, default=4)
    ap.add_argument("--kinds", default="kirchhoff,sql,tutte")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    threads = [int(t) for t in args.threads.split(",")]
    kinds = args.kinds.split(",")
    exe = build() / "meshlap-bench"
    rows = []
    with tempfile.TemporaryDirectory() as d:
        meshes = []
        V, F = load_vf(MESHES / "stanford-bunny.obj")
        for n in sizes:
            if n == 2903:
                meshes.append(("cow", MESHES / "cow.obj"))
            else:
                Vp, Fp = bfs_patch(V, F, n)
                p = Path(d) / f"bunny-{n}.off"
                write_off(p, Vp, Fp)
                meshes.append((f"bunny patch", p))
        for label, path in meshes:
            Vm, Fm = load_vf(path)  # exactly as meshlap cleans it
            n = len(Vm)
            for kind in kinds:
                build_op = {"kirchhoff": kirchhoff, "sql": sql, "tutte": tutte}[kind]
                A = build_op(Fm, n).toarray()
                K = kirchhoff(Fm, n).toarray() if kind == "tutte" else None
                for nt in threads:
                    t_basis, t_faer, t_blocked, t_np, t_gl = [], [], [], [], []
                    for _ in range(args.rounds):
                        if kind == "tutte":
                            r = ours(exe, path, "tutte-coefficients", args.repeat, nt, args.warmup)
                            assert r["vertices"] == n, (r["vertices"], n)
                            t_basis.append(r["tutte-coefficients"]["median"])
                            t_faer.append(r["tutte-faer-only"]["median"])
                            t_blocked.append(r["tutte-blocked-only"]["median"])
                            with threadpool_limits(nt):
                                def peer():
                                    w, E = np.linalg.eig(A)
                                    return np.linalg.solve(E, Vm)
                                t_np.append(peer_time(peer, args.repeat, args.warmup))

                                def gl_peer():
                                    dg = np.diag(K)
                                    s = 1.0 / np.sqrt(dg)
                                    w, U = np.linalg.eigh(K * s[:, None] * s[None, :])
                                    E = U * s[:, None]
                                    return w, E, U.T @ (np.sqrt(dg)[:, None] * Vm)
                                t_gl.append(peer_time(gl_peer, args.repeat, args.warmup))
                        else:
                            r = ours(exe, path, kind, args.repeat, nt, args.warmup)
                            assert r["vertices"] == n, (r["vertices"], n)
                            t_basis.append(r[kind]["median"])
                            t_faer.append(r[f"{kind}-faer-only"]["median"])
                            t_blocked.append(r[f"{kind}-blocked-only"]["median"])
                            with threadpool_limits(nt):
                                t_np.append(peer_time(lambda: np.linalg.eigh(A), args.repeat, args.warmup))
                    tb, tf, tbl, tn = (statistics.median(x)
                                       for x in (t_basis, t_faer, t_blocked, t_np))
                    tg = statistics.median(t_gl) if t_gl else None
                    peer = "numpy eig + solve" if kind == "tutte" else "numpy eigh"
                    ours_name = "basis + coefficients" if kind == "tutte" else "basis"
                    rows.append([label, n, kind, nt, peer, f"{tn:.3f}", ours_name, f"{tb:.3f}",
                                 f"{tbl:.3f}", f"{tf:.3f}", f"{tn / tb:.2f}x",
                                 f"{tg:.3f}" if tg else "-", f"{tg / tb:.2f}x" if tg else "-"])
                    print(rows[-1], flush=True)
    load = os.getloadavg()
    print(f"rounds = {args.rounds}, repeat = {args.repeat}, warm-up = {args.warmup} (medians of per-round medians, seconds); "
          f"load average at the end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    table(rows, ["mesh", "n", "operator", "threads", "peer", "peer s", "meshlap", "meshlap s",
                 "blocked only s", "faer only s", "speed-up", "GL peer s", "speed-up (GL peer)"])


if __name__ == "__main__":
    main()
