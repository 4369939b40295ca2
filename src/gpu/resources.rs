//! Named buffers and images, staging upload and readback.
//!
//! Invariants:
//! - A [`Buffer`]/[`Image`] owns its handle and its memory and releases both when dropped, through the
//!   release queue of `gpu::lifetime` (destroyed once no submitted work can use them). Its fields are
//!   read through getters only.
//! - Every allocation is named (the leak check and the budget error name it).
//! - Host access only through `MemoryLocation::CpuToGpu`/`GpuToCpu` allocations. Mapping a `GpuOnly`
//!   allocation is refused with an error even where it would work (lavapipe has a single host-visible memory
//!   type, which hides that bug until the code meets a discrete GPU). Device-local data goes through
//!   staging buffers and `vkCmdCopyBuffer`.
use super::context::Context;
use super::lifetime::{DeviceShared, Retired};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
pub use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// A buffer and its memory, released when dropped.
#[derive(Debug)]
pub struct Buffer {
    raw: vk::Buffer,
    allocation: Option<Allocation>,
    size: u64,
    usage: vk::BufferUsageFlags,
    location: MemoryLocation,
    name: String,
    owner: Arc<DeviceShared>,
}

impl Drop for Buffer {
    fn drop(&mut self) {
        self.owner
            .release(Retired::Buffer(self.raw, self.allocation.take()));
    }
}

/// Describes an image to create.
#[derive(Clone, Debug)]
pub struct ImageDesc {
    pub extent: vk::Extent3D,
    pub format: vk::Format,
    pub usage: vk::ImageUsageFlags,
    pub layers: u32,
    pub image_type: vk::ImageType,
    pub view_type: vk::ImageViewType,
    pub aspect: vk::ImageAspectFlags,
    /// Samples per pixel (a multisampled render target when more than one).
    pub samples: vk::SampleCountFlags,
}

impl ImageDesc {
    /// A 2D image with one layer and one mip level.
    pub fn d2(width: u32, height: u32, format: vk::Format, usage: vk::ImageUsageFlags) -> Self {
        let aspect = if is_depth_format(format) {
            vk::ImageAspectFlags::DEPTH
        } else {
            vk::ImageAspectFlags::COLOR
        };
        ImageDesc {
            extent: vk::Extent3D {
                width,
                height,
                depth: 1,
            },
            format,
            usage,
            layers: 1,
            image_type: vk::ImageType::TYPE_2D,
            view_type: vk::ImageViewType::TYPE_2D,
            aspect,
            samples: vk::SampleCountFlags::TYPE_1,
        }
    }

    /// A 2D array image with `layers` layers.
    pub fn d2_array(
        width: u32,
        height: u32,
        layers: u32,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
    ) -> Self {
        let mut d = Self::d2(width, height, format, usage);
        d.layers = layers;
        d.view_type = vk::ImageViewType::TYPE_2D_ARRAY;
        d
    }
}

/// Whether `format` is a depth (or depth-stencil) format.
pub fn is_depth_format(format: vk::Format) -> bool {
    matches!(
        format,
        vk::Format::D16_UNORM
            | vk::Format::D32_SFLOAT
            | vk::Format::X8_D24_UNORM_PACK32
            | vk::Format::D16_UNORM_S8_UINT
            | vk::Format::D24_UNORM_S8_UINT
            | vk::Format::D32_SFLOAT_S8_UINT
    )
}

/// An image, its default view and its memory, released when dropped.
#[derive(Debug)]
pub struct Image {
    raw: vk::Image,
    view: vk::ImageView,
    allocation: Option<Allocation>,
    desc: ImageDesc,
    name: String,
    owner: Arc<DeviceShared>,
}

impl Drop for Image {
    fn drop(&mut self) {
        self.owner
            .release(Retired::Image(self.raw, self.view, self.allocation.take()));
    }
}

impl Image {
    /// The image handle.
    pub fn raw(&self) -> vk::Image {
        self.raw
    }

    /// The default view (every layer, the one mip level).
    pub fn view(&self) -> vk::ImageView {
        self.view
    }

    /// What the image was created as.
    pub fn desc(&self) -> &ImageDesc {
        &self.desc
    }

    /// The debug name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Destroys the image now instead of through the release queue.
    ///
    /// # Safety
    /// No submitted command buffer that uses the image may still be executing, and no command buffer that
    /// records it may be submitted afterwards.
    pub unsafe fn destroy_now(mut self) {
        let item = Retired::Image(self.raw, self.view, self.allocation.take());
        self.view = vk::ImageView::null();
        self.raw = vk::Image::null();
        // SAFETY: the caller's promise.
        unsafe { self.owner.destroy(item) };
    }

    /// The full subresource range of the image.
    pub fn range(&self) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            aspect_mask: self.desc.aspect,
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: self.desc.layers,
        }
    }

    /// The pixel format.
    pub fn format(&self) -> vk::Format {
        self.desc.format
    }

    /// Samples per pixel.
    pub fn samples(&self) -> vk::SampleCountFlags {
        self.desc.samples
    }

    /// Width and height.
    pub fn extent2d(&self) -> vk::Extent2D {
        vk::Extent2D {
            width: self.desc.extent.width,
            height: self.desc.extent.height,
        }
    }
}

impl Buffer {
    /// The buffer handle.
    pub fn raw(&self) -> vk::Buffer {
        self.raw
    }

    /// Its size in bytes (as requested; the allocation may be larger).
    pub fn size(&self) -> u64 {
        self.size
    }

    /// The usage it was created with.
    pub fn usage(&self) -> vk::BufferUsageFlags {
        self.usage
    }

    /// Where its memory lives.
    pub fn location(&self) -> MemoryLocation {
        self.location
    }

    /// The debug name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Host-visible bytes of the buffer, or an error for `GpuOnly` memory.
    pub fn mapped(&self) -> Result<&[u8]> {
        self.assert_host_location()?;
        self.allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .map(|s| &s[..self.size as usize])
            .ok_or_else(|| Error::Invalid(format!("buffer '{}' is not mapped", self.name)))
    }

    /// Mutable host-visible bytes of the buffer, or an error for `GpuOnly` memory.
    pub fn mapped_mut(&mut self) -> Result<&mut [u8]> {
        self.assert_host_location()?;
        let size = self.size as usize;
        let name = self.name.clone();
        self.allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .map(|s| &mut s[..size])
            .ok_or_else(|| Error::Invalid(format!("buffer '{name}' is not mapped")))
    }

    fn assert_host_location(&self) -> Result<()> {
        if self.location == MemoryLocation::GpuOnly {
            return Err(Error::Invalid(format!(
                "buffer '{}' lives in GpuOnly memory and must not be mapped; use a staging copy",
                self.name
            )));
        }
        Ok(())
    }

    /// A descriptor for the whole buffer.
    pub fn descriptor(&self) -> vk::DescriptorBufferInfo {
        vk::DescriptorBufferInfo {
            buffer: self.raw,
            offset: 0,
            range: vk::WHOLE_SIZE,
        }
    }

    /// Destroys the buffer now instead of through the release queue.
    ///
    /// # Safety
    /// No submitted command buffer that uses the buffer may still be executing, and no command buffer that
    /// records it may be submitted afterwards.
    pub unsafe fn destroy_now(mut self) {
        let item = Retired::Buffer(self.raw, self.allocation.take());
        self.raw = vk::Buffer::null();
        // SAFETY: the caller's promise.
        unsafe { self.owner.destroy(item) };
    }
}

impl Context {
    /// Reserves `requirements.size` against the memory budget and allocates it (`bytes` is the size the
    /// error message names); on failure nothing stays reserved. When it fails while dropped objects still
    /// wait for the GPU, it waits for the device (which destroys them) and tries once more.
    fn allocate_memory(
        &self,
        name: &str,
        requirements: vk::MemoryRequirements,
        location: MemoryLocation,
        linear: bool,
        bytes: u64,
    ) -> Result<Allocation> {
        let attempt = || {
            self.reserve_bytes(name, requirements.size)?;
            self.allocator()
                .allocate(&AllocationCreateDesc {
                    name,
                    requirements,
                    location,
                    linear,
                    allocation_scheme: AllocationScheme::GpuAllocatorManaged,
                })
                .map_err(|e| {
                    self.shared().release_bytes(requirements.size);
                    Error::Alloc {
                        name: name.into(),
                        bytes,
                        reason: e.to_string(),
                    }
                })
        };
        match attempt() {
            Err(_) if self.objects_awaiting_release() > 0 => {
                self.wait_idle()?;
                attempt()
            }
            result => result,
        }
    }

    /// Creates a named buffer of `size` bytes in `location`.
    pub fn create_buffer(
        &self,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Buffer> {
        if size == 0 {
            return Err(Error::Invalid(format!(
                "buffer '{name}' would be empty (0 bytes)"
            )));
        }
        let max = self.info.max_memory_allocation_size;
        if max > 0 && size > max {
            return Err(Error::Limit {
                what: format!("buffer '{name}' of {} MiB", size >> 20),
                detail: format!(
                    "the device allocates at most {} MiB at once (maxMemoryAllocationSize)",
                    max >> 20
                ),
            });
        }
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create info.
        let raw = unsafe { self.device.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        // Owned from here on: an error below releases whatever exists.
        let mut buffer = Buffer {
            raw,
            allocation: None,
            size,
            usage,
            location,
            name: name.into(),
            owner: self.shared().clone(),
        };
        // SAFETY: raw is a valid buffer.
        let requirements = unsafe { self.device.get_buffer_memory_requirements(raw) };
        let allocation = self.allocate_memory(name, requirements, location, true, size)?;
        // SAFETY: the memory is bound below and freed only with the allocation.
        let (memory, offset) = (unsafe { allocation.memory() }, allocation.offset());
        buffer.allocation = Some(allocation);
        // SAFETY: memory and offset come from an allocation that satisfies the requirements.
        unsafe { self.device.bind_buffer_memory(raw, memory, offset) }.vk("vkBindBufferMemory")?;
        self.set_name(raw, name);
        Ok(buffer)
    }

    /// Creates a device-local buffer holding `data`, uploaded through a staging buffer.
    pub fn upload_buffer(
        &self,
        name: &str,
        data: &[u8],
        usage: vk::BufferUsageFlags,
    ) -> Result<Buffer> {
        let buf = self.create_buffer(
            name,
            data.len() as u64,
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        self.write_buffer(&buf, 0, data)?;
        Ok(buf)
    }

    /// Writes `data` at `offset` into `buf`: directly when it is host-visible, else through staging.
    pub fn write_buffer(&self, buf: &Buffer, offset: u64, data: &[u8]) -> Result<()> {
        if data.is_empty() {
            return Ok(());
        }
        if offset + data.len() as u64 > buf.size {
            return Err(Error::Invalid(format!(
                "write of {} bytes at {offset} overflows buffer '{}' ({} bytes)",
                data.len(),
                buf.name,
                buf.size
            )));
        }
        if buf.location != MemoryLocation::GpuOnly {
            let ptr = buf
                .allocation
                .as_ref()
                .and_then(|a| a.mapped_ptr())
                .ok_or_else(|| Error::Invalid(format!("buffer '{}' is not mapped", buf.name)))?;
            // SAFETY: the range was checked above; the memory is host-visible and coherent or flushed by the
            // allocator; the GPU is not using this range (caller's contract).
            unsafe {
                std::ptr::copy_nonoverlapping(
                    data.as_ptr(),
                    (ptr.as_ptr() as *mut u8).add(offset as usize),
                    data.len(),
                )
            };
            return Ok(());
        }
        let mut staging = self.create_buffer(
            &format!("{} (staging)", buf.name),
            data.len() as u64,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        let result = staging
            .mapped_mut()
            .map(|m| m.copy_from_slice(data))
            .and_then(|()| {
                self.one_shot(|cmd| {
                    let region = vk::BufferCopy {
                        src_offset: 0,
                        dst_offset: offset,
                        size: data.len() as u64,
                    };
                    // SAFETY: both buffers are valid; the region is in range.
                    unsafe {
                        self.device
                            .cmd_copy_buffer(cmd, staging.raw, buf.raw, &[region])
                    };
                    Ok(())
                })
            });
        result
    }

    /// Reads the whole of `buf` back to the host (through a staging copy unless it is host-visible).
    pub fn read_buffer(&self, buf: &Buffer) -> Result<Vec<u8>> {
        self.read_buffer_range(buf, 0, buf.size)
    }

    /// Reads the whole of `buf` back as values of `T` (trailing bytes that do not fill a `T` are dropped).
    pub fn read_pod<T: bytemuck::Pod>(&self, buf: &Buffer) -> Result<Vec<T>> {
        let bytes = self.read_buffer(buf)?;
        let n = bytes.len() / std::mem::size_of::<T>().max(1);
        Ok(bytemuck::pod_collect_to_vec(
            &bytes[..n * std::mem::size_of::<T>()],
        ))
    }

    /// Reads `size` bytes at `offset` of `buf` back to the host.
    pub fn read_buffer_range(&self, buf: &Buffer, offset: u64, size: u64) -> Result<Vec<u8>> {
        if offset + size > buf.size {
            return Err(Error::Invalid(format!(
                "read past the end of buffer '{}'",
                buf.name
            )));
        }
        if size == 0 {
            return Ok(Vec::new());
        }
        if buf.location == MemoryLocation::GpuToCpu {
            return Ok(buf.mapped()?[offset as usize..(offset + size) as usize].to_vec());
        }
        if !buf.usage.contains(vk::BufferUsageFlags::TRANSFER_SRC) {
            return Err(Error::Invalid(format!(
                "buffer '{}' was not created with TRANSFER_SRC",
                buf.name
            )));
        }
        let staging = self.create_buffer(
            &format!("{} (readback)", buf.name),
            size,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        let result = self
            .one_shot(|cmd| {
                // Make earlier shader writes visible to the copy.
                let barrier = [vk::MemoryBarrier2::default()
                    .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                    .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
                    .dst_stage_mask(vk::PipelineStageFlags2::COPY)
                    .dst_access_mask(vk::AccessFlags2::TRANSFER_READ)];
                self.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().memory_barriers(&barrier),
                );
                let region = vk::BufferCopy {
                    src_offset: offset,
                    dst_offset: 0,
                    size,
                };
                // SAFETY: both buffers valid, region in range.
                unsafe {
                    self.device
                        .cmd_copy_buffer(cmd, buf.raw, staging.raw, &[region])
                };
                let host = [vk::MemoryBarrier2::default()
                    .src_stage_mask(vk::PipelineStageFlags2::COPY)
                    .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                    .dst_stage_mask(vk::PipelineStageFlags2::HOST)
                    .dst_access_mask(vk::AccessFlags2::HOST_READ)];
                self.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().memory_barriers(&host),
                );
                Ok(())
            })
            .and_then(|()| staging.mapped().map(|m| m.to_vec()));
        result
    }

    /// Creates a named device-local image with a default view.
    pub fn create_image(&self, name: &str, desc: &ImageDesc) -> Result<Image> {
        let max2d = self.limits.max_image_dimension2_d;
        if desc.extent.width == 0 || desc.extent.height == 0 || desc.layers == 0 {
            return Err(Error::Invalid(format!("image '{name}' would be empty")));
        }
        if desc.extent.width > max2d || desc.extent.height > max2d {
            return Err(Error::Limit {
                what: format!(
                    "image '{name}' of {}×{}",
                    desc.extent.width, desc.extent.height
                ),
                detail: format!("maxImageDimension2D is {max2d}"),
            });
        }
        if desc.layers > self.limits.max_image_array_layers {
            return Err(Error::Limit {
                what: format!("image '{name}' with {} layers", desc.layers),
                detail: format!(
                    "maxImageArrayLayers is {}",
                    self.limits.max_image_array_layers
                ),
            });
        }
        let info = vk::ImageCreateInfo::default()
            .image_type(desc.image_type)
            .format(desc.format)
            .extent(desc.extent)
            .mip_levels(1)
            .array_layers(desc.layers)
            .samples(desc.samples)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(desc.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid create info.
        let raw = unsafe { self.device.create_image(&info, None) }.vk("vkCreateImage")?;
        // Owned from here on: an error below releases whatever exists (a null view is ignored).
        let mut image = Image {
            raw,
            view: vk::ImageView::null(),
            allocation: None,
            desc: desc.clone(),
            name: name.into(),
            owner: self.shared().clone(),
        };
        // SAFETY: valid image.
        let requirements = unsafe { self.device.get_image_memory_requirements(raw) };
        let allocation = self.allocate_memory(
            name,
            requirements,
            MemoryLocation::GpuOnly,
            false,
            requirements.size,
        )?;
        // SAFETY: the memory is bound below and freed only with the allocation.
        let (memory, offset) = (unsafe { allocation.memory() }, allocation.offset());
        image.allocation = Some(allocation);
        // SAFETY: the allocation satisfies the requirements.
        unsafe { self.device.bind_image_memory(raw, memory, offset) }.vk("vkBindImageMemory")?;
        let view_info = vk::ImageViewCreateInfo::default()
            .image(raw)
            .view_type(desc.view_type)
            .format(desc.format)
            .subresource_range(vk::ImageSubresourceRange {
                aspect_mask: desc.aspect,
                base_mip_level: 0,
                level_count: 1,
                base_array_layer: 0,
                layer_count: desc.layers,
            });
        // SAFETY: valid image with bound memory.
        image.view =
            unsafe { self.device.create_image_view(&view_info, None) }.vk("vkCreateImageView")?;
        self.set_name(raw, name);
        self.set_name(image.view, &format!("{name} (view)"));
        Ok(image)
    }
}

impl Context {
    /// A 2D view of one layer of an array image (same format and aspect), released when dropped.
    pub fn create_layer_view(
        &self,
        image: &Image,
        layer: u32,
    ) -> Result<super::lifetime::Owned<vk::ImageView>> {
        let info = vk::ImageViewCreateInfo::default()
            .image(image.raw)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(image.desc.format)
            .subresource_range(vk::ImageSubresourceRange {
                aspect_mask: image.desc.aspect,
                base_mip_level: 0,
                level_count: 1,
                base_array_layer: layer,
                layer_count: 1,
            });
        // SAFETY: valid image and create info; the view is released before the image (it is dropped first
        // or in the same release batch, in order).
        let view = unsafe { self.device.create_image_view(&info, None) }.vk("vkCreateImageView")?;
        Ok(self.own(view, &format!("{} (layer {layer})", image.name)))
    }

    /// Creates a named sampler, released when dropped.
    pub fn create_sampler(
        &self,
        info: &vk::SamplerCreateInfo<'_>,
        name: &str,
    ) -> Result<super::lifetime::Owned<vk::Sampler>> {
        // SAFETY: valid create info.
        let raw = unsafe { self.device.create_sampler(info, None) }.vk("vkCreateSampler")?;
        Ok(self.own(raw, name))
    }
}

/// Records an image layout transition with a synchronization2 barrier.
#[allow(clippy::too_many_arguments)]
pub fn image_barrier(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    image: vk::Image,
    range: vk::ImageSubresourceRange,
    old: vk::ImageLayout,
    new: vk::ImageLayout,
    src: (vk::PipelineStageFlags2, vk::AccessFlags2),
    dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
) {
    let b = [vk::ImageMemoryBarrier2::default()
        .src_stage_mask(src.0)
        .src_access_mask(src.1)
        .dst_stage_mask(dst.0)
        .dst_access_mask(dst.1)
        .old_layout(old)
        .new_layout(new)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range)];
    ctx.cmd_pipeline_barrier2(
        cmd,
        &vk::DependencyInfo::default().image_memory_barriers(&b),
    );
}

/// A byte range of a buffer a pass writes into: all of one of gregvox's own ([`From<&Buffer>`]) or a
/// range of a caller's buffer (whose usage flags and alignment the caller vouches for; see
/// `api::VertexTarget`).
#[derive(Clone, Copy, Debug)]
pub struct BufferRange<'a> {
    pub buffer: vk::Buffer,
    pub offset: u64,
    pub size: u64,
    /// What to call it in messages.
    pub name: &'a str,
}

impl<'a> From<&'a Buffer> for BufferRange<'a> {
    fn from(b: &'a Buffer) -> Self {
        BufferRange {
            buffer: b.raw(),
            offset: 0,
            size: b.size(),
            name: b.name(),
        }
    }
}

/// Records a global memory barrier.
pub fn memory_barrier(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    src: (vk::PipelineStageFlags2, vk::AccessFlags2),
    dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
) {
    let b = [vk::MemoryBarrier2::default()
        .src_stage_mask(src.0)
        .src_access_mask(src.1)
        .dst_stage_mask(dst.0)
        .dst_access_mask(dst.1)];
    ctx.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().memory_barriers(&b));
}

/// Records `bytes` into `buffer` from offset 0 (`vkCmdUpdateBuffer` in 64 KiB pieces) between barriers: after
/// earlier compute reads and copies, before later compute reads. How a frame changes a small input (a cage's
/// positions, a flag's corners) without a submission: frames in flight keep what they were recorded with.
/// The buffer needs `TRANSFER_DST` usage and at least `bytes.len()` bytes (a multiple of 4).
pub fn record_update(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    buffer: &Buffer,
    bytes: &[u8],
) -> Result<()> {
    if bytes.len() as u64 > buffer.size() || bytes.len() % 4 != 0 {
        return Err(Error::Invalid(format!(
            "{} bytes cannot update buffer '{}' of {} bytes",
            bytes.len(),
            buffer.name(),
            buffer.size()
        )));
    }
    memory_barrier(
        ctx,
        cmd,
        (
            vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::NONE,
        ),
        (
            vk::PipelineStageFlags2::ALL_TRANSFER,
            vk::AccessFlags2::TRANSFER_WRITE,
        ),
    );
    for (k, chunk) in bytes.chunks(65536).enumerate() {
        // SAFETY: recording outside a render pass; the range lies inside the buffer (checked above).
        unsafe {
            ctx.device
                .cmd_update_buffer(cmd, buffer.raw(), k as u64 * 65536, chunk)
        };
    }
    memory_barrier(
        ctx,
        cmd,
        (
            vk::PipelineStageFlags2::ALL_TRANSFER,
            vk::AccessFlags2::TRANSFER_WRITE,
        ),
        (
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_READ,
        ),
    );
    Ok(())
}

/// Splits `count` items of `item_bytes` each into chunks (first item, count) whose byte range fits one storage
/// binding (`max_range`, i.e. `maxStorageBufferRange`: 128 MiB on lavapipe) and starts at a multiple of
/// `align` (`minStorageBufferOffsetAlignment`): how a pass reaches a buffer larger than one binding.
///
/// ```
/// use gregvox::gpu::resources::storage_chunks;
/// // Level-64 patch grids: 65² vertices of 32 B per patch, 128 MiB per binding, 16 B alignment.
/// assert_eq!(
///     storage_chunks(2000, 65 * 65 * 32, 128 << 20, 16),
///     vec![(0, 992), (992, 992), (1984, 16)]
/// );
/// assert_eq!(storage_chunks(10, 25 * 32, 128 << 20, 256), vec![(0, 10)]);
/// ```
pub fn storage_chunks(count: u64, item_bytes: u64, max_range: u64, align: u64) -> Vec<(u64, u64)> {
    let mut per = max_range / item_bytes.max(1);
    // Every chunk's offset (a multiple of per·item_bytes) must be a multiple of the alignment.
    let align = align.max(1);
    let step = align / gcd(item_bytes.max(1), align);
    per -= per % step;
    let per = per.max(1);
    (0..count)
        .step_by(per as usize)
        .map(|first| (first, per.min(count - first)))
        .collect()
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// Compute storage writes → later compute storage reads and writes (one dispatch feeding the next, or
/// atomics accumulating across dispatches).
pub fn compute_to_compute(ctx: &Context, cmd: vk::CommandBuffer) {
    memory_barrier(
        ctx,
        cmd,
        (
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
        ),
        (
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
        ),
    );
}

/// Compute storage writes made available to the host's reads once the submission's fence has signalled
/// (a host kernel reading what the device wrote).
pub fn compute_writes_to_host(ctx: &Context, cmd: vk::CommandBuffer) {
    memory_barrier(
        ctx,
        cmd,
        (
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
        ),
        (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
    );
}

/// The barrier that ends a compute pass: its storage writes become available to every later reader in
/// gregvox (vertex input, vertex/fragment/compute shaders, copies). One broad barrier instead of one per
/// consumer keeps the passes independent of who reads their output.
pub fn compute_writes_to_readers(ctx: &Context, cmd: vk::CommandBuffer) {
    memory_barrier(
        ctx,
        cmd,
        (
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
        ),
        (
            vk::PipelineStageFlags2::VERTEX_ATTRIBUTE_INPUT
                | vk::PipelineStageFlags2::VERTEX_SHADER
                | vk::PipelineStageFlags2::FRAGMENT_SHADER
                | vk::PipelineStageFlags2::COMPUTE_SHADER
                | vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::VERTEX_ATTRIBUTE_READ
                | vk::AccessFlags2::SHADER_STORAGE_READ
                | vk::AccessFlags2::SHADER_SAMPLED_READ
                | vk::AccessFlags2::TRANSFER_READ,
        ),
    );
}
