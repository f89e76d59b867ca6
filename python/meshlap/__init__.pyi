# Type stubs of meshlap. Shapes in comments: n vertices, m faces, k eigenpairs.
# Every operator is positive semi-definite, F = D − W (Zhang 2004).
# Inputs: V float64 (n, 3) (float32/int accepted, copied), F int64 (m, 3)
# (int32/uint32 accepted, copied to uint32).
import os
from typing import Any, Dict, Literal, Optional, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt
import scipy.sparse

from .errors import (
    CodecError as CodecError,
    Error as Error,
    MeshError as MeshError,
    MeshIOError as MeshIOError,
    MetricError as MetricError,
    OperatorError as OperatorError,
    PartitionError as PartitionError,
    RenderError as RenderError,
    RepairError as RepairError,
    SolveError as SolveError,
    SpectralError as SpectralError,
    WatermarkError as WatermarkError,
)

__version__: str
OPERATOR_KINDS: Tuple[str, ...]

_F64 = npt.NDArray[np.float64]
_I64 = npt.NDArray[np.int64]
_ArrayLike = npt.ArrayLike
_Path = Union[str, os.PathLike[str]]

# (V float64 (n, 3), F int64 (m, 3)), cleaned as the CLI cleans.
def read_mesh(path_or_builtin: _Path, format: Optional[str] = ...) -> Tuple[_F64, _I64]: ...
# scalars float64 (n,), colors uint8 (n, 3): PLY vertex properties.
def write_mesh(path: _Path, V: _ArrayLike, F: _ArrayLike, scalars: Optional[_ArrayLike] = ..., colors: Optional[_ArrayLike] = ..., *, scalar_name: str = ..., format: Optional[str] = ..., ascii: bool = ...) -> None: ...
# Keys of `meshlap info --json`.
def info(V: _ArrayLike, F: _ArrayLike) -> Dict[str, Any]: ...
# (V float64 (n', 3), F int64 (m', 3), report dict).
def clean(V: _ArrayLike, F: _ArrayLike, split_nonmanifold: bool = ...) -> Tuple[_F64, _I64, Dict[str, Any]]: ...
# n×n float64 csr_array, F = D − W.
def operator(V: _ArrayLike, F: _ArrayLike, kind: str = ..., *, sql_diagonal: str = ..., mass: str = ...) -> scipy.sparse.csr_array: ...
# n×n diagonal float64 csr_array.
def mass_matrix(V: _ArrayLike, F: _ArrayLike, kind: str = ...) -> scipy.sparse.csr_array: ...
def properties(V: _ArrayLike, F: _ArrayLike, kind: str, *, dense_limit: Optional[int] = ..., sql_diagonal: str = ..., mass: str = ...) -> Dict[str, Any]: ...
# (evals float64 (k,), evecs float64 (n, k)) [, info dict]; all n pairs unless count.
@overload
def spectrum(V: _ArrayLike, F: _ArrayLike, kind: str = ..., count: Optional[int] = ..., *, path: str = ..., normalization: str = ..., dense_solver: str = ..., sql_diagonal: str = ..., mass: str = ..., tol: Optional[float] = ..., refine: bool = ..., band_size: Optional[int] = ..., block_size: Optional[int] = ..., return_info: Literal[False] = ...) -> Tuple[_F64, _F64]: ...
@overload
def spectrum(V: _ArrayLike, F: _ArrayLike, kind: str = ..., count: Optional[int] = ..., *, path: str = ..., normalization: str = ..., dense_solver: str = ..., sql_diagonal: str = ..., mass: str = ..., tol: Optional[float] = ..., refine: bool = ..., band_size: Optional[int] = ..., block_size: Optional[int] = ..., return_info: Literal[True]) -> Tuple[_F64, _F64, Dict[str, Any]]: ...
# (evals float64 (k,), evecs float64 (n, k)) [, residuals float64 (k,)].
@overload
def eigs(V: _ArrayLike, F: _ArrayLike, k: int, kind: str = ..., *, tol: Optional[float] = ..., sql_diagonal: str = ..., mass: str = ..., refine: bool = ..., band_size: Optional[int] = ..., block_size: Optional[int] = ..., return_residuals: Literal[False] = ...) -> Tuple[_F64, _F64]: ...
@overload
def eigs(V: _ArrayLike, F: _ArrayLike, k: int, kind: str = ..., *, tol: Optional[float] = ..., sql_diagonal: str = ..., mass: str = ..., refine: bool = ..., band_size: Optional[int] = ..., block_size: Optional[int] = ..., return_residuals: Literal[True]) -> Tuple[_F64, _F64, _F64]: ...
# A: n×n symmetric PSD (sparse or dense); M: positive diagonal (sparse, dense or (n,)).
@overload
def eigsh(A: Any, k: int, M: Any = ..., tol: float = ..., *, refine: bool = ..., band_size: Optional[int] = ..., block_size: Optional[int] = ..., return_residuals: Literal[False] = ...) -> Tuple[_F64, _F64]: ...
@overload
def eigsh(A: Any, k: int, M: Any = ..., tol: float = ..., *, refine: bool = ..., band_size: Optional[int] = ..., block_size: Optional[int] = ..., return_residuals: Literal[True]) -> Tuple[_F64, _F64, _F64]: ...
# V′ float64 (n, 3).
def project(V: _ArrayLike, F: _ArrayLike, kind: str, keep: Union[int, str], patch_size: Optional[int] = ...) -> _F64: ...
# float64 (n, 4): η_x, η_y, η_z, η for m = 1..n.
def compaction(V: _ArrayLike, F: _ArrayLike, kind: str, *, centre: bool = ...) -> _F64: ...
# (V′ float64 (n, 3), info dict with iterations, residuals, solves[].history).
def smooth(V: _ArrayLike, F: _ArrayLike, filter: str = ..., operator: str = ..., lam: Optional[float] = ..., steps: Optional[int] = ..., solver: Optional[str] = ..., *, stop: Optional[str] = ..., tol: Optional[float] = ..., max_iterations: Optional[int] = ..., kpb: Optional[float] = ..., order: Optional[int] = ..., passband: Optional[float] = ..., preserve: str = ..., dense_limit: Optional[int] = ...) -> Tuple[_F64, Dict[str, Any]]: ...
# (V float64 (n', 3), F int64 (m', 3), report dict).
def repair_sql(V: _ArrayLike, F: _ArrayLike, method: str = ..., *, max_dihedral: Optional[float] = ...) -> Tuple[_F64, _I64, Dict[str, Any]]: ...
# int32 labels (n,) [, stats dict].
def partition(V: _ArrayLike, F: _ArrayLike, patch_size: int, *, seed: int = ..., method: str = ..., return_stats: bool = ...) -> Any: ...
# .mlz bytes [, report dict].
def compress(V: _ArrayLike, F: _ArrayLike, bits: Optional[float] = ..., target_bpv: Optional[float] = ..., mode: Optional[str] = ..., *, operator: Optional[str] = ..., patch_size: Optional[int] = ..., keep_ratio: Optional[float] = ..., coefficients: Optional[int] = ..., band_slope: Optional[float] = ..., dead_zone: Optional[float] = ..., prediction: bool = ..., border_residuals: bool = ..., rdo_lambda: Optional[float] = ..., select: bool = ..., preserve_order: bool = ..., return_report: bool = ...) -> Any: ...
# (V float64 (n, 3), F int64 (m, 3)).
def decompress(data: Union[bytes, bytearray, memoryview]) -> Tuple[_F64, _I64]: ...
# Keys of `meshlap compare --json`; map: int (n_b,).
def compare(Va: _ArrayLike, Fa: _ArrayLike, Vb: _ArrayLike, Fb: _ArrayLike, *, map: Optional[_ArrayLike] = ..., samples: int = ...) -> Dict[str, Any]: ...
# uint8 (H, W, 3); scalars float64 (n,); size = (W, H).
def render(V: _ArrayLike, F: _ArrayLike, scalars: Optional[_ArrayLike] = ..., colormap: str = ..., azimuth: float = ..., elevation: float = ..., size: Optional[Tuple[int, int]] = ..., *, smooth: bool = ..., wireframe: bool = ..., legend: bool = ...) -> npt.NDArray[np.uint8]: ...
# evals float64 (k,), evecs float64 (n, k) → float64 (n, T) [, times (T,)].
def hks(evals: _ArrayLike, evecs: _ArrayLike, times: Optional[_ArrayLike] = ..., *, count: int = ..., return_times: bool = ...) -> Any: ...
# → float64 (n, E) [, energies (E,), sigma].
def wks(evals: _ArrayLike, evecs: _ArrayLike, energies: Optional[_ArrayLike] = ..., *, sigma: Optional[float] = ..., count: int = ..., return_energies: bool = ...) -> Any: ...
def set_threads(n: int) -> None: ...
def get_threads() -> int: ...
def keep_freed_memory() -> bool: ...

def watermark_embed(
    V: _ArrayLike,
    F: _ArrayLike,
    key: int,
    message: str,
    *,
    operator: Optional[str] = ...,
    strength: Optional[float] = ...,
    chip_rate: Optional[int] = ...,
    patch_size: Optional[int] = ...,
    band: Optional[int] = ...,
) -> Tuple[_F64, Dict[str, Any]]:
    """(V′ float64 (n, 3), report); V float (n, 3), F int (m, 3); message hex."""
    ...
def watermark_detect(
    Vs: _ArrayLike,
    Fs: _ArrayLike,
    Vo: _ArrayLike,
    Fo: _ArrayLike,
    key: int,
    bits: int = ...,
    *,
    expect: Optional[str] = ...,
    operator: Optional[str] = ...,
    patch_size: Optional[int] = ...,
    band: Optional[int] = ...,
    chip_rate: Optional[int] = ...,
) -> Dict[str, Any]:
    """Detection report (keys of `meshlap watermark detect --json`)."""
    ...
