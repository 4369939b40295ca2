//! Multi-pass GPU workflows composed from the passes: solid voxelization (`voxelize`: depth peeling,
//! A-buffer, the resident voxelizer), the Gregory surface from a cage (`gregory`, with `cage` building its
//! topology), the capturing vertex-pull path (`vertex_pull`), the thesis's flag of boundary-curve patches
//! (`flag`) and the mesh kernels of a deforming mesh (`mesh`: normals, S·x); `evaluator` chooses, per
//! device, between a Vulkan kernel and its host twin writing the same buffers. Each workflow owns its
//! passes and its buffers: for one run (the voxelizers) or for its lifetime (the surfaces, the resident
//! voxelizer, the mesh kernels); all of them release themselves when dropped.
pub mod cage;
pub mod evaluator;
pub mod flag;
pub mod gregory;
pub mod mesh;
pub mod vertex_pull;
pub mod voxelize;
