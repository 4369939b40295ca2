//! gregvox: a Vulkan-native engine (on `ash`) for smooth Gregory surfaces and solid voxels.
//!
//! Layering (nothing below imports from a row above it):
//! `cli` → `demo` → `engine` → `passes` → `surface`, `voxel` → `mesh` → `geom`; `gpu` is the Vulkan foundation and knows no
//! geometry; `error` is shared by all.
pub mod bench;
pub mod cli;
pub mod demo;
pub mod engine;
pub mod error;
pub mod geom;
pub mod gpu;
pub mod io;
pub mod mesh;
pub mod passes;
pub mod surface;
pub mod voxel;

pub use error::{Error, Result};
