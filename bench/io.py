"""I/O throughput of a 2.6M-vertex mesh from the page cache: meshlap's readers against
trimesh and against the raw bandwidth of the same bytes, measured in the same run.

builtin:icosphere:9 (2,621,442 vertices, 5,242,880 faces) is written once as binary
PLY and as OBJ. Each round then times, in turn and on the same file:
  - meshlap read            `meshlap-bench read FILE` (parse only),
  - meshlap read+clean+topology  `meshlap-bench load FILE` (what every command does),
  - trimesh                 `trimesh.load(FILE, process=False)`,
  - raw page-cache read     the file's bytes read into a fresh buffer (`read()`) and
                            into a buffer already touched (`readinto`),
  - memcpy                  numpy copy of that many bytes between two touched buffers.
meshlap's figure per round is the median of `--repeat` reads inside one process (its
first read pays the process's first page faults). Medians over the rounds; MB/s are
file bytes per second; ratios are meshlap's throughput over the other's.

Run: bench/.venv/bin/python bench/io.py [--rounds N] [--repeat N]
"""
import argparse
import statistics
import tempfile
import time
from pathlib import Path

from common import THREADS, limit_threads, meshlap_bench, table


def timed(fn):
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def raw_read(path):
    with open(path, "rb", buffering=0) as f:
        return f.read()


def raw_readinto(path, buf):
    with open(path, "rb", buffering=0) as f:
        n = f.readinto(buf)
    assert n == len(buf)


def main():
    import numpy as np
    import trimesh

    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    rows, load_rows, raw_rows = [], [], []
    with limit_threads(), tempfile.TemporaryDirectory() as d:
        for ext in ["ply", "obj"]:
            path = Path(d) / f"ico9.{ext}"
            meshlap_bench("write", "builtin:icosphere:9", path, "--repeat", 1)
            size = path.stat().st_size
            raw_read(path)  # into the page cache
            m = trimesh.load(str(path), process=False, force="mesh")  # reads it all
            assert (len(m.vertices), len(m.faces)) == (2621442, 5242880), (len(m.vertices), len(m.faces))
            del m
            buf = np.empty(size, dtype=np.uint8)
            src = np.ones(size, dtype=np.uint8)
            dst = np.zeros(size, dtype=np.uint8)
            t = {k: [] for k in ["read", "load", "trimesh", "raw_read", "raw_readinto", "memcpy"]}
            for r in range(args.rounds):
                # Alternate which side goes first, so a drift in machine load is shared.
                sides = ["meshlap", "trimesh", "raw"]
                if r % 2:
                    sides.reverse()
                for side in sides:
                    if side == "meshlap":
                        t["read"].append(meshlap_bench("read", path, "--repeat", args.repeat)["read"]["median"])
                        t["load"].append(meshlap_bench("load", path, "--repeat", args.repeat)["load"]["median"])
                    elif side == "trimesh":
                        t["trimesh"].append(timed(lambda: trimesh.load(str(path), process=False, force="mesh")))
                    else:
                        t["raw_read"].append(timed(lambda: raw_read(path)))
                        t["raw_readinto"].append(timed(lambda: raw_readinto(path, buf)))
                        t["memcpy"].append(timed(lambda: np.copyto(dst, src)))
            med = {k: statistics.median(v) for k, v in t.items()}
            mbs = {k: size / v / 1e6 for k, v in med.items()}
            rows.append([ext, f"{size / 1e6:.0f}",
                         f"{med['read']:.3f}", f"{mbs['read']:.0f}",
                         f"{med['trimesh']:.3f}", f"{mbs['trimesh']:.0f}", f"{med['trimesh'] / med['read']:.1f}x",
                         f"{mbs['read'] / mbs['raw_read']:.2f}", f"{mbs['read'] / mbs['memcpy']:.2f}"])
            load_rows.append([ext, f"{med['load']:.3f}", f"{mbs['load']:.0f}", f"{med['trimesh'] / med['load']:.1f}x"])
            raw_rows.append([ext, f"{mbs['raw_read']:.0f}", f"{mbs['raw_readinto']:.0f}", f"{mbs['memcpy']:.0f}"])
            print(ext, {k: [round(x, 4) for x in v] for k, v in t.items()}, flush=True)
    print(f"\nthreads = {THREADS}, rounds = {args.rounds}, meshlap repeat = {args.repeat}; "
          "builtin:icosphere:9 (2,621,442 vertices, 5,242,880 faces)\n")
    table(rows, ["format", "MB", "meshlap read s", "MB/s", "trimesh s", "MB/s", "trimesh / meshlap",
                 "meshlap / raw read", "meshlap / memcpy"])
    print()
    table(load_rows, ["format", "read+clean+topology s", "MB/s", "trimesh (read only) / it"])
    print()
    table(raw_rows, ["format", "raw read() MB/s", "raw readinto MB/s", "memcpy MB/s"])


if __name__ == "__main__":
    main()
