"""Loading: meshlap (read + clean + connectivity) vs trimesh.load (+ its edge
adjacency), and write/re-read throughput of a 2.6M-vertex mesh with peak memory.

Run on an idle machine: ../shared/tools/quiet-run -- bench/.venv/bin/python bench/load.py
(the mesh table alternates the two sides over ROUNDS rounds).
"""
import statistics
import subprocess
import tempfile
from pathlib import Path

from common import MESHES, THREADS, build, limit_threads, meshlap_bench, table, timeit

ROUNDS = 3


def trimesh_load(path):
    import trimesh
    m = trimesh.load(path, process=True, force="mesh")
    # connectivity comparable to ours: unique edges and face adjacency
    m.edges_unique
    m.face_adjacency
    return m


def peak_mib(*args):
    """Runs meshlap-bench with ARGS under /usr/bin/time; (its JSON, peak RSS in MiB)."""
    import json
    exe = build() / "meshlap-bench"
    with tempfile.TemporaryDirectory() as d:
        mem = Path(d) / "mem.txt"
        out = subprocess.run(["/usr/bin/time", "-f", "%M", "-o", str(mem), str(exe), *map(str, args)],
                             check=True, capture_output=True, text=True).stdout
        return json.loads(out), int(mem.read_text().split()[-1]) / 1024


def main():
    rows = []
    with limit_threads(), tempfile.TemporaryDirectory() as d:
        # trimesh loads igea.ply (faces in one `tristrips` element) with ZERO faces, so
        # its time there is not comparable; we also time both on igea re-written by
        # meshlap as a plain binary PLY face list, which trimesh reads completely.
        igea_faces = Path(d) / "igea-faces.ply"
        meshlap_bench("write", MESHES / "igea.ply", igea_faces, "--repeat", 1)
        for path in [MESHES / "stanford-bunny.obj", MESHES / "horse.ply", MESHES / "igea.ply", igea_faces]:
            path = str(path)
            # Alternated rounds (meshlap, trimesh, meshlap, ...); medians of the round
            # medians.
            ours_r, peer_r = [], []
            for _ in range(ROUNDS):
                ours_r.append(meshlap_bench("load", path, "--repeat", 3)["load"]["median"])
                peer_r.append(timeit(lambda: trimesh_load(path), repeat=3))
            ours, t = statistics.median(ours_r), statistics.median(peer_r)
            faces = len(trimesh_load(path).faces)
            name = "igea.ply as face list" if path == str(igea_faces) else Path(path).name
            rows.append([name, f"{t * 1e3:.1f}", f"{ours * 1e3:.1f}", f"{t / ours:.1f}x", faces])
    print(f"threads = {THREADS}")
    table(rows, ["mesh", "trimesh ms", "meshlap ms", "speed-up", "trimesh faces"])

    # 2.6M vertices written and re-read, one process per step so that each peak RSS
    # is that step's own (the write step includes generating the icosphere).
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for ext in ["ply", "obj"]:
            f = Path(d) / f"ico9.{ext}"
            w, wmem = peak_mib("write", "builtin:icosphere:9", f, "--repeat", 3)
            r, rmem = peak_mib("read", f, "--repeat", 3)
            lr, lmem = peak_mib("load", f, "--repeat", 1)
            rows.append([ext, f"{w['write']['bytes'] / 1e6:.0f}", f"{w['write']['median']:.2f}",
                         f"{w['write']['mb_s']:.0f}", f"{wmem:.0f}", f"{r['read']['median']:.2f}",
                         f"{r['read']['mb_s']:.0f}", f"{rmem:.0f}", f"{lr['load']['median']:.2f}", f"{lmem:.0f}"])
    print(f"\nbuiltin:icosphere:9 (2,621,442 vertices, 5,242,880 faces)")
    table(rows, ["format", "MB", "write s", "write MB/s", "write peak MiB", "read s", "read MB/s",
                 "read peak MiB", "read+clean+topology s", "its peak MiB"])


if __name__ == "__main__":
    main()
