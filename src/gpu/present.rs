//! Present targets: an offscreen image ring with PNG readback here, and a window swapchain
//! (`gpu::swapchain`, feature `window`), behind one trait.
//!
//! Invariants:
//! - A frame renders into [`TargetImage::view`], which [`PresentTarget::acquire`] hands out in layout
//!   `UNDEFINED` (contents discarded) and which the renderer leaves in `COLOR_ATTACHMENT_OPTIMAL`;
//!   [`PresentTarget::record_finish`] then records what the target needs (offscreen: copy into the slot's
//!   readback buffer; swapchain: transition to `PRESENT_SRC_KHR`).
//! - The offscreen ring has one image per frame slot, so a slot's pixels are complete once that slot's
//!   fence has signalled; [`OffscreenTarget::read_rgba`] is only valid then.
//! - Targets release their objects when dropped (`gpu::lifetime`).
use super::context::Context;
use super::resources::{image_barrier, Buffer, Image, ImageDesc, MemoryLocation};
use crate::error::{Error, Result};
use ash::vk;
use std::path::Path;

/// The image a frame renders into.
#[derive(Clone, Copy, Debug)]
pub struct TargetImage {
    pub index: u32,
    pub slot: usize,
    pub image: vk::Image,
    pub view: vk::ImageView,
    pub extent: vk::Extent2D,
    pub format: vk::Format,
    /// Wait on this before writing the image (swapchain only).
    pub acquired: Option<vk::Semaphore>,
    /// Signal this when rendering is done (swapchain only).
    pub rendered: Option<vk::Semaphore>,
}

/// Where frames go. See the module invariants.
pub trait PresentTarget {
    /// The color format frames must render in.
    fn format(&self) -> vk::Format;
    /// The current size.
    fn extent(&self) -> vk::Extent2D;
    /// The image for frame slot `slot`, or `None` when this frame must be skipped (minimised window, or a
    /// swapchain that was just recreated).
    fn acquire(&mut self, ctx: &Context, slot: usize) -> Result<Option<TargetImage>>;
    /// Records the work that follows rendering (readback copy or transition for presentation).
    fn record_finish(&mut self, ctx: &Context, cmd: vk::CommandBuffer, img: &TargetImage);
    /// Hands the frame to the presentation engine (after the frame's submit).
    fn present(&mut self, ctx: &Context, img: &TargetImage) -> Result<()>;
    /// Asks for a new size (window resized); applied at the next acquire.
    fn resize(&mut self, extent: vk::Extent2D);
}

/// Transitions for the renderer: from `UNDEFINED` to color attachment.
pub fn begin_color_target(ctx: &Context, cmd: vk::CommandBuffer, image: vk::Image) {
    image_barrier(
        ctx,
        cmd,
        image,
        color_range(),
        vk::ImageLayout::UNDEFINED,
        vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
        (
            vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
            vk::AccessFlags2::NONE,
        ),
        (
            vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
            vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
        ),
    );
}

pub(crate) fn color_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

/// An offscreen ring of color images with host readback.
pub struct OffscreenTarget {
    images: Vec<Image>,
    readback: Vec<Buffer>,
    rendered: Vec<bool>,
    extent: vk::Extent2D,
    format: vk::Format,
    pending_extent: Option<vk::Extent2D>,
    slots: usize,
}

impl OffscreenTarget {
    /// A ring of `slots` images of `width`×`height` in `B8G8R8A8_UNORM` (the usual swapchain format, so the
    /// same pipelines serve both targets).
    pub fn new(ctx: &Context, width: u32, height: u32, slots: usize) -> Result<Self> {
        let mut t = OffscreenTarget {
            images: Vec::new(),
            readback: Vec::new(),
            rendered: Vec::new(),
            extent: vk::Extent2D { width, height },
            format: vk::Format::B8G8R8A8_UNORM,
            pending_extent: None,
            slots: slots.max(1),
        };
        t.build(ctx)?;
        Ok(t)
    }

    fn build(&mut self, ctx: &Context) -> Result<()> {
        let vk::Extent2D { width, height } = self.extent;
        for i in 0..self.slots {
            let desc = ImageDesc::d2(
                width,
                height,
                self.format,
                vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
            );
            self.images
                .push(ctx.create_image(&format!("offscreen color {i}"), &desc)?);
            self.readback.push(ctx.create_buffer(
                &format!("offscreen readback {i}"),
                width as u64 * height as u64 * 4,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?);
            self.rendered.push(false);
        }
        Ok(())
    }

    fn release(&mut self) {
        self.images.clear();
        self.readback.clear();
        self.rendered.clear();
    }

    /// Whether slot `slot` holds a finished frame (after its fence).
    pub fn has_frame(&self, slot: usize) -> bool {
        self.rendered.get(slot).copied().unwrap_or(false)
    }

    /// RGBA8 pixels (rows top to bottom) of the frame last rendered in `slot`. Call after its fence.
    pub fn read_rgba(&self, slot: usize) -> Result<Vec<u8>> {
        let mut px = self.readback[slot].mapped()?.to_vec();
        if self.format == vk::Format::B8G8R8A8_UNORM {
            for p in px.chunks_exact_mut(4) {
                p.swap(0, 2);
            }
        }
        Ok(px)
    }

    /// Writes the frame of `slot` as a PNG file, atomically (temporary file, then rename).
    pub fn write_png(&self, slot: usize, path: &Path) -> Result<()> {
        let rgba = self.read_rgba(slot)?;
        write_png_rgba(path, self.extent.width, self.extent.height, &rgba)
    }
}

/// Writes RGBA8 pixels as a PNG file via a temporary file and a rename.
pub fn write_png_rgba(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<()> {
    // Through the one output writer (temporary file + rename); encoder errors become I/O errors on `path`.
    crate::io::write_atomic(path, |w| {
        let io = |e: png::EncodingError| match e {
            png::EncodingError::IoError(e) => e,
            e => std::io::Error::other(e.to_string()),
        };
        let mut enc = png::Encoder::new(w, width, height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(io)?;
        w.write_image_data(rgba).map_err(io)?;
        w.finish().map_err(io)
    })
}

impl PresentTarget for OffscreenTarget {
    fn format(&self) -> vk::Format {
        self.format
    }

    fn extent(&self) -> vk::Extent2D {
        self.extent
    }

    fn acquire(&mut self, ctx: &Context, slot: usize) -> Result<Option<TargetImage>> {
        if let Some(e) = self.pending_extent.take() {
            // Resizing recreates every slot: wait for the GPU to release them.
            ctx.wait_idle()?;
            self.release();
            self.extent = e;
            if e.width > 0 && e.height > 0 {
                self.build(ctx)?;
            }
        }
        if self.extent.width == 0 || self.extent.height == 0 {
            return Ok(None); // minimised
        }
        let Some(img) = self.images.get(slot) else {
            return Err(Error::Invalid(format!(
                "offscreen target has no slot {slot}"
            )));
        };
        self.rendered[slot] = false;
        Ok(Some(TargetImage {
            index: slot as u32,
            slot,
            image: img.raw(),
            view: img.view(),
            extent: self.extent,
            format: self.format,
            acquired: None,
            rendered: None,
        }))
    }

    fn record_finish(&mut self, ctx: &Context, cmd: vk::CommandBuffer, img: &TargetImage) {
        image_barrier(
            ctx,
            cmd,
            img.image,
            color_range(),
            vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            (
                vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_READ,
            ),
        );
        let region = vk::BufferImageCopy {
            buffer_offset: 0,
            buffer_row_length: 0,
            buffer_image_height: 0,
            image_subresource: vk::ImageSubresourceLayers {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            },
            image_offset: vk::Offset3D::default(),
            image_extent: vk::Extent3D {
                width: img.extent.width,
                height: img.extent.height,
                depth: 1,
            },
        };
        // SAFETY: recording command buffer; image in TRANSFER_SRC layout; buffer sized for the image.
        unsafe {
            ctx.device.cmd_copy_image_to_buffer(
                cmd,
                img.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                self.readback[img.slot].raw(),
                &[region],
            )
        };
        let host = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::HOST)
            .dst_access_mask(vk::AccessFlags2::HOST_READ)];
        ctx.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().memory_barriers(&host));
    }

    fn present(&mut self, _ctx: &Context, img: &TargetImage) -> Result<()> {
        self.rendered[img.slot] = true;
        Ok(())
    }

    fn resize(&mut self, extent: vk::Extent2D) {
        if extent != self.extent {
            self.pending_extent = Some(extent);
        }
    }
}
