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
    "default_device",
    "load_mesh",
    "load_cage",
    "evaluate_at",
    "voxelize",
    "mesh_matrices",
    "action_map",
    "vertex_normals",
    "topology",
    "subdivide",
    "simplify",
]

Faces = Union[np.ndarray, Sequence[Sequence[int]]]


class Device:
    """The Vulkan device (lavapipe where there is no GPU).

    ``name``: a case-insensitive substring of the device name; default ``GREGVOX_DEVICE``, else the first
    (discrete > integrated > virtual > CPU). ``validation``: ``True`` requires the Vulkan validation layer,
    ``False`` turns it off, ``None`` follows ``GREGVOX_VALIDATION``. Raises ``RuntimeError`` when no Vulkan
    driver or no matching device is found.

    >>> dev = gregvox.Device()            # doctest: +SKIP
    >>> dev.info["name"]                  # doctest: +SKIP
    'llvmpipe (LLVM 15.0.6, 256 bits)'
    """

    def __init__(self, name: Optional[str] = None, validation: Optional[bool] = None):
        if name is not None and not isinstance(name, str):
            raise TypeError("name must be a string")
        self._device = _gregvox.Device(name, validation)
        self.info: Dict[str, Any] = json.loads(self._device.info_json)

    @property
    def validation_messages(self) -> List[str]:
        """Every Vulkan validation message received so far (empty when the layer is off)."""
        return self._device.validation_messages

    def finish(self) -> None:
        """Waits for the device, releases its cached pipelines and closes it. Raises ``RuntimeError`` if a GPU
        allocation is still alive, the validation layer reported anything, or a ``GregorySurface`` still
        uses the device. Calling it is optional; a device is released when the last object using it goes."""
        global _default_device
        self._device.finish()
        if _default_device is self:
            _default_device = None

    def __repr__(self) -> str:
        return f"gregvox.Device({self.info.get('name')!r})"


_default_device: Optional[Device] = None


def default_device() -> Device:
    """The device used when a call is given none: made on first use, shared by every call after."""
    global _default_device
    if _default_device is None:
        _default_device = Device()
    return _default_device


def _device(device: Optional[Device]) -> Device:
    if device is not None:
        if not isinstance(device, Device):
            raise TypeError("device must be a gregvox.Device")
        return device
    return default_device()


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
    """A voxel grid, with the grid contract of ``gregvox voxelize``: ``occupancy`` is a bool array
    (X, Y, Z) indexed ``[x, y, z]``; voxel ``(i, j, k)`` spans ``origin + (i, j, k) * voxel_size`` to
    ``origin + (i + 1, j + 1, k + 1) * voxel_size``, its centre at ``origin + ((i, j, k) + 0.5) * voxel_size``.

    ``report`` is what ``gregvox voxelize --json`` prints (method, frame, rule, notes…).
    """

    def __init__(self, occupancy, origin, voxel_size, packed, report):
        self.occupancy: np.ndarray = occupancy
        self.origin: np.ndarray = np.asarray(origin, dtype=np.float64)
        self.voxel_size: np.ndarray = np.asarray(voxel_size, dtype=np.float64)
        self.report: Dict[str, Any] = report
        #: Seconds the engine's own ``Gpu::voxelize`` call took (without the copy into NumPy).
        self.library_seconds: float = 0.0
        self._packed = packed

    @property
    def dims(self) -> Tuple[int, int, int]:
        """(X, Y, Z): the shape of ``occupancy``."""
        return tuple(int(d) for d in self.occupancy.shape)

    @property
    def index_to_world(self) -> np.ndarray:
        """The 4×4 matrix taking (i, j, k, 1) to the centre of voxel (i, j, k): the ``index_to_world`` of
        the ``.npy``/``.raw``/``.vox`` sidecar JSON that ``gregvox voxelize`` writes."""
        m = np.eye(4)
        m[:3, :3] = np.diag(self.voxel_size)
        m[:3, 3] = self.origin + 0.5 * self.voxel_size
        return m

    def centers(self) -> np.ndarray:
        """World centres of the solid voxels, float64 (n, 3), in ``np.argwhere(occupancy)`` order."""
        return self.origin + (np.argwhere(self.occupancy) + 0.5) * self.voxel_size

    def save(self, path: Union[str, os.PathLike], npy_packed: bool = False, ply_boundary: bool = False) -> None:
        """Writes the grid in the format its extension names: ``.binvox``, ``.npy`` (bool (X, Y, Z), or
        packed bits with ``npy_packed``), ``.npz`` (sparse coordinates), ``.nrrd``, ``.ply`` (the solid
        voxels' centres, or the boundary mesh with ``ply_boundary``), ``.raw`` or ``.vox``, with the sidecar
        JSON where the CLI writes one, or ``.obj``, ``.stl``, ``.glb``: the solid's boundary mesh (see
        ``boundary_mesh``); byte for byte what ``gregvox voxelize --out`` writes. The file is written
        atomically; ``OSError`` if it cannot be, ``ValueError`` if the format cannot hold the grid."""
        self._packed.save(os.fspath(path), bool(npy_packed), bool(ply_boundary))

    def boundary_mesh(self) -> Tuple[np.ndarray, np.ndarray]:
        """The solid's boundary as a closed, manifold, consistently oriented triangle mesh in world
        coordinates: ``V`` float64 (n, 3) and ``F`` int64 (m, 3), each voxel face between a solid and an
        empty voxel as two triangles (more where an edge is pinched), normals outward. Voxels touching only
        along an edge or at a corner get separate shells (their shared corners and edges are split and moved
        1/64 of a voxel apart), so the mesh is manifold on any grid, and voxelizing it on the same grid gives
        the grid back. ``save`` to ``.obj``/``.ply`` keeps the faces as polygons. ``ValueError`` for a
        noise-like grid whose boundary exceeds 2^28 voxel faces."""
        return self._packed.boundary_mesh()

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

    ``bbox``: ``((xmin, ymin, zmin), (xmax, ymax, zmax))``. ``rule``: auto or gwn (the exact generalized
    winding number, solid where |w| >= 1/2: holes, seams and soups need no repair), gwn-positive (w >= 1/2,
    libigl's convention), winding, positive, parity. ``fill``: solid, surface, both. ``method``: auto, peel,
    abuffer, cpu.
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
    try:
        occ, origin, size, packed, report, seconds = _gregvox.voxelize(
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
    except ValueError as e:
        raise ValueError(_python_names(str(e))) from None
    grid = Grid(occ.view(np.bool_), origin, size, packed, json.loads(report))
    grid.library_seconds = seconds
    return grid


def query(
    V: Any,
    F: Faces,
    points: Any,
    what: Sequence[str] = ("winding", "occupancy"),
    rule: str = "gwn",
    sdf_sign: str = "inside-negative",
    tolerance: float = 1e-6,
    device: Optional[Device] = None,
) -> Dict[str, np.ndarray]:
    """Exact winding numbers, occupancy and distances of a mesh at ``points`` ((n, 3), float32 or float64),
    as ``gregvox query`` computes them: a dict with one array per name of ``what`` in the order of the
    points: ``winding`` float64 (within ``tolerance``), ``occupancy`` bool (``rule``: gwn = |w| >= 1/2,
    gwn-positive = w >= 1/2, decided by bounds), ``sdf`` and ``udf`` float32 (``sdf_sign``:
    inside-negative as libigl/Open3D/Warp, or inside-positive as trimesh/pysdf); ``closest`` adds ``face``
    (uint32, the nearest triangle of the fan triangulation), ``closest`` and ``barycentric`` (float64
    (n, 3)). The signs come from the exact winding number: right on open meshes and soups. With ``device``
    (a ``Device``), the distances' nearest triangles are searched on it, in float64 (the same arrays as the
    CPU's; ``gregvox query --device``). The GIL is released while it runs."""
    V, ptr, idx = _mesh(V, F)
    P = np.ascontiguousarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), not {P.shape}")
    if isinstance(what, str):
        what = [w.strip() for w in what.split(",")]
    dev = None if device is None else _device(device)._device
    out = _gregvox.query(V, ptr, idx, P, [str(w) for w in what], str(rule), str(sdf_sign), float(tolerance),
                         dev)
    if "occupancy" in out:
        out["occupancy"] = out["occupancy"].view(np.bool_)
    return out


# The engine names the CLI's flags in its messages; a Python caller gave keyword arguments.
_FLAG_NAMES = [("--res ", "res="), ("--dims ", "dims="), ("--voxel-size ", "voxel_size="), ("--bbox", "bbox"),
               ("--pad ", "pad="), ("--res", "res"), ("--dims", "dims"), ("--voxel-size", "voxel_size"),
               ("--fill both", 'fill="both"'), ("--rule", "rule"), ("--method", "method")]


def _python_names(message: str) -> str:
    for flag, name in _FLAG_NAMES:
        message = message.replace(flag, name)
    return message


def _index_array(name: str, a: Any, width: int) -> np.ndarray:
    a = np.asarray([] if a is None else a)
    if a.size == 0:
        return np.zeros(0, dtype=np.int64)
    if a.dtype.kind not in "iu":
        raise ValueError(f"{name} must hold integer indices, not {a.dtype}")
    if (width == 2 and (a.ndim != 2 or a.shape[1] != 2)) or (width == 1 and a.ndim != 1):
        shape = "(k, 2) vertex pairs" if width == 2 else "a 1-D array"
        raise ValueError(f"{name} must be {shape}, not shape {a.shape}")
    return np.ascontiguousarray(a, dtype=np.int64).reshape(-1)


def _sharpness(name: str, s: Any, n: int) -> np.ndarray:
    s = np.asarray(s, dtype=np.float64)
    if s.ndim == 0:
        s = np.full(n, float(s))
    if s.shape != (n,):
        raise ValueError(f"{name} must be one number or one per item ({n}), not shape {s.shape}")
    if not np.isfinite(s).all():
        raise ValueError(f"{name} must be finite")
    return np.ascontiguousarray(s)


def _tags(creases: Any = None, crease_sharpness: Any = 10.0, corners: Any = None, corner_sharpness: Any = 10.0,
          holes: Any = None, boundary: str = "edge-only") -> Tuple[Any, ...]:
    cp = _index_array("creases", creases, 2)
    vs = _index_array("corners", corners, 1)
    return (cp, _sharpness("crease_sharpness", crease_sharpness, cp.size // 2), vs,
            _sharpness("corner_sharpness", corner_sharpness, vs.size), _index_array("holes", holes, 1), boundary)


def _uv(uvs: Any, uv_faces: Any, uv_rule: int, ptr: np.ndarray) -> Optional[Tuple[np.ndarray, np.ndarray, int]]:
    if uvs is None and uv_faces is None:
        return None
    if uvs is None or uv_faces is None:
        raise ValueError("give uvs and uv_faces together")
    u = np.ascontiguousarray(np.asarray(uvs, dtype=np.float64))
    if u.ndim != 2 or u.shape[1] != 2:
        raise ValueError(f"uvs must have shape (k, 2), not {u.shape}")
    uptr, idx = _faces(uv_faces)
    if not np.array_equal(uptr, ptr):
        raise ValueError("uv_faces must have one value index per corner of every face of F, face by face")
    if int(uv_rule) != uv_rule or not 0 <= uv_rule <= 5:
        raise ValueError(f"uv_rule must be 0…5 (Sdc FVarLinearInterpolation), not {uv_rule!r}")
    return u, idx, int(uv_rule)


def _isolation(isolation: Optional[int]) -> Optional[int]:
    if isolation is None:
        return None
    if int(isolation) != isolation or not 0 <= isolation <= 10:
        raise ValueError(f"isolation must be an integer from 0 to 10, not {isolation!r}")
    return int(isolation)


def load_cage(path: Union[str, os.PathLike]) -> Tuple[np.ndarray, Faces, Dict[str, Any]]:
    """Loads a subdivision cage: ``V``, ``F`` as :func:`load_mesh` gives them and the OpenSubdiv tags of an OBJ
    (``t crease``, ``t corner``, ``t hole``, ``t interpolateboundary``) as keyword arguments for
    :class:`GregorySurface` and :func:`evaluate_at`: ``creases`` (k, 2) int64 vertex pairs, ``crease_sharpness``
    (k,), ``corners`` (m,), ``corner_sharpness`` (m,), ``holes`` (h,) face indices, ``boundary`` ("none",
    "edge-only", "edge-and-corner"). Sharpness 10 is infinitely sharp; semi-sharp features refine the cage
    ⌈s⌉ times (``isolation``, a keyword of both, can ask for more, as OpenSubdiv's ``RefineAdaptive(L)``).

    A cage with UVs (``vt`` on every face) also gets ``uvs`` (k, 2) float64, ``uv_faces`` (one value index per
    face corner, shaped as ``F``) and ``uv_rule`` (``t facevaryinginterpolateboundary``, 0…5; 1, corners
    only, without the tag): the UVs then follow the surface as OpenSubdiv's face-varying patches do.

    Raises ``ValueError`` naming the line for a tag gregvox does not know.
    """
    (V, ptr, idx), (cp, cs, vs, vsh, hs, boundary, uv) = _gregvox.load_cage(os.fspath(path))
    tags = {"creases": cp.reshape(-1, 2), "crease_sharpness": cs, "corners": vs, "corner_sharpness": vsh,
            "holes": hs, "boundary": boundary}
    if uv is not None:
        tags.update(uvs=uv[0], uv_faces=_faces_out(ptr, uv[1]), uv_rule=uv[2])
    return V, _faces_out(ptr, idx), tags


def evaluate_at(V: Any, F: Faces, fuv: Any, *, creases: Any = None, crease_sharpness: Any = 10.0,
                corners: Any = None, corner_sharpness: Any = 10.0, holes: Any = None, boundary: str = "edge-only",
                isolation: Optional[int] = None, tangents: str = "opensubdiv", uvs: Any = None,
                uv_faces: Any = None, uv_rule: int = 1) -> Dict[str, np.ndarray]:
    """The limit surface of the cage at (face, u, v) rows (``fuv`` (N, 3): an OpenSubdiv ptex face index, an
    all-quad cage's face index, and u, v in [0, 1]), on the CPU in float64: ``position``, ``du``, ``dv``,
    ``duu``, ``duv``, ``dvv``, each (N, 3), the exact derivatives with respect to the face's (u, v), and
    ``uv`` (N, 2) when UVs are given (``uvs``, ``uv_faces``, ``uv_rule`` as :func:`load_cage` returns them).
    What ``gregvox evaluate`` writes.

    >>> import gregvox, numpy as np
    >>> V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    >>> gregvox.evaluate_at(V, [[0, 1, 2, 3]], [[0, 0.25, 0.5]])["position"]
    array([[0.25, 0.5 , 0.  ]])
    """
    fuv = np.asarray(fuv, dtype=np.float64)
    if fuv.ndim != 2 or fuv.shape[1] != 3:
        raise ValueError(f"fuv must have shape (N, 3), not {fuv.shape}")
    tags = _tags(creases, crease_sharpness, corners, corner_sharpness, holes, boundary)
    V, ptr, idx = _mesh(V, F)
    arrays = _gregvox.evaluate_at(V, ptr, idx, (*tags, _isolation(isolation), _uv(uvs, uv_faces, uv_rule, ptr)),
                                  np.ascontiguousarray(fuv), tangents)
    out = dict(zip(["position", "du", "dv", "duu", "duv", "dvv"], arrays[:6]))
    if arrays[6] is not None:
        out["uv"] = arrays[6]
    return out


class GregorySurface:
    """The ACC-2 Gregory surface of a quad cage (a non-quad cage is refined once), evaluated on the GPU.
    Tags as :func:`load_cage` returns them: infinitely sharp creases and corners (sharpness 10), holes and
    the boundary rule; semi-sharp ones refine the cage ⌈s⌉ times, or ``isolation`` times when larger; UVs
    (``uvs``, ``uv_faces``, ``uv_rule``) follow the surface as OpenSubdiv's face-varying patches.

    >>> import gregvox, numpy as np
    >>> V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    >>> s = gregvox.GregorySurface(V, [[0, 1, 2, 3]])
    >>> P, N = s.evaluate(4)
    >>> P.shape
    (1, 5, 5, 3)
    """

    def __init__(self, V: Any, F: Faces, tangents: str = "opensubdiv", device: Optional[Device] = None, *,
                 creases: Any = None, crease_sharpness: Any = 10.0, corners: Any = None,
                 corner_sharpness: Any = 10.0, holes: Any = None, boundary: str = "edge-only",
                 isolation: Optional[int] = None, uvs: Any = None, uv_faces: Any = None, uv_rule: int = 1):
        V, ptr, idx = _mesh(V, F)
        self._n = V.shape[0]
        self.has_uv = uvs is not None
        tags = _tags(creases, crease_sharpness, corners, corner_sharpness, holes, boundary)
        self._surface = _gregvox.GregorySurface(_device(device)._device, V, ptr, idx,
                                                (*tags, _isolation(isolation), _uv(uvs, uv_faces, uv_rule, ptr)),
                                                tangents)

    @property
    def patch_count(self) -> int:
        return self._surface.patch_count

    def evaluate(self, level: int, uvs: bool = False) -> Tuple[np.ndarray, ...]:
        """Positions and unit normals, float32 (patches, level+1, level+1, 3): sample ``[p, j, i]`` at
        (u, v) = (i/level, j/level) of patch p, bit for bit what ``gregvox tessellate --no-weld`` writes.
        ``uvs=True`` adds the UVs, float32 (patches, level+1, level+1, 2), evaluated on the device beside the
        positions (the ``vt`` that ``tessellate`` writes); ``ValueError`` if the surface has none."""
        P, N, UV = self._surface.evaluate(int(level))
        if not uvs:
            return P, N
        if UV is None:
            raise ValueError("the surface has no UVs (pass uvs= and uv_faces=, or load a cage with vt)")
        return P, N, UV

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
    """The mesh matrices as ``scipy.sparse.csr_matrix`` (int64 values):

    - ``M`` (|V| × |F|): ``M[v, f] = k`` when v is the k-th corner (1-based) of face f, in winding order;
    - ``B`` (|V| × |F|): the binary pattern of M (vertex–face incidence);
    - ``E`` (|V| × |V|): ``E[i, j] = f + 1`` for the half-edge i → j of face f (the face on its left);
    - ``adjacency`` (|V| × |V|): 1 where i and j share an edge (the pattern of E + Eᵀ);
    - ``dual_adjacency`` (|F| × |F|): 1 where two faces share an edge (E[i, j] and E[j, i]);
    - ``vertex_corners`` (|V| × corners): 1 at (v, c) for each corner c at vertex v, corners numbered in
      face order (the flattened ``F``);
    - the action maps of the common per-face formulas, float64: ``edge_12`` and ``edge_13``
      (``edge_12.T @ V`` is each face's P2 − P1, ``edge_13.T @ V`` its P3 − P1) and ``centroid``
      (``centroid.T @ V``: the vertex average of each face, ``B`` over the face's corner count).

    An action map turns M into the operator of a per-face formula: see :func:`action_map`.

    >>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    >>> m = gregvox.mesh_matrices(V, [[0, 1, 2], [2, 1, 3]])
    >>> m["M"].toarray()
    array([[1, 0],
           [2, 2],
           [3, 1],
           [0, 3]])
    >>> int(m["E"][1, 2]), int(m["E"][2, 1])   # faces 0 and 1, plus one
    (1, 2)
    """
    from scipy.sparse import coo_matrix, csr_matrix

    out = {}
    for name, (data, cols, ptr, shape) in _gregvox.mesh_matrices(*_mesh(V, F)).items():
        out[name] = csr_matrix((data, cols, ptr), shape=shape)
    M, E = out["M"], out["E"]
    out["B"] = csr_matrix((np.ones_like(M.data), M.indices, M.indptr), shape=M.shape)
    pattern = csr_matrix((np.ones_like(E.data), E.indices, E.indptr), shape=E.shape)
    adjacency = ((pattern + pattern.T) > 0).astype(np.int64)
    out["adjacency"] = csr_matrix(adjacency)
    # Half-edges whose twin exists: the face on the left of i -> j and the one on the left of j -> i.
    coo = E.tocoo()
    twin = np.asarray(E[coo.col, coo.row]).ravel()
    keep = twin > 0
    f, g = coo.data[keep] - 1, twin[keep] - 1
    n_faces = M.shape[1]
    dual = coo_matrix((np.ones(f.size, dtype=np.int64), (f, g)), shape=(n_faces, n_faces)).tocsr()
    dual.data[:] = 1
    out["dual_adjacency"] = dual
    # The action maps of the common per-face formulas (see action_map): edge vectors and centroids.
    out["edge_12"] = action_map(M, [-1, 1, 0])
    out["edge_13"] = action_map(M, [-1, 0, 1])
    order = np.bincount(M.indices, minlength=M.shape[1])  # corners per face
    centroid = csr_matrix((1.0 / order[M.indices], M.indices.copy(), M.indptr.copy()), shape=M.shape)
    out["centroid"] = centroid
    return out



def action_map(M: Any, weights: Sequence[float]) -> Any:
    """``M`` with each slot value k replaced by ``weights[k - 1]`` (0 past the end): a float64
    ``csr_matrix`` whose transpose applied to the vertex positions gives one result per face,
    ``(M_φᵀ V)[f] = Σ_k φ(k) · V[F[f, k - 1]]``; applied itself to per-face values, one result per vertex.

    >>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    >>> M = gregvox.mesh_matrices(V, [[0, 1, 2]])["M"]
    >>> gregvox.action_map(M, [-1, 1, 0]).T @ V     # the edge vector P2 - P1 of each face
    array([[1., 0., 0.]])
    """
    from scipy.sparse import csr_matrix

    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 1:
        raise ValueError(f"weights must be a sequence of numbers, not shape {w.shape}")
    if not np.isfinite(w).all():
        raise ValueError("weights must be finite")
    table = np.zeros(int(M.data.max(initial=0)) + 1)
    n = min(w.size, table.size - 1)
    table[1 : n + 1] = w[:n]
    return csr_matrix((table[M.data], M.indices.copy(), M.indptr.copy()), shape=M.shape)


def vertex_normals(V: Any, F: Faces, weighting: str = "area") -> np.ndarray:
    """Unit vertex normals, float64 (n, 3), each the normalized sum of its faces' normals weighted by face
    ``area`` (libigl's default), corner ``angle`` (trimesh's ``vertex_normals``) or ``uniform``; an
    unreferenced vertex gets a zero normal (never NaN)."""
    return _gregvox.vertex_normals(*_mesh(V, F), str(weighting))


def simplify(
    V: Any,
    F: Faces,
    ratio: Optional[float] = None,
    faces: Optional[int] = None,
    error: Optional[float] = None,
    placement: str = "optimal",
    lock_border: bool = False,
    allow_topology: bool = False,
    prune: float = 0.0,
    report: bool = False,
):
    """Reduces a mesh by parallel quadric edge collapses, as ``gregvox simplify``: returns ``(V, F, error)``,
    ``V`` float64 (n, 3), ``F`` int64 (m, 3) triangles, ``error`` the largest collapse error (a length in the
    mesh's units); with ``report=True`` the third item is the whole report (a dict: faces, vertices, error,
    relative_error, collapses, passes, locked_vertices, pruned_faces, seconds).

    Targets (the first reached stops; at least one): ``ratio`` of the triangles kept, ``faces`` at most,
    ``error`` a fraction of the bounding-box diagonal. ``placement``: "optimal" (the quadric's minimum) or
    "keep" (an endpoint). The topology is kept (manifold stays manifold, closed stays closed, the Euler
    characteristic and the pieces stay) unless ``allow_topology``; no triangle flips; borders move only
    along themselves (``lock_border``: not at all); attribute seams (two vertices at one position) reduce
    both sides together and stay closed, and where three or more copies meet they stay;
    ``prune`` removes pieces smaller than that fraction of the diagonal. The GIL is released while it runs.

    >>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    >>> F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]])
    >>> V2, F2, err = gregvox.simplify(V, F, ratio=0.5)
    >>> F2.shape  # a tetrahedron is the smallest closed mesh
    (4, 3)
    """
    if ratio is None and faces is None and error is None:
        raise ValueError("simplify needs a target: ratio, faces or error")
    V, ptr, idx = _mesh(V, F)
    (V2, ptr2, idx2), rep = _gregvox.simplify(
        V,
        ptr,
        idx,
        None if ratio is None else float(ratio),
        None if faces is None else int(faces),
        None if error is None else float(error),
        str(placement),
        bool(lock_border),
        bool(allow_topology),
        float(prune),
    )
    rep = json.loads(rep)
    F2 = idx2.reshape(-1, 3)
    return V2, F2, (rep if report else rep["error"])
