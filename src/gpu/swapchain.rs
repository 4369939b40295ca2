//! `SwapchainTarget`: a window surface and its swapchain as a [`PresentTarget`] (feature `window`).
//!
//! Invariants: one acquire semaphore per frame slot and one render-finished semaphore per swapchain image (a
//! present may still wait on it when the slot comes round again). Out-of-date and suboptimal results and
//! resizes recreate the swapchain (after waiting for the device); a zero-sized (minimised) window skips
//! frames. Dropping the target waits for the device first: the presentation engine's use of the images is not
//! covered by the release queue's submission serials.
use super::context::Context;
use super::lifetime::{DeviceShared, Owned};
use super::present::{color_range, PresentTarget, TargetImage};
use super::resources::{image_barrier, Buffer, MemoryLocation};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use std::sync::Arc;

/// A window swapchain (winit + ash-window).
pub struct SwapchainTarget {
    /// A screenshot readback (buffer, its extent, whether the copy was recorded); see `request_capture`.
    capture: Option<(Buffer, vk::Extent2D, bool)>,
    images: Vec<vk::Image>,
    // Field order is release order: views and semaphores, then the swapchain, then its surface.
    views: Vec<Owned<vk::ImageView>>,
    rendered: Vec<Owned<vk::Semaphore>>,
    acquired: Vec<Owned<vk::Semaphore>>,
    swapchain: Option<Owned<vk::SwapchainKHR>>,
    surface: Owned<vk::SurfaceKHR>,
    format: vk::SurfaceFormatKHR,
    extent: vk::Extent2D,
    wanted: vk::Extent2D,
    needs_rebuild: bool,
    present_mode: vk::PresentModeKHR,
    shared: Arc<DeviceShared>,
}

impl Drop for SwapchainTarget {
    fn drop(&mut self) {
        // SAFETY: valid device. Presentation may still read the images: wait before anything is released.
        let _ = unsafe { self.shared.device.device_wait_idle() };
        self.shared.idle();
    }
}

impl SwapchainTarget {
    /// Creates the surface for `window` and a swapchain of `width`×`height` (the window's inner size) with
    /// one acquire semaphore per frame slot. The context must have been created with the window's
    /// surface extensions.
    pub fn new(
        ctx: &Context,
        display: raw_window_handle::RawDisplayHandle,
        window: raw_window_handle::RawWindowHandle,
        width: u32,
        height: u32,
        slots: usize,
        vsync: bool,
    ) -> Result<Self> {
        let surface_fn = ctx.surface_instance.as_ref().ok_or_else(|| {
            Error::Invalid("the context was created without surface extensions".into())
        })?;
        // SAFETY: the handles come from a live window that outlives the target (caller's contract).
        let surface =
            unsafe { ash_window::create_surface(&ctx.entry, &ctx.instance, display, window, None) }
                .vk("vkCreate*SurfaceKHR")?;
        // Not named: a surface is an instance-level object, and naming it through the device's debug-utils
        // entry point crashes the validation layer on lavapipe.
        let owned_surface = Owned::new(ctx.shared(), surface);
        // SAFETY: valid physical device and surface.
        let supported = unsafe {
            surface_fn.get_physical_device_surface_support(
                ctx.physical_device,
                ctx.queue_family,
                surface,
            )
        }
        .unwrap_or(false);
        if !supported {
            return Err(Error::NoDevice(
                "the chosen queue cannot present to this window".into(),
            ));
        }
        // SAFETY: valid physical device and surface.
        let formats =
            unsafe { surface_fn.get_physical_device_surface_formats(ctx.physical_device, surface) }
                .vk("vkGetPhysicalDeviceSurfaceFormatsKHR")?;
        let format = formats
            .iter()
            .copied()
            .find(|f| f.format == vk::Format::B8G8R8A8_UNORM)
            .or_else(|| {
                formats
                    .iter()
                    .copied()
                    .find(|f| f.format == vk::Format::R8G8B8A8_UNORM)
            })
            .or_else(|| formats.first().copied())
            .ok_or_else(|| Error::NoDevice("the surface offers no format".into()))?;
        // SAFETY: valid physical device and surface.
        let modes = unsafe {
            surface_fn.get_physical_device_surface_present_modes(ctx.physical_device, surface)
        }
        .unwrap_or_default();
        let present_mode = if !vsync && modes.contains(&vk::PresentModeKHR::MAILBOX) {
            vk::PresentModeKHR::MAILBOX
        } else if !vsync && modes.contains(&vk::PresentModeKHR::IMMEDIATE) {
            vk::PresentModeKHR::IMMEDIATE
        } else {
            vk::PresentModeKHR::FIFO
        };
        let mut t = SwapchainTarget {
            surface: owned_surface,
            swapchain: None,
            images: Vec::new(),
            views: Vec::new(),
            rendered: Vec::new(),
            acquired: Vec::new(),
            format,
            extent: vk::Extent2D { width, height },
            wanted: vk::Extent2D { width, height },
            needs_rebuild: true,
            capture: None,
            present_mode,
            shared: ctx.shared().clone(),
        };
        for i in 0..slots.max(1) {
            // SAFETY: valid device.
            let s = unsafe {
                ctx.device
                    .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
            }
            .vk("vkCreateSemaphore")?;
            t.acquired
                .push(ctx.own(s, &format!("swapchain acquired {i}")));
        }
        t.rebuild(ctx)?;
        Ok(t)
    }

    /// Releases the views and render semaphores (the device is idle when the swapchain is rebuilt).
    fn release_images(&mut self) {
        self.views.clear();
        self.rendered.clear();
        self.images.clear();
    }

    /// (Re)creates the swapchain at the wanted size. Returns false if the window is minimised.
    fn rebuild(&mut self, ctx: &Context) -> Result<bool> {
        let surface_fn = ctx.surface_instance.as_ref().expect("checked in new");
        let swapchain_fn = ctx.swapchain_device.as_ref().expect("swapchain device");
        // SAFETY: valid physical device and surface.
        let caps = unsafe {
            surface_fn
                .get_physical_device_surface_capabilities(ctx.physical_device, self.surface.raw())
        }
        .vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR")?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: self
                    .wanted
                    .width
                    .clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: self
                    .wanted
                    .height
                    .clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        if extent.width == 0 || extent.height == 0 {
            return Ok(false);
        }
        ctx.wait_idle()?;
        self.release_images();
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let old = self.swapchain.take();
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface.raw())
            .min_image_count(count)
            .image_format(self.format.format)
            .image_color_space(self.format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(vk::CompositeAlphaFlagsKHR::OPAQUE)
            .present_mode(self.present_mode)
            .clipped(true)
            .old_swapchain(old.as_ref().map_or(vk::SwapchainKHR::null(), Owned::raw));
        // SAFETY: valid create info; the old swapchain is retired by this call.
        let swapchain =
            unsafe { swapchain_fn.create_swapchain(&info, None) }.vk("vkCreateSwapchainKHR")?;
        // The device is idle and the old swapchain is retired: releasing it destroys it now.
        drop(old);
        self.swapchain = Some(ctx.own(swapchain, "swapchain"));
        // SAFETY: valid swapchain.
        self.images = unsafe { swapchain_fn.get_swapchain_images(swapchain) }
            .vk("vkGetSwapchainImagesKHR")?;
        for (i, &image) in self.images.iter().enumerate() {
            let vi = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(self.format.format)
                .subresource_range(color_range());
            // SAFETY: valid swapchain image.
            let view =
                unsafe { ctx.device.create_image_view(&vi, None) }.vk("vkCreateImageView")?;
            self.views
                .push(ctx.own(view, &format!("swapchain view {i}")));
            // SAFETY: valid device.
            let sem = unsafe {
                ctx.device
                    .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
            }
            .vk("vkCreateSemaphore")?;
            self.rendered
                .push(ctx.own(sem, &format!("swapchain rendered {i}")));
        }
        self.extent = extent;
        self.needs_rebuild = false;
        Ok(true)
    }
}

impl SwapchainTarget {
    /// Asks for the next presented frame to be copied to a readback buffer as well (screenshot).
    pub fn request_capture(&mut self, ctx: &Context) -> Result<()> {
        if self.capture.is_none() {
            let e = self.extent;
            let buf = ctx.create_buffer(
                "screenshot readback",
                e.width.max(1) as u64 * e.height.max(1) as u64 * 4,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?;
            self.capture = Some((buf, e, false));
        }
        Ok(())
    }

    /// The captured frame as (width, height, RGBA8 rows top to bottom) once its copy was recorded; call after
    /// that frame's fence (e.g. after `Frames::wait_all`). Frees the readback buffer.
    pub fn take_capture(&mut self) -> Result<Option<(u32, u32, Vec<u8>)>> {
        if !self.capture.as_ref().is_some_and(|c| c.2) {
            return Ok(None);
        }
        let (buf, e, _) = self.capture.take().expect("checked above");
        let mut px = buf.mapped().map(|m| m.to_vec());
        if let Ok(px) = px.as_mut() {
            if matches!(
                self.format.format,
                vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB
            ) {
                for p in px.chunks_exact_mut(4) {
                    p.swap(0, 2);
                }
            }
        }
        Ok(Some((e.width, e.height, px?)))
    }
}

impl PresentTarget for SwapchainTarget {
    fn format(&self) -> vk::Format {
        self.format.format
    }

    fn extent(&self) -> vk::Extent2D {
        self.extent
    }

    fn acquire(&mut self, ctx: &Context, slot: usize) -> Result<Option<TargetImage>> {
        if self.wanted.width == 0 || self.wanted.height == 0 {
            return Ok(None); // minimised
        }
        if self.needs_rebuild && !self.rebuild(ctx)? {
            return Ok(None);
        }
        let swapchain_fn = ctx.swapchain_device.as_ref().expect("swapchain device");
        let sem = self.acquired[slot].raw();
        // SAFETY: valid swapchain; the slot's semaphore is unsignalled (its previous wait has completed
        // because the caller waited for the slot's fence).
        match unsafe {
            swapchain_fn.acquire_next_image(
                self.swapchain
                    .as_ref()
                    .map_or(vk::SwapchainKHR::null(), Owned::raw),
                u64::MAX,
                sem,
                vk::Fence::null(),
            )
        } {
            Ok((index, suboptimal)) => {
                if suboptimal {
                    // Render this one; rebuild before the next.
                    self.needs_rebuild = true;
                }
                let i = index as usize;
                Ok(Some(TargetImage {
                    index,
                    slot,
                    image: self.images[i],
                    view: self.views[i].raw(),
                    extent: self.extent,
                    format: self.format.format,
                    acquired: Some(sem),
                    rendered: Some(self.rendered[i].raw()),
                }))
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.needs_rebuild = true;
                Ok(None)
            }
            Err(result) => Err(Error::Vulkan {
                call: "vkAcquireNextImageKHR",
                result,
            }),
        }
    }

    fn record_finish(&mut self, ctx: &Context, cmd: vk::CommandBuffer, img: &TargetImage) {
        let mut layout = vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL;
        let mut src = (
            vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
            vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
        );
        if let Some((buf, e, recorded)) = self.capture.as_mut() {
            // Only a frame of the size the buffer was made for (a resize in between drops nothing: the
            // request stays until a frame of that size comes, or a new request replaces it at its size).
            if !*recorded && *e == img.extent {
                image_barrier(
                    ctx,
                    cmd,
                    img.image,
                    color_range(),
                    layout,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    src,
                    (
                        vk::PipelineStageFlags2::COPY,
                        vk::AccessFlags2::TRANSFER_READ,
                    ),
                );
                let region = vk::BufferImageCopy {
                    image_subresource: vk::ImageSubresourceLayers {
                        aspect_mask: vk::ImageAspectFlags::COLOR,
                        mip_level: 0,
                        base_array_layer: 0,
                        layer_count: 1,
                    },
                    image_extent: vk::Extent3D {
                        width: e.width,
                        height: e.height,
                        depth: 1,
                    },
                    ..Default::default()
                };
                // SAFETY: recording; image in TRANSFER_SRC layout; buffer sized for the extent.
                unsafe {
                    ctx.device.cmd_copy_image_to_buffer(
                        cmd,
                        img.image,
                        vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                        buf.raw(),
                        &[region],
                    )
                };
                let host = [vk::MemoryBarrier2::default()
                    .src_stage_mask(vk::PipelineStageFlags2::COPY)
                    .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                    .dst_stage_mask(vk::PipelineStageFlags2::HOST)
                    .dst_access_mask(vk::AccessFlags2::HOST_READ)];
                ctx.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().memory_barriers(&host),
                );
                *recorded = true;
                layout = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
                src = (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::NONE);
            }
        }
        image_barrier(
            ctx,
            cmd,
            img.image,
            color_range(),
            layout,
            vk::ImageLayout::PRESENT_SRC_KHR,
            src,
            (vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE),
        );
    }

    fn present(&mut self, ctx: &Context, img: &TargetImage) -> Result<()> {
        let swapchain_fn = ctx.swapchain_device.as_ref().expect("swapchain device");
        let waits = [self.rendered[img.index as usize].raw()];
        let swapchains = [self
            .swapchain
            .as_ref()
            .map_or(vk::SwapchainKHR::null(), Owned::raw)];
        let indices = [img.index];
        let info = vk::PresentInfoKHR::default()
            .wait_semaphores(&waits)
            .swapchains(&swapchains)
            .image_indices(&indices);
        // SAFETY: valid queue and swapchain; the image was acquired and rendered.
        match unsafe { swapchain_fn.queue_present(ctx.queue, &info) } {
            Ok(false) => Ok(()),
            Ok(true) | Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.needs_rebuild = true;
                Ok(())
            }
            Err(result) => Err(Error::Vulkan {
                call: "vkQueuePresentKHR",
                result,
            }),
        }
    }

    fn resize(&mut self, extent: vk::Extent2D) {
        if extent != self.wanted {
            self.wanted = extent;
            self.needs_rebuild = true;
        }
    }
}
