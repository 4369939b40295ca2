//! The Vulkan foundation: context, validation sink, object lifetime (release queue), resources, frames,
//! pipeline builders, generated shader statics, profiler, present targets. Knows no geometry.
pub mod context;
pub mod debug;
pub mod external;
pub mod frames;
pub mod lifetime;
pub mod pipeline;
pub mod present;
pub mod profiler;
pub mod resources;
#[cfg(feature = "window")]
pub mod swapchain;

pub use context::{Context, ContextDesc, DeviceInfo, OptionalFeatures, Validation};
pub use external::{DeviceRequirements, ExternalDevice, ExternalRecording};
pub use frames::Frames;
pub use lifetime::{Owned, OwnedHandle};
pub use present::{OffscreenTarget, PresentTarget, TargetImage};
pub use profiler::Profiler;
pub use resources::{Buffer, Image, ImageDesc, MemoryLocation};
#[cfg(feature = "window")]
pub use swapchain::SwapchainTarget;

pub mod shaders {
    //! SPIR-V of every shader in `glsl/`, compiled by `build.rs` (one u32 array per file).
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}
