#!/usr/bin/env bash
# Creates bench/.venv with the Python peers of the side-by-side benchmarks.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
if [ ! -x "$here/.venv/bin/python" ]; then
  python3 -m venv "$here/.venv"
fi
"$here/.venv/bin/python" -m pip install --quiet --upgrade pip
"$here/.venv/bin/python" -m pip install --quiet numpy scipy libigl trimesh DracoPy threadpoolctl pymetis
"$here/.venv/bin/python" - <<'PY'
import numpy, scipy, igl, trimesh, DracoPy, threadpoolctl
print("peers:", "numpy", numpy.__version__, "scipy", scipy.__version__, "trimesh", trimesh.__version__)
PY
