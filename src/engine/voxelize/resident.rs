//! [`ResidentVoxelizer`]: depth peeling whose grid never leaves the GPU (the demo's live voxels).
use super::peel::PeelImages;
use super::*;
use crate::gpu::resources::memory_barrier;
use crate::passes::voxel_fill::FillJob;
use crate::voxel::cpu::FillRule;

/// A depth-peeling voxelizer whose output never leaves the GPU: built once for a fixed grid frame, peel axis z
/// and a fixed number of peeling passes, it records peel + fill into the caller's command buffer (every
/// frame, say) and leaves the bit grid (bit axis z) in a device-local buffer.
///
/// Why a fixed layer count: the one-shot voxelizers read the deepest column's crossing count back before
/// peeling; a per-frame path cannot wait for that. Layers past a column's last crossing are cleared to 0 and
/// the fill stops at the first 0, so peeling more layers than needed gives the same grid bit for bit; peeling
/// fewer would drop crossings, so the caller chooses `layers` from counts measured up front
/// ([`PeelVoxelizer::count_layers`]).
pub struct ResidentVoxelizer {
    peel: PeelVoxelizer,
    pub frame: GridFrame,
    pub layers: u32,
    pub rule: FillRule,
    images: PeelImages,
    grid: Buffer,
}

impl ResidentVoxelizer {
    /// Builds the passes (vertices of `stride` bytes, positions first) and the resources for `frame`.
    pub fn new(
        ctx: &Context,
        stride: u32,
        frame: GridFrame,
        layers: u32,
        rule: FillRule,
    ) -> Result<Self> {
        frame.validate()?;
        check_framebuffer(ctx, &frame, Axis::Z)?;
        let bytes = VoxelGrid::bytes_for(&frame, Axis::Z);
        if bytes > ctx.limits.max_storage_buffer_range as u64 {
            let [x, y, z] = frame.dims;
            return Err(Error::Limit {
                what: format!("a resident {x}×{y}×{z} grid ({bytes} bytes)"),
                detail: format!(
                    "one storage binding holds at most {} bytes",
                    ctx.limits.max_storage_buffer_range
                ),
            });
        }
        if layers == 0 || layers > ctx.limits.max_image_array_layers {
            return Err(Error::Limit {
                what: format!("{layers} peeling passes"),
                detail: format!(
                    "between 1 and maxImageArrayLayers ({})",
                    ctx.limits.max_image_array_layers
                ),
            });
        }
        Ok(ResidentVoxelizer {
            peel: PeelVoxelizer::new(ctx, stride)?,
            frame,
            layers,
            rule,
            images: PeelImages::new(
                ctx,
                peel_push(&frame, Axis::Z, None).framebuffer(),
                layers,
                "resident peel",
            )?,
            grid: ctx.create_buffer(
                "resident voxel grid",
                bytes,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )?,
        })
    }

    /// The device-local bit grid (bit axis z, `VoxelGrid` layout).
    pub fn grid(&self) -> &Buffer {
        &self.grid
    }

    /// Records the voxelization of `geom`: every earlier command has finished with the images and the grid
    /// before they are rewritten, and on exit the grid is visible to compute shaders and transfers.
    pub fn record(&self, ctx: &Context, cmd: vk::CommandBuffer, geom: &PeelGeometry) -> Result<()> {
        let push = peel_push(&self.frame, Axis::Z, None);
        self.peel.record_peeling(
            ctx,
            cmd,
            geom,
            &push,
            &self.images.depth,
            &self.images.layers,
            &self.images.layer_views,
            self.layers,
            &mut None,
        )?;
        // Earlier readers of the grid (last frame's ray cast, copies) before the fill overwrites it.
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
        self.peel.fill.record(
            ctx,
            cmd,
            self.images.layers.view(),
            self.peel.peel.sampler(),
            &self.grid,
            &FillJob {
                columns: push.columns(),
                layer_count: self.layers,
                rule: self.rule,
                first_column: 0,
                column_count: self.frame.columns(Axis::Z) as u32,
            },
        )?;
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::ALL_TRANSFER,
                vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::SHADER_STORAGE_WRITE
                    | vk::AccessFlags2::TRANSFER_READ,
            ),
        );
        Ok(())
    }

    /// Reads the grid back (tests; the demo never does).
    pub fn read_grid(&self, ctx: &Context) -> Result<VoxelGrid> {
        let words = ctx.read_pod::<u32>(&self.grid)?;
        let mut g = VoxelGrid::empty(self.frame, Axis::Z);
        g.words.copy_from_slice(&words);
        Ok(g)
    }
}
