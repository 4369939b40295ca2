//! A wgpu program (Vulkan backend) that embeds gregvox: wgpu opens the device, with gregvox's extensions
//! and features added through wgpu-hal's device-creation callback; gregvox gets wgpu's raw device and queue
//! through the hal interop (`Adapter::as_hal`, `Device::as_hal`, `Queue::as_hal`) and evaluates its surface
//! every frame straight into a vertex buffer wgpu owns (made by the host with its memory, handed to wgpu
//! with `create_buffer_from_hal`), which a wgpu render pipeline (WGSL) draws. No host copy of the surface.
//!
//! ```text
//! cargo run --example wgpu_host -- --offscreen --frames 100 --out target/wgpu_host [--validation]
//!     [--size 640x480] [--level 8]
//! ```
//!
//! Offscreen only: PNG frames into `--out`. `tests/embedding.rs` runs [`run`] under the validation layer
//! and compares its frames with gregvox's own surface renderer.
use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;
use gregvox::api::{Deformation, ExternalDevice, Gpu, SurfaceUpdate, VertexTarget};
use std::path::PathBuf;
use wgpu::hal::api::Vulkan;

#[path = "support/host_common.rs"]
mod host_common;
pub use host_common::{frame_cage, CLEAR};
use host_common::{parse_args, CommonArgs};

/// How the host runs.
#[derive(Clone, Debug)]
pub struct HostOptions {
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    pub level: u32,
    pub deformation: Deformation,
    pub amplitude: f32,
    pub time_step: f32,
    /// Frames whose pixels [`run`] returns.
    pub keep: Vec<u32>,
    pub out: Option<PathBuf>,
    /// Ask wgpu for the validation layer (wgpu turns synchronization validation on with it).
    pub validation: bool,
}

impl Default for HostOptions {
    fn default() -> Self {
        HostOptions {
            width: 320,
            height: 240,
            frames: 100,
            level: 6,
            deformation: Deformation::Twist,
            amplitude: 0.4,
            time_step: 1.0 / 30.0,
            keep: Vec::new(),
            out: None,
            validation: false,
        }
    }
}

/// What a run saw.
pub struct HostRun {
    pub frames: Vec<(u32, Vec<u8>)>,
    pub view_proj: glam::Mat4,
    pub eye: glam::Vec3,
    /// Whether the validation layer was on (wgpu falls back silently when it is missing).
    pub validated: bool,
}

const SHADER: &str = r#"
struct Push { view_proj: mat4x4<f32>, eye: vec4<f32> };
@group(0) @binding(0) var<uniform> pc: Push;
struct Out {
    @builtin(position) clip: vec4<f32>,
    @location(0) world_pos: vec3<f32>,
    @location(1) world_normal: vec3<f32>,
};
@vertex
fn vs(@location(0) position: vec4<f32>, @location(1) normal: vec4<f32>) -> Out {
    var o: Out;
    o.world_pos = position.xyz;
    o.world_normal = normal.xyz;
    o.clip = pc.view_proj * vec4<f32>(position.xyz, 1.0);
    return o;
}
@fragment
fn fs(i: Out) -> @location(0) vec4<f32> {
    var n = normalize(i.world_normal);
    let v = normalize(pc.eye.xyz - i.world_pos);
    if (dot(n, v) < 0.0) { n = -n; }
    return vec4<f32>(0.5 * n + 0.5, 1.0);
}
"#;

/// The raw Vulkan side the host keeps beside wgpu: a command pool for gregvox's recordings and the
/// timeline semaphore its submissions signal.
struct RawSide {
    device: ash::Device,
    queue: vk::Queue,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    timeline: vk::Semaphore,
}

impl RawSide {
    fn new(device: ash::Device, queue: vk::Queue, family: u32) -> Result<RawSide> {
        // SAFETY: valid device; destroyed in `destroy`.
        unsafe {
            let pool = device.create_command_pool(
                &vk::CommandPoolCreateInfo::default()
                    .queue_family_index(family)
                    .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                None,
            )?;
            let cmd = device.allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default()
                    .command_pool(pool)
                    .level(vk::CommandBufferLevel::PRIMARY)
                    .command_buffer_count(1),
            )?[0];
            let mut kind = vk::SemaphoreTypeCreateInfo::default()
                .semaphore_type(vk::SemaphoreType::TIMELINE)
                .initial_value(0);
            let timeline = device.create_semaphore(
                &vk::SemaphoreCreateInfo::default().push_next(&mut kind),
                None,
            )?;
            Ok(RawSide {
                device,
                queue,
                pool,
                cmd,
                timeline,
            })
        }
    }

    fn wait(&self, value: u64) -> Result<()> {
        let s = [self.timeline];
        let v = [value];
        // SAFETY: valid timeline semaphore.
        unsafe {
            self.device.wait_semaphores(
                &vk::SemaphoreWaitInfo::default().semaphores(&s).values(&v),
                u64::MAX,
            )
        }?;
        Ok(())
    }

    fn destroy(&self) {
        // SAFETY: every submission of the pool has completed (waited on).
        unsafe {
            self.device.destroy_semaphore(self.timeline, None);
            self.device.destroy_command_pool(self.pool, None);
        }
    }
}

/// A buffer the host makes on the raw device (so it knows its `vk::Buffer`) and hands to wgpu, which
/// then owns it (and frees its memory) like any buffer of its own.
fn raw_vertex_buffer(
    instance: &ash::Instance,
    physical_device: vk::PhysicalDevice,
    device: &ash::Device,
    bytes: u64,
) -> Result<(vk::Buffer, vk::DeviceMemory)> {
    // SAFETY: valid device; the buffer and memory go to wgpu (`from_raw_managed`), which destroys them.
    unsafe {
        let buffer = device.create_buffer(
            &vk::BufferCreateInfo::default().size(bytes).usage(
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::VERTEX_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_SRC
                    | vk::BufferUsageFlags::TRANSFER_DST,
            ),
            None,
        )?;
        let req = device.get_buffer_memory_requirements(buffer);
        let props = instance.get_physical_device_memory_properties(physical_device);
        let index = (0..props.memory_type_count)
            .find(|&i| {
                req.memory_type_bits & (1 << i) != 0
                    && props.memory_types[i as usize]
                        .property_flags
                        .contains(vk::MemoryPropertyFlags::DEVICE_LOCAL)
            })
            .ok_or_else(|| anyhow!("no device-local memory for the vertex buffer"))?;
        let memory = device.allocate_memory(
            &vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(index),
            None,
        )?;
        device.bind_buffer_memory(buffer, memory, 0)?;
        Ok((buffer, memory))
    }
}

/// Runs the host as `opts` says (see the module docs).
pub fn run(opts: &HostOptions) -> Result<HostRun> {
    let mut flags = wgpu::InstanceFlags::empty();
    if opts.validation {
        flags |= wgpu::InstanceFlags::VALIDATION | wgpu::InstanceFlags::DEBUG;
    }
    let instance = wgpu::Instance::new(&wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        flags,
        ..Default::default()
    });
    let adapter =
        pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
            .context("no Vulkan adapter for wgpu")?;
    let features = wgpu::Features::empty();
    // SAFETY: the adapter is a Vulkan one (only that backend was asked for).
    let hal_instance =
        unsafe { instance.as_hal::<Vulkan>() }.ok_or_else(|| anyhow!("not Vulkan"))?;
    let shared = hal_instance.shared_instance();
    let api_version = shared.instance_api_version();
    let validated = shared.extensions().contains(&ash::ext::debug_utils::NAME) && opts.validation;
    let (open, requirements) = {
        // SAFETY: as above.
        let hal_adapter =
            unsafe { adapter.as_hal::<Vulkan>() }.ok_or_else(|| anyhow!("not a Vulkan adapter"))?;
        let req = Gpu::requirements(
            shared.raw_instance(),
            hal_adapter.raw_physical_device(),
            api_version,
        )?;
        // wgpu chains the features promoted to 1.2/1.3 one struct each (timeline semaphores among them),
        // so gregvox's others are added the same way, never as PhysicalDeviceVulkan12/13Features.
        let mut host_query_reset =
            vk::PhysicalDeviceHostQueryResetFeatures::default().host_query_reset(true);
        let mut scalar =
            vk::PhysicalDeviceScalarBlockLayoutFeatures::default().scalar_block_layout(true);
        let (mut sync2, mut dynamic_rendering) = req.khr_features();
        let extensions = req.device_extensions.clone();
        let callback: Box<wgpu::hal::vulkan::CreateDeviceCallback<'_>> = Box::new(|args| {
            for e in extensions {
                if !args.extensions.contains(&e) {
                    args.extensions.push(e);
                }
            }
            *args.create_info = std::mem::take(args.create_info)
                .push_next(&mut host_query_reset)
                .push_next(&mut scalar)
                .push_next(&mut sync2)
                .push_next(&mut dynamic_rendering);
        });
        // SAFETY: the callback adds extensions and features the adapter has (`requirements` checked them).
        let open = unsafe {
            hal_adapter.open_with_callback(features, &wgpu::MemoryHints::default(), Some(callback))
        }
        .map_err(|e| anyhow!("opening the device through wgpu-hal: {e}"))?;
        (open, req)
    };
    let desc = wgpu::DeviceDescriptor {
        label: Some("wgpu_host"),
        required_features: features,
        ..Default::default()
    };
    // SAFETY: `open` was created from this adapter with `features`.
    let (device, queue) = unsafe { adapter.create_device_from_hal(open, &desc) }?;
    let (raw_device, raw_queue, family, physical_device) = {
        // SAFETY: Vulkan device and queue.
        let d = unsafe { device.as_hal::<Vulkan>() }.ok_or_else(|| anyhow!("not Vulkan"))?;
        // SAFETY: as above.
        let q = unsafe { queue.as_hal::<Vulkan>() }.ok_or_else(|| anyhow!("not Vulkan"))?;
        let _ = &q;
        (
            d.raw_device().clone(),
            d.raw_queue(),
            d.queue_family_index(),
            d.raw_physical_device(),
        )
    };
    let raw_instance = shared.raw_instance().clone();
    let raw = RawSide::new(raw_device.clone(), raw_queue, family)?;
    let result = frames(
        opts,
        &FramesCtx {
            entry: shared.entry().clone(),
            instance: raw_instance,
            physical_device,
            raw: &raw,
            family,
            api_version: requirements.api_version,
            validated,
            device: &device,
            queue: &queue,
        },
    );
    // SAFETY: gregvox is gone and every submission completed; wgpu is idle after its poll.
    let _ = device.poll(wgpu::PollType::wait_indefinitely());
    raw.destroy();
    let mut run = result?;
    run.validated = validated;
    Ok(run)
}

struct FramesCtx<'a> {
    entry: ash::Entry,
    instance: ash::Instance,
    physical_device: vk::PhysicalDevice,
    raw: &'a RawSide,
    family: u32,
    api_version: u32,
    validated: bool,
    device: &'a wgpu::Device,
    queue: &'a wgpu::Queue,
}

fn frames(opts: &HostOptions, c: &FramesCtx) -> Result<HostRun> {
    let (w, h) = (opts.width, opts.height);
    // SAFETY: wgpu's device, created with gregvox's requirements; it outlives `gpu` (dropped in this
    // function); this thread alone uses the queue.
    let gpu = unsafe {
        Gpu::from_external(&ExternalDevice {
            entry: c.entry.clone(),
            instance: c.instance.clone(),
            physical_device: c.physical_device,
            device: c.raw.device.clone(),
            queue: c.raw.queue,
            queue_family: c.family,
            api_version: c.api_version,
            // wgpu decides the core features; gregvox uses none of its optional ones here.
            enabled_features: vk::PhysicalDeviceFeatures::default(),
            debug_utils: c.validated,
            memory_budget: None,
        })
    }?;
    let cage = gregvox::engine::cage::builtin_cage(4, 2, 2);
    let surface = gpu.gregory_surface(&cage, opts.level)?;
    let (view_proj, eye) = frame_cage(surface.rest_cage(), w, h);

    // The vertex buffer: the host's raw buffer, owned by wgpu from here on; gregvox evaluates into it.
    let bytes = surface.vertex_bytes();
    let (raw_buffer, memory) =
        raw_vertex_buffer(&c.instance, c.physical_device, &c.raw.device, bytes)?;
    // SAFETY: created on this device with VERTEX | STORAGE usage and bound memory of `bytes`.
    let vertices = unsafe {
        let hal = wgpu::hal::vulkan::Buffer::from_raw_managed(raw_buffer, memory, 0, bytes);
        c.device.create_buffer_from_hal::<Vulkan>(
            hal,
            &wgpu::BufferDescriptor {
                label: Some("gregvox vertices (wgpu's)"),
                size: bytes,
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            },
        )
    };
    let indices = surface.indices();
    let index_buffer = wgpu::util::DeviceExt::create_buffer_init(
        c.device,
        &wgpu::util::BufferInitDescriptor {
            label: Some("grid indices"),
            contents: bytemuck::cast_slice(&indices),
            usage: wgpu::BufferUsages::INDEX,
        },
    );
    // wgpu's clip space has y up (its Vulkan backend flips the viewport); the shared camera is Vulkan's
    // (y down), so the host flips it back.
    let wgpu_view_proj = glam::Mat4::from_scale(glam::Vec3::new(1.0, -1.0, 1.0)) * view_proj;
    let mut push = Vec::with_capacity(80);
    push.extend_from_slice(bytemuck::cast_slice(&wgpu_view_proj.to_cols_array()));
    push.extend_from_slice(bytemuck::cast_slice(&[eye.x, eye.y, eye.z, 1.0f32]));
    let uniform = wgpu::util::DeviceExt::create_buffer_init(
        c.device,
        &wgpu::util::BufferInitDescriptor {
            label: Some("camera"),
            contents: &push,
            usage: wgpu::BufferUsages::UNIFORM,
        },
    );
    // Parsed here and handed over as naga IR: given WGSL text, wgpu (with `InstanceFlags::DEBUG`, which
    // its debug-utils messenger needs) embeds the text as `OpSource WGSL`, a source language older
    // SPIR-V validators reject ("Invalid source language operand"), and this host runs validated.
    let module = wgpu::naga::front::wgsl::parse_str(SHADER).expect("the host's WGSL parses");
    let shader = c.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("normals"),
        source: wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(module)),
    });
    let layout = c
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
    let bind = c.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: uniform.as_entire_binding(),
        }],
    });
    let pipeline_layout = c
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[&layout],
            ..Default::default()
        });
    let attributes = wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x4];
    let pipeline = c
        .device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("gregvox surface, wgpu pipeline"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[wgpu::VertexBufferLayout {
                    array_stride: gregvox::api::SurfaceBuffers::VERTEX_STRIDE as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &attributes,
                }],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: true,
                depth_compare: wgpu::CompareFunction::Less,
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::TextureFormat::Rgba8Unorm.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
    let extent = wgpu::Extent3d {
        width: w,
        height: h,
        depth_or_array_layers: 1,
    };
    let color = c.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("color"),
        size: extent,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let depth = c.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("depth"),
        size: extent,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Depth32Float,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    let color_view = color.create_view(&Default::default());
    let depth_view = depth.create_view(&Default::default());
    let row = (w * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = c.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: row as u64 * h as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });

    let mut kept = Vec::new();
    for f in 0..opts.frames {
        // gregvox: into the host's raw command buffer, submitted on wgpu's queue before wgpu's frame.
        let cmd = c.raw.cmd;
        // SAFETY: the previous frame's submissions completed (waited at the end of each frame).
        unsafe {
            c.raw
                .device
                .reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())?;
            c.raw.device.begin_command_buffer(
                cmd,
                &vk::CommandBufferBeginInfo::default()
                    .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )?;
        }
        let recording = gpu.begin_recording()?;
        surface.record(
            cmd,
            &SurfaceUpdate {
                deformation: opts.deformation,
                t: f as f32 * opts.time_step,
                amplitude: opts.amplitude,
                target: Some(VertexTarget {
                    buffer: raw_buffer,
                    offset: 0,
                    size: bytes,
                }),
            },
        )?;
        let value = f as u64 + 1;
        // SAFETY: recorded; the queue is wgpu's, used from this thread only; wgpu submits after it.
        unsafe {
            c.raw.device.end_command_buffer(cmd)?;
            let cmds = [cmd];
            let signal = [c.raw.timeline];
            let values = [value];
            let mut timeline =
                vk::TimelineSemaphoreSubmitInfo::default().signal_semaphore_values(&values);
            let submit = vk::SubmitInfo::default()
                .command_buffers(&cmds)
                .signal_semaphores(&signal)
                .push_next(&mut timeline);
            c.raw
                .device
                .queue_submit(c.raw.queue, &[submit], vk::Fence::null())?;
            recording.submitted(c.raw.timeline, value);
        }
        // wgpu: draw the vertices gregvox wrote (its end barrier made them visible to vertex input).
        let mut encoder = c.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("frame"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &color_view,
                    resolve_target: None,
                    depth_slice: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: CLEAR[0].into(),
                            g: CLEAR[1].into(),
                            b: CLEAR[2].into(),
                            a: CLEAR[3].into(),
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                ..Default::default()
            });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.set_vertex_buffer(0, vertices.slice(..));
            pass.set_index_buffer(index_buffer.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..indices.len() as u32, 0, 0..1);
        }
        encoder.copy_texture_to_buffer(
            color.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(h),
                },
            },
            extent,
        );
        c.queue.submit([encoder.finish()]);
        c.raw.wait(value)?;
        let keep = opts.keep.contains(&f);
        if keep || opts.out.is_some() {
            let slice = readback.slice(..);
            slice.map_async(wgpu::MapMode::Read, |_| {});
            c.device
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| anyhow!("wgpu poll: {e}"))?;
            let px: Vec<u8> = {
                let data = slice.get_mapped_range();
                data.chunks(row as usize)
                    .flat_map(|r| r[..w as usize * 4].to_vec())
                    .collect()
            };
            readback.unmap();
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
        } else {
            c.device
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| anyhow!("wgpu poll: {e}"))?;
        }
    }
    drop(surface);
    gpu.finish()?;
    Ok(HostRun {
        frames: kept,
        view_proj,
        eye,
        validated: c.validated,
    })
}

#[allow(dead_code)]
fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut opts = HostOptions::default();
    parse_args(
        &args,
        "wgpu_host --offscreen [--frames N] [--out DIR] [--size WxH] [--level L] [--validation]",
        CommonArgs {
            width: &mut opts.width,
            height: &mut opts.height,
            frames: &mut opts.frames,
            level: &mut opts.level,
            out: &mut opts.out,
            validation: &mut opts.validation,
        },
        |_, _| Ok(None),
    )?;
    let run = run(&opts)?;
    if opts.validation && !run.validated {
        bail!("--validation: wgpu found no validation layer");
    }
    println!(
        "wgpu_host: {} frames{} with a gregvox surface evaluated into a wgpu vertex buffer",
        opts.frames,
        opts.out
            .as_ref()
            .map(|d| format!(" written to {}", d.display()))
            .unwrap_or_default()
    );
    Ok(())
}
