//! `gregvox._gregvox`: the Python bindings, a thin client of `gregvox::api` (the same calls the CLI makes).
//!
//! Invariants: arrays come in C-contiguous with the dtype checked by the Python layer (`gregvox/__init__.py`
//! converts and checks shapes; this module checks again, so a direct call cannot crash the interpreter);
//! every GPU call runs with the GIL released; gregvox errors become `OSError` (files), `ValueError` (bad
//! input) or `RuntimeError` (the device), with gregvox's one-line message; the `Gpu` is shared through an
//! `Arc`, so a surface keeps its device alive and the device is destroyed after the last object using it.
use glam::DVec3;
use gregvox::api::tessellate::{Patches, TessellateOptions};
use gregvox::api::{
    self, BoundaryInterpolation, Cage, ContextDesc, CornerTag, Crease, Fill, FillRule, Gpu,
    GridSize, LimitEvaluator, Mesh, Method, SaveOptions, Scheme, SubdivTags, Tangents, Validation,
    VoxelGrid, VoxelizeOptions,
};
use gregvox::mesh::NormalWeighting;
use gregvox::Error;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::sync::{Arc, Mutex};

/// A gregvox error as the Python exception of its kind.
fn to_py(e: Error) -> PyErr {
    let msg = e.to_string().replace('\n', " ");
    match e {
        Error::Io { .. } => PyOSError::new_err(msg),
        Error::Parse { .. } | Error::Invalid(_) | Error::Mesh(_) => PyValueError::new_err(msg),
        _ => PyRuntimeError::new_err(msg),
    }
}

/// The value named by `given` among `options` (a keyword argument such as `rule="gwn"`), or a
/// `ValueError` listing the names.
fn choice<T: Copy>(what: &str, given: &str, options: &[(&str, T)]) -> PyResult<T> {
    options
        .iter()
        .find(|(name, _)| *name == given)
        .map(|&(_, value)| value)
        .ok_or_else(|| {
            let names: Vec<&str> = options.iter().map(|(name, _)| *name).collect();
            bad(format!(
                "{what} '{given}' is not one of {}",
                names.join(", ")
            ))
        })
}

const GIB: f64 = (1u64 << 30) as f64;

/// `tangents="opensubdiv"` or `"exact"`.
fn tangents_of(given: &str) -> PyResult<Tangents> {
    choice(
        "tangents",
        given,
        &[
            ("opensubdiv", Tangents::OpenSubdiv),
            ("exact", Tangents::Exact),
        ],
    )
}

fn bad(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// A mesh from `V` (n, 3) float64 and faces as `face_ptr` (m + 1) and `indices` int64, validated by the
/// engine (finite coordinates, indices in range, faces of 3 or more corners).
fn mesh_of(
    v: &PyReadonlyArray2<'_, f64>,
    face_ptr: &PyReadonlyArray1<'_, i64>,
    indices: &PyReadonlyArray1<'_, i64>,
) -> PyResult<Mesh> {
    let shape = v.shape();
    if shape[1] != 3 {
        return Err(bad(format!("V must have shape (n, 3), not {shape:?}")));
    }
    let v = v.as_slice().map_err(|_| bad("V must be C-contiguous"))?;
    let ptr = face_ptr
        .as_slice()
        .map_err(|_| bad("face_ptr must be contiguous"))?;
    let idx = indices
        .as_slice()
        .map_err(|_| bad("F must be contiguous"))?;
    let n = (v.len() / 3) as i64;
    if let Some(bad_index) = idx.iter().find(|&&i| i < 0 || i >= n) {
        return Err(bad(format!(
            "F holds the index {bad_index}, outside 0..{n} (the vertices of V)"
        )));
    }
    let positions: Vec<DVec3> = v
        .chunks_exact(3)
        .map(|p| DVec3::new(p[0], p[1], p[2]))
        .collect();
    // Indices are in range (checked above); offsets outside u32 are refused here, and
    // `Mesh::from_offsets` checks that the rest start at 0, never decrease and cover the indices.
    if ptr.iter().any(|&x| !(0..=u32::MAX as i64).contains(&x)) || n > u32::MAX as i64 {
        return Err(bad(
            "face offsets outside 0..2³², or more than 2³² vertices",
        ));
    }
    let ptr: Vec<u32> = ptr.iter().map(|&x| x as u32).collect();
    let idx: Vec<u32> = idx.iter().map(|&x| x as u32).collect();
    Mesh::from_offsets(positions, ptr, idx).map_err(to_py)
}

/// The Vulkan device. `finish` closes it; every later use raises `RuntimeError`.
#[pyclass(module = "gregvox._gregvox", frozen)]
struct Device {
    gpu: Mutex<Option<Arc<Gpu>>>,
}

impl Device {
    /// The device, shared with the caller for one call (a surface keeps its own clone).
    fn gpu(&self) -> PyResult<Arc<Gpu>> {
        self.gpu
            .lock()
            .map_err(|_| PyRuntimeError::new_err("the device is in use"))?
            .clone()
            .ok_or_else(|| PyRuntimeError::new_err("the device was closed by finish()"))
    }
}

#[pymethods]
impl Device {
    /// `name`: a case-insensitive substring of the device name (default: `GREGVOX_DEVICE`, else the first
    /// device; lavapipe where there is no GPU). `validation`: `True` requires the Vulkan validation layer,
    /// `False` turns it off, `None` follows `GREGVOX_VALIDATION` (off in release builds).
    #[new]
    #[pyo3(signature = (name=None, validation=None))]
    fn new(py: Python<'_>, name: Option<String>, validation: Option<bool>) -> PyResult<Self> {
        let desc = ContextDesc {
            device_filter: name,
            validation: match validation {
                None => Validation::Auto,
                Some(true) => Validation::Required,
                Some(false) => Validation::Off,
            },
            ..ContextDesc::default()
        };
        let gpu = py.allow_threads(|| Gpu::with_desc(&desc)).map_err(to_py)?;
        Ok(Device {
            gpu: Mutex::new(Some(Arc::new(gpu))),
        })
    }

    /// What `gregvox info --json` reports of the device, as a JSON text.
    #[getter]
    fn info_json(&self) -> PyResult<String> {
        serde_json::to_string(self.gpu()?.info())
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    /// Every validation message the device has received so far (empty when the layer is off).
    #[getter]
    fn validation_messages(&self) -> PyResult<Vec<String>> {
        Ok(self.gpu()?.context().validation.messages())
    }

    /// Waits for the device, releases what it caches and closes it: raises `RuntimeError` if a GPU
    /// allocation is still alive or the validation layer spoke, or if a surface still uses the device.
    fn finish(&self, py: Python<'_>) -> PyResult<()> {
        let mut slot = self
            .gpu
            .lock()
            .map_err(|_| PyRuntimeError::new_err("the device is in use"))?;
        let Some(gpu) = slot.take() else {
            return Ok(());
        };
        match Arc::try_unwrap(gpu) {
            Ok(gpu) => py.allow_threads(|| gpu.finish()).map_err(to_py),
            Err(gpu) => {
                let users = Arc::strong_count(&gpu) - 1;
                *slot = Some(gpu);
                Err(PyRuntimeError::new_err(format!(
                    "the device is still used by {users} GregorySurface object(s): delete them first"
                )))
            }
        }
    }
}

/// A mesh as NumPy arrays: V float64 (n, 3), face offsets int64 (m + 1), indices int64.
type MeshArrays<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
);

/// Subdivision tags as flat arrays: crease vertex pairs (2k) and sharpness (k), corner vertices (m) and
/// sharpness (m), hole faces (h), the boundary rule's name.
type TagArrays<'py> = (
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i64>>,
    &'static str,
    UvArrays<'py>,
);

/// UVs as the Python layer sees them: values float64 (k, 2), one index per face corner (int64, the order of
/// the face indices) and the face-varying rule (0…5), or None.
type UvArrays<'py> = Option<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<i64>>, u32)>;

const BOUNDARIES: &[(&str, BoundaryInterpolation)] = &[
    ("none", BoundaryInterpolation::None),
    ("edge-only", BoundaryInterpolation::EdgeOnly),
    ("edge-and-corner", BoundaryInterpolation::EdgeAndCorner),
];

fn index_u32(what: &str, i: i64) -> PyResult<u32> {
    u32::try_from(i).map_err(|_| bad(format!("{what}: index {i} is out of range")))
}

/// The tags as the Python layer passes them, one tuple: crease vertex pairs (2k) and sharpness (k), corner
/// vertices (m) and sharpness (m), hole faces (h), the boundary rule's name, the isolation level, and the
/// UVs (values (k, 2), one index per corner, the face-varying rule 0…5) or None.
type TagArgs<'a> = (
    PyReadonlyArray1<'a, i64>,
    PyReadonlyArray1<'a, f64>,
    PyReadonlyArray1<'a, i64>,
    PyReadonlyArray1<'a, f64>,
    PyReadonlyArray1<'a, i64>,
    String,
    Option<u32>,
    Option<(PyReadonlyArray2<'a, f64>, PyReadonlyArray1<'a, i64>, u32)>,
);

/// A cage from the mesh and tag arrays, checked by the engine (`Cage::new`: edges exist, indices in
/// range, sharpness finite).
fn cage_of(mesh: Mesh, tags: &TagArgs<'_>) -> PyResult<Cage> {
    let (crease_pairs, crease_sharpness, corners, corner_sharpness, holes, boundary, isolation, uv) =
        tags;
    let isolation = *isolation;
    let cp = crease_pairs
        .as_slice()
        .map_err(|_| bad("creases must be contiguous"))?;
    let cs = crease_sharpness
        .as_slice()
        .map_err(|_| bad("crease_sharpness must be contiguous"))?;
    let vs = corners
        .as_slice()
        .map_err(|_| bad("corners must be contiguous"))?;
    let vsh = corner_sharpness
        .as_slice()
        .map_err(|_| bad("corner_sharpness must be contiguous"))?;
    let hs = holes
        .as_slice()
        .map_err(|_| bad("holes must be contiguous"))?;
    if cp.len() != 2 * cs.len() || vs.len() != vsh.len() {
        return Err(bad(
            "creases and crease_sharpness, corners and corner_sharpness must have matching lengths",
        ));
    }
    let mut tags = SubdivTags {
        boundary: choice("boundary", boundary.as_str(), BOUNDARIES)?,
        isolation,
        ..SubdivTags::default()
    };
    for (k, &s) in cs.iter().enumerate() {
        tags.creases.push(Crease {
            a: index_u32("creases", cp[2 * k])?,
            b: index_u32("creases", cp[2 * k + 1])?,
            sharpness: s.max(0.0) as f32,
        });
    }
    for (&v, &s) in vs.iter().zip(vsh) {
        tags.corners.push(CornerTag {
            vertex: index_u32("corners", v)?,
            sharpness: s.max(0.0) as f32,
        });
    }
    for &h in hs {
        tags.holes.push(index_u32("holes", h)?);
    }
    let Some((values, uv_indices, rule)) = uv else {
        return Cage::new(mesh, tags).map_err(to_py);
    };
    if *rule > 5 {
        return Err(bad(format!(
            "uv_rule {rule} is not a face-varying rule (0…5: Sdc FVarLinearInterpolation)"
        )));
    }
    tags.fvar_interpolation = Some(*rule);
    if values.shape()[1] != 2 {
        return Err(bad(format!(
            "uvs must have shape (k, 2), not {:?}",
            values.shape()
        )));
    }
    let vals: Vec<[f64; 2]> = values
        .as_slice()
        .map_err(|_| bad("uvs must be C-contiguous"))?
        .chunks_exact(2)
        .map(|c| [c[0], c[1]])
        .collect();
    let idx = uv_indices
        .as_slice()
        .map_err(|_| bad("uv_faces must be contiguous"))?
        .iter()
        .map(|&i| index_u32("uv_faces", i))
        .collect::<PyResult<Vec<u32>>>()?;
    Cage::new(mesh, tags)
        .and_then(|c| c.with_uv(vals, idx))
        .map_err(to_py)
}

fn tag_arrays<'py>(py: Python<'py>, tags: &SubdivTags) -> TagArrays<'py> {
    let cp: Vec<i64> = tags
        .creases
        .iter()
        .flat_map(|c| [c.a as i64, c.b as i64])
        .collect();
    let cs: Vec<f64> = tags.creases.iter().map(|c| c.sharpness as f64).collect();
    let vs: Vec<i64> = tags.corners.iter().map(|c| c.vertex as i64).collect();
    let vsh: Vec<f64> = tags.corners.iter().map(|c| c.sharpness as f64).collect();
    let hs: Vec<i64> = tags.holes.iter().map(|&h| h as i64).collect();
    let boundary = BOUNDARIES
        .iter()
        .find(|(_, b)| *b == tags.boundary)
        .map(|(n, _)| *n)
        .unwrap_or("edge-only");
    (
        cp.into_pyarray(py),
        cs.into_pyarray(py),
        vs.into_pyarray(py),
        vsh.into_pyarray(py),
        hs.into_pyarray(py),
        boundary,
        None,
    )
}

/// Loads a cage file: the mesh arrays and its OpenSubdiv tags (an OBJ's `t` lines; other formats none).
#[pyfunction]
fn load_cage<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<(MeshArrays<'py>, TagArrays<'py>)> {
    let cage = py.allow_threads(|| api::load_cage(&path)).map_err(to_py)?;
    let mut tags = tag_arrays(py, &cage.tags);
    if let Some(uv) = &cage.uv {
        let flat: Vec<f64> = uv.values.iter().flatten().copied().collect();
        let idx: Vec<i64> = uv.indices.iter().map(|&i| i as i64).collect();
        tags.6 = Some((
            flat.into_pyarray(py)
                .reshape([uv.values.len(), 2])
                .expect("k × 2 values"),
            idx.into_pyarray(py),
            cage.tags.fvar_linear().tag(),
        ));
    }
    Ok((arrays_of(py, &cage.mesh), tags))
}

type Samples<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Option<Bound<'py, PyArray2<f64>>>,
);

/// The limit surface at (face, u, v) rows (`fuv`, (N, 3) float64): position, du, dv, duu, duv, dvv.
#[pyfunction]
fn evaluate_at<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    face_ptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
    tags: TagArgs<'_>,
    fuv: PyReadonlyArray2<'_, f64>,
    tangents: &str,
) -> PyResult<Samples<'py>> {
    let cage = cage_of(mesh_of(&v, &face_ptr, &indices)?, &tags)?;
    gregvox::engine::cage::check_cage_valence(&cage.mesh).map_err(to_py)?;
    let tangents = tangents_of(tangents)?;
    if fuv.shape()[1] != 3 {
        return Err(bad(format!(
            "fuv must have shape (N, 3), not {:?}",
            fuv.shape()
        )));
    }
    let rows = fuv
        .as_slice()
        .map_err(|_| bad("fuv must be C-contiguous"))?;
    let mut at = Vec::with_capacity(rows.len() / 3);
    for (r, x) in rows.chunks_exact(3).enumerate() {
        if !(x[0] >= 0.0 && x[0].fract() == 0.0 && x[0] <= u32::MAX as f64) {
            return Err(bad(format!(
                "fuv row {r}: face {} is not a non-negative whole number",
                x[0]
            )));
        }
        at.push((x[0] as u32, x[1], x[2]));
    }
    let (s, uv) = py
        .allow_threads(|| -> gregvox::Result<_> {
            let e = LimitEvaluator::new(&cage, tangents)?;
            let uv = if e.has_uv() {
                Some(e.evaluate_uv(&at)?)
            } else {
                None
            };
            Ok((e.evaluate(&at)?, uv))
        })
        .map_err(to_py)?;
    let col = |f: fn(&api::LimitSample) -> DVec3| {
        let flat: Vec<f64> = s.iter().flat_map(|x| f(x).to_array()).collect();
        flat.into_pyarray(py)
            .reshape([s.len(), 3])
            .expect("N × 3 values")
    };
    Ok((
        col(|x| x.position),
        col(|x| x.du),
        col(|x| x.dv),
        col(|x| x.duu),
        col(|x| x.duv),
        col(|x| x.dvv),
        uv.map(|uv| {
            let n = uv.len();
            let flat: Vec<f64> = uv.into_iter().flatten().collect();
            flat.into_pyarray(py).reshape([n, 2]).expect("N × 2 values")
        }),
    ))
}

/// Loads any mesh file of the loader: (V float64 (n, 3), face offsets int64 (m + 1), indices int64).
#[pyfunction]
fn load_mesh<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<MeshArrays<'py>> {
    let mesh = py.allow_threads(|| api::load_mesh(&path)).map_err(to_py)?;
    Ok(arrays_of(py, &mesh))
}

fn arrays_of<'py>(py: Python<'py>, mesh: &Mesh) -> MeshArrays<'py> {
    let v: Vec<f64> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
    let v = v
        .into_pyarray(py)
        .reshape([mesh.positions.len(), 3])
        .expect("n × 3 values");
    let ptr: Vec<i64> = mesh.face_ptr.iter().map(|&x| x as i64).collect();
    let idx: Vec<i64> = mesh.indices.iter().map(|&x| x as i64).collect();
    (v, ptr.into_pyarray(py), idx.into_pyarray(py))
}

/// The `mesh --json` topology report, as a JSON text.
#[pyfunction]
fn topology_json(
    py: Python<'_>,
    v: PyReadonlyArray2<'_, f64>,
    face_ptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
) -> PyResult<String> {
    let mesh = mesh_of(&v, &face_ptr, &indices)?;
    let report = py.allow_threads(|| api::topology(&mesh));
    serde_json::to_string(&report).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// Subdivision: the refined mesh as arrays.
#[pyfunction]
fn subdivide<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    face_ptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
    levels: u32,
    scheme: &str,
) -> PyResult<MeshArrays<'py>> {
    let mesh = mesh_of(&v, &face_ptr, &indices)?;
    let scheme = choice(
        "scheme",
        scheme,
        &[
            ("catmull-clark", Scheme::CatmullClark),
            ("loop", Scheme::Loop),
            ("loop-warren", Scheme::LoopWarren),
        ],
    )?;
    let out = py
        .allow_threads(|| api::subdivide(&mesh, levels, scheme))
        .map_err(to_py)?;
    Ok(arrays_of(py, &out))
}

/// Mesh reduction (`gregvox simplify`): ((V float64 (n, 3), offsets, indices of triangles), report JSON).
#[pyfunction]
#[pyo3(signature = (v, face_ptr, indices, ratio, faces, error, placement, lock_border, allow_topology, prune))]
#[allow(clippy::too_many_arguments)]
fn simplify<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    face_ptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
    ratio: Option<f64>,
    faces: Option<usize>,
    error: Option<f64>,
    placement: &str,
    lock_border: bool,
    allow_topology: bool,
    prune: f64,
) -> PyResult<(MeshArrays<'py>, String)> {
    let mesh = mesh_of(&v, &face_ptr, &indices)?;
    let placement = choice(
        "placement",
        placement,
        &[
            ("keep", api::Placement::Keep),
            ("optimal", api::Placement::Optimal),
        ],
    )?;
    let opts = api::SimplifyOptions {
        ratio,
        faces,
        error,
        placement,
        lock_border,
        allow_topology,
        prune,
    };
    let out = py
        .allow_threads(|| api::simplify(&mesh, &opts))
        .map_err(to_py)?;
    let report =
        serde_json::to_string(&out.report).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok((arrays_of(py, &out.mesh), report))
}

/// The mesh matrices as CSR triplets (data, indices, indptr, shape) by name: `M` (|V| × |F|, the slot of
/// each corner, 1-based), `E` (|V| × |V|, face + 1 of each half-edge i → j), `Mt_corner` (the vertex →
/// corner map: for row v, the corner ids).
#[pyfunction]
fn mesh_matrices<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    face_ptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    let mesh = mesh_of(&v, &face_ptr, &indices)?;
    let m = py.allow_threads(|| api::MeshMatrix::from_mesh(&mesh));
    let dict = pyo3::types::PyDict::new(py);
    let csr = |data: Vec<i64>, cols: Vec<i64>, ptr: Vec<i64>, shape: (usize, usize)| {
        (
            data.into_pyarray(py),
            cols.into_pyarray(py),
            ptr.into_pyarray(py),
            shape,
        )
    };
    let s = m.to_sparse();
    dict.set_item(
        "M",
        csr(
            s.val.iter().map(|&x| x as i64).collect(),
            s.col.iter().map(|&x| x as i64).collect(),
            s.row_ptr.iter().map(|&x| x as i64).collect(),
            (s.n_rows as usize, s.n_cols as usize),
        ),
    )?;
    let vc = m.vertex_corners();
    let e = m.half_edge_face();
    let ptr: Vec<i64> = vc.ptr.iter().map(|&x| x as i64).collect();
    dict.set_item(
        "E",
        csr(
            e.face1.iter().map(|&x| x as i64).collect(),
            e.col.iter().map(|&x| x as i64).collect(),
            ptr.clone(),
            (m.n_verts(), m.n_verts()),
        ),
    )?;
    dict.set_item(
        "vertex_corners",
        csr(
            vec![1; vc.corner.len()],
            vc.corner.iter().map(|&x| x as i64).collect(),
            ptr,
            (m.n_verts(), m.n_corners()),
        ),
    )?;
    Ok(dict)
}

/// Unit vertex normals, float64 (n, 3), weighted by face `area` (libigl's default), `angle` (trimesh's) or
/// `uniform`; an unreferenced vertex gets a zero normal.
#[pyfunction]
fn vertex_normals<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    face_ptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
    weighting: &str,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let mesh = mesh_of(&v, &face_ptr, &indices)?;
    let weighting = choice(
        "weighting",
        weighting,
        &[
            ("area", NormalWeighting::Area),
            ("angle", NormalWeighting::Angle),
            ("uniform", NormalWeighting::Uniform),
        ],
    )?;
    let n = py.allow_threads(|| {
        let m = api::MeshMatrix::from_mesh(&mesh);
        gregvox::mesh::vertex_normals(&m, &mesh.positions, weighting)
    });
    let flat: Vec<f64> = n.iter().flat_map(|p| p.to_array()).collect();
    flat.into_pyarray(py).reshape([n.len(), 3])
}

/// A packed voxel grid (the engine's), kept for `save`.
#[pyclass(module = "gregvox._gregvox", frozen)]
struct PackedGrid {
    grid: VoxelGrid,
}

#[pymethods]
impl PackedGrid {
    /// Writes the grid in the format the extension names (.binvox, .npy, .npz, .nrrd, .ply, .raw, .vox; .obj, .stl, .glb:
    /// the solid's boundary mesh), atomically.
    #[pyo3(signature = (path, npy_packed=false, ply_boundary=false))]
    fn save(
        &self,
        py: Python<'_>,
        path: std::path::PathBuf,
        npy_packed: bool,
        ply_boundary: bool,
    ) -> PyResult<()> {
        if let Err(e) = gregvox::io::check_output(&path) {
            return Err(to_py(e));
        }
        let opts = SaveOptions {
            npy_packed,
            ply_boundary,
        };
        py.allow_threads(|| self.grid.save_with(&path, &opts))
            .map_err(to_py)
    }
    /// The solid's boundary: vertices float64 (n, 3) and triangles int64 (m, 3), closed, manifold,
    /// outward (each voxel face's polygon fanned from its first corner).
    #[allow(clippy::type_complexity)]
    fn boundary_mesh<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(
        Bound<'py, numpy::PyArray2<f64>>,
        Bound<'py, numpy::PyArray2<i64>>,
    )> {
        let mesh = py
            .allow_threads(|| gregvox::voxel::boundary::boundary_mesh(&self.grid))
            .map_err(to_py)?;
        let v: Vec<f64> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
        let tris = mesh.fan_triangles();
        let f: Vec<i64> = tris.iter().flatten().map(|&i| i as i64).collect();
        Ok((
            v.into_pyarray(py).reshape([mesh.positions.len(), 3])?,
            f.into_pyarray(py).reshape([tris.len(), 3])?,
        ))
    }
}

/// Voxelizes a mesh: (occupancy uint8 (X, Y, Z) C order, origin, voxel size, the packed grid, the report
/// as JSON, the seconds `Gpu::voxelize` itself took).
#[pyfunction]
#[pyo3(signature = (device, v, face_ptr, indices, res=None, dims=None, voxel_size=None, bbox=None, pad=0, rule="auto", fill="solid", method="auto"))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn voxelize<'py>(
    py: Python<'py>,
    device: &Device,
    v: PyReadonlyArray2<'_, f64>,
    face_ptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
    res: Option<u32>,
    dims: Option<[u32; 3]>,
    voxel_size: Option<f64>,
    bbox: Option<([f64; 3], [f64; 3])>,
    pad: u32,
    rule: &str,
    fill: &str,
    method: &str,
) -> PyResult<(
    Bound<'py, numpy::PyArray3<u8>>,
    [f64; 3],
    [f64; 3],
    PackedGrid,
    String,
    f64,
)> {
    let mesh = mesh_of(&v, &face_ptr, &indices)?;
    let mut opts = VoxelizeOptions::default();
    let sizes = res.is_some() as u32 + dims.is_some() as u32 + voxel_size.is_some() as u32;
    if sizes > 1 {
        return Err(bad("give one of res, dims and voxel_size"));
    }
    opts.grid.size = match (res, dims, voxel_size) {
        (Some(r), _, _) => GridSize::Res(r),
        (_, Some(d), _) => GridSize::Dims(d),
        (_, _, Some(h)) => GridSize::VoxelSize(h),
        _ => GridSize::Res(128),
    };
    if let Some((lo, hi)) = bbox {
        opts = opts.bbox(lo, hi);
    }
    opts = opts.pad(pad);
    opts.rule = choice(
        "rule",
        rule,
        &[
            ("auto", FillRule::Gwn),
            ("gwn", FillRule::Gwn),
            ("gwn-positive", FillRule::GwnPositive),
            ("winding", FillRule::Winding),
            ("positive", FillRule::Positive),
            ("parity", FillRule::Parity),
        ],
    )?;
    opts.fill = choice(
        "fill",
        fill,
        &[
            ("solid", Fill::Solid),
            ("surface", Fill::Surface),
            ("both", Fill::Both),
        ],
    )?;
    opts.method = choice(
        "method",
        method,
        &[
            ("auto", Method::Auto),
            ("peel", Method::Peel),
            ("abuffer", Method::Abuffer),
            ("cpu", Method::Cpu),
        ],
    )?;
    // The NumPy array takes a byte per voxel: refuse, before any work, a grid whose array would not fit.
    let frame = api::grid_frame(&mesh, &opts).map_err(to_py)?;
    let bytes = frame.voxel_count();
    if let Some(free) = gregvox::io::host_memory_available() {
        // The packed grid (an eighth) and the engine's working set come on top of the array.
        if bytes > free / 2 {
            let [x, y, z] = frame.dims;
            return Err(bad(format!(
                "the occupancy array of {x}×{y}×{z} voxels needs {:.1} GiB (a byte per voxel), more than \
                 half of the {:.1} GiB of memory available: choose a coarser grid",
                bytes as f64 / GIB,
                free as f64 / GIB
            )));
        }
    }
    let gpu = device.gpu()?;
    let (dense, v, seconds) = py
        .allow_threads(|| -> gregvox::Result<_> {
            let start = std::time::Instant::now();
            let v = gpu.voxelize(&mesh, &opts)?;
            let seconds = start.elapsed().as_secs_f64();
            // The one copy into NumPy: the packed bits expanded to one byte per voxel, x-major.
            let mut dense = vec![0u8; v.grid.frame.voxel_count() as usize];
            v.grid.write_dense_xyz(&mut dense);
            Ok((dense, v, seconds))
        })
        .map_err(to_py)?;
    let d = v.grid.frame.dims.map(|x| x as usize);
    let occupancy = dense.into_pyarray(py).reshape(d)?;
    // The `voxelize --json` summary, with the notes the CLI prints on stderr and the library's own time.
    let mut summary = v.summary_json();
    if let Some(o) = summary.as_object_mut() {
        o.insert("notes".into(), v.report.notes.clone().into());
        o.insert("seconds".into(), seconds.into());
    }
    let report = summary.to_string();
    Ok((
        occupancy,
        v.grid.frame.origin,
        v.grid.frame.voxel_size,
        PackedGrid { grid: v.grid },
        report,
        seconds,
    ))
}

/// The ACC-2 Gregory surface of a quad cage, evaluated on the device.
#[pyclass(module = "gregvox._gregvox", frozen)]
struct GregorySurface {
    gpu: Arc<Gpu>,
    patches: Mutex<Patches>,
}

#[pymethods]
impl GregorySurface {
    #[new]
    fn new(
        py: Python<'_>,
        device: &Device,
        v: PyReadonlyArray2<'_, f64>,
        face_ptr: PyReadonlyArray1<'_, i64>,
        indices: PyReadonlyArray1<'_, i64>,
        tags: TagArgs<'_>,
        tangents: &str,
    ) -> PyResult<Self> {
        let cage = cage_of(mesh_of(&v, &face_ptr, &indices)?, &tags)?;
        let tangents = tangents_of(tangents)?;
        let patches = py
            .allow_threads(|| Patches::from_tagged_cage(&cage, tangents))
            .map_err(to_py)?;
        Ok(GregorySurface {
            gpu: device.gpu()?,
            patches: Mutex::new(patches),
        })
    }

    /// Number of patches.
    #[getter]
    fn patch_count(&self) -> u32 {
        self.patches.lock().map(|p| p.count()).unwrap_or(0)
    }

    /// Evaluates every patch at `level` on the device: positions and normals, float32 (P, L+1, L+1, 3), as
    /// `gregvox tessellate --no-weld` writes them (the same GPU path, the same bits).
    #[allow(clippy::type_complexity)]
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        level: u32,
    ) -> PyResult<(
        Bound<'py, numpy::PyArray4<f32>>,
        Bound<'py, numpy::PyArray4<f32>>,
        Option<Bound<'py, numpy::PyArray4<f32>>>,
    )> {
        let gpu = self.gpu.clone();
        let patches = &self.patches;
        let t = py
            .allow_threads(|| -> gregvox::Result<_> {
                let patches = patches
                    .lock()
                    .map_err(|_| Error::Invalid("the surface is in use".into()))?;
                let opts = TessellateOptions {
                    level,
                    ..TessellateOptions::default()
                };
                let mut profiler = gpu.profiler()?;
                gpu.tessellate(&patches, &opts, &mut profiler)
            })
            .map_err(to_py)?;
        if t.levels.is_some() {
            return Err(bad(
                "this surface's grids have levels of their own (a cage with non-quad faces past the \
                 uniform refinement's limit, gridded per ptex face): use gregvox tessellate",
            ));
        }
        let n = (level + 1) as usize;
        let shape = [t.patches as usize, n, n, 3];
        let o = t.origin;
        let far = o != [0.0; 3];
        let mut p = Vec::with_capacity(t.vertices.len() * 3);
        let mut nn = Vec::with_capacity(t.vertices.len() * 3);
        for v in &t.vertices {
            // A far cage is evaluated in a local frame: back to world coordinates (in f64, then rounded).
            let xyz = v.xyz();
            p.extend((0..3).map(|k| {
                if far {
                    (xyz[k] as f64 + o[k]) as f32
                } else {
                    xyz[k]
                }
            }));
            nn.extend(v.normal_xyz());
        }
        let uv = match &t.uvs {
            Some(uv) => {
                let flat: Vec<f32> = uv.iter().flatten().copied().collect();
                Some(flat.into_pyarray(py).reshape([shape[0], n, n, 2])?)
            }
            None => None,
        };
        Ok((
            p.into_pyarray(py).reshape(shape)?,
            nn.into_pyarray(py).reshape(shape)?,
            uv,
        ))
    }

    /// Moves the cage (same vertex count); the next `evaluate` runs on the new positions.
    fn set_cage(&self, v: PyReadonlyArray2<'_, f64>) -> PyResult<()> {
        let shape = v.shape();
        let v = v.as_slice().map_err(|_| bad("V must be C-contiguous"))?;
        let mut patches = self
            .patches
            .lock()
            .map_err(|_| PyRuntimeError::new_err("the surface is in use"))?;
        let n = match &*patches {
            Patches::Cage { rest, .. } => rest.len(),
            Patches::Ptex { cage, .. } => cage.mesh.positions.len(),
            Patches::Beziex(_) => return Err(bad(
                "set_cage: this surface is a Beziex model, not a cage: build a new GregorySurface",
            )),
        };
        if shape[1] != 3 || shape[0] != n {
            return Err(bad(format!(
                "the cage has {n} vertices: V must have shape ({n}, 3), not {shape:?}"
            )));
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(bad("V holds a NaN or infinite coordinate"));
        }
        let moved: Vec<DVec3> = v
            .chunks_exact(3)
            .map(|p| DVec3::new(p[0], p[1], p[2]))
            .collect();
        match &mut *patches {
            Patches::Cage { rest, .. } => *rest = moved,
            // Past the uniform limit: the feature-adaptive patches of the moved cage (the same stencils).
            Patches::Ptex {
                cage,
                evaluator,
                adaptive,
                ..
            } => {
                evaluator.set_positions(adaptive, &moved).map_err(to_py)?;
                cage.mesh.positions = moved;
            }
            Patches::Beziex(_) => {}
        }
        Ok(())
    }
}

/// The triangles of `patches` uniform (L+1)² grids, as `tessellate --no-weld` writes them (uint32 (m, 3)).
#[pyfunction]
fn grid_indices<'py>(
    py: Python<'py>,
    patches: u32,
    level: u32,
) -> PyResult<Bound<'py, PyArray2<u32>>> {
    if !(1..=64).contains(&level) {
        return Err(bad(format!("level {level} is outside 1..=64")));
    }
    let idx = gregvox::passes::gregory_eval::grid_indices(patches, level);
    let m = idx.len() / 3;
    idx.into_pyarray(py).reshape([m, 3])
}

/// Point queries (`gregvox::api::query`): for each name of `what` (winding, occupancy, sdf, udf, closest)
/// an array in the order of the points: winding float64 (n,), occupancy bool as uint8 (n,), sdf/udf float32
/// (n,), closest = (face uint32 (n,), point float64 (n, 3), barycentric float64 (n, 3)). With `device`, the
/// distances' nearest triangles are searched on it (the same arrays). The GIL is released while the mesh is
/// prepared and the points are answered.
#[pyfunction]
#[pyo3(signature = (v, face_ptr, indices, points, what, rule="gwn", sdf_sign="inside-negative", tolerance=1e-6, device=None))]
#[allow(clippy::too_many_arguments)]
fn query<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    face_ptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
    points: PyReadonlyArray2<'_, f64>,
    what: Vec<String>,
    rule: &str,
    sdf_sign: &str,
    tolerance: f64,
    device: Option<&Device>,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    use gregvox::api::query::{MeshQuery, QueryOptions, SdfSign};
    use gregvox::voxel::gwn::Inside;
    let mesh = mesh_of(&v, &face_ptr, &indices)?;
    if points.shape()[1] != 3 {
        return Err(bad(format!(
            "points must have shape (n, 3), not {:?}",
            points.shape()
        )));
    }
    let flat = points
        .as_slice()
        .map_err(|_| bad("points must be C-contiguous"))?;
    let pts: Vec<[f64; 3]> = flat.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    let opts = QueryOptions {
        inside: choice(
            "rule",
            rule,
            &[
                ("gwn", Inside::Magnitude),
                ("gwn-positive", Inside::Positive),
            ],
        )?,
        sdf_sign: choice(
            "sdf_sign",
            sdf_sign,
            &[
                ("inside-negative", SdfSign::InsideNegative),
                ("inside-positive", SdfSign::InsidePositive),
            ],
        )?,
        tolerance,
        ..QueryOptions::default()
    };
    for w in &what {
        if !["winding", "occupancy", "sdf", "udf", "closest"].contains(&w.as_str()) {
            return Err(bad(format!(
                "what '{w}' is not one of winding, occupancy, sdf, udf, closest"
            )));
        }
    }
    let want = |n: &str| what.iter().any(|w| w == n);
    let gpu = device.map(|d| d.gpu()).transpose()?;
    type Answers = (
        Option<Vec<f64>>,
        Option<Vec<bool>>,
        Option<api::query::Distances>,
        Option<api::query::Distances>,
    );
    let (winding, occupancy, sdf, udf): Answers = py
        .allow_threads(|| -> gregvox::Result<Answers> {
            let q = if want("winding") || want("occupancy") || want("sdf") {
                MeshQuery::new(&mesh, &opts)?
            } else {
                MeshQuery::distances_only(&mesh, &opts)?
            };
            // Occupancy once (its array and the sdf's sign), the nearest triangles once (sdf and udf).
            let (w, o) = if want("winding") {
                let (w, o) = q.winding_and_occupancy(&pts)?;
                (Some(w), Some(o))
            } else if want("occupancy") || want("sdf") {
                (None, Some(q.occupancy(&pts)?))
            } else {
                (None, None)
            };
            let (sdf, udf) = if want("sdf") || want("udf") || want("closest") {
                let nearest = q.nearest_triangles(&pts, gpu.as_deref().map(|g| (g, false)))?;
                let sdf = want("sdf")
                    .then(|| q.distance_rows(&nearest, o.as_deref()))
                    .transpose()?;
                let udf = (want("udf") || sdf.is_none())
                    .then(|| q.distance_rows(&nearest, None))
                    .transpose()?;
                (sdf, udf)
            } else {
                (None, None)
            };
            let o = o.filter(|_| want("occupancy"));
            Ok((w, o, sdf, udf))
        })
        .map_err(to_py)?;
    let out = pyo3::types::PyDict::new(py);
    let n = pts.len();
    if let Some(w) = winding {
        out.set_item("winding", w.into_pyarray(py))?;
    }
    if let Some(o) = occupancy {
        let bytes: Vec<u8> = o.iter().map(|&b| b as u8).collect();
        out.set_item("occupancy", bytes.into_pyarray(py))?;
    }
    if let Some(d) = &sdf {
        out.set_item("sdf", d.distance.clone().into_pyarray(py))?;
    }
    if let (true, Some(d)) = (want("udf"), &udf) {
        out.set_item("udf", d.distance.clone().into_pyarray(py))?;
    }
    if want("closest") {
        if let Some(d) = sdf.as_ref().or(udf.as_ref()) {
            out.set_item("face", d.face.clone().into_pyarray(py))?;
            let c: Vec<f64> = d.closest.iter().flatten().copied().collect();
            out.set_item("closest", c.into_pyarray(py).reshape([n, 3])?)?;
            let b: Vec<f64> = d.barycentric.iter().flatten().copied().collect();
            out.set_item("barycentric", b.into_pyarray(py).reshape([n, 3])?)?;
        }
    }
    Ok(out)
}

#[pymodule]
fn _gregvox(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Device>()?;
    m.add_class::<PackedGrid>()?;
    m.add_class::<GregorySurface>()?;
    m.add_function(wrap_pyfunction!(load_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(load_cage, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate_at, m)?)?;
    m.add_function(wrap_pyfunction!(topology_json, m)?)?;
    m.add_function(wrap_pyfunction!(subdivide, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_matrices, m)?)?;
    m.add_function(wrap_pyfunction!(voxelize, m)?)?;
    m.add_function(wrap_pyfunction!(grid_indices, m)?)?;
    m.add_function(wrap_pyfunction!(vertex_normals, m)?)?;
    m.add_function(wrap_pyfunction!(query, m)?)?;
    m.add_function(wrap_pyfunction!(simplify, m)?)?;
    Ok(())
}
