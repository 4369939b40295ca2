//! One GPU pass per file. Each owns its pipelines and layouts and exposes `new`, `record`, `destroy`;
//! buffers are passed in, never owned by two passes.
pub mod abuffer;
pub mod iota;
pub mod peel;
pub mod spinner;
pub mod triangles;
pub mod voxel_fill;
