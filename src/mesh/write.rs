//! Mesh writers: OBJ, binary PLY, binary STL and GLB (one mesh, or a chain of levels of detail as one
//! file with `MSFT_lod`), chosen by the output's extension ([`write_mesh`], [`write_glb_levels`]).
//!
//! Invariants: every write goes through a temporary file renamed into place ([`crate::io::write_atomic`]),
//! so a failed write leaves nothing; PLY, STL and GLB store positions as f32 (what their readers expect);
//! STL and GLB store triangles (polygons fanned from their first corner); an extension outside the list
//! is an error naming it, before anything is written.
//!
//! Cost: O(V + F) with the whole output built in memory (PLY, STL, GLB: one buffer each) and written once;
//! a polygon over 255 corners (PLY's `uchar` count) is an error, not a truncated face.
use super::obj::{write_obj, Mesh};
use crate::error::{Error, Result};
use std::path::Path;

/// The mesh formats written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshOut {
    Obj,
    Ply,
    Stl,
    Glb,
}

impl MeshOut {
    /// The format of an output path, from its extension.
    ///
    /// ```
    /// use gregvox::mesh::write::MeshOut;
    /// assert_eq!(MeshOut::of("a/b.GLB".as_ref()).unwrap(), MeshOut::Glb);
    /// assert!(MeshOut::of("b.fbx".as_ref()).is_err());
    /// ```
    pub fn of(path: &Path) -> Result<MeshOut> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("obj") => Ok(MeshOut::Obj),
            Some("ply") => Ok(MeshOut::Ply),
            Some("stl") => Ok(MeshOut::Stl),
            Some("glb") => Ok(MeshOut::Glb),
            _ => Err(Error::Invalid(format!(
                "{}: unknown mesh output extension (write .obj, .ply, .stl or .glb)",
                path.display()
            ))),
        }
    }
}

/// Writes `mesh` in the format of `path`'s extension.
pub fn write_mesh(path: impl AsRef<Path>, mesh: &Mesh) -> Result<()> {
    let path = path.as_ref();
    match MeshOut::of(path)? {
        MeshOut::Obj => write_obj(path, mesh),
        MeshOut::Ply => write_ply(path, mesh),
        MeshOut::Stl => write_stl(path, mesh),
        MeshOut::Glb => write_glb_levels(path, &[(mesh, serde_json::Value::Null)]),
    }
}

/// Binary little-endian PLY: f32 positions, polygon faces as `uchar int` lists.
pub fn write_ply(path: impl AsRef<Path>, mesh: &Mesh) -> Result<()> {
    if let Some(f) = (0..mesh.n_faces()).find(|&f| mesh.face(f).len() > 255) {
        return Err(Error::Invalid(format!(
            "{}: face {f} has {} corners, more than a PLY list of uchar count holds",
            path.as_ref().display(),
            mesh.face(f).len()
        )));
    }
    crate::io::write_atomic(path.as_ref(), |w| {
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment gregvox\nelement vertex {}\n\
             property float x\nproperty float y\nproperty float z\nelement face {}\n\
             property list uchar int vertex_indices\nend_header\n",
            mesh.positions.len(),
            mesh.n_faces()
        )?;
        let mut buf = Vec::with_capacity(12 * mesh.positions.len());
        for p in &mesh.positions {
            for c in p.to_array() {
                buf.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        w.write_all(&buf)?;
        buf.clear();
        for f in 0..mesh.n_faces() {
            let face = mesh.face(f);
            buf.push(face.len() as u8);
            for &v in face {
                buf.extend_from_slice(&(v as i32).to_le_bytes());
            }
        }
        w.write_all(&buf)
    })
}

/// Binary STL: 80-byte header, the triangle count, each triangle's unit normal and corners (f32).
pub fn write_stl(path: impl AsRef<Path>, mesh: &Mesh) -> Result<()> {
    let tri = mesh.fan_triangles();
    if tri.len() > u32::MAX as usize {
        return Err(Error::Invalid(format!(
            "{}: {} triangles, more than binary STL counts",
            path.as_ref().display(),
            tri.len()
        )));
    }
    crate::io::write_atomic(path.as_ref(), |w| {
        let mut header = [b' '; 80];
        header[..7].copy_from_slice(b"gregvox");
        w.write_all(&header)?;
        w.write_all(&(tri.len() as u32).to_le_bytes())?;
        let mut buf = Vec::with_capacity(50 * tri.len());
        for t in &tri {
            let p = t.map(|v| mesh.positions[v as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            for q in [n, p[0], p[1], p[2]] {
                for c in q.to_array() {
                    buf.extend_from_slice(&(c as f32).to_le_bytes());
                }
            }
            buf.extend_from_slice(&[0, 0]);
        }
        w.write_all(&buf)
    })
}

/// One GLB with one triangle mesh per level, each with its `extras` (the level's report). Level 0 is the
/// scene's node; with more levels it names the others through `MSFT_lod` (nearest first), as engines that
/// read levels of detail from glTF expect.
pub fn write_glb_levels(
    path: impl AsRef<Path>,
    levels: &[(&Mesh, serde_json::Value)],
) -> Result<()> {
    use serde_json::json;
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut meshes, mut nodes) = (vec![], vec![], vec![], vec![]);
    for (k, (mesh, extras)) in levels.iter().enumerate() {
        let tri = mesh.fan_triangles();
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        let pos_at = bin.len();
        for p in &mesh.positions {
            for (i, c) in p.to_array().into_iter().enumerate() {
                let c = c as f32;
                lo[i] = lo[i].min(c);
                hi[i] = hi[i].max(c);
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        let idx_at = bin.len();
        for t in &tri {
            for v in t {
                bin.extend_from_slice(&v.to_le_bytes());
            }
        }
        let end = bin.len();
        let (vp, vi) = (views.len(), views.len() + 1);
        views.push(json!({"buffer": 0, "byteOffset": pos_at, "byteLength": idx_at - pos_at, "target": 34962}));
        views.push(
            json!({"buffer": 0, "byteOffset": idx_at, "byteLength": end - idx_at, "target": 34963}),
        );
        let (ap, ai) = (accessors.len(), accessors.len() + 1);
        let mut pos = json!({"bufferView": vp, "componentType": 5126, "count": mesh.positions.len(), "type": "VEC3"});
        if !mesh.positions.is_empty() {
            pos["min"] = json!(lo);
            pos["max"] = json!(hi);
        }
        accessors.push(pos);
        accessors.push(json!({"bufferView": vi, "componentType": 5125, "count": 3 * tri.len(), "type": "SCALAR"}));
        meshes.push(json!({"name": format!("LOD{k}"), "primitives": [{"attributes": {"POSITION": ap}, "indices": ai, "mode": 4}]}));
        let mut node = json!({"mesh": k, "name": format!("LOD{k}")});
        if !extras.is_null() {
            node["extras"] = extras.clone();
        }
        nodes.push(node);
    }
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": concat!("gregvox ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": nodes,
        "meshes": meshes,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
    });
    if levels.len() > 1 {
        doc["extensionsUsed"] = json!(["MSFT_lod"]);
        doc["nodes"][0]["extensions"] =
            json!({"MSFT_lod": {"ids": (1..levels.len()).collect::<Vec<_>>()}});
    }
    let mut text = serde_json::to_vec(&doc).map_err(|e| Error::Invalid(e.to_string()))?;
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    if total > u32::MAX as usize {
        return Err(Error::Invalid(format!(
            "{}: {total} bytes, more than a GLB holds (4 GiB)",
            path.as_ref().display()
        )));
    }
    crate::io::write_atomic(path.as_ref(), |w| {
        w.write_all(b"glTF")?;
        w.write_all(&2u32.to_le_bytes())?;
        w.write_all(&(total as u32).to_le_bytes())?;
        w.write_all(&(text.len() as u32).to_le_bytes())?;
        w.write_all(b"JSON")?;
        w.write_all(&text)?;
        w.write_all(&(bin.len() as u32).to_le_bytes())?;
        w.write_all(b"BIN\0")?;
        w.write_all(&bin)
    })
}
