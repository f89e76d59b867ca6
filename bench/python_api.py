"""meshlap's Python API side by side with its peers, in one process.

Run: python3 bench/python_api.py [--small] [--rounds N] [--k K] [--tols T1,T2]
     [--eigsh-only | --no-eigsh] [--json-out FILE]

Creates bench/.venv-python on first use (numpy, scipy, threadpoolctl, trimesh,
robust_laplacian, libigl, and meshlap itself built with `pip install .` in release
mode), then re-runs itself inside it. Both sides get the same threads (BENCH_THREADS,
default 2): meshlap.set_threads and threadpoolctl for the peers' BLAS. Every
comparison runs in A B A B … rounds (alternating, so drift and load hit both sides
alike) and reports medians and the ratio.

Comparisons (the issue's benchmark):
- meshlap.eigsh(L, k, M) vs scipy.sparse.linalg.eigsh(L, k, M, sigma=-1e-8·mean diag)
  on robust_laplacian's (L, M) and on the SQL (M = I), with the largest residual
  ‖Lv − λMv‖ of each side so equal accuracy is checked, not assumed; meshlap at each
  tolerance of --tols (the default 1e-10, and 1e-12, where its residuals reach
  ARPACK's), each alternated with scipy;
- meshlap.operator(kind="cotan") vs igl.cotmatrix, at least 15 rounds, and again
  after meshlap.keep_freed_memory() (glibc's setting, process-wide: igl's buffers are
  reused too; meshlap's own come from its mimalloc, which reuses them either way);
- meshlap.mass_matrix vs igl.massmatrix (Voronoi), with the largest difference;
- meshlap.read_mesh vs trimesh.load, where trimesh reads the same triangles (it reads
  no faces from a PLY of triangle strips such as igea.ply: that row is not compared);
- the binding overhead on a 1k-vertex mesh: meshlap.operator (argument checks,
  conversions, csr_array) against the raw extension call on prepared arrays.

MESHLAP_BENCH_PROFILE=dev builds meshlap with the dev profile instead of release
(reusing `cargo test`'s artifacts): for checking the script, not for figures.
--small runs on builtin:icosphere:3 (642 vertices) with k = 20 and 3 rounds, to check
that the script works; the figures of a loaded machine are not benchmarks.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VENV = ROOT / "bench" / ".venv-python"
MESHES = ROOT.parent / "shared" / "data" / "meshes"
THREADS = int(os.environ.get("BENCH_THREADS", "2"))
# Cargo profile of the meshlap build in the venv (release for figures; `dev` reuses
# the test build's artifacts for a quick check that the script runs).
PROFILE = os.environ.get("MESHLAP_BENCH_PROFILE", "release")
for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "RAYON_NUM_THREADS"):
    os.environ[var] = str(THREADS)


def ensure_venv():
    """Re-executes inside bench/.venv-python, creating it first if needed."""
    py = VENV / "bin" / "python"
    # The peers' own BLAS kernel: without OPENBLAS_CORETYPE / OPENBLAS_L2_SIZE, which
    # force an older one where this workplace sets them (see bench/common.py).
    forced = ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")
    env = {k: v for k, v in os.environ.items() if k not in forced}
    if Path(sys.prefix).resolve() == VENV.resolve():
        if len(env) != len(os.environ):
            os.execve(str(py), [str(py), *sys.argv], env)
        return
    if not py.exists():
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
        pip = [str(py), "-m", "pip", "install", "--quiet"]
        subprocess.run(pip + ["numpy", "scipy", "threadpoolctl", "trimesh"], check=True)
        for optional in ["robust_laplacian", "libigl"]:
            if subprocess.run(pip + [optional]).returncode != 0:
                print(f"note: {optional} did not install; its comparison is skipped", file=sys.stderr)
    # (Re)install meshlap from this checkout, optimised.
    subprocess.run(
        [str(py), "-m", "pip", "install", "--quiet", "--force-reinstall", "--no-deps",
         str(ROOT)],
        check=True,
        env={**os.environ, "CARGO_TARGET_DIR": str(ROOT / "target"), "MATURIN_PEP517_ARGS": "--profile " + PROFILE},
    )
    # The install compiled after quiet-run checked the load.
    from settle import wait_for_load
    wait_for_load("installed meshlap")
    os.execve(str(py), [str(py), *sys.argv], env)


def rounds(a, b, n):
    """A B A B … n times; medians of each side."""
    ta, tb = [], []
    ra = rb = None
    for _ in range(n):
        t = time.perf_counter()
        ra = a()
        ta.append(time.perf_counter() - t)
        t = time.perf_counter()
        rb = b()
        tb.append(time.perf_counter() - t)
    return statistics.median(ta), statistics.median(tb), ra, rb


def max_residual(L, M, evals, evecs):
    import numpy as np
    import scipy.sparse as sp

    Md = sp.eye_array(L.shape[0]) if M is None else M
    R = L @ evecs - (Md @ evecs) * evals
    return float(np.linalg.norm(R, axis=0).max())


def eigen_problems(V, F):
    """The eigsh problems of a mesh: (name, L, M, L as CSC, M as CSC, scipy's shift)
    for the SQL (M = I) and robust_laplacian's (L, M) when it is installed."""
    import meshlap

    problems = [("SQL", meshlap.operator(V, F, "sql"), None)]
    try:
        import robust_laplacian

        L, M = robust_laplacian.mesh_laplacian(V, F)
        problems.append(("robust_laplacian (L, M)", L.tocsr(), M.tocsr()))
    except ImportError:
        print("robust_laplacian missing: skipped", file=sys.stderr)
    return [
        (name, L, M, L.tocsc(), None if M is None else M.tocsc(), -1e-8 * float(abs(L.diagonal()).mean()))
        for name, L, M in problems
    ]


def accuracy(rows, row, n_rounds, k):
    """eigsh variants on the bunny, each alternated with scipy's shift-invert eigsh."""
    import numpy as np
    import scipy.sparse.linalg as spla

    import meshlap

    mesh = str(MESHES / "stanford-bunny.obj")
    V, F = meshlap.read_mesh(mesh)
    for name, L, M, Lc, Mc, sigma in eigen_problems(V, F):
        for tol, refine in [(1e-10, False), (1e-10, True), (1e-12, True)]:
            ta, tb, ra, rb = rounds(
                lambda: meshlap.eigsh(L, k, M, tol=tol, refine=refine),
                lambda: spla.eigsh(Lc, k, Mc, sigma=sigma, which="LM"),
                n_rounds,
            )
            extra = {
                "k": k,
                "tol": tol,
                "refine": refine,
                "residual_meshlap": max_residual(L, M, *ra),
                "residual_scipy": max_residual(L, M, rb[0], rb[1]),
                "max_eigenvalue_difference": float(abs(ra[0] - np.sort(rb[0])).max()),
            }
            row(f"eigsh {name} tol {tol:g}{' refine' if refine else ''}", mesh, ta, tb, extra)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--small", action="store_true")
    ap.add_argument("--rounds", type=int, default=None)
    ap.add_argument("--k", type=int, default=None)
    ap.add_argument("--json-out")
    ap.add_argument("--accuracy", action="store_true",
                    help="only eigsh on stanford-bunny.obj: meshlap with and without refinement "
                         "and at tol 1e-10 / 1e-12 against scipy, alternated, with each side's residual")
    ap.add_argument("--tols", default="1e-10,1e-12",
                    help="meshlap.eigsh tolerances, each alternated with scipy (default: the "
                         "default 1e-10 and 1e-12, where meshlap's residuals match ARPACK's)")
    ap.add_argument("--eigsh-only", action="store_true", help="only the eigsh rows")
    ap.add_argument("--no-eigsh", action="store_true",
                    help="skip the eigsh rows (the cotangent operator, read_mesh and the binding only)")
    args = ap.parse_args()
    tols = [float(t) for t in args.tols.split(",")]
    ensure_venv()

    import numpy as np
    import scipy.sparse.linalg as spla
    from threadpoolctl import threadpool_info, threadpool_limits

    import meshlap

    for i in threadpool_info():
        if i.get("user_api") == "blas":
            print(f"peers' BLAS: {i.get('internal_api')} {i.get('version')}, kernel "
                  f"{i.get('architecture')}", flush=True)

    meshlap.set_threads(THREADS)
    n_rounds = args.rounds or (3 if args.small else 5)
    k = args.k or (20 if args.small else 200)
    if args.small:
        meshes = ["builtin:icosphere:3"]
    else:
        meshes = [str(MESHES / "stanford-bunny.obj"), str(MESHES / "igea.ply")]
    rows = []

    def row(what, mesh, ours, theirs, extra=None):
        r = {"what": what, "mesh": Path(mesh).name, "meshlap_s": ours, "peer_s": theirs, "speedup": theirs / ours}
        r.update(extra or {})
        rows.append(r)
        print(f"{what:34s} {Path(mesh).name:22s} meshlap {ours:9.4f} s  peer {theirs:9.4f} s  x{theirs / ours:6.2f}"
              + ("" if not extra else "  " + json.dumps(extra)))

    if args.accuracy:
        with threadpool_limits(limits=THREADS):
            accuracy(rows, row, n_rounds, k)
        if args.json_out:
            Path(args.json_out).write_text(json.dumps({"threads": THREADS, "rows": rows}, indent=2))
        return

    with threadpool_limits(limits=THREADS):
        for mesh in meshes:
            V, F = meshlap.read_mesh(mesh)
            for name, L, M, Lc, Mc, sigma in [] if args.no_eigsh else eigen_problems(V, F):
                for tol in tols:
                    ta, tb, ra, rb = rounds(
                        lambda: meshlap.eigsh(L, k, M, tol=tol),
                        lambda: spla.eigsh(Lc, k, Mc, sigma=sigma, which="LM"),
                        n_rounds,
                    )
                    ev_b = np.sort(rb[0])
                    extra = {
                        "k": k,
                        "tol": tol,
                        "residual_meshlap": max_residual(L, M, *ra),
                        "residual_scipy": max_residual(L, M, rb[0], rb[1]),
                        "max_eigenvalue_difference": float(abs(ra[0] - ev_b).max()),
                    }
                    row(f"eigsh {name} tol {tol:g}", mesh, ta, tb, extra)
            if args.eigsh_only:
                continue
            try:
                import igl

                # Calls of a few milliseconds: at least 15 alternated rounds.
                ta, tb, _, _ = rounds(lambda: meshlap.operator(V, F, "cotan"), lambda: igl.cotmatrix(V, F),
                                      max(n_rounds, 15))
                row("cotan operator vs igl.cotmatrix", mesh, ta, tb)
                # The lumped Voronoi mass alone (no stiffness, no connectivity on our
                # side), with the largest relative difference to igl's.
                ta, tb, ra, rb = rounds(lambda: meshlap.mass_matrix(V, F),
                                        lambda: igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_VORONOI),
                                        max(n_rounds, 15))
                da, db = ra.diagonal(), rb.diagonal()
                row("mass_matrix vs igl.massmatrix", mesh, ta, tb,
                    {"max_relative_difference": float(abs(da - db).max() / abs(db).max())})
            except ImportError:
                print("libigl missing: skipped", file=sys.stderr)
            if not mesh.startswith("builtin:"):
                try:
                    import trimesh

                    ta, tb, ra, rb = rounds(lambda: meshlap.read_mesh(mesh),
                                            lambda: trimesh.load(mesh, process=False), max(n_rounds, 15))
                    # Only a peer that read the same triangles is compared: trimesh
                    # returns a point cloud for a PLY of triangle strips (igea.ply).
                    peer_faces = len(getattr(rb, "faces", []))
                    if peer_faces == len(ra[1]) and len(rb.vertices) == len(ra[0]):
                        row("read_mesh vs trimesh.load", mesh, ta, tb)
                    else:
                        print(f"read_mesh vs trimesh.load           {Path(mesh).name:22s} not compared: trimesh "
                              f"read {peer_faces} faces, meshlap {len(ra[1])} (meshlap {ta:.4f} s)")
                except ImportError:
                    print("trimesh missing: skipped", file=sys.stderr)
        if args.eigsh_only:
            meshes = []
        # Binding overhead on a 1k-vertex mesh: the Python call against the same work
        # without the Python layer's conversions (the raw extension call).
        V, F = meshlap.read_mesh("builtin:icosphere:3")  # 642 vertices
        V1, F1 = meshlap.read_mesh("builtin:torus:40:25")  # 1000 vertices
        Fu = F1.astype(np.uint32)
        ta, tb, _, _ = rounds(
            lambda: meshlap.operator(V1, F1, "cotan"),
            lambda: meshlap._meshlap.operator(V1, Fu, "cotan", "zero-row-sum", "voronoi"),
            max(n_rounds, 20),
        )
        row("binding overhead (1k, full vs raw)", "builtin:torus:40:25", tb, ta, {"overhead": ta / tb - 1})
        # Last, since it cannot be undone: glibc told to keep freed memory, which the
        # process-wide setting gives both sides (igl's Eigen buffers come from the
        # same malloc), and the cotangent rows again.
        if not args.eigsh_only:
            try:
                import igl

                kept = meshlap.keep_freed_memory()
                for mesh in meshes:
                    V, F = meshlap.read_mesh(mesh)
                    ta, tb, _, _ = rounds(lambda: meshlap.operator(V, F, "cotan"), lambda: igl.cotmatrix(V, F),
                                          max(n_rounds, 15))
                    row("cotan vs igl, freed memory kept", mesh, ta, tb, {"keep_freed_memory": kept})
            except ImportError:
                pass
    if args.json_out:
        Path(args.json_out).write_text(json.dumps({"threads": THREADS, "rows": rows}, indent=2))


if __name__ == "__main__":
    main()
