//! glTF 2.0 reading: `.gltf` JSON (buffers in external files relative to it, or base64 `data:` URIs) and
//! binary `.glb`.
//!
//! Invariants of the loaded mesh: every triangle primitive (modes TRIANGLES, TRIANGLE_STRIP,
//! TRIANGLE_FAN; POINTS and LINES primitives are skipped, and a file with no triangle left is refused) of
//! every node reachable from the default scene (else scene 0, else every root node), in depth-first node
//! order then primitive order, with the node's world transform (matrix or TRS, composed from the root
//! down, in `f64`) applied to its positions; a transform that mirrors (negative determinant) reverses the
//! triangles' winding, as the glTF specification says, so they stay outward. Indexed and non-indexed
//! primitives; positions as `FLOAT` or, as `KHR_mesh_quantization` allows, (normalized) 8/16-bit integers.
//! Strip and fan triangles follow the specification's vertex order; their degenerate triangles (the usual
//! way to join strips) are skipped. Then the whole mesh is welded exactly (`super::load`: exporters split
//! vertices at seams and per primitive).
//!
//! Errors name the file, then where: `byte N` for the GLB container, `line N` for JSON syntax, the glTF
//! object (`accessor 3`, `node 2`, `mesh 0 primitive 1`) for everything else, then the problem: chunk
//! lengths past the file, accessor or buffer-view ranges past their buffer, an index past the vertices, a
//! node cycle or a node with two parents, a missing or short buffer file, sparse accessors (not read).
//! Every range is checked in `u128` before it is sliced, and a scene that instances its meshes so often
//! that the loaded mesh would exceed 64 × its input bytes (and 256 MiB) is refused before reading.
//!
//! What comes from the `gltf` crate (default features off: no image decoders, no file access): the JSON
//! schema and its validation (every index in range, enums valid, required fields present), which is most of
//! glTF's complexity and which it does well. What is written here: the GLB container (for byte offsets in
//! errors), buffer resolution (`gltf`'s `import` feature pulls in the `image` decoders and reads whole
//! files unchecked), and accessor reading: `gltf`'s reader returns `None` with no reason for a range past
//! its buffer and computes `count - 1` unchecked, and node traversal is ours to guard against cycles.
use super::load::{line_of, weld_exact};
use super::Mesh;
use crate::error::{Error, Result};
use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::Mode;
use ::gltf::{Document, Semantic};
use base64::Engine;
use glam::{DMat4, DQuat, DVec3};
use std::borrow::Cow;
use std::path::Path;

const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// The chunks of a GLB that a mesh needs.
struct Chunks<'a> {
    json: &'a [u8],
    /// Byte offset of the JSON chunk's data in the file.
    json_at: usize,
    bin: Option<&'a [u8]>,
}

/// The JSON and BIN chunks of a GLB, and the JSON's byte offset.
fn split_glb<'a>(bytes: &'a [u8], path: &Path) -> Result<Chunks<'a>> {
    let err = |at: usize, msg: String| Error::parse(path, format!("byte {at}: {msg}"));
    if bytes.len() < 12 {
        return Err(err(
            bytes.len(),
            format!(
                "file ends inside the 12-byte GLB header ({} bytes)",
                bytes.len()
            ),
        ));
    }
    let version = u32_at(bytes, 4);
    if version != 2 {
        return Err(err(
            4,
            format!("GLB version {version} (only glTF 2.0 is supported)"),
        ));
    }
    let length = u32_at(bytes, 8) as usize;
    if length > bytes.len() {
        return Err(err(
            8,
            format!(
                "the GLB header says the file has {length} bytes, but it has {} (truncated?)",
                bytes.len()
            ),
        ));
    }
    if length < 12 {
        return Err(err(
            8,
            format!("the GLB header gives a length of {length} bytes (less than the header)"),
        ));
    }
    let data = &bytes[..length];
    let (mut json, mut bin) = (None, None);
    let mut pos = 12usize;
    while pos < data.len() {
        if pos + 8 > data.len() {
            return Err(err(pos, "file ends inside a GLB chunk header".into()));
        }
        let clen = u32_at(data, pos) as usize;
        let ctype = u32_at(data, pos + 4);
        let start = pos + 8;
        if clen as u128 > (data.len() - start) as u128 {
            return Err(err(
                pos,
                format!(
                    "a GLB chunk of {clen} bytes runs past the end of the file ({} bytes after its header)",
                    data.len() - start
                ),
            ));
        }
        let chunk = &data[start..start + clen];
        match ctype {
            CHUNK_JSON if json.is_none() && pos == 12 => json = Some((chunk, start)),
            CHUNK_BIN if bin.is_none() && json.is_some() => bin = Some(chunk),
            _ if pos == 12 => return Err(err(pos, "the first GLB chunk is not JSON".into())),
            _ => {} // unknown chunks are skipped, as the specification says
        }
        pos = start + clen;
    }
    let Some((json, at)) = json else {
        return Err(err(12, "the GLB has no JSON chunk".into()));
    };
    Ok(Chunks {
        json,
        json_at: at,
        bin,
    })
}

/// Where a JSON syntax error is: `byte N` inside a GLB, `line N` in a `.gltf`.
fn json_error(e: &serde_json::Error, json: &[u8], glb_offset: Option<usize>, path: &Path) -> Error {
    let msg = e.to_string();
    let msg = msg.split(" at line ").next().unwrap_or(&msg).to_string();
    let where_ = match glb_offset {
        Some(base) => {
            // line/column → byte offset in the chunk
            let mut off = 0usize;
            for _ in 1..e.line() {
                match json[off..].iter().position(|&b| b == b'\n') {
                    Some(p) => off += p + 1,
                    None => break,
                }
            }
            format!("byte {}", base + off + e.column().saturating_sub(1))
        }
        None => format!("line {}", e.line().max(1)),
    };
    Error::parse(path, format!("{where_}: invalid glTF JSON: {msg}"))
}

/// Reads glTF or GLB (see the module doc).
pub(crate) fn parse_gltf(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let (json, glb_offset, bin) = if bytes.starts_with(b"glTF") {
        let c = split_glb(bytes, path)?;
        (c.json, Some(c.json_at), c.bin)
    } else {
        if let Some(pos) = bytes.iter().position(|&b| b == 0) {
            return Err(Error::parse(
                path,
                format!(
                    "line {}: binary data (NUL byte); not glTF JSON (nor GLB: no 'glTF' magic)",
                    line_of(bytes, pos)
                ),
            ));
        }
        (bytes, None, None)
    };
    let root: ::gltf::json::Root =
        serde_json::from_slice(json).map_err(|e| json_error(&e, json, glb_offset, path))?;
    let doc = Document::from_json(root).map_err(|e| match e {
        ::gltf::Error::Validation(errs) => {
            let shown: Vec<String> = errs
                .iter()
                .take(4)
                .map(|(p, e)| format!("{p}: {e}"))
                .collect();
            let more = if errs.len() > 4 {
                format!(" (and {} more)", errs.len() - 4)
            } else {
                String::new()
            };
            Error::parse(path, format!("invalid glTF: {}{more}", shown.join("; ")))
        }
        e => Error::parse(path, format!("invalid glTF: {e}")),
    })?;
    Loader {
        doc: &doc,
        path,
        bin,
        buffers: vec![None; doc.buffers().len()],
        input_bytes: bytes.len() as u128,
    }
    .load()
}

/// One triangle primitive placed in the scene.
struct Instance {
    mesh: usize,
    prim: usize,
    node: usize,
    world: DMat4,
}

/// Where the faces of an instance start in the loaded mesh, for messages.
struct Span {
    first_face: usize,
    mesh: usize,
    prim: usize,
    node: usize,
    strip: bool,
}

struct Loader<'a> {
    doc: &'a Document,
    path: &'a Path,
    bin: Option<&'a [u8]>,
    buffers: Vec<Option<Cow<'a, [u8]>>>,
    input_bytes: u128,
}

impl<'a> Loader<'a> {
    fn err(&self, msg: String) -> Error {
        Error::parse(self.path, msg)
    }

    fn local_transform(&self, node: &::gltf::Node) -> Result<DMat4> {
        let m = match node.transform() {
            ::gltf::scene::Transform::Matrix { matrix } => {
                DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)))
            }
            ::gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            } => {
                let q = DQuat::from_array(rotation.map(f64::from));
                let len = q.length();
                if !len.is_finite() || len == 0.0 {
                    return Err(self.err(format!(
                        "node {}: the rotation {rotation:?} is not a unit quaternion",
                        node.index()
                    )));
                }
                let q = if len == 1.0 { q } else { q / len };
                DMat4::from_scale_rotation_translation(
                    DVec3::from(scale.map(f64::from)),
                    q,
                    DVec3::from(translation.map(f64::from)),
                )
            }
        };
        if !m.is_finite() {
            return Err(self.err(format!(
                "node {}: the transform has a non-finite entry",
                node.index()
            )));
        }
        Ok(m)
    }

    /// Every triangle primitive of the scene with its world transform; checks the node hierarchy.
    fn instances(&self) -> Result<(Vec<Instance>, usize)> {
        let n = self.doc.nodes().len();
        let mut parent: Vec<Option<usize>> = vec![None; n];
        for node in self.doc.nodes() {
            for c in node.children() {
                if let Some(p) = parent[c.index()] {
                    return Err(self.err(format!(
                        "node {} is a child of both node {p} and node {}: glTF nodes form trees",
                        c.index(),
                        node.index()
                    )));
                }
                parent[c.index()] = Some(node.index());
            }
        }
        // Each node has at most one parent, so a cycle is found by walking up (every node walked once).
        let mut state = vec![0u8; n]; // 0 unseen, 1 on the current walk, 2 done
        for start in 0..n {
            let mut walk = Vec::new();
            let mut v = Some(start);
            while let Some(x) = v {
                match state[x] {
                    2 => break,
                    1 => {
                        return Err(self.err(format!(
                            "node {x} is its own ancestor: the node hierarchy has a cycle"
                        )))
                    }
                    _ => {
                        state[x] = 1;
                        walk.push(x);
                        v = parent[x];
                    }
                }
            }
            for x in walk {
                state[x] = 2;
            }
        }
        let roots: Vec<usize> = match self
            .doc
            .default_scene()
            .or_else(|| self.doc.scenes().next())
        {
            Some(scene) => scene.nodes().map(|n| n.index()).collect(),
            None => (0..n).filter(|&i| parent[i].is_none()).collect(),
        };
        let nodes: Vec<::gltf::Node> = self.doc.nodes().collect();
        let mut out = Vec::new();
        let mut skipped = 0usize;
        let mut seen = vec![false; n];
        let mut stack: Vec<(usize, DMat4)> =
            roots.iter().rev().map(|&r| (r, DMat4::IDENTITY)).collect();
        while let Some((i, parent_world)) = stack.pop() {
            if std::mem::replace(&mut seen[i], true) {
                return Err(self.err(format!(
                    "node {i} is listed twice as a scene root or as a root and a child"
                )));
            }
            let node = &nodes[i];
            let world = parent_world * self.local_transform(node)?;
            if let Some(mesh) = node.mesh() {
                for prim in mesh.primitives() {
                    match prim.mode() {
                        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan => {
                            out.push(Instance {
                                mesh: mesh.index(),
                                prim: prim.index(),
                                node: i,
                                world,
                            })
                        }
                        _ => skipped += 1,
                    }
                }
            }
            let children: Vec<usize> = node.children().map(|c| c.index()).collect();
            for &c in children.iter().rev() {
                stack.push((c, world));
            }
        }
        Ok((out, skipped))
    }

    /// The bytes of buffer `b` (resolved once).
    fn buffer(&mut self, b: usize) -> Result<&[u8]> {
        if self.buffers[b].is_none() {
            let buf = self.doc.buffers().nth(b).expect("validated index");
            let declared = buf.length();
            let data: Cow<[u8]> = match buf.source() {
                ::gltf::buffer::Source::Bin => match self.bin {
                    Some(bin) => Cow::Borrowed(bin),
                    None => {
                        return Err(self.err(format!(
                            "buffer {b} is the GLB's BIN chunk, but the file has none"
                        )))
                    }
                },
                ::gltf::buffer::Source::Uri(uri) => self.resolve_uri(b, uri, declared)?,
            };
            if data.len() < declared {
                return Err(self.err(format!(
                    "buffer {b}: its byteLength is {declared}, but its data has only {} bytes",
                    data.len()
                )));
            }
            self.buffers[b] = Some(match data {
                Cow::Borrowed(d) => Cow::Borrowed(&d[..declared]),
                Cow::Owned(mut d) => {
                    d.truncate(declared);
                    Cow::Owned(d)
                }
            });
        }
        Ok(self.buffers[b].as_deref().unwrap())
    }

    fn resolve_uri(&self, b: usize, uri: &str, declared: usize) -> Result<Cow<'a, [u8]>> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let Some((meta, payload)) = rest.split_once(',') else {
                return Err(self.err(format!(
                    "buffer {b}: a data: URI without a ',' before its data"
                )));
            };
            if !meta.ends_with(";base64") {
                return Err(self.err(format!("buffer {b}: only base64 data: URIs are supported")));
            }
            let data = base64::engine::general_purpose::STANDARD
                .decode(payload.trim_end())
                .map_err(|e| {
                    self.err(format!("buffer {b}: invalid base64 in its data: URI: {e}"))
                })?;
            return Ok(Cow::Owned(data));
        }
        if uri.contains("://") {
            return Err(self.err(format!(
                "buffer {b}: URI '{uri}' is not a relative file path (only files beside the glTF and data: URIs are read)"
            )));
        }
        let rel = percent_decode(uri)
            .ok_or_else(|| self.err(format!("buffer {b}: URI '{uri}' has an invalid %-escape")))?;
        let file = self.path.parent().unwrap_or(Path::new("")).join(&rel);
        let read_err = |e: std::io::Error| {
            self.err(format!("buffer {b}: cannot read '{}': {e}", file.display()))
        };
        let f = std::fs::File::open(&file).map_err(read_err)?;
        let len = f.metadata().map_err(read_err)?.len();
        if (len as u128) < declared as u128 {
            return Err(self.err(format!(
                "buffer {b}: '{}' has {len} bytes, but the buffer's byteLength is {declared}",
                file.display()
            )));
        }
        // Reads only the declared bytes (the file is at least that long).
        let mut data = Vec::with_capacity(declared);
        use std::io::Read;
        f.take(declared as u64)
            .read_to_end(&mut data)
            .map_err(read_err)?;
        Ok(Cow::Owned(data))
    }

    /// Where an accessor's bytes are, checked against its view and the view against its buffer's declared
    /// length (no data is read): buffer index, first byte in the buffer, bytes covered, stride.
    fn accessor_range(
        &self,
        acc: &::gltf::Accessor,
        role: &str,
    ) -> Result<(usize, usize, usize, usize)> {
        let a = acc.index();
        if acc.sparse().is_some() {
            return Err(self.err(format!(
                "accessor {a} ({role}) is sparse; sparse accessors are not supported"
            )));
        }
        let Some(view) = acc.view() else {
            return Err(self.err(format!("accessor {a} ({role}) has no bufferView")));
        };
        let elem = acc.data_type().size() * acc.dimensions().multiplicity();
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(self.err(format!(
                "accessor {a} ({role}): bufferView {} has a byteStride of {stride}, less than the {elem}-byte element",
                view.index()
            )));
        }
        let count = acc.count() as u128;
        let span = if count == 0 {
            0
        } else {
            (count - 1) * stride as u128 + elem as u128
        };
        let need = acc.offset() as u128 + span;
        if need > view.length() as u128 {
            return Err(self.err(format!(
                "accessor {a} ({role}): {count} elements of {elem} bytes (stride {stride}) from byte {} of \
                 bufferView {} need {need} bytes, but the bufferView has {}",
                acc.offset(),
                view.index(),
                view.length()
            )));
        }
        let buffer = view.buffer();
        let end = view.offset() as u128 + view.length() as u128;
        if end > buffer.length() as u128 {
            return Err(self.err(format!(
                "bufferView {}: bytes {}..{end} run past the end of buffer {} ({} bytes)",
                view.index(),
                view.offset(),
                buffer.index(),
                buffer.length()
            )));
        }
        // span ≤ need ≤ the view's length, so it fits a usize.
        Ok((
            buffer.index(),
            view.offset() + acc.offset(),
            span as usize,
            stride,
        ))
    }

    /// The bytes an accessor covers (see [`Self::accessor_range`]) and its stride.
    fn accessor(&mut self, acc: &::gltf::Accessor, role: &str) -> Result<(&[u8], usize)> {
        let (b, start, len, stride) = self.accessor_range(acc, role)?;
        // The buffer's data is at least its declared length (checked on resolving), which holds the range.
        let data = self.buffer(b)?;
        Ok((&data[start..start + len], stride))
    }

    fn positions(&mut self, acc: &::gltf::Accessor, role: &str) -> Result<Vec<DVec3>> {
        if acc.dimensions() != Dimensions::Vec3 {
            return Err(self.err(format!(
                "accessor {} ({role}) is {:?}, not VEC3",
                acc.index(),
                acc.dimensions()
            )));
        }
        let (ty, norm, count) = (acc.data_type(), acc.normalized(), acc.count());
        let path = self.path;
        let (data, stride) = self.accessor(acc, role)?;
        let comp = ty.size();
        let read = |b: &[u8]| -> Option<f64> {
            Some(match (ty, norm) {
                (DataType::F32, _) => f64::from(f32::from_le_bytes(b[..4].try_into().ok()?)),
                (DataType::I8, false) => f64::from(b[0] as i8),
                (DataType::I8, true) => (f64::from(b[0] as i8) / 127.0).max(-1.0),
                (DataType::U8, false) => f64::from(b[0]),
                (DataType::U8, true) => f64::from(b[0]) / 255.0,
                (DataType::I16, false) => f64::from(i16::from_le_bytes([b[0], b[1]])),
                (DataType::I16, true) => {
                    (f64::from(i16::from_le_bytes([b[0], b[1]])) / 32767.0).max(-1.0)
                }
                (DataType::U16, false) => f64::from(u16::from_le_bytes([b[0], b[1]])),
                (DataType::U16, true) => f64::from(u16::from_le_bytes([b[0], b[1]])) / 65535.0,
                _ => return None,
            })
        };
        let mut out = Vec::with_capacity(count);
        for i in 0..count {
            let e = &data[i * stride..];
            let mut c = [0.0; 3];
            for (k, slot) in c.iter_mut().enumerate() {
                *slot = read(&e[k * comp..]).ok_or_else(|| {
                    Error::parse(
                        path,
                        format!(
                            "accessor {} ({role}): positions of type {ty:?} are not supported",
                            acc.index()
                        ),
                    )
                })?;
            }
            out.push(DVec3::from(c));
        }
        Ok(out)
    }

    fn indices(&mut self, acc: &::gltf::Accessor, role: &str) -> Result<Vec<u32>> {
        if acc.dimensions() != Dimensions::Scalar {
            return Err(self.err(format!("accessor {} ({role}) is not SCALAR", acc.index())));
        }
        let (ty, count, a) = (acc.data_type(), acc.count(), acc.index());
        if !matches!(ty, DataType::U8 | DataType::U16 | DataType::U32) {
            return Err(self.err(format!(
                "accessor {a} ({role}): indices of type {ty:?} (they must be unsigned)"
            )));
        }
        let (data, stride) = self.accessor(acc, role)?;
        Ok((0..count)
            .map(|i| {
                let e = &data[i * stride..];
                match ty {
                    DataType::U8 => u32::from(e[0]),
                    DataType::U16 => u32::from(u16::from_le_bytes([e[0], e[1]])),
                    _ => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
                }
            })
            .collect())
    }

    fn load(mut self) -> Result<Mesh> {
        let (instances, skipped) = self.instances()?;
        if instances.is_empty() {
            return Err(self.err(format!(
                "empty mesh: no triangle primitive in the scene ({skipped} point or line primitives skipped)"
            )));
        }
        let doc = self.doc;
        let prim_of = |inst: &Instance| {
            doc.meshes()
                .nth(inst.mesh)
                .and_then(|m| m.primitives().nth(inst.prim))
                .expect("validated indices")
        };
        // The loaded size, before reading anything: instancing can multiply a small file.
        let mut total_vertices = 0u128;
        let mut total_corners = 0u128;
        let mut buffer_bytes = 0u128;
        for b in doc.buffers() {
            buffer_bytes += b.length() as u128;
        }
        for inst in &instances {
            let prim = prim_of(inst);
            let Some(pacc) = prim.get(&Semantic::Positions) else {
                return Err(self.err(format!(
                    "mesh {} primitive {}: no POSITION attribute",
                    inst.mesh, inst.prim
                )));
            };
            let role = format!("POSITION of mesh {} primitive {}", inst.mesh, inst.prim);
            self.accessor_range(&pacc, &role)?;
            let n = pacc.count() as u128;
            total_vertices += n;
            // A strip or fan of k indices makes k - 2 triangles: 3k corners bound every mode.
            let k = match prim.indices() {
                Some(iacc) => {
                    let role = format!("indices of mesh {} primitive {}", inst.mesh, inst.prim);
                    self.accessor_range(&iacc, &role)?;
                    iacc.count() as u128
                }
                None => n,
            };
            total_corners += 3 * k;
        }
        let loaded = 24 * total_vertices + 4 * total_corners;
        let input = self.input_bytes + buffer_bytes;
        if total_vertices >= u32::MAX as u128
            || total_corners >= u32::MAX as u128
            || loaded > (256u128 << 20).max(64 * input)
        {
            return Err(self.err(format!(
                "the scene instances {total_vertices} vertices and {total_corners} corners ({loaded} bytes \
                 loaded from {input} bytes of input); refusing so large a mesh"
            )));
        }
        let mut positions: Vec<DVec3> = Vec::new();
        let mut face_ptr = vec![0u32];
        let mut indices: Vec<u32> = Vec::new();
        let mut spans: Vec<Span> = Vec::new();
        for inst in &instances {
            let prim = prim_of(inst);
            let role = format!("POSITION of mesh {} primitive {}", inst.mesh, inst.prim);
            let pacc = prim.get(&Semantic::Positions).expect("checked above");
            let local = self.positions(&pacc, &role)?;
            let n = local.len();
            let idx: Vec<u32> = match prim.indices() {
                Some(iacc) => {
                    let role = format!("indices of mesh {} primitive {}", inst.mesh, inst.prim);
                    let idx = self.indices(&iacc, &role)?;
                    if let Some((k, &v)) = idx.iter().enumerate().find(|(_, &v)| v as usize >= n) {
                        return Err(self.err(format!(
                            "mesh {} primitive {}: index {k} of accessor {} is {v}, out of range (POSITION \
                             accessor {} has {n} vertices)",
                            inst.mesh,
                            inst.prim,
                            iacc.index(),
                            pacc.index()
                        )));
                    }
                    idx
                }
                None => (0..n as u32).collect(),
            };
            let base = positions.len() as u32;
            for (v, p) in local.iter().enumerate() {
                let w = inst.world.transform_point3(*p);
                if !w.is_finite() {
                    return Err(self.err(format!(
                        "mesh {} primitive {}: vertex {v} has a non-finite position ({w}) (node {})",
                        inst.mesh, inst.prim, inst.node
                    )));
                }
                positions.push(w);
            }
            let mode = prim.mode();
            let mirrored = inst.world.determinant() < 0.0;
            spans.push(Span {
                first_face: face_ptr.len() - 1,
                mesh: inst.mesh,
                prim: inst.prim,
                node: inst.node,
                strip: mode != Mode::Triangles,
            });
            let mut push = |t: [u32; 3]| {
                let t = if mirrored { [t[0], t[2], t[1]] } else { t };
                indices.extend(t.iter().map(|&v| v + base));
                face_ptr.push(indices.len() as u32);
            };
            match mode {
                Mode::Triangles => {
                    if idx.len() % 3 != 0 {
                        return Err(self.err(format!(
                            "mesh {} primitive {}: {} indices is not a whole number of triangles",
                            inst.mesh,
                            inst.prim,
                            idx.len()
                        )));
                    }
                    for (t, c) in idx.chunks_exact(3).enumerate() {
                        if c[0] == c[1] || c[1] == c[2] || c[0] == c[2] {
                            return Err(self.err(format!(
                                "mesh {} primitive {}: triangle {t} names vertex {} twice",
                                inst.mesh,
                                inst.prim,
                                if c[0] == c[1] || c[0] == c[2] {
                                    c[0]
                                } else {
                                    c[1]
                                }
                            )));
                        }
                        push([c[0], c[1], c[2]]);
                    }
                }
                Mode::TriangleStrip => {
                    for i in 0..idx.len().saturating_sub(2) {
                        let t = if i % 2 == 0 {
                            [idx[i], idx[i + 1], idx[i + 2]]
                        } else {
                            [idx[i + 1], idx[i], idx[i + 2]]
                        };
                        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                            push(t);
                        }
                    }
                }
                _ => {
                    for i in 1..idx.len().saturating_sub(1) {
                        let t = [idx[i], idx[i + 1], idx[0]];
                        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                            push(t);
                        }
                    }
                }
            }
        }
        if face_ptr.len() == 1 {
            return Err(
                self.err("empty mesh: the scene's triangle primitives have no triangle".into())
            );
        }
        let mesh = Mesh {
            positions,
            face_ptr,
            indices,
        };
        let span_of = |f: usize| &spans[spans.partition_point(|s| s.first_face <= f) - 1];
        weld_exact(
            &mesh,
            self.path,
            |f| {
                let s = span_of(f);
                format!(
                    "mesh {} primitive {} (node {}): triangle {}",
                    s.mesh,
                    s.prim,
                    s.node,
                    f - s.first_face
                )
            },
            |f| span_of(f).strip,
        )
    }
}

/// `%XX` escapes of a URI path decoded (UTF-8); `None` for a malformed escape.
fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}
