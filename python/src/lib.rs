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
    self, ContextDesc, Fill, FillRule, Gpu, GridSize, Mesh, Method, Scheme, Tangents, VoxelGrid,
    VoxelizeOptions,
};
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
    if ptr.first() != Some(&0)
        || ptr.last().copied() != Some(idx.len() as i64)
        || ptr.windows(2).any(|w| w[1] < w[0])
    {
        return Err(bad("face offsets do not cover F"));
    }
    let positions: Vec<DVec3> = v
        .chunks_exact(3)
        .map(|p| DVec3::new(p[0], p[1], p[2]))
        .collect();
    let faces: Vec<Vec<u32>> = ptr
        .windows(2)
        .map(|w| {
            idx[w[0] as usize..w[1] as usize]
                .iter()
                .map(|&i| i as u32)
                .collect()
        })
        .collect();
    Mesh::from_polygons(positions, &faces).map_err(to_py)
}

/// The Vulkan device.
#[pyclass(module = "gregvox._gregvox", frozen)]
struct Device {
    gpu: Arc<Gpu>,
}

#[pymethods]
impl Device {
    /// `name`: a case-insensitive substring of the device name (default: `GREGVOX_DEVICE`, else the first
    /// device; lavapipe where there is no GPU).
    #[new]
    #[pyo3(signature = (name=None))]
    fn new(py: Python<'_>, name: Option<String>) -> PyResult<Self> {
        let desc = ContextDesc {
            device_filter: name,
            ..ContextDesc::default()
        };
        let gpu = py.allow_threads(|| Gpu::with_desc(&desc)).map_err(to_py)?;
        Ok(Device { gpu: Arc::new(gpu) })
    }

    /// What `gregvox info --json` reports of the device, as a JSON text.
    #[getter]
    fn info_json(&self) -> PyResult<String> {
        serde_json::to_string(self.gpu.info()).map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }
}

/// Loads any mesh file of the loader: (V float64 (n, 3), face offsets int64 (m + 1), indices int64).
#[pyfunction]
fn load_mesh<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<(
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
)> {
    let mesh = py.allow_threads(|| api::load_mesh(&path)).map_err(to_py)?;
    Ok(arrays_of(py, &mesh))
}

fn arrays_of<'py>(
    py: Python<'py>,
    mesh: &Mesh,
) -> (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
) {
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
    v: PyReadonlyArray2<'_, f64>,
    face_ptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
) -> PyResult<String> {
    let mesh = mesh_of(&v, &face_ptr, &indices)?;
    serde_json::to_string(&api::topology(&mesh)).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// Subdivision: the refined mesh as arrays.
#[pyfunction]
#[allow(clippy::type_complexity)]
fn subdivide<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    face_ptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
    levels: u32,
    scheme: &str,
) -> PyResult<(
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
)> {
    let mesh = mesh_of(&v, &face_ptr, &indices)?;
    let scheme = match scheme {
        "catmull-clark" => Scheme::CatmullClark,
        "loop" => Scheme::Loop,
        "loop-warren" => Scheme::LoopWarren,
        s => {
            return Err(bad(format!(
                "scheme '{s}' is not one of catmull-clark, loop, loop-warren"
            )))
        }
    };
    let out = py
        .allow_threads(|| api::subdivide(&mesh, levels, scheme))
        .map_err(to_py)?;
    Ok(arrays_of(py, &out))
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
    let m = api::MeshMatrix::from_mesh(&mesh);
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

/// A packed voxel grid (the engine's), kept for `save`.
#[pyclass(module = "gregvox._gregvox", frozen)]
struct PackedGrid {
    grid: VoxelGrid,
}

#[pymethods]
impl PackedGrid {
    /// Writes the grid in the format the extension names (.binvox, .npy, .raw, .vox, .vdb…), atomically.
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        if let Err(e) = gregvox::io::check_output(&path) {
            return Err(to_py(e));
        }
        py.allow_threads(|| self.grid.save(&path)).map_err(to_py)
    }
}

/// Voxelizes a mesh: (occupancy uint8 (X, Y, Z) C order, origin, voxel size, the packed grid, the report
/// as JSON).
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
    opts.rule = match rule {
        "auto" | "gwn" => FillRule::Gwn,
        "winding" => FillRule::Winding,
        "parity" => FillRule::Parity,
        r => {
            return Err(bad(format!(
                "rule '{r}' is not one of auto, gwn, winding, parity"
            )))
        }
    };
    opts.fill = match fill {
        "solid" => Fill::Solid,
        "surface" => Fill::Surface,
        "both" => Fill::Both,
        f => {
            return Err(bad(format!(
                "fill '{f}' is not one of solid, surface, both"
            )))
        }
    };
    opts.method = match method {
        "auto" => Method::Auto,
        "peel" => Method::Peel,
        "abuffer" => Method::Abuffer,
        "cpu" => Method::Cpu,
        m => {
            return Err(bad(format!(
                "method '{m}' is not one of auto, peel, abuffer, cpu"
            )))
        }
    };
    let gpu = device.gpu.clone();
    let (dense, v) = py
        .allow_threads(|| -> gregvox::Result<_> {
            let v = gpu.voxelize(&mesh, &opts)?;
            let mut dense = vec![0u8; v.grid.frame.voxel_count() as usize];
            v.grid.write_dense_xyz(&mut dense);
            Ok((dense, v))
        })
        .map_err(to_py)?;
    let d = v.grid.frame.dims.map(|x| x as usize);
    let occupancy = dense.into_pyarray(py).reshape(d)?;
    let report = serde_json::to_string(&v.report).unwrap_or_default();
    Ok((
        occupancy,
        v.grid.frame.origin,
        v.grid.frame.voxel_size,
        PackedGrid { grid: v.grid },
        report,
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
        device: &Device,
        v: PyReadonlyArray2<'_, f64>,
        face_ptr: PyReadonlyArray1<'_, i64>,
        indices: PyReadonlyArray1<'_, i64>,
        tangents: &str,
    ) -> PyResult<Self> {
        let mesh = mesh_of(&v, &face_ptr, &indices)?;
        let tangents = match tangents {
            "opensubdiv" => Tangents::OpenSubdiv,
            "exact" => Tangents::Exact,
            t => {
                return Err(bad(format!(
                    "tangents '{t}' is not one of opensubdiv, exact"
                )))
            }
        };
        let patches = Patches::from_cage(&mesh, tangents).map_err(to_py)?;
        Ok(GregorySurface {
            gpu: device.gpu.clone(),
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
        let n = (level + 1) as usize;
        let shape = [t.patches as usize, n, n, 3];
        let o = t.origin;
        let far = o != [0.0; 3];
        let mut p = Vec::with_capacity(t.vertices.len() * 3);
        let mut nn = Vec::with_capacity(t.vertices.len() * 3);
        for v in &t.vertices {
            for k in 0..3 {
                p.push(if far {
                    (v.position[k] as f64 + o[k]) as f32
                } else {
                    v.position[k]
                });
                nn.push(v.normal[k]);
            }
        }
        Ok((
            p.into_pyarray(py).reshape(shape)?,
            nn.into_pyarray(py).reshape(shape)?,
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
        let Patches::Cage { rest, .. } = &mut *patches else {
            return Err(bad("not a cage"));
        };
        if shape[1] != 3 || shape[0] != rest.len() {
            return Err(bad(format!(
                "the cage has {} vertices: V must have shape ({}, 3), not {shape:?}",
                rest.len(),
                rest.len()
            )));
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(bad("V holds a NaN or infinite coordinate"));
        }
        for (r, p) in rest.iter_mut().zip(v.chunks_exact(3)) {
            *r = DVec3::new(p[0], p[1], p[2]);
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
    Ok(idx.into_pyarray(py).reshape([m, 3])?)
}

#[pymodule]
fn _gregvox(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Device>()?;
    m.add_class::<PackedGrid>()?;
    m.add_class::<GregorySurface>()?;
    m.add_function(wrap_pyfunction!(load_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(topology_json, m)?)?;
    m.add_function(wrap_pyfunction!(subdivide, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_matrices, m)?)?;
    m.add_function(wrap_pyfunction!(voxelize, m)?)?;
    m.add_function(wrap_pyfunction!(grid_indices, m)?)?;
    Ok(())
}
