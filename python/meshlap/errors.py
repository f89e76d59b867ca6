"""Exceptions of meshlap.

Every error the library reports is a :class:`meshlap.Error`, a :class:`ValueError`
subclass; the subclasses name the part that failed. The message is the library's own
(the same line ``meshlap`` prints after ``meshlap: error:``), and for bad arguments it
names the argument and the expected shape.
"""

from __future__ import annotations


class Error(ValueError):
    """Base class of every meshlap error (a :class:`ValueError`)."""


class MeshError(Error):
    """Bad mesh input: wrong shape or dtype of V or F, NaN/inf coordinates, a face
    index out of range or negative, an empty mesh, a non-manifold edge or vertex
    where a manifold is needed (run :func:`meshlap.clean` with
    ``split_nonmanifold=True``)."""


class MeshIOError(Error, OSError):
    """A mesh file could not be read or written (missing file, unknown format,
    malformed content). Also an :class:`OSError`."""


class OperatorError(Error):
    """An operator could not be assembled (isolated vertex, zero-length edge,
    degenerate face for a geometric operator, unknown kind or option)."""


class SpectralError(Error):
    """An eigensolve or spectral transform failed or was given bad input (A not
    symmetric or not square, k out of range, M not positive diagonal, ...)."""


class SolveError(Error):
    """A filter or linear solve failed (not positive definite, no convergence,
    invalid filter parameters)."""


class RepairError(Error):
    """The SQL negative-weight repair failed."""


class PartitionError(Error):
    """Partitioning failed (METIS) or was given a bad patch size or too many Lloyd
    steps."""


class CodecError(Error):
    """Compression failed (bad parameters, non-manifold mesh) or a ``.mlz`` stream
    is truncated, corrupt or foreign."""


class MetricError(Error):
    """A distortion metric could not be computed."""


class RenderError(Error):
    """A picture could not be rendered (bad size, scalars of the wrong length,
    unknown colormap)."""


__all__ = [
    "Error",
    "MeshError",
    "MeshIOError",
    "OperatorError",
    "SpectralError",
    "SolveError",
    "RepairError",
    "PartitionError",
    "CodecError",
    "MetricError",
    "RenderError",
    "WatermarkError",
]


class WatermarkError(Error):
    """Watermark embedding or detection failed: a bad message or key, a mesh too small
    for the message, a suspect that cannot be registered to the original, or an
    attack's invalid parameter."""
