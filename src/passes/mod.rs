//! One GPU pass per file. Each owns its pipelines and layouts and exposes `new` and `record`; it releases
//! them when dropped, through the release queue of `gpu::lifetime`. Buffers are passed in, never owned by
//! two passes.
pub mod abuffer;
pub mod adaptive_levels;
pub mod beziex_eval;
pub mod bounds;
pub mod cage_deform;
pub mod closest_point;
pub mod draw;
pub mod gregory_eval;
pub mod iota;
pub mod lines;
pub mod mesh_normals;
pub mod overlay;
pub mod patch_at;
pub mod patch_pull;
pub mod peel;
pub mod peel_check;
pub mod shadow_map;
pub mod spinner;
pub mod spmv;
pub mod surface_curvature;
pub mod surface_draw;
pub mod triangles;
pub mod voxel_fill;
pub mod voxel_raycast;
pub mod voxel_surface;
