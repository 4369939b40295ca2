//! A plain ash renderer that embeds gregvox: it creates its own instance, device, images, pipelines and
//! command buffers, asks gregvox what the device needs before creating it, lends gregvox the device
//! (`Gpu::from_external`), and every frame records gregvox's deformation and evaluation into its own
//! command buffer before drawing gregvox's vertex buffer with its own pipeline, in the same render pass as
//! its own geometry (a vertex layout of its own). No host copy of the surface; gregvox submits nothing
//! while the frames run. At the end it destroys gregvox, draws one more frame of its own to show its
//! objects were left alone, and destroys its own.
//!
//! ```text
//! cargo run --example ash_host -- --offscreen --frames 100 --out target/ash_host [--validation]
//!     [--size 640x480] [--cage CAGE.obj] [--level 8] [--adaptive 6]
//! ```
//!
//! `--adaptive PIXELS`: screen-space adaptive tessellation (`--level` the maximum), per-patch levels and
//! indirect draw commands recorded by gregvox into the host's command buffer every frame.
//!
//! Offscreen only: PNG frames into `--out` (the window path is gregvox's own demo). `tests/embedding.rs`
//! runs [`run`] under the validation layer (synchronization validation included) and compares its
//! frames with gregvox's own surface renderer.
use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;
use gregvox::api::{AdaptiveParams, Deformation, ExternalDevice, Gpu, Mesh, SurfaceUpdate};
use std::ffi::{c_void, CStr};
use std::path::PathBuf;
use std::sync::Mutex;

#[allow(dead_code)]
mod host_shaders {
    include!(concat!(env!("OUT_DIR"), "/example_shaders.rs"));
}

#[path = "support/host_common.rs"]
mod host_common;
pub use host_common::{frame_cage, CLEAR};
use host_common::{parse_args, CommonArgs};

/// Frames the host keeps in flight.
const FRAMES_IN_FLIGHT: usize = 2;
const COLOR_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;
const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// How the host runs.
#[derive(Clone, Debug)]
pub struct HostOptions {
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    /// The cage (`None`: gregvox's built-in 4×2×2 box cage).
    pub cage: Option<PathBuf>,
    pub level: u32,
    pub deformation: Deformation,
    pub amplitude: f32,
    /// Seconds between frames.
    pub time_step: f32,
    /// Draw the host's own geometry (a triangle in a corner) beside the surface.
    pub scene: bool,
    /// Frames whose pixels [`run`] returns.
    pub keep: Vec<u32>,
    /// Write every frame as `frame_NNNN.png` here.
    pub out: Option<PathBuf>,
    /// Require the validation layer, with synchronization validation.
    pub validation: bool,
    /// Switch the surface to `level + 2` before this frame, while earlier frames are in flight (its old
    /// buffers must then wait for them).
    pub level_change_at: Option<u32>,
    /// Also draw a second, still surface up to this frame, and drop it right after submitting that frame
    /// (its buffers must wait in gregvox's release queue until the host's timeline says the frame is done).
    pub second_surface_until: Option<u32>,
    /// Screen-space adaptive tessellation (`level` the maximum) at this many pixels per segment: gregvox
    /// records per-patch levels and indirect commands each frame and `record_draw` draws them.
    pub adaptive: Option<f32>,
}

impl Default for HostOptions {
    fn default() -> Self {
        HostOptions {
            width: 320,
            height: 240,
            frames: 100,
            cage: None,
            level: 6,
            deformation: Deformation::Twist,
            amplitude: 0.4,
            time_step: 1.0 / 30.0,
            scene: true,
            keep: Vec::new(),
            out: None,
            validation: false,
            level_change_at: None,
            second_surface_until: None,
            adaptive: None,
        }
    }
}

/// What a run saw.
pub struct HostRun {
    /// (frame, RGBA8 rows top to bottom) of the kept frames.
    pub frames: Vec<(u32, Vec<u8>)>,
    /// The frame the host drew after gregvox was destroyed (its own geometry only).
    pub after_gregvox: Vec<u8>,
    /// Every validation message of the run (the host's messenger: the device's whole life).
    pub validation_messages: Vec<String>,
    /// The camera: Vulkan clip-from-world and the eye.
    pub view_proj: glam::Mat4,
    pub eye: glam::Vec3,
    /// gregvox allocations alive just before gregvox was dropped, after its last frame completed
    /// (the surface dropped first): must be none.
    pub gregvox_allocations_left: Vec<String>,
    /// With `adaptive`: the per-patch levels of the last frame.
    pub adaptive_levels: Vec<u32>,
}

unsafe extern "system" fn host_messenger(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    ty: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    let counts = ty.intersects(
        vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
            | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
    ) && severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
    );
    if counts && !data.is_null() {
        // SAFETY: the layer passes a valid callback-data struct for the duration of the call.
        let data = unsafe { &*data };
        let text = if data.p_message.is_null() {
            "(no message)".to_string()
        } else {
            // SAFETY: a NUL-terminated string owned by the layer.
            unsafe { CStr::from_ptr(data.p_message) }
                .to_string_lossy()
                .into_owned()
        };
        // SAFETY: `user` is the run's message list, which outlives the messenger (see `Host`).
        if let Ok(mut m) = unsafe { &*(user as *const Mutex<Vec<String>>) }.lock() {
            m.push(text);
        }
    }
    vk::FALSE
}

/// An image with its memory and view (the host's own, made with plain Vulkan calls).
struct HostImage {
    image: vk::Image,
    memory: vk::DeviceMemory,
    view: vk::ImageView,
}

/// A buffer with its memory.
struct HostBuffer {
    buffer: vk::Buffer,
    memory: vk::DeviceMemory,
}

/// The host's Vulkan objects.
struct Host {
    /// The messenger's messages (boxed: the messenger holds its address until it is destroyed).
    messages: Box<Mutex<Vec<String>>>,
    entry: ash::Entry,
    instance: ash::Instance,
    messenger: (ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT),
    physical_device: vk::PhysicalDevice,
    device: ash::Device,
    queue: vk::Queue,
    queue_family: u32,
    api_version: u32,
    features: vk::PhysicalDeviceFeatures,
    dynamic_rendering: Option<ash::khr::dynamic_rendering::Device>,
    memory: vk::PhysicalDeviceMemoryProperties,
}

impl Host {
    fn new(validation: bool) -> Result<Host> {
        // SAFETY: loading the system Vulkan loader.
        let entry = unsafe { ash::Entry::load() }.context("loading libvulkan")?;
        // SAFETY: loader call.
        let loader_version =
            unsafe { entry.try_enumerate_instance_version() }?.unwrap_or(vk::API_VERSION_1_0);
        let api_version = vk::API_VERSION_1_3.min(loader_version);
        let app = vk::ApplicationInfo::default()
            .application_name(c"ash_host")
            .api_version(api_version);
        let layers = [c"VK_LAYER_KHRONOS_validation".as_ptr()];
        let extensions = [ash::ext::debug_utils::NAME.as_ptr()];
        let sync = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&sync);
        let mut info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_extension_names(&extensions);
        if validation {
            info = info.enabled_layer_names(&layers).push_next(&mut features);
        }
        // SAFETY: `info` and what it points to live until the call returns.
        let instance = unsafe { entry.create_instance(&info, None) }
            .context("vkCreateInstance (is the validation layer installed?)")?;
        let du = ash::ext::debug_utils::Instance::new(&entry, &instance);
        let messages = Box::new(Mutex::new(Vec::new()));
        let messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                    | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(host_messenger))
            .user_data(&*messages as *const Mutex<Vec<String>> as *mut c_void);
        // SAFETY: valid instance with debug utils enabled.
        let messenger = unsafe { du.create_debug_utils_messenger(&messenger_info, None) }?;
        // The first device gregvox can use, discrete first.
        // SAFETY: valid instance.
        let mut devices = unsafe { instance.enumerate_physical_devices() }?;
        devices.sort_by_key(|&pd| {
            // SAFETY: pd comes from the instance.
            let t = unsafe { instance.get_physical_device_properties(pd) }.device_type;
            (t != vk::PhysicalDeviceType::DISCRETE_GPU) as u8
        });
        let mut refusals = Vec::new();
        let mut chosen = None;
        for pd in devices {
            match Gpu::requirements(&instance, pd, api_version) {
                Ok(req) => {
                    chosen = Some((pd, req));
                    break;
                }
                Err(e) => refusals.push(e.to_string()),
            }
        }
        let Some((physical_device, req)) = chosen else {
            bail!("no device can host gregvox: {}", refusals.join("; "));
        };
        // The device: gregvox's requirements, merged with the host's own (dynamic rendering, which
        // gregvox needs too).
        let features = req.core_features();
        let mut f12 = req.vulkan12_features();
        let mut f13 = req.vulkan13_features();
        let (mut sync2, mut dynr) = req.khr_features();
        let extensions: Vec<*const std::ffi::c_char> =
            req.device_extensions.iter().map(|e| e.as_ptr()).collect();
        let priorities = [1.0f32];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(req.queue_family)
            .queue_priorities(&priorities)];
        let mut info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .enabled_extension_names(&extensions)
            .enabled_features(&features)
            .push_next(&mut f12);
        info = if req.core13 {
            info.push_next(&mut f13)
        } else {
            info.push_next(&mut sync2).push_next(&mut dynr)
        };
        // SAFETY: valid physical device and create info.
        let device = unsafe { instance.create_device(physical_device, &info, None) }?;
        // SAFETY: family and index requested above.
        let queue = unsafe { device.get_device_queue(req.queue_family, 0) };
        let dynamic_rendering =
            (!req.core13).then(|| ash::khr::dynamic_rendering::Device::new(&instance, &device));
        // SAFETY: valid physical device.
        let memory = unsafe { instance.get_physical_device_memory_properties(physical_device) };
        Ok(Host {
            messages,
            entry,
            instance,
            messenger: (du, messenger),
            physical_device,
            device,
            queue,
            queue_family: req.queue_family,
            api_version: req.api_version,
            features,
            dynamic_rendering,
            memory,
        })
    }

    fn memory_type(&self, bits: u32, want: vk::MemoryPropertyFlags) -> Result<u32> {
        (0..self.memory.memory_type_count)
            .find(|&i| {
                bits & (1 << i) != 0
                    && self.memory.memory_types[i as usize]
                        .property_flags
                        .contains(want)
            })
            .ok_or_else(|| anyhow!("no memory type with {want:?}"))
    }

    fn image(
        &self,
        w: u32,
        h: u32,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
    ) -> Result<HostImage> {
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: w,
                height: h,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage);
        let d = &self.device;
        // SAFETY: valid device and create info; each object is destroyed in `destroy_image`.
        unsafe {
            let image = d.create_image(&info, None)?;
            let req = d.get_image_memory_requirements(image);
            let alloc = vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(
                    self.memory_type(req.memory_type_bits, vk::MemoryPropertyFlags::DEVICE_LOCAL)?,
                );
            let memory = d.allocate_memory(&alloc, None)?;
            d.bind_image_memory(image, memory, 0)?;
            let view = d.create_image_view(
                &vk::ImageViewCreateInfo::default()
                    .image(image)
                    .view_type(vk::ImageViewType::TYPE_2D)
                    .format(format)
                    .subresource_range(range(aspect_of(format))),
                None,
            )?;
            Ok(HostImage {
                image,
                memory,
                view,
            })
        }
    }

    fn buffer(&self, bytes: u64, usage: vk::BufferUsageFlags) -> Result<HostBuffer> {
        let d = &self.device;
        // SAFETY: valid device; destroyed in `destroy_buffer`.
        unsafe {
            let buffer = d.create_buffer(
                &vk::BufferCreateInfo::default().size(bytes).usage(usage),
                None,
            )?;
            let req = d.get_buffer_memory_requirements(buffer);
            let alloc = vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(self.memory_type(
                    req.memory_type_bits,
                    vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT,
                )?);
            let memory = d.allocate_memory(&alloc, None)?;
            d.bind_buffer_memory(buffer, memory, 0)?;
            Ok(HostBuffer { buffer, memory })
        }
    }

    fn write(&self, b: &HostBuffer, data: &[u8]) -> Result<()> {
        // SAFETY: host-visible, coherent memory at least `data.len()` long, not in use by the device.
        unsafe {
            let p = self.device.map_memory(
                b.memory,
                0,
                data.len() as u64,
                vk::MemoryMapFlags::empty(),
            )?;
            std::ptr::copy_nonoverlapping(data.as_ptr(), p as *mut u8, data.len());
            self.device.unmap_memory(b.memory);
        }
        Ok(())
    }

    fn read(&self, b: &HostBuffer, bytes: usize) -> Result<Vec<u8>> {
        let mut out = vec![0u8; bytes];
        // SAFETY: host-visible, coherent memory; the copy into it has completed (waited on).
        unsafe {
            let p =
                self.device
                    .map_memory(b.memory, 0, bytes as u64, vk::MemoryMapFlags::empty())?;
            std::ptr::copy_nonoverlapping(p as *const u8, out.as_mut_ptr(), bytes);
            self.device.unmap_memory(b.memory);
        }
        Ok(out)
    }

    fn destroy_image(&self, i: HostImage) {
        // SAFETY: the device is idle.
        unsafe {
            self.device.destroy_image_view(i.view, None);
            self.device.destroy_image(i.image, None);
            self.device.free_memory(i.memory, None);
        }
    }

    fn destroy_buffer(&self, b: HostBuffer) {
        // SAFETY: the device is idle.
        unsafe {
            self.device.destroy_buffer(b.buffer, None);
            self.device.free_memory(b.memory, None);
        }
    }

    fn shader(&self, words: &[u32]) -> Result<vk::ShaderModule> {
        // SAFETY: valid SPIR-V compiled by build.rs.
        Ok(unsafe {
            self.device
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(words), None)
        }?)
    }

    /// A pipeline for dynamic rendering into the host's targets.
    fn pipeline(
        &self,
        layout: vk::PipelineLayout,
        shaders: (&[u32], &[u32]),
        bindings: &[vk::VertexInputBindingDescription],
        attributes: &[vk::VertexInputAttributeDescription],
    ) -> Result<vk::Pipeline> {
        let vs = self.shader(shaders.0)?;
        let fs = self.shader(shaders.1)?;
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(vs)
                .name(c"main"),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(fs)
                .name(c"main"),
        ];
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(bindings)
            .vertex_attribute_descriptions(attributes);
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(vk::CompareOp::LESS);
        let blend = [vk::PipelineColorBlendAttachmentState::default()
            .color_write_mask(vk::ColorComponentFlags::RGBA)];
        let blending = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend);
        let dynamic = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic);
        let formats = [COLOR_FORMAT];
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&formats)
            .depth_attachment_format(DEPTH_FORMAT);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blending)
            .dynamic_state(&dynamic)
            .layout(layout)
            .push_next(&mut rendering);
        // SAFETY: everything `info` points to lives until the call returns.
        let result = unsafe {
            self.device
                .create_graphics_pipelines(vk::PipelineCache::null(), &[info], None)
        };
        // SAFETY: the modules are no longer needed once the pipeline exists (or failed).
        unsafe {
            self.device.destroy_shader_module(vs, None);
            self.device.destroy_shader_module(fs, None);
        }
        result
            .map(|p| p[0])
            .map_err(|(_, e)| anyhow!("vkCreateGraphicsPipelines: {e}"))
    }

    fn begin_rendering(&self, cmd: vk::CommandBuffer, info: &vk::RenderingInfo<'_>) {
        // SAFETY: recording command buffer, outside a render pass.
        unsafe {
            match &self.dynamic_rendering {
                Some(ext) => ext.cmd_begin_rendering(cmd, info),
                None => self.device.cmd_begin_rendering(cmd, info),
            }
        }
    }

    fn end_rendering(&self, cmd: vk::CommandBuffer) {
        // SAFETY: inside the render pass begun by `begin_rendering`.
        unsafe {
            match &self.dynamic_rendering {
                Some(ext) => ext.cmd_end_rendering(cmd),
                None => self.device.cmd_end_rendering(cmd),
            }
        }
    }
}

fn aspect_of(format: vk::Format) -> vk::ImageAspectFlags {
    if format == DEPTH_FORMAT {
        vk::ImageAspectFlags::DEPTH
    } else {
        vk::ImageAspectFlags::COLOR
    }
}

fn range(aspect: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: aspect,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

/// The host's frame resources and pipelines.
struct Frame<'h> {
    host: &'h Host,
    color: HostImage,
    depth: HostImage,
    scene_vertices: HostBuffer,
    scene_layout: vk::PipelineLayout,
    scene_pipeline: vk::Pipeline,
    surface_layout: vk::PipelineLayout,
    surface_pipeline: vk::Pipeline,
    extent: vk::Extent2D,
}

/// Records draws inside the host's render pass.
type DrawFn<'a> = &'a dyn Fn(vk::CommandBuffer) -> Result<()>;

/// What the frames with gregvox gave: the kept frames, the camera, gregvox's allocations left, the last
/// adaptive levels.
type GregvoxFrames = (
    Vec<(u32, Vec<u8>)>,
    glam::Mat4,
    glam::Vec3,
    Vec<String>,
    Vec<u32>,
);

/// The host's push constants for gregvox's vertices.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SurfacePush {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
}

impl<'h> Frame<'h> {
    fn new(host: &'h Host, width: u32, height: u32) -> Result<Frame<'h>> {
        let color = host.image(
            width,
            height,
            COLOR_FORMAT,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
        )?;
        let depth = host.image(
            width,
            height,
            DEPTH_FORMAT,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
        )?;
        // The host's own geometry: one triangle in the lower left corner, (x, y, r, g, b) per vertex.
        let scene: [[f32; 5]; 3] = [
            [-0.95, 0.95, 0.9, 0.3, 0.1],
            [-0.55, 0.95, 0.9, 0.8, 0.1],
            [-0.95, 0.55, 0.2, 0.6, 0.9],
        ];
        let scene_vertices = host.buffer(
            std::mem::size_of_val(&scene) as u64,
            vk::BufferUsageFlags::VERTEX_BUFFER,
        )?;
        host.write(&scene_vertices, bytemuck::cast_slice(&scene))?;
        // SAFETY: valid device; destroyed in `destroy`.
        let scene_layout = unsafe {
            host.device
                .create_pipeline_layout(&vk::PipelineLayoutCreateInfo::default(), None)
        }?;
        let scene_pipeline = host.pipeline(
            scene_layout,
            (host_shaders::HOST_SCENE_VERT, host_shaders::HOST_SCENE_FRAG),
            &[vk::VertexInputBindingDescription {
                binding: 0,
                stride: 20,
                input_rate: vk::VertexInputRate::VERTEX,
            }],
            &[
                vk::VertexInputAttributeDescription {
                    location: 0,
                    binding: 0,
                    format: vk::Format::R32G32_SFLOAT,
                    offset: 0,
                },
                vk::VertexInputAttributeDescription {
                    location: 1,
                    binding: 0,
                    format: vk::Format::R32G32B32_SFLOAT,
                    offset: 8,
                },
            ],
        )?;
        let push = [vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
            offset: 0,
            size: std::mem::size_of::<SurfacePush>() as u32,
        }];
        // SAFETY: valid device; destroyed in `destroy`.
        let surface_layout = unsafe {
            host.device.create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&push),
                None,
            )
        }?;
        // gregvox's vertex layout (api::SurfaceBuffers): position and normal, four f32 each.
        let surface_pipeline = host.pipeline(
            surface_layout,
            (
                host_shaders::HOST_SURFACE_VERT,
                host_shaders::HOST_SURFACE_FRAG,
            ),
            &[vk::VertexInputBindingDescription {
                binding: 0,
                stride: gregvox::api::SurfaceBuffers::VERTEX_STRIDE,
                input_rate: vk::VertexInputRate::VERTEX,
            }],
            &[
                vk::VertexInputAttributeDescription {
                    location: 0,
                    binding: 0,
                    format: vk::Format::R32G32B32A32_SFLOAT,
                    offset: 0,
                },
                vk::VertexInputAttributeDescription {
                    location: 1,
                    binding: 0,
                    format: vk::Format::R32G32B32A32_SFLOAT,
                    offset: 16,
                },
            ],
        )?;
        Ok(Frame {
            host,
            color,
            depth,
            scene_vertices,
            scene_layout,
            scene_pipeline,
            surface_layout,
            surface_pipeline,
            extent: vk::Extent2D { width, height },
        })
    }

    /// Records one frame: targets to attachment layout, the render pass (the host's triangle, then
    /// whatever `draw_surface` records), and the copy of the colour image into `readback`.
    fn record(
        &self,
        cmd: vk::CommandBuffer,
        scene: bool,
        surface: Option<(&SurfacePush, DrawFn<'_>)>,
        readback: &HostBuffer,
    ) -> Result<()> {
        let d = &self.host.device;
        let to_attachments = [
            vk::ImageMemoryBarrier::default()
                .image(self.color.image)
                .subresource_range(range(vk::ImageAspectFlags::COLOR))
                .old_layout(vk::ImageLayout::UNDEFINED)
                .new_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .src_access_mask(vk::AccessFlags::empty())
                .dst_access_mask(vk::AccessFlags::COLOR_ATTACHMENT_WRITE),
            vk::ImageMemoryBarrier::default()
                .image(self.depth.image)
                .subresource_range(range(vk::ImageAspectFlags::DEPTH))
                .old_layout(vk::ImageLayout::UNDEFINED)
                .new_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .src_access_mask(vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE)
                .dst_access_mask(
                    vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
                        | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                ),
        ];
        // SAFETY: recording; the previous frame's copy (transfer) and depth writes come first.
        unsafe {
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER
                    | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS
                    | vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
                vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
                    | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_attachments,
            )
        };
        let color = [vk::RenderingAttachmentInfo::default()
            .image_view(self.color.view)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                color: vk::ClearColorValue { float32: CLEAR },
            })];
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(self.depth.view)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::DONT_CARE)
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: 1.0,
                    stencil: 0,
                },
            });
        let area = vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent: self.extent,
        };
        let info = vk::RenderingInfo::default()
            .render_area(area)
            .layer_count(1)
            .color_attachments(&color)
            .depth_attachment(&depth);
        self.host.begin_rendering(cmd, &info);
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: self.extent.width as f32,
            height: self.extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        // SAFETY: inside the render pass; the pipelines match the attachments' formats.
        unsafe {
            d.cmd_set_viewport(cmd, 0, &[viewport]);
            d.cmd_set_scissor(cmd, 0, &[area]);
            if scene {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.scene_pipeline);
                d.cmd_bind_vertex_buffers(cmd, 0, &[self.scene_vertices.buffer], &[0]);
                d.cmd_draw(cmd, 3, 1, 0, 0);
            }
        }
        if let Some((push, draw)) = surface {
            // SAFETY: inside the render pass.
            unsafe {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.surface_pipeline);
                d.cmd_push_constants(
                    cmd,
                    self.surface_layout,
                    vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                    0,
                    bytemuck::bytes_of(push),
                );
            }
            draw(cmd)?;
        }
        self.host.end_rendering(cmd);
        let to_copy = [vk::ImageMemoryBarrier::default()
            .image(self.color.image)
            .subresource_range(range(vk::ImageAspectFlags::COLOR))
            .old_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .new_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
            .src_access_mask(vk::AccessFlags::COLOR_ATTACHMENT_WRITE)
            .dst_access_mask(vk::AccessFlags::TRANSFER_READ)];
        let copy = vk::BufferImageCopy::default()
            .image_subresource(vk::ImageSubresourceLayers {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            })
            .image_extent(vk::Extent3D {
                width: self.extent.width,
                height: self.extent.height,
                depth: 1,
            });
        let to_host = [vk::BufferMemoryBarrier::default()
            .buffer(readback.buffer)
            .size(vk::WHOLE_SIZE)
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::HOST_READ)];
        // SAFETY: recording, outside the render pass.
        unsafe {
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_copy,
            );
            d.cmd_copy_image_to_buffer(
                cmd,
                self.color.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                readback.buffer,
                &[copy],
            );
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &[],
                &to_host,
                &[],
            );
        }
        Ok(())
    }

    fn destroy(self) {
        let h = self.host;
        // SAFETY: the device is idle.
        unsafe {
            h.device.destroy_pipeline(self.scene_pipeline, None);
            h.device.destroy_pipeline(self.surface_pipeline, None);
            h.device.destroy_pipeline_layout(self.scene_layout, None);
            h.device.destroy_pipeline_layout(self.surface_layout, None);
        }
        h.destroy_buffer(self.scene_vertices);
        h.destroy_image(self.color);
        h.destroy_image(self.depth);
    }
}

/// Submits `cmd` on the host's queue, signalling `timeline` to `value`.
fn submit(host: &Host, cmd: vk::CommandBuffer, timeline: vk::Semaphore, value: u64) -> Result<()> {
    let cmds = [cmd];
    let signal = [timeline];
    let values = [value];
    let mut timeline_info =
        vk::TimelineSemaphoreSubmitInfo::default().signal_semaphore_values(&values);
    let submit = vk::SubmitInfo::default()
        .command_buffers(&cmds)
        .signal_semaphores(&signal)
        .push_next(&mut timeline_info);
    // SAFETY: the command buffer is recorded; the queue is used from this thread only.
    unsafe {
        host.device
            .queue_submit(host.queue, &[submit], vk::Fence::null())
    }?;
    Ok(())
}

fn wait(host: &Host, timeline: vk::Semaphore, value: u64) -> Result<()> {
    let semaphores = [timeline];
    let values = [value];
    let info = vk::SemaphoreWaitInfo::default()
        .semaphores(&semaphores)
        .values(&values);
    // SAFETY: valid timeline semaphore.
    unsafe { host.device.wait_semaphores(&info, u64::MAX) }?;
    Ok(())
}

/// Runs the host as `opts` says (see the module docs).
pub fn run(opts: &HostOptions) -> Result<HostRun> {
    let host = Host::new(opts.validation)?;
    let result = run_on(&host, opts);
    // SAFETY: `run_on` leaves the device idle, with nothing of gregvox's and none of the frame's objects.
    unsafe {
        let _ = host.device.device_wait_idle();
        host.device.destroy_device(None);
        host.messenger
            .0
            .destroy_debug_utils_messenger(host.messenger.1, None);
        host.instance.destroy_instance(None);
    }
    let mut run = result?;
    run.validation_messages = host.messages.lock().map(|m| m.clone()).unwrap_or_default();
    Ok(run)
}

fn run_on(host: &Host, opts: &HostOptions) -> Result<HostRun> {
    let (w, h) = (opts.width, opts.height);
    let frame = Frame::new(host, w, h)?;
    let pixels = w as usize * h as usize * 4;
    let readback: Vec<HostBuffer> = (0..FRAMES_IN_FLIGHT)
        .map(|_| host.buffer(pixels as u64, vk::BufferUsageFlags::TRANSFER_DST))
        .collect::<Result<_>>()?;
    // SAFETY: valid device; destroyed below.
    let pool = unsafe {
        host.device.create_command_pool(
            &vk::CommandPoolCreateInfo::default()
                .queue_family_index(host.queue_family)
                .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
            None,
        )
    }?;
    // SAFETY: valid pool.
    let cmds = unsafe {
        host.device.allocate_command_buffers(
            &vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(FRAMES_IN_FLIGHT as u32),
        )
    }?;
    let mut timeline_type = vk::SemaphoreTypeCreateInfo::default()
        .semaphore_type(vk::SemaphoreType::TIMELINE)
        .initial_value(0);
    // SAFETY: valid device; destroyed below.
    let timeline = unsafe {
        host.device.create_semaphore(
            &vk::SemaphoreCreateInfo::default().push_next(&mut timeline_type),
            None,
        )
    }?;

    let gregvox_part = (|| -> Result<GregvoxFrames> {
        // SAFETY: the device was created with `Gpu::requirements`; it outlives `gpu` (dropped in this
        // closure); the queue is used from this thread only.
        let gpu = unsafe {
            Gpu::from_external(&ExternalDevice {
                entry: host.entry.clone(),
                instance: host.instance.clone(),
                physical_device: host.physical_device,
                device: host.device.clone(),
                queue: host.queue,
                queue_family: host.queue_family,
                api_version: host.api_version,
                enabled_features: host.features,
                debug_utils: true,
                memory_budget: None,
            })
        }?;
        let cage: Mesh = match &opts.cage {
            Some(p) => gregvox::api::load_mesh(p)?,
            None => gregvox::engine::cage::builtin_cage(4, 2, 2),
        };
        let mut surface = gpu.gregory_surface(&cage, opts.level)?;
        let (view_proj, eye) = frame_cage(surface.rest_cage(), w, h);
        if let Some(pixels_per_segment) = opts.adaptive {
            surface.set_adaptive(Some(AdaptiveParams {
                view_proj,
                viewport: [w as f32, h as f32],
                pixels_per_segment,
            }))?;
        }
        let mut second = match opts.second_surface_until {
            Some(_) => Some(gpu.gregory_surface(&gregvox::engine::cage::builtin_cage(1, 1, 1), 2)?),
            None => None,
        };
        let push = SurfacePush {
            view_proj: view_proj.to_cols_array_2d(),
            eye: [eye.x, eye.y, eye.z, 1.0],
        };
        let mut kept = Vec::new();
        let mut in_slot: Vec<Option<u32>> = vec![None; FRAMES_IN_FLIGHT];
        // Reads a finished slot's frame back (kept, or written as PNG).
        let finish_slot =
            |f: Option<u32>, slot: usize, kept: &mut Vec<(u32, Vec<u8>)>| -> Result<()> {
                let Some(f) = f else { return Ok(()) };
                let keep = opts.keep.contains(&f);
                if keep || opts.out.is_some() {
                    let px = host.read(&readback[slot], pixels)?;
                    if let Some(dir) = &opts.out {
                        std::fs::create_dir_all(dir)?;
                        gregvox::gpu::present::write_png_rgba(
                            &dir.join(format!("frame_{f:04}.png")),
                            w,
                            h,
                            &px,
                        )?;
                    }
                    if keep {
                        kept.push((f, px));
                    }
                }
                Ok(())
            };
        for f in 0..opts.frames {
            let slot = f as usize % FRAMES_IN_FLIGHT;
            if f as usize >= FRAMES_IN_FLIGHT {
                // The slot's previous frame (f − FRAMES_IN_FLIGHT) signalled f − FRAMES_IN_FLIGHT + 1.
                wait(host, timeline, (f as usize - FRAMES_IN_FLIGHT + 1) as u64)?;
                finish_slot(in_slot[slot].take(), slot, &mut kept)?;
            }
            let cmd = cmds[slot];
            // SAFETY: the slot's previous submission completed (waited above).
            unsafe {
                host.device
                    .reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())?;
                host.device.begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )?;
            }
            if opts.level_change_at == Some(f) {
                surface.set_level(opts.level + 2)?;
            }
            let recording = gpu.begin_recording()?;
            surface.record(
                cmd,
                &SurfaceUpdate {
                    deformation: opts.deformation,
                    t: f as f32 * opts.time_step,
                    amplitude: opts.amplitude,
                    target: None,
                },
            )?;
            if let Some(s) = &second {
                s.record(cmd, &SurfaceUpdate::default())?;
            }
            let draw = |cmd| -> Result<()> {
                surface.record_draw(cmd)?;
                if let Some(s) = &second {
                    s.record_draw(cmd)?;
                }
                Ok(())
            };
            frame.record(cmd, opts.scene, Some((&push, &draw)), &readback[slot])?;
            // SAFETY: recording state.
            unsafe { host.device.end_command_buffer(cmd) }?;
            submit(host, cmd, timeline, f as u64 + 1)?;
            // SAFETY: submitted on the lent queue just now, signalling `timeline` to f + 1; the semaphore
            // lives until after `gpu` is dropped.
            unsafe { recording.submitted(timeline, f as u64 + 1) };
            if opts.second_surface_until == Some(f) {
                // In flight: gregvox keeps its buffers until the timeline passes f + 1.
                second = None;
            }
            in_slot[slot] = Some(f);
        }
        wait(host, timeline, opts.frames as u64)?;
        for (slot, f) in in_slot.iter_mut().enumerate() {
            finish_slot(f.take(), slot, &mut kept)?;
        }
        kept.sort_by_key(|(f, _)| *f);
        // The last frame's per-patch levels (a one-shot read: the frames are done).
        let levels = match opts.adaptive {
            Some(_) => surface.engine().read_levels(gpu.context())?,
            None => Vec::new(),
        };
        drop(surface);
        gpu.context().poll_external()?;
        let left = gpu.context().live_allocations();
        gpu.finish()?;
        Ok((kept, view_proj, eye, left, levels))
    })();

    // gregvox is gone (or failed); the host's own objects draw one more frame of its own.
    let after = (|| -> Result<Vec<u8>> {
        // SAFETY: everything submitted so far completed (waited, or gregvox waited for the device).
        unsafe { host.device.device_wait_idle() }?;
        let cmd = cmds[0];
        // SAFETY: idle device.
        unsafe {
            host.device
                .reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())?;
            host.device
                .begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default())?;
        }
        frame.record(cmd, true, None, &readback[0])?;
        // SAFETY: recording state.
        unsafe { host.device.end_command_buffer(cmd) }?;
        submit(host, cmd, timeline, opts.frames as u64 + 1)?;
        wait(host, timeline, opts.frames as u64 + 1)?;
        host.read(&readback[0], pixels)
    })();

    // SAFETY: the device is idle once this returns.
    unsafe {
        let _ = host.device.device_wait_idle();
        host.device.destroy_semaphore(timeline, None);
        host.device.destroy_command_pool(pool, None);
    }
    for b in readback {
        host.destroy_buffer(b);
    }
    frame.destroy();
    let (frames, view_proj, eye, left, adaptive_levels) = gregvox_part?;
    Ok(HostRun {
        frames,
        after_gregvox: after?,
        validation_messages: Vec::new(),
        view_proj,
        eye,
        gregvox_allocations_left: left,
        adaptive_levels,
    })
}

#[allow(dead_code)]
fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut opts = HostOptions::default();
    let (mut scene, mut cage, mut adaptive) = (opts.scene, None, None);
    parse_args(
        &args,
        "ash_host --offscreen [--frames N] [--out DIR] [--size WxH] [--cage FILE] [--level L] \
         [--adaptive PIXELS] [--no-scene] [--validation]",
        CommonArgs {
            width: &mut opts.width,
            height: &mut opts.height,
            frames: &mut opts.frames,
            level: &mut opts.level,
            out: &mut opts.out,
            validation: &mut opts.validation,
        },
        |name, next| {
            let value = || next.ok_or_else(|| anyhow!("{name} needs a value"));
            Ok(match name {
                "--no-scene" => {
                    scene = false;
                    Some(false)
                }
                "--cage" => {
                    cage = Some(PathBuf::from(value()?));
                    Some(true)
                }
                "--adaptive" => {
                    adaptive = Some(value()?.parse().context("--adaptive")?);
                    Some(true)
                }
                _ => None,
            })
        },
    )?;
    (opts.scene, opts.cage, opts.adaptive) = (scene, cage, adaptive);
    let run = run(&opts)?;
    if !run.validation_messages.is_empty() {
        bail!(
            "{} validation message(s), the first: {}",
            run.validation_messages.len(),
            run.validation_messages[0]
        );
    }
    if !run.gregvox_allocations_left.is_empty() {
        bail!(
            "gregvox allocations left: {:?}",
            run.gregvox_allocations_left
        );
    }
    println!(
        "ash_host: {} frames{} with a gregvox surface drawn by the host's own pipeline",
        opts.frames,
        opts.out
            .as_ref()
            .map(|d| format!(" written to {}", d.display()))
            .unwrap_or_default()
    );
    Ok(())
}
