//! `AbufferPass`: solid voxelization from one fragment list per column (glsl/abuffer_scan.comp,
//! abuffer_scatter.frag, abuffer_fill.comp), the §6 alternative to peeling that never drops an equal-depth
//! fragment. The count pre-pass is the peel pass's (`PeelPass::record_count`); this pass adds:
//! - `record_scan`: exclusive prefix sum of the R² column counts (+1 trailing slot = the total Φ) in a
//!   multi-level layout ([`scan_levels`]): level l is scanned in 1,024-element blocks whose totals form level
//!   l+1, up to a single block, then the block offsets are added back down. Every dispatch goes through
//!   `dispatch_linear` (2D beyond 65,535 groups); R² = 2048² is 4,097 blocks at level 0.
//! - `record_scatter`: one geometry pass with no attachments; each fragment stores ±(z+1) at
//!   `offset[col] + atomicAdd(cursor[col], 1)`.
//! - `record_fill`: per column, insertion sort then the winding (or parity) fill of `voxel_fill.comp`, for a
//!   slab of columns written from word 0 of `out`.
//!
//! Invariants: the pass owns its three pipelines; every buffer is the caller's. No image is used. The caller
//! places the barriers between the count copy, scan, scatter and fill (each `record_*` ends with its own
//! writes made visible to the next stage it documents). `cursor` must be zero before the scatter.
use crate::error::Result;
use crate::gpu::pipeline::{
    Binding, ComputePipeline, DescriptorSetLayoutBuilder, GraphicsDesc, GraphicsPipeline,
};
use crate::gpu::resources::memory_barrier;
use crate::gpu::{shaders, Buffer, Context};
use crate::passes::peel::{PeelGeometry, PeelPush};
use crate::voxel::cpu::FillRule;
use ash::vk;

/// Elements per scan block (abuffer_scan.comp: 64 invocations × [`SCAN_PER_INVOCATION`]).
pub const SCAN_BLOCK: u64 = 1024;

/// Consecutive elements each scan invocation handles serially.
pub const SCAN_PER_INVOCATION: u64 = 16;

/// The levels of a multi-level exclusive scan of `n` elements: (first word, length) of each level, level 0
/// first, the last of length 1 (the grand total of the level below).
///
/// ```
/// use gregvox::passes::abuffer::scan_levels;
/// assert_eq!(scan_levels(10), vec![(0, 10), (10, 1)]);
/// assert_eq!(scan_levels(2048 * 2048 + 1), vec![(0, 4194305), (4194305, 4097), (4198402, 5), (4198407, 1)]);
/// ```
pub fn scan_levels(n: u64) -> Vec<(u64, u64)> {
    let mut levels = vec![(0, n)];
    let mut len = n;
    let mut at = n;
    loop {
        len = len.div_ceil(SCAN_BLOCK);
        levels.push((at, len));
        at += len;
        if len <= 1 {
            return levels;
        }
    }
}

/// Words of a scan buffer for `n` elements (all levels).
pub fn scan_words(n: u64) -> u64 {
    let l = scan_levels(n);
    let (at, len) = l[l.len() - 1];
    at + len
}

/// What to fill (a slab of columns).
#[derive(Clone, Copy, Debug)]
pub struct AbufferFillJob {
    pub columns: crate::passes::peel::ColumnFrame,
    pub rule: FillRule,
    pub first_column: u32,
    pub column_count: u32,
}

/// Push constants of the scan (`Push` in glsl/abuffer_scan.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct ScanPush {
    /// First word of this level.
    data: u32,
    /// Elements in this level.
    n: u32,
    /// First word of the next level (block totals).
    sums: u32,
    /// 0: scan blocks, 1: add block offsets.
    mode: u32,
}

/// Push constants of the fill (`Push` in glsl/abuffer_fill.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct FillPush {
    /// Columns per row (voxels along u).
    width: u32,
    /// ceil(depth/32).
    words: u32,
    /// 0: winding, 1: parity.
    rule: u32,
    /// First column (v·width + u) of this slab.
    first_column: u32,
    /// Columns in this slab.
    column_count: u32,
    /// Voxels along the peel axis.
    depth: u32,
    /// Depth range start and length (grid units), as the peel shaders map it.
    depth_lo: f32,
    depth_span: f32,
}

/// The A-buffer passes.
pub struct AbufferPass {
    scan: ComputePipeline,
    scatter: GraphicsPipeline,
    fill: ComputePipeline,
}

fn compute_to_compute() -> (
    (vk::PipelineStageFlags2, vk::AccessFlags2),
    (vk::PipelineStageFlags2, vk::AccessFlags2),
) {
    (
        (
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
        ),
        (
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
        ),
    )
}

impl AbufferPass {
    /// Builds the pipelines (vertices of `stride` bytes, positions first, as the peel pass).
    pub fn new(ctx: &Context, stride: u32) -> Result<Self> {
        let scan_layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "abuffer scan set")?;
        let scan = ComputePipeline::new(
            ctx,
            "abuffer scan",
            shaders::ABUFFER_SCAN_COMP,
            vec![scan_layout],
            std::mem::size_of::<ScanPush>() as u32,
            (SCAN_BLOCK / SCAN_PER_INVOCATION) as u32,
        )?;
        let scatter = Self::scatter_pipeline(ctx, stride)?;
        let fill_layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(1, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(2, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "abuffer fill set")?;
        let fill = ComputePipeline::new(
            ctx,
            "abuffer fill",
            shaders::ABUFFER_FILL_COMP,
            vec![fill_layout],
            std::mem::size_of::<FillPush>() as u32,
            64,
        )?;
        Ok(AbufferPass {
            scan,
            scatter,
            fill,
        })
    }

    fn scatter_pipeline(ctx: &Context, stride: u32) -> Result<GraphicsPipeline> {
        let layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::FRAGMENT)
            .storage_buffer(1, vk::ShaderStageFlags::FRAGMENT)
            .storage_buffer(2, vk::ShaderStageFlags::FRAGMENT)
            .build(ctx, "abuffer scatter set")?;
        let mut d = GraphicsDesc::new(
            shaders::PEEL_VERT,
            shaders::ABUFFER_SCATTER_FRAG,
            vk::Format::UNDEFINED,
            vk::Format::UNDEFINED,
        );
        // The same vertex input and raster state as the peel count pre-pass: the fragment counts must agree.
        d.vertex_bindings = vec![vk::VertexInputBindingDescription {
            binding: 0,
            stride,
            input_rate: vk::VertexInputRate::VERTEX,
        }];
        d.vertex_attributes = vec![vk::VertexInputAttributeDescription {
            location: 0,
            binding: 0,
            format: vk::Format::R32G32B32_SFLOAT,
            offset: 0,
        }];
        d.push_constant_bytes = std::mem::size_of::<PeelPush>() as u32;
        d.push_constant_stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        d.cull_mode = vk::CullModeFlags::NONE;
        d.front_face = vk::FrontFace::COUNTER_CLOCKWISE;
        d.set_layouts = vec![layout];
        GraphicsPipeline::new(ctx, "abuffer scatter", d)
    }

    /// Records the exclusive scan of the `n` elements at word 0 of `scan` (sized [`scan_words`]`(n)`); on
    /// exit the scanned level 0 is visible to fragment and compute shaders and to transfers.
    pub fn record_scan(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        scan: &Buffer,
        n: u64,
    ) -> Result<()> {
        let levels = scan_levels(n);
        let (src, dst) = compute_to_compute();
        let push = |data: u64, len: u64, sums: u64, mode: u32| ScanPush {
            data: data as u32,
            n: len as u32,
            sums: sums as u32,
            mode,
        };
        // Up: scan every level but the last (a single total).
        for l in 0..levels.len() - 1 {
            let (data, len) = levels[l];
            self.scan.bind(
                ctx,
                cmd,
                &[(0, Binding::Storage(scan.raw()))],
                bytemuck::bytes_of(&push(data, len, levels[l + 1].0, 0)),
            );
            self.scan
                .dispatch_linear(ctx, cmd, len.div_ceil(SCAN_PER_INVOCATION))?;
            memory_barrier(ctx, cmd, src, dst);
        }
        // Down: add each scanned level's offsets to the blocks of the level below.
        for l in (0..levels.len().saturating_sub(2)).rev() {
            let (data, len) = levels[l];
            self.scan.bind(
                ctx,
                cmd,
                &[(0, Binding::Storage(scan.raw()))],
                bytemuck::bytes_of(&push(data, len, levels[l + 1].0, 1)),
            );
            self.scan
                .dispatch_linear(ctx, cmd, len.div_ceil(SCAN_PER_INVOCATION))?;
            memory_barrier(ctx, cmd, src, dst);
        }
        memory_barrier(
            ctx,
            cmd,
            src,
            (
                vk::PipelineStageFlags2::FRAGMENT_SHADER
                    | vk::PipelineStageFlags2::COMPUTE_SHADER
                    | vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::TRANSFER_READ,
            ),
        );
        Ok(())
    }

    /// Records the scatter pass (offsets = scanned level 0 of `scan`; `cursor` zeroed, one word per column; `frags` Φ
    /// floats). On exit the fragments are visible to compute shaders.
    #[allow(clippy::too_many_arguments)]
    pub fn record_scatter(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        geom: &PeelGeometry,
        push: &PeelPush,
        scan: &Buffer,
        cursor: &Buffer,
        frags: &Buffer,
    ) {
        let extent = push.framebuffer();
        let info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D {
                offset: vk::Offset2D::default(),
                extent,
            })
            .layer_count(1);
        ctx.cmd_begin_rendering(cmd, &info);
        self.scatter.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(scan.raw())),
                (1, Binding::Storage(cursor.raw())),
                (2, Binding::Storage(frags.raw())),
            ],
            bytemuck::bytes_of(push),
            extent,
        );
        // SAFETY: recording inside dynamic rendering with the pipeline bound.
        unsafe {
            ctx.device
                .cmd_bind_vertex_buffers(cmd, 0, &[geom.vertices.raw()], &[0]);
            ctx.device
                .cmd_bind_index_buffer(cmd, geom.indices.raw(), 0, vk::IndexType::UINT32);
            ctx.device
                .cmd_draw_indexed(cmd, geom.index_count, 1, 0, 0, 0);
        }
        ctx.cmd_end_rendering(cmd);
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
    }

    /// Records the sort + fill of `job`'s columns into `out` (from word 0). On exit the bits are visible to
    /// transfers.
    pub fn record_fill(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        scan: &Buffer,
        frags: &Buffer,
        out: &Buffer,
        job: &AbufferFillJob,
    ) -> Result<()> {
        let words = job.columns.words();
        if job.column_count as u64 * words as u64 * 4 > out.size() {
            return Err(crate::Error::Invalid(format!(
                "voxel slab does not fit buffer '{}'",
                out.name()
            )));
        }
        let push = FillPush {
            width: job.columns.width,
            words,
            rule: match job.rule {
                FillRule::Winding | FillRule::Gwn => 0,
                FillRule::Parity => 1,
                FillRule::Positive | FillRule::GwnPositive => 2,
            },
            first_column: job.first_column,
            column_count: job.column_count,
            depth: job.columns.depth,
            depth_lo: job.columns.depth_lo,
            depth_span: job.columns.depth_span,
        };
        self.fill.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(scan.raw())),
                (1, Binding::Storage(frags.raw())),
                (2, Binding::Storage(out.raw())),
            ],
            bytemuck::bytes_of(&push),
        );
        self.fill
            .dispatch_linear(ctx, cmd, job.column_count as u64)?;
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_READ,
            ),
        );
        Ok(())
    }
}
