#!/usr/bin/env bash
# Creates bench/.venv with the Python peers of the side-by-side benchmarks.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
if [ ! -x "$here/.venv/bin/python" ]; then
  python3 -m venv "$here/.venv"
fi
"$here/.venv/bin/python" -m pip install --quiet --upgrade pip
"$here/.venv/bin/python" -m pip install --quiet numpy scipy libigl trimesh DracoPy threadpoolctl pymetis
# CHOLMOD for bench/solvers.py: needs the SuiteSparse headers first
#   apt-get install libsuitesparse-dev        (Debian 12 ships SuiteSparse 5.12)
# scikit-sparse 0.4.13+ needs SuiteSparse 7, so pin 0.4.12 and build it against the
# installed numpy (a wheel built in pip's isolated environment fails to import).
if [ -f /usr/include/suitesparse/cholmod.h ]; then
  "$here/.venv/bin/python" -m pip install --quiet "cython<3.1" setuptools wheel
  "$here/.venv/bin/python" -m pip install --quiet --no-build-isolation --no-cache-dir "scikit-sparse==0.4.12"
else
  echo "libsuitesparse-dev not installed: bench/solvers.py will skip CHOLMOD" >&2
fi
"$here/.venv/bin/python" - <<'PY'
import numpy, scipy, igl, trimesh, DracoPy, threadpoolctl
print("peers:", "numpy", numpy.__version__, "scipy", scipy.__version__, "trimesh", trimesh.__version__)
PY
