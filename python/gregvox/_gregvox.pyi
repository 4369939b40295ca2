# Type stubs of the native module (src/lib.rs); call it through the gregvox package, which checks and
# converts arrays first.
from typing import Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
# UVs: values (k, 2), one value index per face corner, the face-varying rule (0…5)
Uv = Optional[Tuple[F64, I64, int]]
# crease pairs (2k), crease sharpness (k), corners, corner sharpness, holes, boundary rule, isolation level, UVs
Tags = Tuple[I64, F64, I64, F64, I64, str, Optional[int], Uv]
CsrTriplets = Tuple[I64, I64, I64, Tuple[int, int]]

class Device:
    def __init__(self, name: Optional[str] = ..., validation: Optional[bool] = ...) -> None: ...
    @property
    def info_json(self) -> str: ...
    @property
    def validation_messages(self) -> List[str]: ...
    def finish(self) -> None: ...

class PackedGrid:
    def save(self, path: str, npy_packed: bool = ..., ply_boundary: bool = ...) -> None: ...
    def boundary_mesh(self) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]: ...

class GregorySurface:
    def __init__(
        self,
        device: Device,
        v: F64,
        face_ptr: I64,
        indices: I64,
        tags: Tags,
        tangents: str,
    ) -> None: ...
    @property
    def patch_count(self) -> int: ...
    def evaluate(
        self, level: int
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], Optional[npt.NDArray[np.float32]]]: ...
    def set_cage(self, v: F64) -> None: ...

def load_mesh(path: str) -> Tuple[F64, I64, I64]: ...
def load_cage(path: str) -> Tuple[Tuple[F64, I64, I64], Tuple[I64, F64, I64, F64, I64, str, Uv]]: ...
def evaluate_at(
    v: F64,
    face_ptr: I64,
    indices: I64,
    tags: Tags,
    fuv: F64,
    tangents: str,
) -> Tuple[F64, F64, F64, F64, F64, F64, Optional[F64]]: ...
def topology_json(v: F64, face_ptr: I64, indices: I64) -> str: ...
def subdivide(v: F64, face_ptr: I64, indices: I64, levels: int, scheme: str) -> Tuple[F64, I64, I64]: ...
def mesh_matrices(v: F64, face_ptr: I64, indices: I64) -> Dict[str, CsrTriplets]: ...
def vertex_normals(v: F64, face_ptr: I64, indices: I64, weighting: str) -> F64: ...
def grid_indices(patches: int, level: int) -> npt.NDArray[np.uint32]: ...
def voxelize(
    device: Device,
    v: F64,
    face_ptr: I64,
    indices: I64,
    res: Optional[int] = ...,
    dims: Optional[Tuple[int, int, int]] = ...,
    voxel_size: Optional[float] = ...,
    bbox: Optional[Tuple[Tuple[float, float, float], Tuple[float, float, float]]] = ...,
    pad: int = ...,
    rule: str = ...,
    fill: str = ...,
    method: str = ...,
) -> Tuple[npt.NDArray[np.uint8], List[float], List[float], PackedGrid, str, float]: ...
def query(
    v: F64,
    face_ptr: I64,
    indices: I64,
    points: F64,
    what: List[str],
    rule: str = ...,
    sdf_sign: str = ...,
    tolerance: float = ...,
) -> Dict[str, npt.NDArray[np.generic]]: ...
def simplify(
    v: F64,
    face_ptr: I64,
    indices: I64,
    ratio: Optional[float],
    faces: Optional[int],
    error: Optional[float],
    placement: str,
    lock_border: bool,
    allow_topology: bool,
    prune: float,
) -> Tuple[Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int64]], str]: ...
