"""Shared helpers of the side-by-side benchmarks: build meshlap, pin threads, time."""
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from settle import wait_for_load

ROOT = Path(__file__).resolve().parent.parent
MESHES = ROOT.parent / "shared" / "data" / "meshes"
THREADS = int(os.environ.get("BENCH_THREADS", "2"))


def mesh_path(name):
    """A mesh argument: a path as given when it exists, else a name in MESHES (so that
    `operators.py igea.ply` works from any directory)."""
    path = Path(name)
    return path if path.exists() else MESHES / name


# The peers' own BLAS kernel. Some machines of this workplace set OPENBLAS_CORETYPE and
# OPENBLAS_L2_SIZE (older OpenBLAS builds failed on their processors); with them the
# current OpenBLAS in numpy's wheel runs an older kernel than the CPU's (Haswell's AVX2
# instead of SkylakeX's AVX-512 on the 2026-12-02 Zen 5 host), which slows numpy and
# flatters every ratio against it. OpenBLAS reads them once, when numpy is first
# imported, so a script that finds them set starts again without them (whatever it has
# imported so far). BENCH_KEEP_OPENBLAS_ENV=1 keeps them, to measure their effect.
_FORCED = ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")
if any(v in os.environ for v in _FORCED) and os.environ.get("BENCH_KEEP_OPENBLAS_ENV") != "1":
    _env = {k: v for k, v in os.environ.items() if k not in _FORCED}
    sys.stdout.flush()
    os.execve(sys.executable, sys.orig_argv, _env)

# Same threads on both sides: our rayon pool and the peers' BLAS.
os.environ["RAYON_NUM_THREADS"] = str(THREADS)
for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[var] = str(THREADS)


def blas_kernel():
    """The peers' BLAS as threadpoolctl sees it: library, version, kernel, threads."""
    import numpy  # noqa: F401  (loads OpenBLAS)
    from threadpoolctl import threadpool_info
    return "; ".join(
        f"{i.get('internal_api')} {i.get('version')}, kernel {i.get('architecture')}, "
        f"{i.get('num_threads')} threads"
        for i in threadpool_info() if i.get("user_api") == "blas")


# On stderr: a script's stdout may be data (fairing_cold.py's workers print JSON).
print(f"peers' BLAS: {blas_kernel()} (OPENBLAS_CORETYPE "
      f"{os.environ.get('OPENBLAS_CORETYPE', 'unset')})", file=sys.stderr, flush=True)


_BUILT = None


def build():
    """Builds the release binaries once per process and returns their directory. When
    the build changed them (it compiled), waits for the load to settle before any
    timing (`settle.wait_for_load`). With BENCH_NO_BUILD=1 the binaries already built
    are used as they are (an error if they are missing): for a series of runs that
    must all time one build while the source changes beside them."""
    global _BUILT
    release = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "release"
    if _BUILT is not None:
        return _BUILT
    binaries = [release / "meshlap", release / "meshlap-bench"]
    if os.environ.get("BENCH_NO_BUILD") == "1":
        missing = [str(b) for b in binaries if not b.exists()]
        if missing:
            sys.exit(f"BENCH_NO_BUILD=1 but not built: {', '.join(missing)}")
        _BUILT = release
        return release

    def stamps():
        return [b.stat().st_mtime_ns if b.exists() else None for b in binaries]

    before = stamps()
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "meshlap-cli"], cwd=ROOT, check=True)
    if stamps() != before:
        wait_for_load("rebuilt the binaries")
    _BUILT = release
    return release


def meshlap(*args):
    exe = build() / "meshlap"
    return subprocess.run([str(exe), *map(str, args)], check=True, capture_output=True, text=True).stdout


def meshlap_bench(*args):
    exe = build() / "meshlap-bench"
    out = subprocess.run([str(exe), *map(str, args)], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def timeit(fn, repeat=7):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def limit_threads():
    from threadpoolctl import threadpool_limits
    return threadpool_limits(limits=THREADS)


def load_vf(path):
    """Vertices and faces exactly as meshlap cleans them (via a temporary OFF)."""
    import numpy as np
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        off = Path(d) / "m.off"
        meshlap("convert", path, off)
        lines = [l for l in off.read_text().split("\n") if l.strip() and not l.startswith("#")]
        nv, nf = map(int, lines[1].split()[:2])
        V = np.array([list(map(float, l.split()[:3])) for l in lines[2:2 + nv]])
        F = np.array([list(map(int, l.split()[1:4])) for l in lines[2 + nv:2 + nv + nf]], dtype=np.int64)
    return V, F


def table(rows, header):
    widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(len(header))]
    line = "| " + " | ".join(h.ljust(w) for h, w in zip(header, widths)) + " |"
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    print(line)
    print(sep)
    for r in rows:
        print("| " + " | ".join(str(c).ljust(w) for c, w in zip(r, widths)) + " |")
    sys.stdout.flush()
