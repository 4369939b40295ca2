//! The mesh compute kernels in native code, threads across rows: glsl/face_normals.comp,
//! glsl/vertex_normals.comp and glsl/spmv.comp, for devices that are CPUs, where
//! [`crate::engine::mesh`] runs them on the buffers the Vulkan kernels would read and write
//! (docs/benchmarks.md, suite `mesh`, has why: on lavapipe the kernels' gathers and fixed costs leave them
//! slower than gregvox's own single-threaded CPU code).
//!
//! Invariants:
//! - Operation for operation the shaders' arithmetic, each output summed in the shader's order (the shaders
//!   forbid fused multiply-adds with `precise`; Rust never fuses): every thread count writes the same bits,
//!   and a Vulkan driver that does not fuse (lavapipe) writes the same bits as these kernels.
//! - Points are `vec4` (xyz, w): outputs are written whole, w = 0 for normals and 1 for S·x.
//! - The caller has checked the layout ([`NormalsLayout::check`], [`check_spmv`]): every index is in
//!   range, so a kernel never reads out of bounds (and never panics on the checked layout).
//! - Rows are split over rayon tasks of about [`ROWS_PER_TASK`] outputs: enough to hide a task's overhead,
//!   enough tasks to balance the cores.
use crate::error::{Error, Result};
use rayon::prelude::*;

/// Outputs per rayon task.
pub const ROWS_PER_TASK: usize = 4096;

/// The connectivity the normal kernels read: the five arrays `GpuMeshMatrix` uploads.
#[derive(Clone, Copy)]
pub struct NormalsLayout<'a> {
    /// Face f's corners are `face_ptr[f]..face_ptr[f + 1]`.
    pub face_ptr: &'a [u32],
    /// Corner → vertex.
    pub corner_vertex: &'a [u32],
    /// Corner → face.
    pub corner_face: &'a [u32],
    /// Vertex v's corners are `vc_corner[vc_ptr[v]..vc_ptr[v + 1]]`.
    pub vc_ptr: &'a [u32],
    /// Vertex → corner CSR columns.
    pub vc_corner: &'a [u32],
}

impl NormalsLayout<'_> {
    /// Faces.
    pub fn faces(&self) -> usize {
        self.face_ptr.len().saturating_sub(1)
    }

    /// Vertices.
    pub fn vertices(&self) -> usize {
        self.vc_ptr.len().saturating_sub(1)
    }

    /// Checks every index the kernels follow: monotone row pointers inside their arrays, corners naming
    /// existing vertices and faces.
    pub fn check(&self) -> Result<()> {
        let bad = |what: &str| Err(Error::Invalid(format!("mesh normal layout: {what}")));
        let (nf, nv, nc) = (self.faces(), self.vertices(), self.corner_vertex.len());
        if self.face_ptr.is_empty() || self.vc_ptr.is_empty() {
            return bad("empty row pointers");
        }
        // Strictly increasing: the face kernel reads each face's first corner.
        let increasing = self.face_ptr.windows(2).all(|w| w[0] < w[1]);
        if !increasing || !monotone(self.face_ptr, nc) {
            return bad("face pointers do not give every face a corner within the corners");
        }
        if !monotone(self.vc_ptr, self.vc_corner.len()) {
            return bad("vertex-corner pointers are not monotone within their columns");
        }
        if self.corner_face.len() != nc {
            return bad("corner → face and corner → vertex differ in length");
        }
        if self.corner_vertex.iter().any(|&v| v as usize >= nv) {
            return bad("a corner names a vertex past the vertices");
        }
        if self.corner_face.iter().any(|&f| f as usize >= nf) {
            return bad("a corner names a face past the faces");
        }
        if self.vc_corner.iter().any(|&c| c as usize >= nc) {
            return bad("a vertex names a corner past the corners");
        }
        Ok(())
    }
}

/// Each step non-decreasing and the last entry within `len`.
fn monotone(ptr: &[u32], len: usize) -> bool {
    ptr.windows(2).all(|w| w[0] <= w[1]) && ptr.last().is_some_and(|&e| e as usize <= len)
}

#[inline(always)]
fn sub3(a: [f32; 4], b: [f32; 4]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// GLSL's `cross`.
#[inline(always)]
fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - b[1] * a[2],
        a[2] * b[0] - b[2] * a[0],
        a[0] * b[1] - b[0] * a[1],
    ]
}

/// glsl/face_normals.comp: unnormalised face normals (the fan sum of corner cross products), w = 0.
/// `positions` and `out` hold at least the layout's vertices and faces (checked by the caller).
pub fn face_normals(l: &NormalsLayout, positions: &[[f32; 4]], out: &mut [[f32; 4]]) {
    par_rows(&mut out[..l.faces()], |f| {
        let (a, b) = (l.face_ptr[f] as usize, l.face_ptr[f + 1] as usize);
        let p0 = positions[l.corner_vertex[a] as usize];
        let mut n = [0.0f32; 3];
        for c in a + 1..b.saturating_sub(1) {
            let t = cross(
                sub3(positions[l.corner_vertex[c] as usize], p0),
                sub3(positions[l.corner_vertex[c + 1] as usize], p0),
            );
            n = [n[0] + t[0], n[1] + t[1], n[2] + t[2]];
        }
        [n[0], n[1], n[2], 0.0]
    });
}

/// glsl/vertex_normals.comp: each vertex's face normals summed in corner order and normalised as GLSL's
/// `acc / length(acc)`; (0, 0, 0) where the sum has zero length (no faces, or cancelling ones).
pub fn vertex_normals(l: &NormalsLayout, face_normals: &[[f32; 4]], out: &mut [[f32; 4]]) {
    par_rows(&mut out[..l.vertices()], |v| {
        let mut acc = [0.0f32; 3];
        for &c in &l.vc_corner[l.vc_ptr[v] as usize..l.vc_ptr[v + 1] as usize] {
            let n = face_normals[l.corner_face[c as usize] as usize];
            acc = [acc[0] + n[0], acc[1] + n[1], acc[2] + n[2]];
        }
        let len = ((acc[0] * acc[0] + acc[1] * acc[1]) + acc[2] * acc[2]).sqrt();
        if len > 0.0 {
            [acc[0] / len, acc[1] / len, acc[2] / len, 0.0]
        } else {
            [0.0; 4]
        }
    });
}

/// Checks a CSR matrix for [`spmv`]: `row_ptr` monotone within the entries, one value per column index,
/// every column below `cols`.
pub fn check_spmv(row_ptr: &[u32], col: &[u32], val: &[f32], cols: usize) -> Result<()> {
    let bad = |what: &str| Err(Error::Invalid(format!("sparse matrix: {what}")));
    if row_ptr.is_empty() || !monotone(row_ptr, col.len()) {
        return bad("row pointers are not monotone within the entries");
    }
    if col.len() != val.len() {
        return bad("column and value arrays differ in length");
    }
    if col.iter().any(|&c| c as usize >= cols) {
        return bad("a column index is past the columns");
    }
    Ok(())
}

/// glsl/spmv.comp: `y[r] = (Σ_k x[col_k].xyz · val_k, 1)` summed in row order, for every row of the
/// checked CSR matrix (`y` holds at least its rows, `x` its columns).
pub fn spmv(row_ptr: &[u32], col: &[u32], val: &[f32], x: &[[f32; 4]], y: &mut [[f32; 4]]) {
    par_rows(&mut y[..row_ptr.len() - 1], |r| {
        let (a, b) = (row_ptr[r] as usize, row_ptr[r + 1] as usize);
        let mut acc = [0.0f32; 3];
        for (&c, &w) in col[a..b].iter().zip(&val[a..b]) {
            let p = x[c as usize];
            acc = [acc[0] + p[0] * w, acc[1] + p[1] * w, acc[2] + p[2] * w];
        }
        [acc[0], acc[1], acc[2], 1.0]
    });
}

/// `out[r] = row(r)` for every r, in rayon tasks of [`ROWS_PER_TASK`] rows.
#[inline]
fn par_rows(out: &mut [[f32; 4]], row: impl Fn(usize) -> [f32; 4] + Sync) {
    out.par_chunks_mut(ROWS_PER_TASK)
        .enumerate()
        .for_each(|(task, chunk)| {
            let first = task * ROWS_PER_TASK;
            for (k, o) in chunk.iter_mut().enumerate() {
                *o = row(first + k);
            }
        });
}

/// Points as the kernels read them: `vec4` (xyz rounded to f32, w = 1).
pub fn to_vec4(points: &[glam::DVec3]) -> Vec<[f32; 4]> {
    points
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32, 1.0])
        .collect()
}

/// Arithmetic and memory traffic of one kernel run, counted from the kernels' code (the shaders' and these
/// functions': each add, subtract, multiply, divide and square root 1 flop; every index, point and output
/// element loaded or stored once, caches ignored).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KernelCounts {
    pub flops: u64,
    pub bytes: u64,
}

impl NormalsLayout<'_> {
    /// Both normal kernels on this layout. Face pass, per fan triangle of a face: two differences (6), a
    /// cross product (6 multiplies, 3 subtracts), the sum (3); per face: 2 pointers, per corner an index
    /// and a vec4 point, one vec4 written. Vertex pass, per corner of a vertex: 3 adds, a corner and a face
    /// index and a vec4 normal read; per vertex: `length` (3 multiplies, 2 adds, 1 square root), 3 divides,
    /// 2 pointers read and a vec4 written.
    pub fn counts(&self) -> KernelCounts {
        let (nf, nv) = (self.faces() as u64, self.vertices() as u64);
        let corners = self.corner_vertex.len() as u64;
        let fan: u64 = self
            .face_ptr
            .windows(2)
            .map(|w| (w[1] - w[0]).saturating_sub(2) as u64)
            .sum();
        let refs = self.vc_corner.len() as u64;
        KernelCounts {
            flops: 18 * fan + 3 * refs + 9 * nv,
            bytes: (8 + 16) * nf + 20 * corners + 24 * refs + (8 + 16) * nv,
        }
    }
}

/// [`spmv`] on a matrix of `rows` rows and `nnz` entries: per entry a multiply and an add per coordinate (6)
/// and a column, a value and a vec4 point read; per row 2 pointers read and a vec4 written.
pub fn spmv_counts(rows: u64, nnz: u64) -> KernelCounts {
    KernelCounts {
        flops: 6 * nnz,
        bytes: (4 + 4 + 16) * nnz + (8 + 16) * rows,
    }
}
