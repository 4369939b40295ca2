"""gregvox: solid voxels and Gregory surfaces on the GPU (Vulkan), NumPy arrays in and out.

The same engine as the ``gregvox`` command line: ``voxelize`` gives the grid ``gregvox voxelize`` writes,
``GregorySurface.evaluate`` the points ``gregvox tessellate --no-weld`` writes.

>>> import gregvox, numpy as np
>>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
>>> F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]])
>>> grid = gregvox.voxelize(V, F, res=16)
>>> grid.occupancy.shape, grid.occupancy.dtype
((16, 16, 16), dtype('bool'))
"""
from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _gregvox

__all__ = [
    "Device",
    "Grid",
    "GregorySurface",
    "load_mesh",
    "voxelize",
    "mesh_matrices",
    "topology",
    "subdivide",
]

Faces = Union[np.ndarray, Sequence[Sequence[int]]]


class Device:
    """The Vulkan device (lavapipe where there is no GPU).

    ``name``: a case-insensitive substring of the device name; default ``GREGVOX_DEVICE``, else the first.
    """

    def __init__(self, name: Optional[str] = None):
        self._device = _gregvox.Device(name)
        self.info: Dict[str, Any] = json.loads(self._device.info_json)

    def __repr__(self) -> str:
        return f"gregvox.Device({self.info.get('name')!r})"


_default_device: Optional[Device] = None


def _device(device: Optional[Device]) -> Device:
    global _default_device
    if device is not None:
        if not isinstance(device, Device):
            raise TypeError("device must be a gregvox.Device")
        return device
    if _default_device is None:
        _default_device = Device()
    return _default_device


def _vertices(V: Any) -> np.ndarray:
    V = np.asarray(V)
    if V.dtype.kind not in "fiu" or V.dtype == np.bool_:
        raise ValueError(f"V must hold numbers, not {V.dtype}")
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"V must have shape (n, 3), not {V.shape}")
    V = np.ascontiguousarray(V, dtype=np.float64)
    if not np.isfinite(V).all():
        row = int(np.argwhere(~np.isfinite(V))[0][0])
        raise ValueError(f"V[{row}] is not finite (NaN or infinity)")
    return V


def _faces(F: Faces) -> Tuple[np.ndarray, np.ndarray]:
    """Faces as (offsets, indices) int64: an (m, k) integer array or a list of index sequences."""
    if isinstance(F, np.ndarray) and F.ndim == 2:
        if F.dtype.kind not in "iu":
            raise ValueError(f"F must hold integers, not {F.dtype}")
        if F.shape[1] < 3 and F.shape[0] > 0:
            raise ValueError(f"faces need 3 or more vertices: F has shape {F.shape}")
        idx = np.ascontiguousarray(F, dtype=np.int64).reshape(-1)
        ptr = np.arange(0, idx.size + 1, max(F.shape[1], 1), dtype=np.int64)[: F.shape[0] + 1]
        return ptr, idx
    if isinstance(F, np.ndarray) and F.ndim != 1:
        raise ValueError(f"F must have shape (m, k) or be a list of faces, not {F.shape}")
    faces = [np.asarray(f) for f in F]
    for k, f in enumerate(faces):
        if f.ndim != 1 or (f.size and f.dtype.kind not in "iu"):
            raise ValueError(f"face {k} is not a sequence of integer indices")
        if f.size < 3:
            raise ValueError(f"face {k} has {f.size} vertices; a face needs 3 or more")
    ptr = np.zeros(len(faces) + 1, dtype=np.int64)
    if faces:
        ptr[1:] = np.cumsum([f.size for f in faces])
        idx = np.ascontiguousarray(np.concatenate(faces), dtype=np.int64)
    else:
        idx = np.zeros(0, dtype=np.int64)
    return ptr, idx


def _mesh(V: Any, F: Faces) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    V = _vertices(V)
    ptr, idx = _faces(F)
    if idx.size == 0:
        raise ValueError("the mesh has no faces")
    return V, ptr, idx


def _faces_out(ptr: np.ndarray, idx: np.ndarray) -> Faces:
    sizes = np.diff(ptr)
    if sizes.size and (sizes == 3).all():
        return idx.reshape(-1, 3)
    return [idx[a:b] for a, b in zip(ptr[:-1], ptr[1:])]


def load_mesh(path: Union[str, os.PathLike]) -> Tuple[np.ndarray, Faces]:
    """Loads OBJ, STL, PLY, OFF or glTF/GLB: ``V`` float64 (n, 3) and ``F`` int64 (m, 3), or a list of index
    arrays when the faces are not all triangles.

    Raises ``OSError`` for a file that cannot be read, ``ValueError`` for a malformed one.
    """
    V, ptr, idx = _gregvox.load_mesh(os.fspath(path))
    return V, _faces_out(ptr, idx)


class Grid:
    """A voxel grid: ``occupancy`` a bool array (X, Y, Z) indexed ``[x, y, z]``; voxel ``(i, j, k)`` spans
    ``origin + (i, j, k) * voxel_size`` to ``origin + (i + 1, j + 1, k + 1) * voxel_size``."""

    def __init__(self, occupancy, origin, voxel_size, packed, report):
        self.occupancy: np.ndarray = occupancy
        self.origin: np.ndarray = np.asarray(origin, dtype=np.float64)
        self.voxel_size: np.ndarray = np.asarray(voxel_size, dtype=np.float64)
        self.report: Dict[str, Any] = report
        self._packed = packed

    @property
    def dims(self) -> Tuple[int, int, int]:
        return tuple(self.occupancy.shape)

    @property
    def index_to_world(self) -> np.ndarray:
        """The 4×4 matrix taking (i, j, k, 1) to the world position of voxel (i, j, k)'s minimum corner."""
        m = np.eye(4)
        m[:3, :3] = np.diag(self.voxel_size)
        m[:3, 3] = self.origin
        return m

    def centers(self) -> np.ndarray:
        """World centres of the solid voxels, float64 (n, 3), in ``np.argwhere`` order."""
        return self.origin + (np.argwhere(self.occupancy) + 0.5) * self.voxel_size

    def save(self, path: Union[str, os.PathLike]) -> None:
        """Writes the grid in the format its extension names (every ``gregvox voxelize --out`` format)."""
        self._packed.save(os.fspath(path))

    def __repr__(self) -> str:
        return f"gregvox.Grid(dims={self.dims}, solid={int(self.occupancy.sum())})"


def voxelize(
    V: Any,
    F: Faces,
    res: Optional[int] = None,
    dims: Optional[Sequence[int]] = None,
    voxel_size: Optional[float] = None,
    bbox: Optional[Sequence[Sequence[float]]] = None,
    pad: int = 0,
    rule: str = "auto",
    fill: str = "solid",
    method: str = "auto",
    device: Optional[Device] = None,
) -> Grid:
    """Solid voxels of a mesh, with the grid contract of ``gregvox voxelize`` (default ``res=128``).

    ``bbox``: ``((xmin, ymin, zmin), (xmax, ymax, zmax))``. ``rule``: auto (the generalized winding number),
    gwn, winding, parity. ``fill``: solid, surface, both. ``method``: auto, peel, abuffer, cpu.
    """
    V, ptr, idx = _mesh(V, F)
    if bbox is not None:
        b = np.asarray(bbox, dtype=np.float64)
        if b.shape != (2, 3):
            raise ValueError(f"bbox must be ((xmin, ymin, zmin), (xmax, ymax, zmax)), not shape {b.shape}")
        bbox = (tuple(b[0]), tuple(b[1]))
    for name, value in (("res", res), ("pad", pad)):
        if value is not None and (int(value) != value or value < 0):
            raise ValueError(f"{name} must be a non-negative integer, not {value!r}")
    if dims is not None:
        dims = tuple(int(d) for d in dims)
        if len(dims) != 3:
            raise ValueError(f"dims must be three integers, not {dims!r}")
    occ, origin, size, packed, report = _gregvox.voxelize(
        _device(device)._device,
        V,
        ptr,
        idx,
        res=None if res is None else int(res),
        dims=dims,
        voxel_size=None if voxel_size is None else float(voxel_size),
        bbox=bbox,
        pad=int(pad),
        rule=rule,
        fill=fill,
        method=method,
    )
    return Grid(occ.view(np.bool_), origin, size, packed, json.loads(report))


class GregorySurface:
    """The ACC-2 Gregory surface of a quad cage (a non-quad cage is refined once), evaluated on the GPU.

    >>> import gregvox, numpy as np
    >>> V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    >>> s = gregvox.GregorySurface(V, [[0, 1, 2, 3]])
    >>> P, N = s.evaluate(4)
    >>> P.shape
    (1, 5, 5, 3)
    """

    def __init__(self, V: Any, F: Faces, tangents: str = "opensubdiv", device: Optional[Device] = None):
        V, ptr, idx = _mesh(V, F)
        self._n = V.shape[0]
        self._surface = _gregvox.GregorySurface(_device(device)._device, V, ptr, idx, tangents)

    @property
    def patch_count(self) -> int:
        return self._surface.patch_count

    def evaluate(self, level: int) -> Tuple[np.ndarray, np.ndarray]:
        """Positions and unit normals, float32 (patches, level+1, level+1, 3): sample ``[p, j, i]`` at
        (u, v) = (i/level, j/level) of patch p, bit for bit what ``gregvox tessellate --no-weld`` writes."""
        return self._surface.evaluate(int(level))

    def set_cage(self, V: Any) -> None:
        """Moves the cage (the same number of vertices); the next ``evaluate`` runs on the GPU again."""
        self._surface.set_cage(_vertices(V))

    def indices(self, level: int) -> np.ndarray:
        """Triangles over the flattened ``evaluate(level)`` points, uint32 (m, 3), two per grid cell."""
        return _gregvox.grid_indices(self.patch_count, int(level))


def topology(V: Any, F: Faces) -> Dict[str, Any]:
    """The ``gregvox mesh --json`` report: vertices, faces, edges, boundary and non-manifold edges, closed,
    components, Euler characteristic, genus, valence histogram…"""
    return json.loads(_gregvox.topology_json(*_mesh(V, F)))


def subdivide(V: Any, F: Faces, levels: int, scheme: str = "catmull-clark") -> Tuple[np.ndarray, Faces]:
    """``levels`` steps of catmull-clark, loop or loop-warren subdivision (what ``gregvox subdivide``
    writes)."""
    if int(levels) != levels or levels < 0:
        raise ValueError(f"levels must be a non-negative integer, not {levels!r}")
    V2, ptr, idx = _gregvox.subdivide(*_mesh(V, F), int(levels), scheme)
    return V2, _faces_out(ptr, idx)


def mesh_matrices(V: Any, F: Faces) -> Dict[str, Any]:
    """The mesh matrices as ``scipy.sparse.csr_matrix``: ``M`` (|V| × |F|, the 1-based slot of each
    corner), ``E`` (|V| × |V|, face + 1 of each half-edge i → j) and ``vertex_corners`` (|V| × corners)."""
    from scipy.sparse import csr_matrix

    out = {}
    for name, (data, cols, ptr, shape) in _gregvox.mesh_matrices(*_mesh(V, F)).items():
        out[name] = csr_matrix((data, cols, ptr), shape=shape)
    return out
