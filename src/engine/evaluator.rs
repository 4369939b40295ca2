//! Which code evaluates a kernel into its device buffers: the Vulkan pass, or on devices that are CPUs its
//! native host twin ([`crate::surface::gregory_host`], [`crate::mesh::host_kernels`]) writing the same
//! buffers through their mappings.
//!
//! Invariants: [`Evaluator::for_device`] is the one place the choice is made (the Gregory surface and the
//! mesh kernels ask it); `GREGVOX_EVALUATOR` overrides it; a build without optimisation (`OPT_LEVEL` 0, set
//! by build.rs as `gregvox_unoptimized`) keeps the Vulkan kernels, whose shaders are optimised by the
//! driver whatever the crate's profile, where the host kernels would run tens of times slower.
use crate::error::{Error, Result};
use crate::gpu::{Context, MemoryLocation};

/// Which code evaluates a kernel (see the module invariants).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Evaluator {
    /// The Vulkan compute kernel.
    Vulkan,
    /// The native SIMD + threads kernel on the host, writing the same buffers through their mappings: for
    /// devices that are CPUs, where it is several times faster (on lavapipe: docs/benchmarks.md, suites
    /// `gregory` and `mesh`).
    Host,
}

impl Evaluator {
    /// The evaluator for `ctx`'s device: [`Evaluator::Host`] when the device is a CPU (in an optimised
    /// build), else [`Evaluator::Vulkan`]; the environment variable `GREGVOX_EVALUATOR` = `vulkan` or
    /// `host` overrides (any other value is an error naming it).
    pub fn for_device(ctx: &Context) -> Result<Self> {
        match std::env::var("GREGVOX_EVALUATOR").ok().as_deref() {
            None | Some("") => Ok(Self::default_for(&ctx.info.device_type)),
            Some("vulkan") => Ok(Evaluator::Vulkan),
            Some("host") => Ok(Evaluator::Host),
            Some(other) => Err(Error::Invalid(format!(
                "GREGVOX_EVALUATOR is '{other}': use 'vulkan' (the compute shader) or 'host' (the native \
                 evaluator)"
            ))),
        }
    }

    /// The choice without the override, from the device type `VkPhysicalDeviceType` names ("CPU", …).
    pub fn default_for(device_type: &str) -> Self {
        if device_type == "CPU" && !cfg!(gregvox_unoptimized) {
            Evaluator::Host
        } else {
            Evaluator::Vulkan
        }
    }

    /// Memory for a buffer the device writes and this evaluator reads: mapped and host-cached for the host
    /// kernels (on a CPU device host memory is the device's memory), device-local otherwise.
    pub fn read_location(self) -> MemoryLocation {
        match self {
            Evaluator::Vulkan => MemoryLocation::GpuOnly,
            Evaluator::Host => MemoryLocation::GpuToCpu,
        }
    }

    /// Memory for a buffer this evaluator writes (or the caller fills) and the device reads: mapped for
    /// the host kernels, device-local otherwise.
    pub fn write_location(self) -> MemoryLocation {
        match self {
            Evaluator::Vulkan => MemoryLocation::GpuOnly,
            Evaluator::Host => MemoryLocation::CpuToGpu,
        }
    }

    /// A short name for tables and logs.
    pub fn label(self) -> &'static str {
        match self {
            Evaluator::Vulkan => "Vulkan kernel",
            Evaluator::Host => "host (native SIMD + threads)",
        }
    }
}
