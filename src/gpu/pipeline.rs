//! Small builders for shader modules, descriptor set layouts and pools, compute pipelines and graphics
//! pipelines with dynamic rendering, and dispatch helpers that respect `maxComputeWorkGroupCount`.
//!
//! Invariants: a pipeline value owns its `vk::Pipeline`, its `vk::PipelineLayout` and the descriptor set
//! layouts handed to it, and releases them when dropped (`gpu::lifetime`); shader modules live only while a
//! pipeline is built. Every constructor releases what it made on any error, with no cleanup code: each
//! handle is owned from the moment it exists.
//! Large 1D dispatches are split into a 2D grid whose x extent is a full row; shaders rebuild the linear
//! index with `linear_invocation()` from `glsl/include/dispatch.glsl`.
use super::context::Context;
use super::lifetime::Owned;
use crate::error::{Error, Result, VkContext};
use ash::vk;

/// Creates a shader module from SPIR-V words.
pub fn shader_module(ctx: &Context, name: &str, spirv: &[u32]) -> Result<vk::ShaderModule> {
    let info = vk::ShaderModuleCreateInfo::default().code(spirv);
    // SAFETY: spirv is u32-aligned SPIR-V produced by build.rs.
    let m = unsafe { ctx.device.create_shader_module(&info, None) }.vk("vkCreateShaderModule")?;
    ctx.set_name(m, name);
    Ok(m)
}

/// One descriptor of a push-descriptor set.
#[derive(Clone, Copy, Debug)]
pub enum Binding {
    /// A whole storage buffer.
    Storage(vk::Buffer),
    /// A range of a storage buffer (`offset` a multiple of `minStorageBufferOffsetAlignment`, `range` at
    /// most `maxStorageBufferRange`): how passes reach buffers larger than one binding may hold.
    StorageRange {
        buffer: vk::Buffer,
        offset: u64,
        range: u64,
    },
    /// A whole uniform buffer.
    Uniform(vk::Buffer),
    /// A combined image sampler.
    Sampled {
        view: vk::ImageView,
        sampler: vk::Sampler,
        layout: vk::ImageLayout,
    },
    /// A storage image.
    StorageImage {
        view: vk::ImageView,
        layout: vk::ImageLayout,
    },
}

impl Binding {
    /// The Vulkan descriptor type.
    pub fn descriptor_type(&self) -> vk::DescriptorType {
        match self {
            Binding::Storage(_) | Binding::StorageRange { .. } => {
                vk::DescriptorType::STORAGE_BUFFER
            }
            Binding::Uniform(_) => vk::DescriptorType::UNIFORM_BUFFER,
            Binding::Sampled { .. } => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            Binding::StorageImage { .. } => vk::DescriptorType::STORAGE_IMAGE,
        }
    }
}

/// Builds a descriptor set layout binding by binding.
#[derive(Default)]
pub struct DescriptorSetLayoutBuilder {
    bindings: Vec<vk::DescriptorSetLayoutBinding<'static>>,
}

impl DescriptorSetLayoutBuilder {
    /// An empty layout.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a binding of `ty` visible to `stages`.
    pub fn binding(
        mut self,
        binding: u32,
        ty: vk::DescriptorType,
        stages: vk::ShaderStageFlags,
    ) -> Self {
        self.bindings.push(
            vk::DescriptorSetLayoutBinding::default()
                .binding(binding)
                .descriptor_type(ty)
                .descriptor_count(1)
                .stage_flags(stages),
        );
        self
    }

    /// Adds a storage buffer binding.
    pub fn storage_buffer(self, binding: u32, stages: vk::ShaderStageFlags) -> Self {
        self.binding(binding, vk::DescriptorType::STORAGE_BUFFER, stages)
    }

    /// Adds a uniform buffer binding.
    pub fn uniform_buffer(self, binding: u32, stages: vk::ShaderStageFlags) -> Self {
        self.binding(binding, vk::DescriptorType::UNIFORM_BUFFER, stages)
    }

    /// Adds a combined image sampler binding.
    pub fn sampled_image(self, binding: u32, stages: vk::ShaderStageFlags) -> Self {
        self.binding(binding, vk::DescriptorType::COMBINED_IMAGE_SAMPLER, stages)
    }

    /// Adds a storage image binding.
    pub fn storage_image(self, binding: u32, stages: vk::ShaderStageFlags) -> Self {
        self.binding(binding, vk::DescriptorType::STORAGE_IMAGE, stages)
    }

    /// Creates a push-descriptor layout (descriptors are pushed with `Context::cmd_push_descriptors`).
    pub fn build(&self, ctx: &Context, name: &str) -> Result<Owned<vk::DescriptorSetLayout>> {
        let info = vk::DescriptorSetLayoutCreateInfo::default()
            .bindings(&self.bindings)
            .flags(vk::DescriptorSetLayoutCreateFlags::PUSH_DESCRIPTOR_KHR);
        // SAFETY: valid create info.
        let l = unsafe { ctx.device.create_descriptor_set_layout(&info, None) }
            .vk("vkCreateDescriptorSetLayout")?;
        Ok(ctx.own(l, name))
    }
}

/// A compute pipeline with its layout and owned set layouts, released when dropped.
pub struct ComputePipeline {
    raw: Owned<vk::Pipeline>,
    layout: Owned<vk::PipelineLayout>,
    _set_layouts: Vec<Owned<vk::DescriptorSetLayout>>,
    local_size: u32,
    name: String,
}

impl ComputePipeline {
    /// Builds a compute pipeline from SPIR-V, taking ownership of `set_layouts`.
    /// `local_size` is the shader's `local_size_x` (for dispatch helpers).
    pub fn new(
        ctx: &Context,
        name: &str,
        spirv: &[u32],
        set_layouts: Vec<Owned<vk::DescriptorSetLayout>>,
        push_constant_bytes: u32,
        local_size: u32,
    ) -> Result<Self> {
        let layout = pipeline_layout(
            ctx,
            name,
            &set_layouts,
            push_constant_bytes,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let module = shader_module(ctx, name, spirv)?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let info = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout.raw())];
        // SAFETY: valid module and layout.
        let result = unsafe {
            ctx.device
                .create_compute_pipelines(vk::PipelineCache::null(), &info, None)
        };
        // SAFETY: modules may be destroyed once the pipeline exists (or failed to).
        unsafe { ctx.device.destroy_shader_module(module, None) };
        let raw = result.map_err(|(_, result)| Error::Vulkan {
            call: "vkCreateComputePipelines",
            result,
        })?[0];
        Ok(ComputePipeline {
            raw: ctx.own(raw, name),
            layout,
            _set_layouts: set_layouts,
            local_size,
            name: name.into(),
        })
    }

    /// The pipeline handle.
    pub fn raw(&self) -> vk::Pipeline {
        self.raw.raw()
    }

    /// The pipeline layout (push constants, push descriptors).
    pub fn layout(&self) -> vk::PipelineLayout {
        self.layout.raw()
    }

    /// The shader's `local_size_x`.
    pub fn local_size(&self) -> u32 {
        self.local_size
    }

    /// The debug name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Binds the pipeline, pushes `bindings` as set 0 (a push-descriptor layout) and `push` as push
    /// constants (each if non-empty).
    pub fn bind(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        bindings: &[(u32, Binding)],
        push: &[u8],
    ) {
        // SAFETY: recording command buffer.
        unsafe {
            ctx.device
                .cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.raw())
        };
        if !bindings.is_empty() {
            ctx.cmd_push_descriptors(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout(),
                0,
                bindings,
            );
        }
        if !push.is_empty() {
            // SAFETY: recording command buffer; the layout has a push-constant range of at least push.len().
            unsafe {
                ctx.device.cmd_push_constants(
                    cmd,
                    self.layout(),
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    push,
                )
            };
        }
    }

    /// Dispatches enough groups for `invocations` threads, split into 2D beyond the device limit.
    pub fn dispatch_linear(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        invocations: u64,
    ) -> Result<()> {
        let [x, y, z] = dispatch_grid(
            invocations,
            self.local_size,
            ctx.limits.max_compute_work_group_count,
        )?;
        if x > 0 {
            // SAFETY: recording command buffer with this pipeline bound.
            unsafe { ctx.device.cmd_dispatch(cmd, x, y, z) };
        }
        Ok(())
    }
}

fn pipeline_layout(
    ctx: &Context,
    name: &str,
    set_layouts: &[Owned<vk::DescriptorSetLayout>],
    push_constant_bytes: u32,
    stages: vk::ShaderStageFlags,
) -> Result<Owned<vk::PipelineLayout>> {
    if push_constant_bytes > ctx.limits.max_push_constants_size {
        return Err(Error::Limit {
            what: format!("{push_constant_bytes} bytes of push constants in '{name}'"),
            detail: format!(
                "maxPushConstantsSize is {}",
                ctx.limits.max_push_constants_size
            ),
        });
    }
    let ranges = [vk::PushConstantRange {
        stage_flags: stages,
        offset: 0,
        size: push_constant_bytes,
    }];
    let raw_layouts: Vec<vk::DescriptorSetLayout> = set_layouts.iter().map(Owned::raw).collect();
    let mut info = vk::PipelineLayoutCreateInfo::default().set_layouts(&raw_layouts);
    if push_constant_bytes > 0 {
        info = info.push_constant_ranges(&ranges);
    }
    // SAFETY: valid create info.
    let l =
        unsafe { ctx.device.create_pipeline_layout(&info, None) }.vk("vkCreatePipelineLayout")?;
    Ok(ctx.own(l, &format!("{name} (layout)")))
}

/// The group counts `[x, y, 1]` that cover `invocations` threads of `local_size`, with x ≤ `max[0]`:
/// beyond it the groups fill whole rows of x and the last row overshoots (shaders bound-check).
///
/// ```
/// use gregvox::gpu::pipeline::dispatch_grid;
/// assert_eq!(dispatch_grid(100, 64, [65535; 3]).unwrap(), [2, 1, 1]);
/// // 5,000,000 threads of 64 are 78,125 groups: two rows of 65,535.
/// assert_eq!(dispatch_grid(5_000_000, 64, [65535; 3]).unwrap(), [65535, 2, 1]);
/// assert_eq!(dispatch_grid(0, 64, [65535; 3]).unwrap(), [0, 0, 0]);
/// ```
pub fn dispatch_grid(invocations: u64, local_size: u32, max: [u32; 3]) -> Result<[u32; 3]> {
    if invocations == 0 {
        return Ok([0, 0, 0]);
    }
    let groups = invocations.div_ceil(local_size.max(1) as u64);
    let max_x = max[0].max(1) as u64;
    if groups <= max_x {
        return Ok([groups as u32, 1, 1]);
    }
    let rows = groups.div_ceil(max_x);
    if rows > max[1] as u64 {
        return Err(Error::Limit {
            what: format!("a dispatch of {invocations} invocations"),
            detail: format!(
                "more than {} × {} workgroups of {local_size}",
                max[0], max[1]
            ),
        });
    }
    Ok([max_x as u32, rows as u32, 1])
}

/// Describes a graphics pipeline drawn with dynamic rendering.
pub struct GraphicsDesc<'a> {
    pub vertex: &'a [u32],
    pub fragment: Option<&'a [u32]>,
    pub tess_control: Option<&'a [u32]>,
    pub tess_eval: Option<&'a [u32]>,
    pub geometry: Option<&'a [u32]>,
    pub vertex_bindings: Vec<vk::VertexInputBindingDescription>,
    pub vertex_attributes: Vec<vk::VertexInputAttributeDescription>,
    pub topology: vk::PrimitiveTopology,
    pub patch_control_points: u32,
    pub polygon_mode: vk::PolygonMode,
    pub cull_mode: vk::CullModeFlags,
    pub front_face: vk::FrontFace,
    pub depth_test: bool,
    pub depth_write: bool,
    pub depth_compare: vk::CompareOp,
    pub depth_bias: bool,
    pub color_formats: Vec<vk::Format>,
    pub depth_format: vk::Format,
    pub blend: bool,
    /// Rasterization samples (the colour and depth targets' sample count).
    pub samples: vk::SampleCountFlags,
    /// Set layouts the pipeline takes ownership of.
    pub set_layouts: Vec<Owned<vk::DescriptorSetLayout>>,
    pub push_constant_bytes: u32,
    pub push_constant_stages: vk::ShaderStageFlags,
}

impl<'a> GraphicsDesc<'a> {
    /// Triangles, no culling, depth test LESS with writes, one color target, no vertex input.
    pub fn new(
        vertex: &'a [u32],
        fragment: &'a [u32],
        color: vk::Format,
        depth: vk::Format,
    ) -> Self {
        GraphicsDesc {
            vertex,
            fragment: Some(fragment),
            tess_control: None,
            tess_eval: None,
            geometry: None,
            vertex_bindings: Vec::new(),
            vertex_attributes: Vec::new(),
            topology: vk::PrimitiveTopology::TRIANGLE_LIST,
            patch_control_points: 0,
            polygon_mode: vk::PolygonMode::FILL,
            cull_mode: vk::CullModeFlags::NONE,
            front_face: vk::FrontFace::COUNTER_CLOCKWISE,
            depth_test: depth != vk::Format::UNDEFINED,
            depth_write: depth != vk::Format::UNDEFINED,
            depth_compare: vk::CompareOp::LESS,
            depth_bias: false,
            color_formats: if color == vk::Format::UNDEFINED {
                Vec::new()
            } else {
                vec![color]
            },
            depth_format: depth,
            blend: false,
            samples: vk::SampleCountFlags::TYPE_1,
            set_layouts: Vec::new(),
            push_constant_bytes: 0,
            push_constant_stages: vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
        }
    }
}

/// A graphics pipeline with its layout and owned set layouts, released when dropped.
pub struct GraphicsPipeline {
    raw: Owned<vk::Pipeline>,
    layout: Owned<vk::PipelineLayout>,
    _set_layouts: Vec<Owned<vk::DescriptorSetLayout>>,
    push_constant_stages: vk::ShaderStageFlags,
    name: String,
}

impl GraphicsPipeline {
    /// Builds the pipeline; viewport and scissor are dynamic state. Takes ownership of the set layouts.
    pub fn new(ctx: &Context, name: &str, desc: GraphicsDesc<'_>) -> Result<Self> {
        let layout = pipeline_layout(
            ctx,
            name,
            &desc.set_layouts,
            desc.push_constant_bytes,
            desc.push_constant_stages,
        )?;
        let mut modules = Vec::new();
        let mut stages = Vec::new();
        let mut result = Ok(());
        for (stage, code) in [
            (vk::ShaderStageFlags::VERTEX, Some(desc.vertex)),
            (
                vk::ShaderStageFlags::TESSELLATION_CONTROL,
                desc.tess_control,
            ),
            (
                vk::ShaderStageFlags::TESSELLATION_EVALUATION,
                desc.tess_eval,
            ),
            (vk::ShaderStageFlags::GEOMETRY, desc.geometry),
            (vk::ShaderStageFlags::FRAGMENT, desc.fragment),
        ] {
            let Some(code) = code else { continue };
            match shader_module(ctx, &format!("{name} {stage:?}"), code) {
                Ok(m) => {
                    modules.push(m);
                    stages.push(
                        vk::PipelineShaderStageCreateInfo::default()
                            .stage(stage)
                            .module(m)
                            .name(c"main"),
                    );
                }
                Err(e) => {
                    result = Err(e);
                    break;
                }
            }
        }
        let pipeline = result.and_then(|()| {
            let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
                .vertex_binding_descriptions(&desc.vertex_bindings)
                .vertex_attribute_descriptions(&desc.vertex_attributes);
            let input_assembly =
                vk::PipelineInputAssemblyStateCreateInfo::default().topology(desc.topology);
            let tess = vk::PipelineTessellationStateCreateInfo::default()
                .patch_control_points(desc.patch_control_points);
            let viewport = vk::PipelineViewportStateCreateInfo::default()
                .viewport_count(1)
                .scissor_count(1);
            let raster = vk::PipelineRasterizationStateCreateInfo::default()
                .polygon_mode(desc.polygon_mode)
                .cull_mode(desc.cull_mode)
                .front_face(desc.front_face)
                .depth_bias_enable(desc.depth_bias)
                .line_width(1.0);
            let multisample = vk::PipelineMultisampleStateCreateInfo::default()
                .rasterization_samples(desc.samples);
            let depth = vk::PipelineDepthStencilStateCreateInfo::default()
                .depth_test_enable(desc.depth_test)
                .depth_write_enable(desc.depth_write)
                .depth_compare_op(desc.depth_compare);
            let attachments: Vec<vk::PipelineColorBlendAttachmentState> = desc
                .color_formats
                .iter()
                .map(|_| {
                    vk::PipelineColorBlendAttachmentState::default()
                        .blend_enable(desc.blend)
                        .src_color_blend_factor(vk::BlendFactor::SRC_ALPHA)
                        .dst_color_blend_factor(vk::BlendFactor::ONE_MINUS_SRC_ALPHA)
                        .color_blend_op(vk::BlendOp::ADD)
                        .src_alpha_blend_factor(vk::BlendFactor::ONE)
                        .dst_alpha_blend_factor(vk::BlendFactor::ONE_MINUS_SRC_ALPHA)
                        .alpha_blend_op(vk::BlendOp::ADD)
                        .color_write_mask(vk::ColorComponentFlags::RGBA)
                })
                .collect();
            let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&attachments);
            let mut dyn_states = vec![vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
            if desc.depth_bias {
                dyn_states.push(vk::DynamicState::DEPTH_BIAS);
            }
            let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dyn_states);
            let stencil_format = vk::Format::UNDEFINED;
            let mut rendering = vk::PipelineRenderingCreateInfo::default()
                .color_attachment_formats(&desc.color_formats)
                .depth_attachment_format(desc.depth_format)
                .stencil_attachment_format(stencil_format);
            let mut info = vk::GraphicsPipelineCreateInfo::default()
                .stages(&stages)
                .vertex_input_state(&vertex_input)
                .input_assembly_state(&input_assembly)
                .viewport_state(&viewport)
                .rasterization_state(&raster)
                .multisample_state(&multisample)
                .depth_stencil_state(&depth)
                .color_blend_state(&blend)
                .dynamic_state(&dynamic)
                .layout(layout.raw())
                .push_next(&mut rendering);
            if desc.tess_control.is_some() {
                info = info.tessellation_state(&tess);
            }
            // SAFETY: everything referenced lives until the call returns.
            unsafe {
                ctx.device
                    .create_graphics_pipelines(vk::PipelineCache::null(), &[info], None)
            }
            .map(|p| p[0])
            .map_err(|(_, result)| Error::Vulkan {
                call: "vkCreateGraphicsPipelines",
                result,
            })
        });
        for m in modules {
            // SAFETY: modules are no longer needed once the pipeline is built (or failed).
            unsafe { ctx.device.destroy_shader_module(m, None) };
        }
        Ok(GraphicsPipeline {
            raw: ctx.own(pipeline?, name),
            layout,
            _set_layouts: desc.set_layouts,
            push_constant_stages: desc.push_constant_stages,
            name: name.into(),
        })
    }

    /// The pipeline handle.
    pub fn raw(&self) -> vk::Pipeline {
        self.raw.raw()
    }

    /// The pipeline layout (push constants, push descriptors).
    pub fn layout(&self) -> vk::PipelineLayout {
        self.layout.raw()
    }

    /// The debug name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The stages its push constants are visible to.
    pub fn push_constant_stages(&self) -> vk::ShaderStageFlags {
        self.push_constant_stages
    }

    /// Binds the pipeline, pushes `bindings` as set 0 and `push` as push constants (each if non-empty) and
    /// sets viewport and scissor to `extent`.
    pub fn bind(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        bindings: &[(u32, Binding)],
        push: &[u8],
        extent: vk::Extent2D,
    ) {
        // SAFETY: recording command buffer inside a dynamic render pass.
        unsafe {
            ctx.device
                .cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.raw())
        };
        if !bindings.is_empty() {
            ctx.cmd_push_descriptors(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.layout(),
                0,
                bindings,
            );
        }
        // SAFETY: as above.
        unsafe {
            if !push.is_empty() {
                ctx.device.cmd_push_constants(
                    cmd,
                    self.layout(),
                    self.push_constant_stages,
                    0,
                    push,
                );
            }
            let vp = vk::Viewport {
                x: 0.0,
                y: 0.0,
                width: extent.width as f32,
                height: extent.height as f32,
                min_depth: 0.0,
                max_depth: 1.0,
            };
            ctx.device.cmd_set_viewport(cmd, 0, &[vp]);
            ctx.device.cmd_set_scissor(
                cmd,
                0,
                &[vk::Rect2D {
                    offset: vk::Offset2D::default(),
                    extent,
                }],
            );
        }
    }
}
