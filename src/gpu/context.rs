//! `Context`: the Vulkan entry, instance, debug messenger, physical and logical device, the one queue, the
//! memory allocator and a one-shot command pool.
//!
//! Invariants:
//! - The instance, device and allocator live in a reference-counted [`DeviceShared`] that every object
//!   made from the context holds (see `gpu::lifetime`); the device is destroyed after the last of them, in
//!   the order spelled out once in `DeviceShared::drop`. Objects release themselves when dropped.
//! - Dropping the context waits for the device, destroys what the release queue holds and counts every GPU
//!   allocation still alive as a leak (named in the log): tests and the CLI fail on a leak.
//! - The device is created by gregvox (`with_desc`) or lent by the caller (`from_external`); both go through
//!   one `assemble`, and the owned path creates its device from the same [`DeviceRequirements`] a caller
//!   asks for. A lent instance and device are never destroyed (see `gpu::external`).
//! - The engine uses synchronization2 and dynamic rendering through [`Context::cmd_pipeline_barrier2`],
//!   [`Context::cmd_begin_rendering`] and [`Context::cmd_end_rendering`], which call the core (1.3) entry
//!   points or the KHR extension ones (1.2 devices) as the device requires.
use super::debug::{messenger_callback, ValidationSink};
use super::external::{DeviceRequirements, ExternalDevice, ExternalRecording};
use super::lifetime::{DeviceParts, DeviceShared, Owned, OwnedHandle};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::{c_char, CStr, CString};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// The name of the Khronos validation layer.
pub const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// The environment variable that caps GPU memory when [`ContextDesc::memory_budget`] is `None`.
pub const MEMORY_BUDGET_ENV: &str = "GREGVOX_MEMORY_BUDGET";

/// Over the whole process: GPU allocations found alive, and validation messages received, when a context
/// was destroyed. Why process-wide: contexts live inside each CLI command, and the CLI checks these at
/// exit to fail loudly on a leak or a validation message (the context itself can only log from `Drop`).
static LEAKED_ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

/// GPU allocations that were still alive when a context of this process was destroyed.
pub fn allocations_leaked_at_destruction() -> usize {
    LEAKED_ALLOCATIONS.load(Ordering::SeqCst)
}

/// Validation messages received by the contexts of this process that have been destroyed (including the
/// layer's report of undestroyed objects, which arrives at device destruction).
pub fn validation_messages_at_destruction() -> usize {
    super::lifetime::VALIDATION_MESSAGES.load(Ordering::SeqCst) as usize
}

/// Parses a byte size: a whole number with an optional `K`, `M` or `G` suffix (powers of 1024, an optional
/// trailing `B` or `iB`), e.g. `64M`, `8MiB`, `1G`, `1048576`.
///
/// ```
/// use gregvox::gpu::context::parse_byte_size;
/// assert_eq!(parse_byte_size("64M"), Some(64 << 20));
/// assert_eq!(parse_byte_size("8MiB"), Some(8 << 20));
/// assert_eq!(parse_byte_size("4096"), Some(4096));
/// assert_eq!(parse_byte_size("0"), None);
/// assert_eq!(parse_byte_size("lots"), None);
/// ```
pub fn parse_byte_size(s: &str) -> Option<u64> {
    let t = s.trim().to_ascii_uppercase();
    let t = t
        .strip_suffix("IB")
        .or_else(|| t.strip_suffix('B'))
        .unwrap_or(&t);
    let (digits, shift) = match t.chars().last()? {
        'K' => (&t[..t.len() - 1], 10),
        'M' => (&t[..t.len() - 1], 20),
        'G' => (&t[..t.len() - 1], 30),
        _ => (t, 0),
    };
    let n: u64 = digits.trim().parse().ok()?;
    n.checked_mul(1u64 << shift).filter(|&b| b > 0)
}

/// The budget from [`MEMORY_BUDGET_ENV`], if set; a malformed value is an error naming the variable.
fn memory_budget_from_env() -> Result<Option<u64>> {
    match std::env::var(MEMORY_BUDGET_ENV) {
        Err(_) => Ok(None),
        Ok(v) => parse_byte_size(&v).map(Some).ok_or_else(|| {
            Error::Invalid(format!(
                "{MEMORY_BUDGET_ENV}='{v}' is not a memory size (a positive whole number of bytes, or with a \
                 K, M or G suffix, e.g. 64M)"
            ))
        }),
    }
}

/// Whether the validation layer is enabled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Validation {
    /// On in debug builds when the layer is installed, or when `GREGVOX_VALIDATION=1`; off with
    /// `GREGVOX_VALIDATION=0`.
    Auto,
    /// Always on; context creation fails if the layer is missing (tests).
    Required,
    /// Never on.
    Off,
}

/// How to build a [`Context`].
#[derive(Clone, Debug)]
pub struct ContextDesc {
    /// Validation layer policy.
    pub validation: Validation,
    /// Substring (case-insensitive) of the device name to pick; `None` reads `GREGVOX_DEVICE`.
    pub device_filter: Option<String>,
    /// Instance extensions a window surface needs (from `ash_window::enumerate_required_extensions`).
    /// Non-empty also enables `VK_KHR_swapchain` on the device.
    pub surface_extensions: Vec<&'static CStr>,
    /// Refuse allocations beyond this many bytes in total (`None`: the device's own limit).
    pub memory_budget: Option<u64>,
    /// Enable the validation layer's synchronization validation as well (slower; tests use it).
    pub sync_validation: bool,
}

impl Default for ContextDesc {
    fn default() -> Self {
        ContextDesc {
            validation: Validation::Auto,
            device_filter: None,
            surface_extensions: Vec::new(),
            memory_budget: None,
            sync_validation: false,
        }
    }
}

/// Optional device features gregvox uses when present.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct OptionalFeatures {
    pub fill_mode_non_solid: bool,
    pub tessellation_shader: bool,
    pub geometry_shader: bool,
    pub fragment_stores_and_atomics: bool,
    pub vertex_pipeline_stores_and_atomics: bool,
    pub shader_int64: bool,
    pub shader_float64: bool,
    pub pipeline_statistics_query: bool,
    pub wide_lines: bool,
}

/// What `gregvox info` reports, gathered once at context creation.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DeviceInfo {
    pub name: String,
    pub device_type: String,
    pub vendor_id: u32,
    pub device_id: u32,
    pub driver_name: String,
    pub driver_info: String,
    pub api_version: String,
    pub driver_version: u32,
    pub max_storage_buffer_range: u32,
    pub max_compute_work_group_count: [u32; 3],
    pub max_compute_work_group_size: [u32; 3],
    pub max_compute_work_group_invocations: u32,
    pub max_compute_shared_memory_size: u32,
    pub max_image_dimension_2d: u32,
    pub max_image_array_layers: u32,
    pub max_push_constants_size: u32,
    pub max_memory_allocation_count: u32,
    pub min_storage_buffer_offset_alignment: u64,
    /// The largest single allocation (`maxMemoryAllocationSize`, Vulkan 1.1); `create_buffer` refuses more.
    pub max_memory_allocation_size: u64,
    pub timestamps_supported: bool,
    pub timestamp_period_ns: f32,
    pub timestamp_valid_bits: u32,
    pub subgroup_size: u32,
    pub device_local_heap_bytes: u64,
    pub memory_types: usize,
    pub validation_layer_present: bool,
    pub validation_enabled: bool,
    pub features: OptionalFeatures,
}

/// The Vulkan context. See the module invariants.
pub struct Context {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    debug_utils_device: Option<ash::ext::debug_utils::Device>,
    pub physical_device: vk::PhysicalDevice,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub limits: vk::PhysicalDeviceLimits,
    pub info: DeviceInfo,
    pub validation: Arc<ValidationSink>,
    shared: Arc<DeviceShared>,
    one_shot_pool: Mutex<vk::CommandPool>,
    push_descriptor: ash::khr::push_descriptor::Device,
    sync2_ext: Option<ash::khr::synchronization2::Device>,
    dynamic_rendering_ext: Option<ash::khr::dynamic_rendering::Device>,
    pub surface_instance: Option<ash::khr::surface::Instance>,
    pub swapchain_device: Option<ash::khr::swapchain::Device>,
}

fn vk_version_string(v: u32) -> String {
    format!(
        "{}.{}.{}",
        vk::api_version_major(v),
        vk::api_version_minor(v),
        vk::api_version_patch(v)
    )
}

fn cstr_array(raw: &[c_char]) -> String {
    // SAFETY: Vulkan fixed-size name arrays are NUL-terminated.
    unsafe { CStr::from_ptr(raw.as_ptr()) }
        .to_string_lossy()
        .into_owned()
}

fn type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

fn type_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
}

/// The device [`Context::new`] would pick, found with a bare instance (no layers, no logical device, no
/// pipelines), so a caller can decide cheaply whether to create one at all: `(name, type)` with the type as
/// [`DeviceInfo::device_type`] names it ("discrete GPU", "CPU", …). `GREGVOX_DEVICE` filters as for
/// [`Context::new`].
pub fn probe_device() -> Result<(String, String)> {
    // SAFETY: loading the system Vulkan loader; failure is reported, not a panic.
    let entry = unsafe { ash::Entry::load() }.map_err(|e| {
        Error::NoDriver(format!(
            "cannot load the Vulkan loader (libvulkan.so.1): {e}"
        ))
    })?;
    // SAFETY: loader call.
    let version = unsafe { entry.try_enumerate_instance_version() }
        .vk("vkEnumerateInstanceVersion")?
        .unwrap_or(vk::API_VERSION_1_0);
    if version < vk::API_VERSION_1_2 {
        return Err(Error::NoDriver(format!(
            "the Vulkan loader supports only API {}; gregvox needs 1.2",
            vk_version_string(version)
        )));
    }
    let app_info = vk::ApplicationInfo::default()
        .application_name(c"gregvox")
        .api_version(vk::API_VERSION_1_2);
    let create_info = vk::InstanceCreateInfo::default().application_info(&app_info);
    // SAFETY: create_info lives until the call returns.
    let instance = unsafe { entry.create_instance(&create_info, None) }.vk("vkCreateInstance")?;
    let filter = std::env::var("GREGVOX_DEVICE")
        .ok()
        .filter(|s| !s.is_empty());
    let chosen = pick_device(&instance, filter.as_deref(), false);
    // SAFETY: nothing was created from the instance.
    unsafe { instance.destroy_instance(None) };
    let c = chosen?;
    Ok((c.name, type_name(c.props.device_type).to_string()))
}

/// Whether the validation layer is installed (needs only the loader).
pub fn validation_layer_present(entry: &ash::Entry) -> bool {
    // SAFETY: plain enumeration call on a loaded entry.
    unsafe { entry.enumerate_instance_layer_properties() }
        .map(|layers| {
            layers
                .iter()
                .any(|l| cstr_array(&l.layer_name) == VALIDATION_LAYER.to_str().unwrap())
        })
        .unwrap_or(false)
}

struct Candidate {
    pd: vk::PhysicalDevice,
    props: vk::PhysicalDeviceProperties,
    family: u32,
    name: String,
}

impl Context {
    /// Creates a context for compute and offscreen rendering with the default policy.
    pub fn new() -> Result<Context> {
        Context::with_desc(&ContextDesc::default())
    }

    /// Creates a context as `desc` says.
    pub fn with_desc(desc: &ContextDesc) -> Result<Context> {
        // Before any Vulkan object exists, so a bad value leaves nothing to clean up.
        let memory_budget = match desc.memory_budget {
            Some(b) => Some(b),
            None => memory_budget_from_env()?,
        };
        // SAFETY: loading the system Vulkan loader; failure is reported, not a panic.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| {
            Error::NoDriver(format!(
                "cannot load the Vulkan loader (libvulkan.so.1): {e}"
            ))
        })?;
        let layer_present = validation_layer_present(&entry);
        let want_validation = match desc.validation {
            Validation::Off => false,
            Validation::Required => true,
            Validation::Auto => match std::env::var("GREGVOX_VALIDATION").ok().as_deref() {
                Some("0") => false,
                Some("1") => true,
                _ => cfg!(debug_assertions) && layer_present,
            },
        };
        if want_validation && !layer_present {
            return Err(Error::NoDriver(
                "the Vulkan validation layer VK_LAYER_KHRONOS_validation is required but not installed \
                 (apt-get install vulkan-validationlayers)"
                    .into(),
            ));
        }

        // SAFETY: loader call.
        let instance_version = unsafe { entry.try_enumerate_instance_version() }
            .vk("vkEnumerateInstanceVersion")?
            .unwrap_or(vk::API_VERSION_1_0);
        if instance_version < vk::API_VERSION_1_2 {
            return Err(Error::NoDriver(format!(
                "the Vulkan loader supports only API {}; gregvox needs 1.2",
                vk_version_string(instance_version)
            )));
        }
        let api = vk::API_VERSION_1_3.min(instance_version);

        let validation = Arc::new(ValidationSink::default());
        let app_name = c"gregvox";
        let app_info = vk::ApplicationInfo::default()
            .application_name(app_name)
            .application_version(1)
            .engine_name(app_name)
            .engine_version(1)
            .api_version(api);
        let mut layers: Vec<*const c_char> = Vec::new();
        let mut extensions: Vec<*const c_char> =
            desc.surface_extensions.iter().map(|e| e.as_ptr()).collect();
        // SAFETY: loader call.
        let available_ext =
            unsafe { entry.enumerate_instance_extension_properties(None) }.unwrap_or_default();
        let has_ext = |name: &CStr| {
            available_ext
                .iter()
                .any(|e| cstr_array(&e.extension_name) == name.to_str().unwrap())
        };
        let debug_utils_available = has_ext(ash::ext::debug_utils::NAME) || want_validation;
        if want_validation {
            layers.push(VALIDATION_LAYER.as_ptr());
        }
        if debug_utils_available {
            extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let sink_ptr = Arc::as_ptr(&validation) as *mut std::ffi::c_void;
        let mut chained_messenger = messenger_info(sink_ptr);
        let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut validation_features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);
        let mut create_info = vk::InstanceCreateInfo::default()
            .application_info(&app_info)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if debug_utils_available {
            // Chained so that messages of instance creation and destruction reach the sink too.
            create_info = create_info.push_next(&mut chained_messenger);
        }
        if want_validation && desc.sync_validation {
            create_info = create_info.push_next(&mut validation_features);
        }
        // SAFETY: create_info and everything it points to live until the call returns.
        let instance =
            unsafe { entry.create_instance(&create_info, None) }.map_err(|e| {
                match e {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => Error::NoDriver(
                "no Vulkan driver found (vkCreateInstance: ERROR_INCOMPATIBLE_DRIVER); install \
                 mesa-vulkan-drivers for the lavapipe CPU driver, or a GPU driver"
                    .into(),
            ),
            vk::Result::ERROR_LAYER_NOT_PRESENT => {
                Error::NoDriver("the Vulkan validation layer could not be loaded".into())
            }
            result => Error::Vulkan { call: "vkCreateInstance", result },
        }
            })?;

        // From here on, a failure must destroy what exists: `Partial` does that on drop.
        let mut partial = Partial {
            entry: &entry,
            instance: Some(instance.clone()),
            messenger: None,
        };
        let debug_utils = if debug_utils_available {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let messenger_info = messenger_info(sink_ptr);
            // SAFETY: valid instance and create info.
            let messenger = unsafe { loader.create_debug_utils_messenger(&messenger_info, None) }
                .vk("vkCreateDebugUtilsMessengerEXT")?;
            partial.messenger = Some((loader.clone(), messenger));
            Some((loader, messenger))
        } else {
            None
        };

        let filter = desc.device_filter.clone().or_else(|| {
            std::env::var("GREGVOX_DEVICE")
                .ok()
                .filter(|s| !s.is_empty())
        });
        let surface_wanted = !desc.surface_extensions.is_empty();
        let chosen = pick_device(&instance, filter.as_deref(), surface_wanted)?;
        let pd = chosen.pd;

        let req = DeviceRequirements::query(&instance, pd, api)?;
        let core_features = req.core_features();
        let mut f12 = req.vulkan12_features();
        let mut f13 = req.vulkan13_features();
        let (mut sync2_khr, mut dynr_khr) = req.khr_features();
        let mut device_ext: Vec<*const c_char> =
            req.device_extensions.iter().map(|e| e.as_ptr()).collect();
        if surface_wanted {
            device_ext.push(ash::khr::swapchain::NAME.as_ptr());
        }
        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(chosen.family)
            .queue_priorities(&priorities)];
        let mut device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(&device_ext)
            .enabled_features(&core_features)
            .push_next(&mut f12);
        device_info = if req.core13 {
            device_info.push_next(&mut f13)
        } else {
            device_info
                .push_next(&mut sync2_khr)
                .push_next(&mut dynr_khr)
        };
        // SAFETY: valid physical device and create info.
        let device =
            unsafe { instance.create_device(pd, &device_info, None) }.vk("vkCreateDevice")?;
        // SAFETY: family and index 0 were requested above.
        let queue = unsafe { device.get_device_queue(chosen.family, 0) };
        // From here on `assemble` destroys the device, the messenger and the instance on failure.
        std::mem::forget(partial);
        Context::assemble(Assembly {
            entry,
            instance,
            physical_device: pd,
            device,
            queue,
            queue_family: chosen.family,
            name: chosen.name,
            core13: req.core13,
            features: req.supported,
            debug_utils,
            names: debug_utils_available,
            validation,
            layer_present,
            validation_enabled: want_validation,
            surface: surface_wanted,
            memory_budget,
            owns_device: true,
        })
    }

    /// A context on a device the caller created and keeps: gregvox makes its allocator, command pool and
    /// pipelines on it, destroys only those, and submits to `device.queue` only from the calls that say
    /// they submit (`one_shot` and the uploads and read-backs built on it). Work recorded into the
    /// caller's own command buffers goes through [`Context::begin_external`].
    ///
    /// # Safety
    /// - Every handle in `device` is valid; `device.device` was created from `device.physical_device` of
    ///   `device.instance` with at least what [`DeviceRequirements::query`] lists enabled, at
    ///   `device.api_version`; `device.queue` is queue 0 or another queue of family `device.queue_family`
    ///   of that device, and `device.enabled_features` are the core features it was created with.
    /// - The instance and the device outlive this context and every object made from it (drop them all
    ///   before `vkDestroyDevice`).
    /// - While a gregvox call that submits or waits runs (and while the context is dropped, which waits
    ///   for the device), no other thread uses the queue.
    pub unsafe fn from_external(device: &ExternalDevice) -> Result<Context> {
        let memory_budget = match device.memory_budget {
            Some(b) => Some(b),
            None => memory_budget_from_env()?,
        };
        let instance = &device.instance;
        let pd = device.physical_device;
        let api = device.api_version;
        if api < vk::API_VERSION_1_2 {
            return Err(Error::NoDevice(format!(
                "the caller's instance was created for Vulkan {}; gregvox needs 1.2",
                vk_version_string(api)
            )));
        }
        let req = DeviceRequirements::query(instance, pd, api)?;
        // SAFETY: the caller's promise: a valid physical device of the instance.
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let family_ok = families.get(device.queue_family as usize).is_some_and(|f| {
            f.queue_flags
                .contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)
        });
        if !family_ok {
            return Err(Error::NoDevice(format!(
                "queue family {} of the caller's device does not do graphics and compute",
                device.queue_family
            )));
        }
        let on = |enabled: vk::Bool32, supported: bool| enabled == vk::TRUE && supported;
        let f = &device.enabled_features;
        let s = req.supported;
        let features = OptionalFeatures {
            fill_mode_non_solid: on(f.fill_mode_non_solid, s.fill_mode_non_solid),
            tessellation_shader: on(f.tessellation_shader, s.tessellation_shader),
            geometry_shader: on(f.geometry_shader, s.geometry_shader),
            fragment_stores_and_atomics: on(
                f.fragment_stores_and_atomics,
                s.fragment_stores_and_atomics,
            ),
            vertex_pipeline_stores_and_atomics: on(
                f.vertex_pipeline_stores_and_atomics,
                s.vertex_pipeline_stores_and_atomics,
            ),
            shader_int64: on(f.shader_int64, s.shader_int64),
            shader_float64: on(f.shader_float64, s.shader_float64),
            pipeline_statistics_query: on(f.pipeline_statistics_query, s.pipeline_statistics_query),
            wide_lines: on(f.wide_lines, s.wide_lines),
        };
        let validation = Arc::new(ValidationSink::default());
        let debug_utils = if device.debug_utils {
            let loader = ash::ext::debug_utils::Instance::new(&device.entry, instance);
            let info = messenger_info(Arc::as_ptr(&validation) as *mut std::ffi::c_void);
            // SAFETY: the caller's promise: the instance has VK_EXT_debug_utils enabled.
            let messenger = unsafe { loader.create_debug_utils_messenger(&info, None) }
                .vk("vkCreateDebugUtilsMessengerEXT")?;
            Some((loader, messenger))
        } else {
            None
        };
        // SAFETY: valid physical device.
        let props = unsafe { instance.get_physical_device_properties(pd) };
        Context::assemble(Assembly {
            entry: device.entry.clone(),
            instance: instance.clone(),
            physical_device: pd,
            device: device.device.clone(),
            queue: device.queue,
            queue_family: device.queue_family,
            name: cstr_array(&props.device_name),
            core13: req.core13,
            features,
            debug_utils,
            names: device.debug_utils,
            validation,
            layer_present: validation_layer_present(&device.entry),
            validation_enabled: false,
            surface: false,
            memory_budget,
            owns_device: false,
        })
    }

    /// The part of context creation shared by the owned and the borrowed device: the allocator, the
    /// release queue, the one-shot pool, the report and the extension loaders.
    fn assemble(a: Assembly) -> Result<Context> {
        let Assembly {
            entry,
            instance,
            physical_device: pd,
            device,
            queue,
            queue_family,
            name,
            core13,
            features: opt,
            debug_utils,
            names,
            validation,
            layer_present,
            validation_enabled,
            surface: surface_wanted,
            memory_budget,
            owns_device,
        } = a;
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: pd,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        });
        let allocator = match allocator {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: nothing has been created from the device yet; only what gregvox made is destroyed.
                unsafe {
                    if let Some((loader, m)) = &debug_utils {
                        loader.destroy_debug_utils_messenger(*m, None);
                    }
                    if owns_device {
                        device.destroy_device(None);
                        instance.destroy_instance(None);
                    }
                }
                return Err(Error::Alloc {
                    name: "allocator".into(),
                    bytes: 0,
                    reason: e.to_string(),
                });
            }
        };
        let surface_instance =
            surface_wanted.then(|| ash::khr::surface::Instance::new(&entry, &instance));
        let swapchain_device =
            surface_wanted.then(|| ash::khr::swapchain::Device::new(&instance, &device));
        // From here on the shared device owns the allocator (and, when `owns_device`, the instance and the
        // device) and destroys them when the last owner goes, on any error below too.
        let shared = DeviceShared::new(DeviceParts {
            entry: entry.clone(),
            instance: instance.clone(),
            device: device.clone(),
            debug_utils,
            surface_instance: surface_instance.clone(),
            swapchain_device: swapchain_device.clone(),
            allocator,
            memory_budget,
            validation: validation.clone(),
            owns_device,
        });
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(
                vk::CommandPoolCreateFlags::TRANSIENT
                    | vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER,
            );
        // SAFETY: valid device.
        let one_shot_pool =
            unsafe { device.create_command_pool(&pool_info, None) }.vk("vkCreateCommandPool")?;

        // Gather the report.
        // SAFETY: valid physical device.
        let props = unsafe { instance.get_physical_device_properties(pd) };
        let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        let mut maintenance3 = vk::PhysicalDeviceMaintenance3Properties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default()
            .push_next(&mut driver_props)
            .push_next(&mut subgroup)
            .push_next(&mut maintenance3);
        // SAFETY: valid physical device; Vulkan 1.2 guarantees the query.
        unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
        // SAFETY: valid physical device.
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        // SAFETY: valid physical device.
        let mem = unsafe { instance.get_physical_device_memory_properties(pd) };
        let device_local_heap_bytes = mem.memory_heaps[..mem.memory_heap_count as usize]
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0);
        let l = props.limits;
        let ts_bits = families[queue_family as usize].timestamp_valid_bits;
        let info = DeviceInfo {
            name,
            device_type: type_name(props.device_type).into(),
            vendor_id: props.vendor_id,
            device_id: props.device_id,
            driver_name: cstr_array(&driver_props.driver_name),
            driver_info: cstr_array(&driver_props.driver_info),
            api_version: vk_version_string(props.api_version),
            driver_version: props.driver_version,
            max_storage_buffer_range: l.max_storage_buffer_range,
            max_compute_work_group_count: l.max_compute_work_group_count,
            max_compute_work_group_size: l.max_compute_work_group_size,
            max_compute_work_group_invocations: l.max_compute_work_group_invocations,
            max_compute_shared_memory_size: l.max_compute_shared_memory_size,
            max_image_dimension_2d: l.max_image_dimension2_d,
            max_image_array_layers: l.max_image_array_layers,
            max_push_constants_size: l.max_push_constants_size,
            max_memory_allocation_count: l.max_memory_allocation_count,
            min_storage_buffer_offset_alignment: l.min_storage_buffer_offset_alignment,
            max_memory_allocation_size: maintenance3.max_memory_allocation_size,
            timestamps_supported: ts_bits > 0 && l.timestamp_period > 0.0,
            timestamp_period_ns: l.timestamp_period,
            timestamp_valid_bits: ts_bits,
            subgroup_size: subgroup.subgroup_size,
            device_local_heap_bytes,
            memory_types: mem.memory_type_count as usize,
            validation_layer_present: layer_present,
            validation_enabled,
            features: opt,
        };
        let debug_utils_device =
            names.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        let (sync2_ext, dynamic_rendering_ext) = if core13 {
            (None, None)
        } else {
            (
                Some(ash::khr::synchronization2::Device::new(&instance, &device)),
                Some(ash::khr::dynamic_rendering::Device::new(&instance, &device)),
            )
        };
        let push_descriptor = ash::khr::push_descriptor::Device::new(&instance, &device);
        let ctx = Context {
            entry,
            instance,
            debug_utils_device,
            physical_device: pd,
            device,
            queue,
            queue_family,
            limits: l,
            info,
            validation,
            shared,
            one_shot_pool: Mutex::new(one_shot_pool),
            push_descriptor,
            sync2_ext,
            dynamic_rendering_ext,
            surface_instance,
            swapchain_device,
        };
        if owns_device {
            ctx.set_name(ctx.queue, "main queue");
        }
        Ok(ctx)
    }

    /// Gives a Vulkan object a debug-utils name (shown in validation messages and tools).
    pub fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(du) = &self.debug_utils_device {
            if let Ok(cname) = CString::new(name.replace('\0', " ")) {
                let info = vk::DebugUtilsObjectNameInfoEXT::default()
                    .object_handle(handle)
                    .object_name(&cname);
                // SAFETY: handle belongs to this device; naming failures are harmless.
                let _ = unsafe { du.set_debug_utils_object_name(&info) };
            }
        }
    }

    /// What every object made from this context shares (device, allocator, release queue).
    pub(crate) fn shared(&self) -> &Arc<DeviceShared> {
        &self.shared
    }

    /// Takes ownership of a handle created from this context's device and names it: it is released
    /// (through the release queue) when the returned value is dropped.
    pub fn own<H: OwnedHandle>(&self, raw: H, name: &str) -> Owned<H> {
        self.set_name(raw, name);
        Owned::new(&self.shared, raw)
    }

    /// Reserves `bytes` against the memory budget; fails with a clear error past it.
    pub(crate) fn reserve_bytes(&self, name: &str, bytes: u64) -> Result<()> {
        self.shared.reserve_bytes(name, bytes)
    }

    /// Locks the allocator.
    pub(crate) fn allocator(&self) -> std::sync::MutexGuard<'_, Allocator> {
        self.shared.allocator()
    }

    /// Names of the GPU allocations alive now, objects dropped but still awaiting release included (after
    /// [`Context::wait_idle`], empty when every object was dropped).
    pub fn live_allocations(&self) -> Vec<String> {
        self.shared
            .live_allocations()
            .into_iter()
            .map(|(name, _)| name)
            .collect()
    }

    /// Objects dropped but not yet destroyed because the GPU may still use them.
    pub fn objects_awaiting_release(&self) -> usize {
        self.shared.waiting()
    }

    /// The allocation budget in bytes, if one is set (desc or [`MEMORY_BUDGET_ENV`]).
    pub fn memory_budget(&self) -> Option<u64> {
        self.shared.memory_budget()
    }

    /// Bytes currently allocated through this context (objects awaiting release included).
    pub fn allocated_bytes(&self) -> u64 {
        self.shared.allocated_bytes()
    }

    /// Records `f` into a fresh command buffer, submits it, waits for it and returns `f`'s value.
    pub fn one_shot<T>(&self, f: impl FnOnce(vk::CommandBuffer) -> Result<T>) -> Result<T> {
        let pool = self.one_shot_pool.lock().unwrap_or_else(|p| p.into_inner());
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(*pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool is externally synchronised by the mutex held for the whole call.
        let cmd = unsafe { self.device.allocate_command_buffers(&alloc) }
            .vk("vkAllocateCommandBuffers")?[0];
        // SAFETY: valid device.
        let fence = match unsafe {
            self.device
                .create_fence(&vk::FenceCreateInfo::default(), None)
        } {
            Ok(f) => self.own(f, "one-shot fence"),
            Err(result) => {
                // SAFETY: cmd was never submitted.
                unsafe { self.device.free_command_buffers(*pool, &[cmd]) };
                return Err(Error::Vulkan {
                    call: "vkCreateFence",
                    result,
                });
            }
        };
        // What `f` drops while recording stays pinned until this submission (or an outer open recording's).
        self.shared.begin_recording();
        let mut serial = None;
        let result = (|| {
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            // SAFETY: cmd is a fresh primary command buffer.
            unsafe { self.device.begin_command_buffer(cmd, &begin) }.vk("vkBeginCommandBuffer")?;
            let value = f(cmd)?;
            // SAFETY: recording state.
            unsafe { self.device.end_command_buffer(cmd) }.vk("vkEndCommandBuffer")?;
            let cmds = [cmd];
            let submit = vk::SubmitInfo::default().command_buffers(&cmds);
            let s = self.shared.next_serial();
            serial = Some(s);
            // SAFETY: the queue is used from one thread at a time by the engine's design (one queue).
            unsafe { self.device.queue_submit(self.queue, &[submit], fence.raw()) }
                .vk("vkQueueSubmit")?;
            // SAFETY: the fence belongs to this device.
            unsafe { self.device.wait_for_fences(&[fence.raw()], true, u64::MAX) }
                .vk("vkWaitForFences")?;
            Ok(value)
        })();
        self.shared.end_recording();
        if result.is_err() {
            // A failed submission may leave work in flight; make sure nothing uses cmd before freeing it.
            // SAFETY: valid device.
            let _ = unsafe { self.device.device_wait_idle() };
            self.shared.idle();
        } else if let Some(s) = serial {
            self.shared.completed(s);
        }
        // SAFETY: the work is complete (waited on) or never submitted.
        unsafe { self.device.free_command_buffers(*pool, &[cmd]) };
        result
    }

    /// `vkCmdPipelineBarrier2` (core 1.3 or `VK_KHR_synchronization2`).
    pub fn cmd_pipeline_barrier2(&self, cmd: vk::CommandBuffer, dep: &vk::DependencyInfo<'_>) {
        // SAFETY: caller passes a command buffer in the recording state.
        unsafe {
            match &self.sync2_ext {
                Some(ext) => ext.cmd_pipeline_barrier2(cmd, dep),
                None => self.device.cmd_pipeline_barrier2(cmd, dep),
            }
        }
    }

    /// `vkCmdBeginRendering` (core 1.3 or `VK_KHR_dynamic_rendering`).
    pub fn cmd_begin_rendering(&self, cmd: vk::CommandBuffer, info: &vk::RenderingInfo<'_>) {
        // SAFETY: caller passes a command buffer in the recording state.
        unsafe {
            match &self.dynamic_rendering_ext {
                Some(ext) => ext.cmd_begin_rendering(cmd, info),
                None => self.device.cmd_begin_rendering(cmd, info),
            }
        }
    }

    /// `vkCmdEndRendering` (core 1.3 or `VK_KHR_dynamic_rendering`).
    pub fn cmd_end_rendering(&self, cmd: vk::CommandBuffer) {
        // SAFETY: caller passes a command buffer inside a dynamic render pass.
        unsafe {
            match &self.dynamic_rendering_ext {
                Some(ext) => ext.cmd_end_rendering(cmd),
                None => self.device.cmd_end_rendering(cmd),
            }
        }
    }

    /// `vkCmdPushDescriptorSetKHR` for set `set` of `layout`.
    pub fn cmd_push_descriptors(
        &self,
        cmd: vk::CommandBuffer,
        bind_point: vk::PipelineBindPoint,
        layout: vk::PipelineLayout,
        set: u32,
        bindings: &[(u32, super::pipeline::Binding)],
    ) {
        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = bindings
            .iter()
            .map(|(_, b)| match *b {
                super::pipeline::Binding::Storage(buffer)
                | super::pipeline::Binding::Uniform(buffer) => [vk::DescriptorBufferInfo {
                    buffer,
                    offset: 0,
                    range: vk::WHOLE_SIZE,
                }],
                super::pipeline::Binding::StorageRange {
                    buffer,
                    offset,
                    range,
                } => [vk::DescriptorBufferInfo {
                    buffer,
                    offset,
                    range,
                }],
                _ => [vk::DescriptorBufferInfo::default()],
            })
            .collect();
        let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = bindings
            .iter()
            .map(|(_, b)| match *b {
                super::pipeline::Binding::Sampled {
                    view,
                    sampler,
                    layout,
                } => [vk::DescriptorImageInfo {
                    sampler,
                    image_view: view,
                    image_layout: layout,
                }],
                super::pipeline::Binding::StorageImage { view, layout } => {
                    [vk::DescriptorImageInfo {
                        sampler: vk::Sampler::null(),
                        image_view: view,
                        image_layout: layout,
                    }]
                }
                _ => [vk::DescriptorImageInfo::default()],
            })
            .collect();
        let writes: Vec<vk::WriteDescriptorSet> = bindings
            .iter()
            .enumerate()
            .map(|(i, (binding, b))| {
                let w = vk::WriteDescriptorSet::default()
                    .dst_binding(*binding)
                    .descriptor_type(b.descriptor_type());
                match b {
                    super::pipeline::Binding::Storage(_)
                    | super::pipeline::Binding::StorageRange { .. }
                    | super::pipeline::Binding::Uniform(_) => w.buffer_info(&buffer_infos[i]),
                    _ => w.image_info(&image_infos[i]),
                }
            })
            .collect();
        // SAFETY: recording command buffer; the layout's set `set` was created with PUSH_DESCRIPTOR_KHR.
        unsafe {
            self.push_descriptor
                .cmd_push_descriptor_set(cmd, bind_point, layout, set, &writes)
        };
    }

    /// Starts recording gregvox work into a command buffer of the caller's: what gregvox drops until the
    /// returned bracket ends waits for that command buffer's submission (see `gpu::external`). Polls the
    /// caller's earlier submissions first, so the release queue drains frame by frame.
    pub fn begin_external(&self) -> Result<ExternalRecording<'_>> {
        self.poll_external()?;
        self.shared.begin_recording();
        Ok(ExternalRecording {
            ctx: self,
            open: true,
        })
    }

    /// Destroys what waited for submissions of the caller's that have completed (their timeline
    /// semaphores reached the values given to [`ExternalRecording::submitted`]).
    pub fn poll_external(&self) -> Result<()> {
        self.shared.poll_external()
    }

    /// Whether the instance and the device are gregvox's own (false: lent by the caller).
    pub fn owns_device(&self) -> bool {
        self.shared.owns_device()
    }

    /// Waits until the device is idle; then everything dropped so far is destroyed.
    pub fn wait_idle(&self) -> Result<()> {
        // SAFETY: valid device.
        unsafe { self.device.device_wait_idle() }.vk("vkDeviceWaitIdle")?;
        self.shared.idle();
        Ok(())
    }
}

/// The messenger gregvox creates: validation, performance and general messages of warning severity and
/// up (and info, for the log) into the sink at `sink`.
fn messenger_info(sink: *mut std::ffi::c_void) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(messenger_callback))
        .user_data(sink)
}

/// What [`Context::assemble`] takes over: a device (created by gregvox or borrowed) and its report.
struct Assembly {
    entry: ash::Entry,
    instance: ash::Instance,
    physical_device: vk::PhysicalDevice,
    device: ash::Device,
    queue: vk::Queue,
    queue_family: u32,
    name: String,
    core13: bool,
    /// The optional features enabled on the device.
    features: OptionalFeatures,
    /// gregvox's messenger (destroyed with the device shared state).
    debug_utils: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// Whether objects get debug-utils names.
    names: bool,
    validation: Arc<ValidationSink>,
    layer_present: bool,
    validation_enabled: bool,
    surface: bool,
    memory_budget: Option<u64>,
    owns_device: bool,
}

/// Destroys what a half-built context created, if `Context::with_desc` fails part-way.
struct Partial<'a> {
    #[allow(dead_code)]
    entry: &'a ash::Entry,
    instance: Option<ash::Instance>,
    messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
}

impl Drop for Partial<'_> {
    fn drop(&mut self) {
        // SAFETY: only reached on the error path, before any device object exists.
        unsafe {
            if let Some((loader, m)) = self.messenger.take() {
                loader.destroy_debug_utils_messenger(m, None);
            }
            if let Some(i) = self.instance.take() {
                i.destroy_instance(None);
            }
        }
    }
}

fn pick_device(
    instance: &ash::Instance,
    filter: Option<&str>,
    surface_wanted: bool,
) -> Result<Candidate> {
    // SAFETY: valid instance.
    let pds = unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
    if pds.is_empty() {
        return Err(Error::NoDevice(
            "the Vulkan loader reports no physical device".into(),
        ));
    }
    let mut all_names = Vec::new();
    let mut candidates = Vec::new();
    for pd in pds {
        // SAFETY: pd comes from the instance.
        let props = unsafe { instance.get_physical_device_properties(pd) };
        let name = cstr_array(&props.device_name);
        all_names.push(format!(
            "{name} (Vulkan {})",
            vk_version_string(props.api_version)
        ));
        if let Some(f) = filter {
            if !name.to_lowercase().contains(&f.to_lowercase()) {
                continue;
            }
        }
        if props.api_version < vk::API_VERSION_1_2 {
            continue;
        }
        // SAFETY: pd comes from the instance.
        let exts =
            unsafe { instance.enumerate_device_extension_properties(pd) }.unwrap_or_default();
        let has = |n: &CStr| {
            exts.iter()
                .any(|e| cstr_array(&e.extension_name) == n.to_str().unwrap())
        };
        if !has(ash::khr::push_descriptor::NAME) {
            continue;
        }
        if props.api_version < vk::API_VERSION_1_3
            && (!has(ash::khr::synchronization2::NAME) || !has(ash::khr::dynamic_rendering::NAME))
        {
            continue;
        }
        // SAFETY: pd comes from the instance.
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let want = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
        let Some(family) = families.iter().position(|f| f.queue_flags.contains(want)) else {
            continue;
        };
        if surface_wanted && !has(ash::khr::swapchain::NAME) {
            continue;
        }
        candidates.push(Candidate {
            pd,
            props,
            family: family as u32,
            name,
        });
    }
    candidates.sort_by_key(|c| type_rank(c.props.device_type));
    candidates.into_iter().next().ok_or_else(|| {
        let what = match filter {
            Some(f) => format!("no device name contains \"{f}\" (GREGVOX_DEVICE) with Vulkan 1.2, synchronization2, dynamic rendering and push descriptors"),
            None => "no device has Vulkan 1.2 with synchronization2, dynamic rendering, push descriptors and a graphics+compute queue".into(),
        };
        Error::NoDevice(format!("{what}; devices: {}", all_names.join(", ")))
    })
}

impl Drop for Context {
    fn drop(&mut self) {
        // Wait for the device, destroy what the release queue holds, then count what is still alive: an
        // object that outlives its context is a leak (it is destroyed, safely, when it is dropped, and the
        // device after it; see `gpu::lifetime`).
        self.shared.shut_down_queue();
        let pool = *self
            .one_shot_pool
            .get_mut()
            .unwrap_or_else(|p| p.into_inner());
        // SAFETY: the device is idle and the pool's command buffers were freed after each use.
        unsafe { self.device.destroy_command_pool(pool, None) };
        let live = self.shared.live_allocations();
        LEAKED_ALLOCATIONS.fetch_add(live.len(), Ordering::SeqCst);
        for (name, size) in &live {
            log::error!("GPU allocation still alive at context destruction: {name} ({size} bytes)");
        }
    }
}
