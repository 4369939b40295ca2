//! `MeshNormalsPass`: area-weighted vertex normals of a (deforming) polygon mesh on the GPU as two gather
//! products of the mesh matrix: face normals `M_φᵀ·P` (glsl/face_normals.comp), then vertex normals `M_φ·N_f`
//! (glsl/vertex_normals.comp). No float atomics: deterministic, and equal to the CPU within f32 rounding.
//!
//! Invariants: the pass owns its pipelines; a [`GpuMeshMatrix`] owns the uploaded connectivity and the face
//! normal scratch buffer; positions (vec4 per vertex) and the output (vec4 per vertex) are the caller's. On
//! exit the output is visible to later compute, vertex shaders and transfers.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::compute_writes_to_readers;
use crate::gpu::{shaders, Buffer, Context, MemoryLocation};
use crate::mesh::MeshMatrix;
use ash::vk;

/// A mesh matrix uploaded for the normal kernels.
pub struct GpuMeshMatrix {
    pub vertices: u32,
    pub faces: u32,
    buffers: Vec<Buffer>, // face_ptr, corner_vertex, corner_face, vc_ptr, vc_corner, face normal scratch
}

impl GpuMeshMatrix {
    /// Uploads the connectivity of `m`.
    pub fn upload(ctx: &Context, m: &MeshMatrix) -> Result<Self> {
        if m.n_faces() == 0 {
            return Err(Error::Invalid("the mesh has no faces".into()));
        }
        let vc = m.vertex_corners();
        let arrays: [(&str, Vec<u32>); 5] = [
            ("face_ptr", m.face_ptr()),
            ("corner_vertex", m.corner_vertex().to_vec()),
            ("corner_face", m.corner_face().to_vec()),
            ("vc_ptr", vc.ptr.clone()),
            (
                "vc_corner",
                if vc.corner.is_empty() {
                    vec![0]
                } else {
                    vc.corner.clone()
                },
            ),
        ];
        let mut buffers = Vec::new();
        for (name, data) in arrays {
            buffers.push(ctx.upload_buffer(
                &format!("mesh {name}"),
                bytemuck::cast_slice(&data),
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?);
        }
        buffers.push(ctx.create_buffer(
            "mesh face normals",
            m.n_faces() as u64 * 16,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuOnly,
        )?);
        Ok(GpuMeshMatrix {
            vertices: m.n_verts() as u32,
            faces: m.n_faces() as u32,
            buffers,
        })
    }
}

/// Push constants of the face kernel (`Push` in glsl/face_normals.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct FacePush {
    faces: u32,
}

/// Push constants of the vertex kernel (`Push` in glsl/vertex_normals.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct VertexPush {
    vertices: u32,
}

/// The two-kernel normal pass.
pub struct MeshNormalsPass {
    faces: ComputePipeline,
    vertices: ComputePipeline,
}

impl MeshNormalsPass {
    /// Builds the pipelines.
    pub fn new(ctx: &Context) -> Result<Self> {
        let layout = |n: u32, name: &str| {
            let mut b = DescriptorSetLayoutBuilder::new();
            for i in 0..n {
                b = b.storage_buffer(i, vk::ShaderStageFlags::COMPUTE);
            }
            b.build(ctx, name)
        };
        let faces = ComputePipeline::new(
            ctx,
            "face normals",
            shaders::FACE_NORMALS_COMP,
            vec![layout(4, "face normals set")?],
            std::mem::size_of::<FacePush>() as u32,
            64,
        )?;
        let vertices = ComputePipeline::new(
            ctx,
            "vertex normals",
            shaders::VERTEX_NORMALS_COMP,
            vec![layout(5, "vertex normals set")?],
            std::mem::size_of::<VertexPush>() as u32,
            64,
        )?;
        Ok(MeshNormalsPass { faces, vertices })
    }

    /// Records area-weighted unit vertex normals of `positions` into `out`.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        m: &GpuMeshMatrix,
        positions: &Buffer,
        out: &Buffer,
    ) -> Result<()> {
        if (m.vertices as u64) * 16 > positions.size().min(out.size()) {
            return Err(Error::Invalid(format!(
                "{} vertices do not fit the position or normal buffer",
                m.vertices
            )));
        }
        let b = &m.buffers;
        let fnb = &b[5];
        self.faces.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(b[0].raw())),
                (1, Binding::Storage(b[1].raw())),
                (2, Binding::Storage(positions.raw())),
                (3, Binding::Storage(fnb.raw())),
            ],
            bytemuck::bytes_of(&FacePush { faces: m.faces }),
        );
        self.faces.dispatch_linear(ctx, cmd, m.faces as u64)?;
        compute_writes_to_readers(ctx, cmd);
        self.vertices.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(b[3].raw())),
                (1, Binding::Storage(b[4].raw())),
                (2, Binding::Storage(b[2].raw())),
                (3, Binding::Storage(fnb.raw())),
                (4, Binding::Storage(out.raw())),
            ],
            bytemuck::bytes_of(&VertexPush {
                vertices: m.vertices,
            }),
        );
        self.vertices.dispatch_linear(ctx, cmd, m.vertices as u64)?;
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }
}
