# Type stubs of gregvox's public API (the implementation and its docstrings are in __init__.py).
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix

Faces = Union[npt.NDArray[np.integer], Sequence[Sequence[int]], Sequence[npt.NDArray[np.integer]]]
PathLike = Union[str, os.PathLike[str]]

__all__: List[str]

class Device:
    info: Dict[str, Any]
    def __init__(self, name: Optional[str] = ..., validation: Optional[bool] = ...) -> None: ...
    @property
    def validation_messages(self) -> List[str]: ...
    def finish(self) -> None: ...

def default_device() -> Device: ...

class Grid:
    occupancy: npt.NDArray[np.bool_]
    origin: npt.NDArray[np.float64]
    voxel_size: npt.NDArray[np.float64]
    report: Dict[str, Any]
    library_seconds: float
    @property
    def dims(self) -> Tuple[int, int, int]: ...
    @property
    def index_to_world(self) -> npt.NDArray[np.float64]: ...
    def centers(self) -> npt.NDArray[np.float64]: ...
    def save(self, path: PathLike, npy_packed: bool = ..., ply_boundary: bool = ...) -> None: ...
    def boundary_mesh(self) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]: ...

class GregorySurface:
    def __init__(
        self,
        V: npt.ArrayLike,
        F: Faces,
        tangents: str = ...,
        device: Optional[Device] = ...,
        *,
        creases: Optional[npt.ArrayLike] = ...,
        crease_sharpness: Union[float, npt.ArrayLike] = ...,
        corners: Optional[npt.ArrayLike] = ...,
        corner_sharpness: Union[float, npt.ArrayLike] = ...,
        holes: Optional[npt.ArrayLike] = ...,
        boundary: str = ...,
        isolation: Optional[int] = ...,
        uvs: Optional[npt.ArrayLike] = ...,
        uv_faces: Optional[Faces] = ...,
        uv_rule: int = ...,
    ) -> None: ...
    has_uv: bool
    @property
    def patch_count(self) -> int: ...
    def evaluate(self, level: int, uvs: bool = ...) -> Tuple[npt.NDArray[np.float32], ...]: ...
    def set_cage(self, V: npt.ArrayLike) -> None: ...
    def indices(self, level: int) -> npt.NDArray[np.uint32]: ...

def load_mesh(path: PathLike) -> Tuple[npt.NDArray[np.float64], Union[npt.NDArray[np.int64], List[npt.NDArray[np.int64]]]]: ...
def load_cage(
    path: PathLike,
) -> Tuple[npt.NDArray[np.float64], Union[npt.NDArray[np.int64], List[npt.NDArray[np.int64]]], Dict[str, Any]]: ...
def evaluate_at(
    V: npt.ArrayLike,
    F: Faces,
    fuv: npt.ArrayLike,
    *,
    creases: Optional[npt.ArrayLike] = ...,
    crease_sharpness: Union[float, npt.ArrayLike] = ...,
    corners: Optional[npt.ArrayLike] = ...,
    corner_sharpness: Union[float, npt.ArrayLike] = ...,
    holes: Optional[npt.ArrayLike] = ...,
    boundary: str = ...,
    isolation: Optional[int] = ...,
    tangents: str = ...,
    uvs: Optional[npt.ArrayLike] = ...,
    uv_faces: Optional[Faces] = ...,
    uv_rule: int = ...,
) -> Dict[str, npt.NDArray[np.float64]]: ...
def voxelize(
    V: npt.ArrayLike,
    F: Faces,
    res: Optional[int] = ...,
    dims: Optional[Sequence[int]] = ...,
    voxel_size: Optional[float] = ...,
    bbox: Optional[Sequence[Sequence[float]]] = ...,
    pad: int = ...,
    rule: str = ...,
    fill: str = ...,
    method: str = ...,
    device: Optional[Device] = ...,
) -> Grid: ...
def topology(V: npt.ArrayLike, F: Faces) -> Dict[str, Any]: ...
def subdivide(
    V: npt.ArrayLike, F: Faces, levels: int, scheme: str = ...
) -> Tuple[npt.NDArray[np.float64], Union[npt.NDArray[np.int64], List[npt.NDArray[np.int64]]]]: ...
def mesh_matrices(V: npt.ArrayLike, F: Faces) -> Dict[str, csr_matrix]: ...
def action_map(M: csr_matrix, weights: Sequence[float]) -> csr_matrix: ...
def vertex_normals(V: npt.ArrayLike, F: Faces, weighting: str = ...) -> npt.NDArray[np.float64]: ...
def query(
    V: npt.ArrayLike,
    F: Faces,
    points: npt.ArrayLike,
    what: Union[str, Sequence[str]] = ...,
    rule: str = ...,
    sdf_sign: str = ...,
    tolerance: float = ...,
) -> Dict[str, npt.NDArray[Any]]: ...
def simplify(
    V: npt.ArrayLike,
    F: Faces,
    ratio: Optional[float] = ...,
    faces: Optional[int] = ...,
    error: Optional[float] = ...,
    placement: str = ...,
    lock_border: bool = ...,
    allow_topology: bool = ...,
    prune: float = ...,
    report: bool = ...,
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], Any]: ...
