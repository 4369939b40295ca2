//! The Vulkan foundation: context, validation sink, resources, frames, pipeline builders, generated shader
//! statics, profiler, present targets. Knows no geometry.
pub mod shaders {
    //! SPIR-V of every shader in `glsl/`, compiled by `build.rs`.
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}
