"""Loading: meshlap (read + clean + connectivity) vs trimesh.load (+ its edge
adjacency), and write/re-read throughput of a 2.6M-vertex mesh with peak memory.

Run: bench/.venv/bin/python bench/load.py
"""
import subprocess
import tempfile
from pathlib import Path

from common import MESHES, THREADS, build, limit_threads, meshlap_bench, table, timeit


def trimesh_load(path):
    import trimesh
    m = trimesh.load(path, process=True, force="mesh")
    # connectivity comparable to ours: unique edges and face adjacency
    m.edges_unique
    m.face_adjacency
    return m


def main():
    rows = []
    with limit_threads():
        for name in ["stanford-bunny.obj", "horse.ply", "igea.ply"]:
            path = str(MESHES / name)
            ours = meshlap_bench("load", path, "--repeat", 7)["load"]["median"]
            t = timeit(lambda: trimesh_load(path), repeat=5)
            faces = len(trimesh_load(path).faces)
            rows.append([name, f"{t * 1e3:.1f}", f"{ours * 1e3:.1f}", f"{t / ours:.1f}x", faces])
    print(f"threads = {THREADS}")
    table(rows, ["mesh", "trimesh ms", "meshlap ms", "speed-up", "trimesh faces"])

    exe = build() / "meshlap-bench"
    with tempfile.TemporaryDirectory() as d:
        mem = Path(d) / "mem.txt"
        out = subprocess.run(
            ["/usr/bin/time", "-f", "%M", "-o", str(mem), str(exe), "io", "builtin:icosphere:9", "--repeat", "3"],
            check=True, capture_output=True, text=True).stdout
        import json
        r = json.loads(out)
        peak = int(mem.read_text().split()[-1]) / 1024
    rows = []
    for ext in ["ply", "obj"]:
        x = r[ext]
        rows.append([ext, f"{x['bytes'] / 1e6:.0f}", f"{x['write']:.2f}", f"{x['write_mb_s']:.0f}",
                     f"{x['read']:.2f}", f"{x['read_mb_s']:.0f}"])
    print(f"\nbuiltin:icosphere:9: {r['vertices']} vertices; peak RSS of the whole run {peak:.0f} MiB")
    table(rows, ["format", "MB", "write s", "write MB/s", "read s", "read MB/s"])


if __name__ == "__main__":
    main()
