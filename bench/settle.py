"""Waiting for the machine to settle after a build, before any timing.

A benchmark script runs under `quiet-run`, which checks the load before the script
starts. A build the script makes first (the release binaries, the Python package)
may compile, loading both cores right before the first timings; so after such a
build the script waits, as quiet-run does, for the one-minute load average to fall
below BENCH_MAX_LOAD (default 0.5; at most BENCH_SETTLE_WAIT seconds, default 900).
No imports beyond the standard library: `python_api.py` calls it before it re-runs
itself in its venv.
"""
import os
import sys
import time


def wait_for_load(after):
    """Waits for the load to settle; says on stderr what it waited after and the load."""
    limit = float(os.environ.get("BENCH_MAX_LOAD", "0.5"))
    deadline = time.time() + float(os.environ.get("BENCH_SETTLE_WAIT", "900"))
    while os.getloadavg()[0] >= limit and time.time() < deadline:
        time.sleep(5)
    print(f"bench: {after}, then waited for the load: {os.getloadavg()[0]:.2f} (limit {limit})",
          file=sys.stderr, flush=True)
