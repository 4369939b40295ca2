//! `SpmvPass`: y = A·x for a CSR matrix on the GPU (glsl/spmv.comp), one invocation per row, a gather in
//! row order (no atomics, deterministic, equal to `SparseMatrix::spmv_f32` bit for bit: the shader forbids
//! fused multiply-adds with `precise`).
//!
//! Invariants: the pass owns only its pipeline. A [`GpuSparse`] owns the three CSR buffers of one matrix;
//! point buffers `x` and `y` are the caller's, `vec4` per point (w ignored on input, 1 on output). On exit
//! `y`'s writes are visible to later compute and vertex-shader reads and to transfers.
//!
//! The affine-split variant ([`SpmvPass::new_affine_split`], glsl/gregory_points.comp) is for matrices whose
//! rows sum to 1 (Gregory stencils): it sums relative to each row's first column and writes `y` as hi + lo
//! (hi in rows `0..rows`, the exact residual lo in rows `rows..2·rows`, w = 0), so `y` needs 2·rows points.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::compute_writes_to_readers;
use crate::gpu::{shaders, Buffer, Context};
use crate::mesh::SparseMatrix;
use ash::vk;

/// A CSR matrix in device-local buffers.
pub struct GpuSparse {
    pub rows: u32,
    pub cols: u32,
    pub row_ptr: Buffer,
    pub col: Buffer,
    pub val: Buffer,
}

impl GpuSparse {
    /// Uploads `m` (values converted to f32).
    pub fn upload(ctx: &Context, name: &str, m: &SparseMatrix<f64>) -> Result<Self> {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let vals: Vec<f32> = m.val.iter().map(|&v| v as f32).collect();
        // A matrix with no entries still needs non-empty buffers.
        let col: Vec<u32> = if m.col.is_empty() {
            vec![0]
        } else {
            m.col.clone()
        };
        let vals = if vals.is_empty() { vec![0.0] } else { vals };
        let row_ptr = ctx.upload_buffer(
            &format!("{name} row_ptr"),
            bytemuck::cast_slice(&m.row_ptr),
            usage,
        )?;
        let col = ctx.upload_buffer(&format!("{name} col"), bytemuck::cast_slice(&col), usage)?;
        let val = ctx.upload_buffer(&format!("{name} val"), bytemuck::cast_slice(&vals), usage)?;
        Ok(GpuSparse {
            rows: m.n_rows,
            cols: m.n_cols,
            row_ptr,
            col,
            val,
        })
    }
}

/// Push constants of both variants (`Push` in glsl/spmv.comp and glsl/gregory_points.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    rows: u32,
}

/// The SpMV compute pass.
pub struct SpmvPass {
    pipeline: ComputePipeline,
    affine_split: bool,
}

impl SpmvPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        Self::build(ctx, false)
    }

    /// Builds the affine-split pipeline (see the module comment): y = A·x as hi + lo, for rows summing to 1.
    pub fn new_affine_split(ctx: &Context) -> Result<Self> {
        Self::build(ctx, true)
    }

    fn build(ctx: &Context, affine_split: bool) -> Result<Self> {
        let mut b = DescriptorSetLayoutBuilder::new();
        for i in 0..5 {
            b = b.storage_buffer(i, vk::ShaderStageFlags::COMPUTE);
        }
        let layout = b.build(ctx, "spmv set")?;
        let (name, spirv) = if affine_split {
            ("gregory points", shaders::GREGORY_POINTS_COMP)
        } else {
            ("spmv", shaders::SPMV_COMP)
        };
        Ok(SpmvPass {
            pipeline: ComputePipeline::new(
                ctx,
                name,
                spirv,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                64,
            )?,
            affine_split,
        })
    }

    /// Records y = A·x.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        a: &GpuSparse,
        x: &Buffer,
        y: &Buffer,
    ) -> Result<()> {
        let y_points = a.rows as u64 * if self.affine_split { 2 } else { 1 };
        if (a.cols as u64) * 16 > x.size() || y_points * 16 > y.size() {
            return Err(Error::Invalid(format!(
                "spmv: {}×{} matrix does not fit x '{}' ({} B) or y '{}' ({} B)",
                a.rows,
                a.cols,
                x.name(),
                x.size(),
                y.name(),
                y.size()
            )));
        }
        let bindings = [
            (0, Binding::Storage(a.row_ptr.raw())),
            (1, Binding::Storage(a.col.raw())),
            (2, Binding::Storage(a.val.raw())),
            (3, Binding::Storage(x.raw())),
            (4, Binding::Storage(y.raw())),
        ];
        self.pipeline.bind(
            ctx,
            cmd,
            &bindings,
            bytemuck::bytes_of(&Push { rows: a.rows }),
        );
        self.pipeline.dispatch_linear(ctx, cmd, a.rows as u64)?;
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }
}
