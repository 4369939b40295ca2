//! Mesh kernels on a device: AREA vertex normals of a deforming mesh ([`DeviceNormals`]) and a sparse
//! product y = S·x such as one subdivision level of a deforming cage ([`DeviceSpmv`]), each on the evaluator
//! [`Evaluator::for_device`] picks: the Vulkan passes ([`crate::passes::mesh_normals`],
//! [`crate::passes::spmv`]) or, on devices that are CPUs, their host twins
//! ([`crate::mesh::host_kernels`]) reading and writing the same buffers through their mappings.
//!
//! Invariants:
//! - Point buffers are the caller's, `vec4` per point (normals: w = 0; S·x: w = 1). For
//!   [`Evaluator::Host`] they must be mappable: [`point_buffer`] makes them in the evaluator's memory.
//! - The connectivity and the matrix are checked when the object is made (every index in range), so an
//!   evaluation never reads out of bounds; sizes of the caller's buffers are checked on every call.
//! - [`DeviceNormals::evaluate`] and [`DeviceSpmv::evaluate`] return with the outputs written: the Vulkan
//!   path submits and waits; the host path runs on the host after the caller's earlier submissions (which
//!   the caller has waited for, as `Context::one_shot` does), and host-coherent memory makes its writes
//!   visible to the next submission.
//! - Both evaluators give the same values: the same operations in the same order (tests/mesh_host.rs).
use super::evaluator::Evaluator;
use crate::error::{Error, Result};
use crate::gpu::{Buffer, Context};
use crate::mesh::host_kernels::{self, KernelCounts, NormalsLayout};
use crate::mesh::{MeshMatrix, SparseMatrix};
use crate::passes::mesh_normals::{GpuMeshMatrix, MeshNormalsPass};
use crate::passes::spmv::{GpuSparse, SpmvPass};
use ash::vk;

/// A buffer of `points` vec4 points that `evaluator`'s kernels can read and write (mapped for the host
/// kernels), filled with `data` when given (else zeros), usable for storage and transfers.
pub fn point_buffer(
    ctx: &Context,
    name: &str,
    evaluator: Evaluator,
    points: usize,
    data: Option<&[[f32; 4]]>,
) -> Result<Buffer> {
    use vk::BufferUsageFlags as U;
    let buf = ctx.create_buffer(
        name,
        points as u64 * 16,
        U::STORAGE_BUFFER | U::TRANSFER_SRC | U::TRANSFER_DST,
        evaluator.write_location(),
    )?;
    if let Some(d) = data {
        ctx.write_buffer(&buf, 0, bytemuck::cast_slice(d))?;
    }
    Ok(buf)
}

fn host_only(what: &str) -> Error {
    Error::Invalid(format!(
        "{what}: the host evaluator runs now, not in a command buffer (use evaluate)"
    ))
}

fn points<'a>(buf: &'a Buffer, what: &str) -> Result<&'a [[f32; 4]]> {
    bytemuck::try_cast_slice(buf.mapped()?)
        .map_err(|e| Error::Invalid(format!("{what} buffer '{}': {e}", buf.name())))
}

fn points_mut<'a>(buf: &'a mut Buffer, what: &str) -> Result<&'a mut [[f32; 4]]> {
    let name = buf.name().to_string();
    bytemuck::try_cast_slice_mut(buf.mapped_mut()?)
        .map_err(|e| Error::Invalid(format!("{what} buffer '{name}': {e}")))
}

fn check_points(buf: &Buffer, what: &str, points: u64) -> Result<()> {
    if buf.size() < points * 16 {
        return Err(Error::Invalid(format!(
            "{what} buffer '{}' holds {} B; {points} points need {} B",
            buf.name(),
            buf.size(),
            points * 16
        )));
    }
    Ok(())
}

/// The host copy of the connectivity (the arrays [`GpuMeshMatrix`] uploads) and the face-normal scratch.
struct HostNormals {
    face_ptr: Vec<u32>,
    corner_vertex: Vec<u32>,
    corner_face: Vec<u32>,
    vc_ptr: Vec<u32>,
    vc_corner: Vec<u32>,
    face_normals: Vec<[f32; 4]>,
}

impl HostNormals {
    /// The layout and the scratch, borrowed apart.
    fn split(&mut self) -> (NormalsLayout<'_>, &mut [[f32; 4]]) {
        (
            NormalsLayout {
                face_ptr: &self.face_ptr,
                corner_vertex: &self.corner_vertex,
                corner_face: &self.corner_face,
                vc_ptr: &self.vc_ptr,
                vc_corner: &self.vc_corner,
            },
            &mut self.face_normals,
        )
    }
}

enum NormalsImpl {
    Vulkan {
        pass: MeshNormalsPass,
        matrix: GpuMeshMatrix,
    },
    Host(HostNormals),
}

/// AREA-weighted unit vertex normals of a mesh whose positions change (see the module invariants).
pub struct DeviceNormals {
    vertices: u32,
    faces: u32,
    counts: KernelCounts,
    imp: NormalsImpl,
}

impl DeviceNormals {
    /// Prepares the connectivity of `m` for `evaluator`.
    pub fn new(ctx: &Context, m: &MeshMatrix, evaluator: Evaluator) -> Result<Self> {
        if m.n_faces() == 0 {
            return Err(Error::Invalid("the mesh has no faces".into()));
        }
        let face_ptr = m.face_ptr();
        let counts = NormalsLayout {
            face_ptr: &face_ptr,
            corner_vertex: m.corner_vertex(),
            corner_face: m.corner_face(),
            vc_ptr: &m.vertex_corners().ptr,
            vc_corner: &m.vertex_corners().corner,
        }
        .counts();
        let imp = match evaluator {
            Evaluator::Vulkan => NormalsImpl::Vulkan {
                pass: MeshNormalsPass::new(ctx)?,
                matrix: GpuMeshMatrix::upload(ctx, m)?,
            },
            Evaluator::Host => {
                let mut host = HostNormals {
                    face_ptr,
                    corner_vertex: m.corner_vertex().to_vec(),
                    corner_face: m.corner_face().to_vec(),
                    vc_ptr: m.vertex_corners().ptr.clone(),
                    vc_corner: m.vertex_corners().corner.clone(),
                    face_normals: vec![[0.0; 4]; m.n_faces()],
                };
                host.split().0.check()?;
                NormalsImpl::Host(host)
            }
        };
        Ok(DeviceNormals {
            vertices: m.n_verts() as u32,
            faces: m.n_faces() as u32,
            counts,
            imp,
        })
    }

    /// The flops and bytes of one evaluation, counted from the kernels' code
    /// ([`NormalsLayout::counts`]).
    pub fn counts(&self) -> KernelCounts {
        self.counts
    }

    /// The evaluator this object runs on.
    pub fn evaluator(&self) -> Evaluator {
        match self.imp {
            NormalsImpl::Vulkan { .. } => Evaluator::Vulkan,
            NormalsImpl::Host(_) => Evaluator::Host,
        }
    }

    /// Vertices of the mesh.
    pub fn vertices(&self) -> u32 {
        self.vertices
    }

    /// Faces of the mesh.
    pub fn faces(&self) -> u32 {
        self.faces
    }

    /// Records the Vulkan kernels into `cmd` (for a caller's own submission or timestamps); an error for
    /// [`Evaluator::Host`], which runs at [`DeviceNormals::evaluate`].
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        positions: &Buffer,
        out: &Buffer,
    ) -> Result<()> {
        check_points(positions, "positions", self.vertices as u64)?;
        check_points(out, "normals", self.vertices as u64)?;
        match &self.imp {
            NormalsImpl::Vulkan { pass, matrix } => pass.record(ctx, cmd, matrix, positions, out),
            NormalsImpl::Host(_) => Err(host_only("vertex normals")),
        }
    }

    /// Writes the unit normal of every vertex of `positions` into `out` (both `vec4` per vertex; vertices
    /// with no face, or a zero normal sum, get 0).
    pub fn evaluate(&mut self, ctx: &Context, positions: &Buffer, out: &mut Buffer) -> Result<()> {
        let NormalsImpl::Host(host) = &mut self.imp else {
            return ctx.one_shot(|cmd| self.record(ctx, cmd, positions, out));
        };
        check_points(positions, "positions", self.vertices as u64)?;
        check_points(out, "normals", self.vertices as u64)?;
        let p = points(positions, "positions")?;
        let o = points_mut(out, "normals")?;
        let (l, face_normals) = host.split();
        host_kernels::face_normals(&l, p, face_normals);
        host_kernels::vertex_normals(&l, face_normals, o);
        Ok(())
    }
}

enum SpmvImpl {
    // Boxed: a pass and three buffers are much larger than the host arrays' three vectors.
    Vulkan(Box<(SpmvPass, GpuSparse)>),
    Host {
        row_ptr: Vec<u32>,
        col: Vec<u32>,
        val: Vec<f32>,
    },
}

/// y = S·x for a fixed sparse matrix S and changing points x (see the module invariants).
pub struct DeviceSpmv {
    rows: u32,
    cols: u32,
    nnz: u64,
    imp: SpmvImpl,
}

impl DeviceSpmv {
    /// Prepares `s` (values rounded to f32) for `evaluator`.
    pub fn new(ctx: &Context, s: &SparseMatrix<f64>, evaluator: Evaluator) -> Result<Self> {
        let val: Vec<f32> = s.val.iter().map(|&v| v as f32).collect();
        // The Vulkan upload trusts the CSR arrays as the kernel does; check them once for both evaluators.
        host_kernels::check_spmv(&s.row_ptr, &s.col, &val, s.n_cols as usize)?;
        if s.row_ptr.len() != s.n_rows as usize + 1 {
            return Err(Error::Invalid(format!(
                "sparse matrix: {} row pointers for {} rows",
                s.row_ptr.len(),
                s.n_rows
            )));
        }
        let imp = match evaluator {
            Evaluator::Vulkan => SpmvImpl::Vulkan(Box::new((
                SpmvPass::new(ctx)?,
                GpuSparse::upload(ctx, "S", s)?,
            ))),
            Evaluator::Host => SpmvImpl::Host {
                row_ptr: s.row_ptr.clone(),
                col: s.col.clone(),
                val,
            },
        };
        Ok(DeviceSpmv {
            rows: s.n_rows,
            cols: s.n_cols,
            nnz: s.col.len() as u64,
            imp,
        })
    }

    /// The evaluator this object runs on.
    pub fn evaluator(&self) -> Evaluator {
        match self.imp {
            SpmvImpl::Vulkan(_) => Evaluator::Vulkan,
            SpmvImpl::Host { .. } => Evaluator::Host,
        }
    }

    /// The flops and bytes of one evaluation, counted from the kernel's code
    /// ([`host_kernels::spmv_counts`]).
    pub fn counts(&self) -> KernelCounts {
        host_kernels::spmv_counts(self.rows as u64, self.nnz)
    }

    /// Rows of S (points of y).
    pub fn rows(&self) -> u32 {
        self.rows
    }

    /// Columns of S (points of x).
    pub fn cols(&self) -> u32 {
        self.cols
    }

    /// Records the Vulkan kernel into `cmd`; an error for [`Evaluator::Host`], which runs at
    /// [`DeviceSpmv::evaluate`].
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        x: &Buffer,
        y: &Buffer,
    ) -> Result<()> {
        check_points(x, "x", self.cols as u64)?;
        check_points(y, "y", self.rows as u64)?;
        match &self.imp {
            SpmvImpl::Vulkan(v) => v.0.record(ctx, cmd, &v.1, x, y),
            SpmvImpl::Host { .. } => Err(host_only("S·x")),
        }
    }

    /// Writes y = S·x (`vec4` points, y's w = 1).
    pub fn evaluate(&self, ctx: &Context, x: &Buffer, y: &mut Buffer) -> Result<()> {
        let SpmvImpl::Host { row_ptr, col, val } = &self.imp else {
            return ctx.one_shot(|cmd| self.record(ctx, cmd, x, y));
        };
        check_points(x, "x", self.cols as u64)?;
        check_points(y, "y", self.rows as u64)?;
        host_kernels::spmv(row_ptr, col, val, points(x, "x")?, points_mut(y, "y")?);
        Ok(())
    }
}
