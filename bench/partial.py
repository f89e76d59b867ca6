"""Partial spectra and partitioning, side by side in one run.

- The k smallest SQL eigenpairs (k = 50, 200) of stanford-bunny.obj: meshlap's banded
  shift-invert block Krylov–Schur vs scipy `eigsh` shift-invert (ARPACK + SuperLU), same
  shift σ = −10⁻³·mean(diag), same threads; scipy at its default tolerance (machine
  precision) and at ours (1e-11, the same per-pair criterion); eigenvalues and residuals
  compared.
- The 1,000 smallest of igea.ply (meshlap only; `--full`).
- Goal 5 of issue 17 against the peer (`--at-scale igea,torus`): igea.ply's 1,000
  smallest and the 200 smallest of `builtin:torus:1250:800` (10⁶ vertices), meshlap
  (`meshlap-bench partial`, its defaults) and scipy's shift-invert `eigsh` (ARPACK +
  SuperLU, σ as above, tol 1e-11: our per-pair criterion) alternated over
  `--rounds-at-scale` rounds, each call in its own process under `/usr/bin/time` for
  its peak RSS; scipy's calls are stopped after `--peer-timeout` seconds and reported
  as "> T". scipy's time excludes reading the matrix; ours includes assembling it.
- Partition edge cut: meshlap (METIS + connectivity repairs) vs pymetis k-way.
- A patch-wise projection end to end with the peak RSS (`--project MESH`).

Usage: bench/.venv/bin/python bench/partial.py [--full] [--counts 50,200]
       [--project builtin:icosphere:6] [--repeat ROUNDS]
       bench/.venv/bin/python bench/partial.py --at-scale igea[,torus]
       [--rounds-at-scale 2] [--peer-timeout 1800]

The bunny rows alternate the two sides (meshlap, scipy at both tolerances, meshlap,
...) for ROUNDS rounds of one call each and report the medians; run it on an idle
machine (`../shared/tools/quiet-run -- ...`).
"""
import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import common


def scipy_eigsh(mtx, k, tol=0.0, repeat=1):
    """scipy eigsh shift-invert (ARPACK + SuperLU); median time of `repeat` runs,
    sorted eigenvalues, the largest residual ‖Av − λv‖ and the orthogonality
    max |VᵀV − I| of the last run.
    `tol` is ARPACK's per-pair criterion ‖r‖ ≤ tol·|θ| on the shift-inverted
    operator (0 = machine precision, scipy's default) — the same criterion as
    meshlap's `PartialOptions::tolerance`."""
    import scipy.io
    import scipy.sparse.linalg as sla
    A = scipy.io.mmread(mtx).tocsc()
    sigma = -1e-3 * A.diagonal().mean()
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        vals, vecs = sla.eigsh(A, k=k, sigma=sigma, which="LM", tol=tol, return_eigenvectors=True)
        times.append(time.perf_counter() - t)
    res = float(np.max(np.linalg.norm(A @ vecs - vecs * vals, axis=0)))
    orth = float(np.max(np.abs(vecs.T @ vecs - np.eye(k))))
    return float(np.median(times)), np.sort(vals), res, orth


def timed_child(cmd, timeout=None):
    """Runs `cmd` under `/usr/bin/time -f %M`: (its stdout, peak RSS in GiB), or
    (None, None) if it ran past `timeout` seconds (then it is killed)."""
    try:
        r = subprocess.run(["/usr/bin/time", "-f", "%M", *map(str, cmd)], capture_output=True,
                           text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, None
    if r.returncode != 0:
        sys.exit(f"{cmd[0]} failed: {r.stderr.strip()}")
    return r.stdout, int(r.stderr.strip().splitlines()[-1]) / 2**20


def eigsh_child(mtx, k):
    """`--eigsh-child`: one scipy `eigsh` call (2 BLAS threads) on the matrix file; prints
    its time, largest residual ‖Av − λv‖, orthogonality max |VᵀV − I| and the sorted
    eigenvalues as JSON."""
    with common.limit_threads():
        seconds, vals, res, orth = scipy_eigsh(mtx, k, tol=1e-11)
    print(json.dumps({"seconds": seconds, "max_residual": res, "orthogonality": orth,
                      "eigenvalues": list(map(float, vals))}))


def at_scale(args):
    """Goal 5 of issue 17 side by side: see the module docstring."""
    known = {"igea": ("igea.ply, k = 1000", str(common.MESHES / "igea.ply"), 1000),
             "torus": ("torus 1M, k = 200", "builtin:torus:1250:800", 200)}
    names = args.at_scale.split(",")
    if any(x not in known for x in names):
        sys.exit(f"--at-scale takes a list of {', '.join(known)}")
    problems = [known[x] for x in names]
    bench = common.build() / "meshlap-bench"
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for label, mesh, k in problems:
            mtx = Path(d) / "sql.mtx"
            common.meshlap("operator", mesh, "--kind", "sql", "--output", mtx, "--json")
            ours, peer = [], []
            for _ in range(args.rounds_at_scale):
                out, gib = timed_child([bench, "partial", mesh, "--count", k, "--repeat", 1])
                p = json.loads(out)["partial"]
                ours.append((p["median"], gib, p))
                print(f"{label}: meshlap {p['median']:.2f} s, {gib:.2f} GiB", flush=True)
                out, gib = timed_child([sys.executable, __file__, "--eigsh-child", mtx, k],
                                       timeout=args.peer_timeout)
                peer.append((json.loads(out), gib) if out else None)
                print(f"{label}: scipy " + (f"{peer[-1][0]['seconds']:.2f} s, {gib:.2f} GiB"
                                            if out else f"> {args.peer_timeout} s"), flush=True)
            om = float(np.median([t for t, _, _ in ours]))
            p = ours[-1][2]
            done = [x for x in peer if x]
            if len(done) == len(peer):
                sm = float(np.median([x[0]["seconds"] for x in done]))
                s, sgib = done[-1]
                dv = float(np.max(np.abs(np.array(p["eigenvalues"]) - np.array(s["eigenvalues"]))))
                rows.append([label, f"{om:.2f}", f"{max(g for _, g, _ in ours):.2f}", f"{sm:.2f}",
                             f"{max(x[1] for x in done):.2f}", f"{sm / om:.2f}x",
                             f"{p['max_residual']:.1e} / {s['max_residual']:.1e}",
                             f"{p['orthogonality']:.1e} / {s['orthogonality']:.1e}", f"{dv:.1e}"])
            else:
                rows.append([label, f"{om:.2f}", f"{max(g for _, g, _ in ours):.2f}",
                             f"> {args.peer_timeout}", "-", f"> {args.peer_timeout / om:.1f}x",
                             f"{p['max_residual']:.1e} / -", f"{p['orthogonality']:.1e} / -", "-"])
    common.table(rows, ["problem", "meshlap s", "GiB", "scipy eigsh s", "GiB", "speed-up",
                        "max residual (ours / scipy)", "orthogonality", "max |Δλ|"])


def pymetis_cut(mtx, nparts):
    import pymetis
    import scipy.io
    A = scipy.io.mmread(mtx).tocsr()
    A.setdiag(0)
    A.eliminate_zeros()
    xadj, adjncy = A.indptr, A.indices
    if hasattr(pymetis, "CSRAdjacency"):
        # pymetis 2025: `xadj`/`adjncy` are deprecated (to be removed in 2027).
        graph = pymetis.CSRAdjacency(adj_starts=xadj, adjacent=adjncy)
        cut, _ = pymetis.part_graph(nparts, adjacency=graph)
    else:
        cut, _ = pymetis.part_graph(nparts, xadj=xadj, adjncy=adjncy)
    return cut


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--counts", default="50,200")
    ap.add_argument("--full", action="store_true", help="also the 1,000 smallest of igea.ply")
    ap.add_argument("--project", default="builtin:icosphere:6")
    ap.add_argument("--patch-size", type=int, default=300)
    ap.add_argument("--repeat", type=int, default=3,
                    help="alternated rounds (one call per side each) for the bunny rows")
    ap.add_argument("--at-scale", metavar="igea,torus",
                    help="only goal 5's problems against scipy eigsh (see the docstring)")
    ap.add_argument("--rounds-at-scale", type=int, default=2)
    ap.add_argument("--peer-timeout", type=float, default=1800.0)
    ap.add_argument("--eigsh-child", nargs=2, metavar=("MTX", "K"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.eigsh_child:
        eigsh_child(args.eigsh_child[0], int(args.eigsh_child[1]))
        return
    if args.at_scale:
        at_scale(args)
        return
    bunny = common.MESHES / "stanford-bunny.obj"
    rows = []
    with tempfile.TemporaryDirectory() as d, common.limit_threads():
        mtx = Path(d) / "sql.mtx"
        common.meshlap("operator", bunny, "--kind", "sql", "--output", mtx, "--json")
        for k in map(int, args.counts.split(",")):
            # Alternated rounds (ours, scipy at both tolerances, ours, ...), one call
            # each per round; medians over the rounds.
            ours_t, scipy_t, last = [], {0.0: [], 1e-11: []}, {}
            for _ in range(args.repeat):
                ours = common.meshlap_bench("partial", bunny, "--count", k, "--repeat", 1)
                p = ours["partial"]
                ours_t.append(p["median"])
                for tol in scipy_t:
                    ts, sv, sres, _ = scipy_eigsh(mtx, k, tol=tol, repeat=1)
                    scipy_t[tol].append(ts)
                    last[tol] = (sv, sres)
            om = float(np.median(ours_t))
            for tol, label in [(0.0, "default (tol = 0)"), (1e-11, "tol = 1e-11 (ours)")]:
                ts = float(np.median(scipy_t[tol]))
                sv, sres = last[tol]
                dv = float(np.max(np.abs(np.array(p["eigenvalues"]) - sv)))
                rows.append([f"bunny SQL k={k}", f"{om:.2f}", label, f"{ts:.2f}",
                             f"{ts / om:.2f}x", f"{p['max_residual']:.1e}", f"{sres:.1e}",
                             f"{dv:.1e}", p["bands"]])
        if args.full:
            igea = common.MESHES / "igea.ply"
            ours = common.meshlap_bench("partial", igea, "--count", 1000, "--repeat", 1)
            p = ours["partial"]
            rows.append(["igea SQL k=1000", f"{p['median']:.2f}", "-", "-", "-",
                         f"{p['max_residual']:.1e}", "-", "-", p["bands"]])
        common.table(rows, ["task", "meshlap s", "scipy eigsh", "scipy s", "speed-up",
                            "our max residual", "scipy max residual", "max |Δλ|", "bands"])
        print()
        part = common.meshlap_bench("partition", bunny, "--patch-size", args.patch_size,
                                    "--repeat", 3)["partition"]
        st = part["stats"]
        cut = pymetis_cut(mtx, st["metis_parts"])
        common.table([[f"bunny P={args.patch_size}", st["metis_parts"], st["patches"],
                       f"{st['min_size']}/{st['mean_size']:.0f}/{st['max_size']}",
                       st["metis_edge_cut"], st["edge_cut"], cut,
                       f"{st['edge_cut'] / cut:.3f}", f"{part['median']:.3f}"]],
                     ["partition", "parts", "patches", "min/mean/max", "METIS cut",
                      "final cut", "pymetis cut", "final/pymetis", "meshlap s"])
        print()
        pr = common.meshlap_bench("project-patches", args.project, "--patch-size",
                                  args.patch_size, "--keep", "0.1", "--repeat", 1)
        pp = pr["project_patches"]
        info = pp["info"]
        common.table([[args.project, info["vertices"], info["patches"], f"{pp['median']:.2f}",
                       f"{info['open_s']:.2f}", f"{info['partition_s']:.2f}",
                       f"{info['transform_s']:.2f}", f"{pp['peak_rss_kb'] / 1024:.0f}"]],
                     ["patch-wise projection (SQL, keep 10%)", "vertices", "patches",
                      "total s", "open s", "partition s", "transform s", "peak RSS MiB"])


if __name__ == "__main__":
    main()
