import os
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import meshlap

#: The shared test meshes beside the repository (as the Rust tests read them).
MESHES = Path(os.environ.get("MESHLAP_MESHES", Path(__file__).resolve().parents[3] / "shared" / "data" / "meshes"))


def shared_mesh(name: str) -> Path:
    p = MESHES / name
    if not p.exists():
        pytest.skip(f"{p} not present")
    return p


@pytest.fixture(scope="session")
def sphere():
    """icosphere level 2: 162 vertices, closed, valences 5 and 6."""
    return meshlap.read_mesh("builtin:icosphere:2")


@pytest.fixture(scope="session")
def big_sphere():
    """icosphere level 3: 642 vertices (above the dense threshold of 600)."""
    return meshlap.read_mesh("builtin:icosphere:3")


@pytest.fixture(scope="session")
def grid():
    """An open grid (boundary), 81 vertices."""
    return meshlap.read_mesh("builtin:grid:8")


def adjacency(F, n):
    """Symmetric 0/1 adjacency from the faces (scipy, independent of meshlap)."""
    F = np.asarray(F)
    i = np.concatenate([F[:, 0], F[:, 1], F[:, 2]])
    j = np.concatenate([F[:, 1], F[:, 2], F[:, 0]])
    a = sp.coo_array((np.ones(len(i)), (i, j)), shape=(n, n)).tocsr()
    a = a + a.T
    a.data[:] = 1.0
    return a
