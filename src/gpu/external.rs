//! gregvox on a device it did not create: what it needs from that device ([`DeviceRequirements`], asked
//! before the caller creates it), the handles the caller lends ([`ExternalDevice`], taken by
//! [`super::Context::from_external`]) and the bracket around gregvox work recorded into the caller's
//! command buffers ([`ExternalRecording`]), which tells the release queue when that work is done.
//!
//! Invariants:
//! - gregvox never destroys the instance, the device, the queue or any object it did not create; it
//!   destroys its own (allocator, pools, pipelines, buffers) through the release queue, never before the
//!   submissions that may use them are known to be complete.
//! - A submission of the caller's is known complete when the timeline semaphore it signals reaches the
//!   value given to [`ExternalRecording::submitted`] (polled by [`super::Context::poll_external`], which
//!   every [`super::Context::begin_external`] calls), or when the device is idle. Queue submissions
//!   complete in submission order on one queue, so gregvox's single "completed" serial stays valid as long
//!   as the caller submits gregvox's work on the queue it lent, and calls `submitted` after the
//!   `vkQueueSubmit` that carries it.
//! - The requirements are the owned path's too: `Context::with_desc` creates its device from
//!   [`DeviceRequirements::query`], so the two paths cannot drift.
use super::context::OptionalFeatures;
use crate::error::{Error, Result};
use ash::vk;
use std::ffi::CStr;

/// What gregvox needs of a physical device, and what it uses when present; ask it before creating the
/// device ([`DeviceRequirements::query`]) and enable at least this.
///
/// Required: Vulkan 1.2 (instance and device), a queue family with graphics and compute,
/// `VK_KHR_push_descriptor`, the Vulkan 1.2 features `timelineSemaphore`, `hostQueryReset` and
/// `scalarBlockLayout`, and `synchronization2` and `dynamicRendering` (core features on 1.3, the KHR
/// extensions on 1.2). Optional core features, each used only when the caller enabled it, are listed
/// with what gregvox does without them in [`OPTIONAL_FEATURES`] (`shaderFloat64` and
/// `fragmentStoresAndAtomics` matter; the others change nothing today).
#[derive(Clone, Debug)]
pub struct DeviceRequirements {
    /// The Vulkan version gregvox will use: the lower of the caller's instance version and the device's.
    pub api_version: u32,
    /// Whether synchronization2 and dynamic rendering are core (1.3) rather than KHR extensions.
    pub core13: bool,
    /// The first queue family with graphics and compute (gregvox records compute and graphics work).
    pub queue_family: u32,
    /// Device extensions to enable (add the caller's own, `VK_KHR_swapchain` for example).
    pub device_extensions: Vec<&'static CStr>,
    /// The optional core features the device supports (enable those you want gregvox to use).
    pub supported: OptionalFeatures,
}

/// The optional features: Vulkan name, and what gregvox does without it.
pub const OPTIONAL_FEATURES: [(&str, &str); 9] = [
    (
        "shaderFloat64",
        "the exact surface voxels are computed on the CPU",
    ),
    ("fillModeNonSolid", "not used today"),
    ("wideLines", "not used today (lines are one pixel wide)"),
    (
        "fragmentStoresAndAtomics",
        "the depth-peeling voxelizer is unavailable (the A-buffer and the CPU remain)",
    ),
    (
        "vertexPipelineStoresAndAtomics",
        "the vertex-pull pass cannot capture its vertices (drawing still works)",
    ),
    ("shaderInt64", "not used today"),
    ("tessellationShader", "not used today"),
    ("geometryShader", "not used today"),
    ("pipelineStatisticsQuery", "not used today"),
];

fn name_of(raw: &[std::ffi::c_char]) -> String {
    // SAFETY: Vulkan fixed-size name arrays are NUL-terminated.
    unsafe { CStr::from_ptr(raw.as_ptr()) }
        .to_string_lossy()
        .into_owned()
}

impl DeviceRequirements {
    /// What gregvox needs of `physical_device` of `instance` (created for `api_version`); an error naming
    /// every missing requirement when the device cannot host gregvox.
    pub fn query(
        instance: &ash::Instance,
        physical_device: vk::PhysicalDevice,
        api_version: u32,
    ) -> Result<DeviceRequirements> {
        // SAFETY: the caller passes a physical device of `instance`.
        let props = unsafe { instance.get_physical_device_properties(physical_device) };
        let name = name_of(&props.device_name);
        let api = api_version.min(props.api_version);
        let mut missing = Vec::new();
        if api < vk::API_VERSION_1_2 {
            missing.push(format!(
                "Vulkan 1.2 (instance and device give {}.{})",
                vk::api_version_major(api),
                vk::api_version_minor(api)
            ));
        }
        let core13 = api >= vk::API_VERSION_1_3;
        // SAFETY: valid physical device.
        let exts = unsafe { instance.enumerate_device_extension_properties(physical_device) }
            .unwrap_or_default();
        let has = |n: &CStr| {
            exts.iter()
                .any(|e| name_of(&e.extension_name) == n.to_string_lossy())
        };
        let mut device_extensions = vec![ash::khr::push_descriptor::NAME];
        if !core13 {
            device_extensions.push(ash::khr::synchronization2::NAME);
            device_extensions.push(ash::khr::dynamic_rendering::NAME);
        }
        for e in &device_extensions {
            if !has(e) {
                missing.push(e.to_string_lossy().into_owned());
            }
        }
        // SAFETY: valid physical device.
        let families =
            unsafe { instance.get_physical_device_queue_family_properties(physical_device) };
        let want = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
        let queue_family = families.iter().position(|f| f.queue_flags.contains(want));
        if queue_family.is_none() {
            missing.push("a queue family with graphics and compute".into());
        }
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f12);
        if core13 {
            features2 = features2.push_next(&mut f13);
        }
        if api >= vk::API_VERSION_1_2 {
            // SAFETY: valid physical device; the chain's structs live until the call returns.
            unsafe { instance.get_physical_device_features2(physical_device, &mut features2) };
        }
        let supported = features2.features;
        for (ok, what) in [
            (f12.timeline_semaphore, "timelineSemaphore"),
            (f12.host_query_reset, "hostQueryReset"),
            (f12.scalar_block_layout, "scalarBlockLayout"),
        ] {
            if api >= vk::API_VERSION_1_2 && ok != vk::TRUE {
                missing.push(what.into());
            }
        }
        if core13 {
            for (ok, what) in [
                (f13.synchronization2, "synchronization2"),
                (f13.dynamic_rendering, "dynamicRendering"),
            ] {
                if ok != vk::TRUE {
                    missing.push(what.into());
                }
            }
        }
        if !missing.is_empty() {
            return Err(Error::NoDevice(format!(
                "{name} cannot host gregvox: it lacks {}",
                missing.join(", ")
            )));
        }
        let t = |b: vk::Bool32| b == vk::TRUE;
        Ok(DeviceRequirements {
            api_version: api,
            core13,
            queue_family: queue_family.expect("checked above") as u32,
            device_extensions,
            supported: OptionalFeatures {
                fill_mode_non_solid: t(supported.fill_mode_non_solid),
                tessellation_shader: t(supported.tessellation_shader),
                geometry_shader: t(supported.geometry_shader),
                fragment_stores_and_atomics: t(supported.fragment_stores_and_atomics),
                vertex_pipeline_stores_and_atomics: t(supported.vertex_pipeline_stores_and_atomics),
                shader_int64: t(supported.shader_int64),
                shader_float64: t(supported.shader_float64),
                pipeline_statistics_query: t(supported.pipeline_statistics_query),
                wide_lines: t(supported.wide_lines),
            },
        })
    }

    /// The core features: every optional one the device supports (merge with yours).
    pub fn core_features(&self) -> vk::PhysicalDeviceFeatures {
        let b = |x: bool| if x { vk::TRUE } else { vk::FALSE };
        let s = &self.supported;
        vk::PhysicalDeviceFeatures {
            fill_mode_non_solid: b(s.fill_mode_non_solid),
            tessellation_shader: b(s.tessellation_shader),
            geometry_shader: b(s.geometry_shader),
            fragment_stores_and_atomics: b(s.fragment_stores_and_atomics),
            vertex_pipeline_stores_and_atomics: b(s.vertex_pipeline_stores_and_atomics),
            shader_int64: b(s.shader_int64),
            shader_float64: b(s.shader_float64),
            pipeline_statistics_query: b(s.pipeline_statistics_query),
            wide_lines: b(s.wide_lines),
            ..Default::default()
        }
    }

    /// The Vulkan 1.2 features gregvox needs (chain it, or set these three on yours).
    pub fn vulkan12_features(&self) -> vk::PhysicalDeviceVulkan12Features<'static> {
        vk::PhysicalDeviceVulkan12Features::default()
            .timeline_semaphore(true)
            .host_query_reset(true)
            .scalar_block_layout(true)
    }

    /// The Vulkan 1.3 features gregvox needs (chain it when [`Self::core13`]).
    pub fn vulkan13_features(&self) -> vk::PhysicalDeviceVulkan13Features<'static> {
        vk::PhysicalDeviceVulkan13Features::default()
            .synchronization2(true)
            .dynamic_rendering(true)
    }

    /// The KHR feature structs to chain instead on a 1.2 device (when not [`Self::core13`]).
    pub fn khr_features(
        &self,
    ) -> (
        vk::PhysicalDeviceSynchronization2Features<'static>,
        vk::PhysicalDeviceDynamicRenderingFeatures<'static>,
    ) {
        (
            vk::PhysicalDeviceSynchronization2Features::default().synchronization2(true),
            vk::PhysicalDeviceDynamicRenderingFeatures::default().dynamic_rendering(true),
        )
    }

    /// The optional features as (Vulkan name, supported here, what gregvox does without it).
    pub fn optional(&self) -> Vec<(&'static str, bool, &'static str)> {
        let s = &self.supported;
        let have = [
            s.shader_float64,
            s.fill_mode_non_solid,
            s.wide_lines,
            s.fragment_stores_and_atomics,
            s.vertex_pipeline_stores_and_atomics,
            s.shader_int64,
            s.tessellation_shader,
            s.geometry_shader,
            s.pipeline_statistics_query,
        ];
        OPTIONAL_FEATURES
            .iter()
            .zip(have)
            .map(|(&(name, without), h)| (name, h, without))
            .collect()
    }
}

/// The device a caller lends gregvox ([`super::Context::from_external`], `api::Gpu::from_external`).
#[derive(Clone)]
pub struct ExternalDevice {
    /// The loader the caller's instance came from.
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    pub physical_device: vk::PhysicalDevice,
    pub device: ash::Device,
    /// The queue gregvox submits its own one-shot work to, and on which the caller submits the command
    /// buffers gregvox recorded into.
    pub queue: vk::Queue,
    pub queue_family: u32,
    /// The `apiVersion` the caller's instance was created with.
    pub api_version: u32,
    /// The core features the device was created with (gregvox uses an optional one only when set here).
    pub enabled_features: vk::PhysicalDeviceFeatures,
    /// Whether the instance has `VK_EXT_debug_utils` enabled: gregvox then names its objects and listens
    /// for validation messages with a messenger of its own (destroyed with the context).
    pub debug_utils: bool,
    /// Refuse gregvox allocations beyond this many bytes in total (`None`: `GREGVOX_MEMORY_BUDGET`, or
    /// the device's own limit).
    pub memory_budget: Option<u64>,
}

/// gregvox work being recorded into a command buffer of the caller's. Objects gregvox drops meanwhile
/// wait for that command buffer's submission. End it with [`ExternalRecording::submitted`] once the
/// command buffer is submitted, or drop it if the command buffer is never submitted.
#[must_use = "call `submitted` after submitting the command buffer"]
pub struct ExternalRecording<'a> {
    pub(crate) ctx: &'a super::Context,
    pub(crate) open: bool,
}

impl ExternalRecording<'_> {
    /// The command buffer that holds the recorded work was submitted (on the queue lent to gregvox) and
    /// signals `semaphore`, a timeline semaphore of the device, to at least `value` when it completes.
    ///
    /// # Safety
    /// `semaphore` is a timeline semaphore of the lent device that stays alive until gregvox has seen it
    /// reach `value` or the context is dropped; the submission was made before this call, on the lent
    /// queue, and no command buffer recorded after `begin_external` is submitted before it.
    pub unsafe fn submitted(mut self, semaphore: vk::Semaphore, value: u64) {
        self.open = false;
        self.ctx.shared().external_submitted(semaphore, value);
    }
}

impl Drop for ExternalRecording<'_> {
    fn drop(&mut self) {
        if self.open {
            // Abandoned: nothing was submitted; what was dropped meanwhile waits for the last submission.
            self.ctx.shared().end_recording();
        }
    }
}
